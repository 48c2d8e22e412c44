// Deployment loading: one test per class of configuration error (asserting the message, with
// file:line:col and the field path), and a simulated-time run of a small deployment.
#include <array>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <map>

#include <gtest/gtest.h>

#include "diagnostics.hpp"
#include "regolith/core/error.hpp"
#include "regolith/hal/plausible_encoders.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/health.hpp"
#include "regolith/runtime/input_timeout.hpp"
#include "regolith/runtime/joint_state.hpp"

using namespace regolith;
using namespace regolith::runtime;
namespace rt = regolith::testing;

namespace {

// A minimal encoder backend for these tests: wheels turning at a constant 1 rad/s.
class ConstantEncoders final : public hal::WheelEncoders {
 public:
  ConstantEncoders(std::string id, std::vector<std::string> wheels, Clock* clock, int lost_per_s = 0,
                   int step_back_every = 0, double step_back_s_at_2s = 0.0, int step_back_hold = 1)
      : id_(std::move(id)),
        wheels_(std::move(wheels)),
        clock_(clock),
        lost_per_s_(lost_per_s),
        step_back_every_(step_back_every),
        step_back_hold_(step_back_hold),
        step_back_ns_(static_cast<TimeNs>(step_back_s_at_2s * 1e9)) {}
  const std::string& id() const override { return id_; }
  const std::vector<std::string>& wheel_names() const override { return wheels_; }
  void start() override { t0_ = clock_->now(); }
  void stop() override {}
  bool latest(std::size_t, TimeNs now, hal::AngleSample& out) const override {
    TimeNs t = now - (now - t0_) % (10 * kNsPerMs);
    // In the last step_back_hold of every step_back_every 10 ms periods the newest usable sample is
    // the one 30 ms before the first of them (its newer ones rejected, or the clock stepped back).
    const TimeNs period = (t - t0_) / (10 * kNsPerMs);
    if (step_back_every_ > 0) {
      const TimeNs hold_start = period - period % step_back_every_ + step_back_every_ - step_back_hold_;
      if (period >= hold_start && hold_start >= 3) t = t0_ + hold_start * 10 * kNsPerMs - 30 * kNsPerMs;
    }
    if (step_back_ns_ > 0 && t - t0_ >= 2 * kNsPerSec) t -= step_back_ns_;  // the device clock steps back at 2 s
    out = {t, to_seconds(t - t0_)};
    return true;
  }
  bool angle_at(std::size_t, TimeNs t, double& a) const override {
    a = to_seconds(t - t0_);
    return true;
  }
  hal::EncoderStats stats() const override {
    hal::EncoderStats st;  // a bus whose receive queue loses lost_per_s frames in every second after the first
    const auto seconds = static_cast<std::uint64_t>((clock_->now() - t0_) / kNsPerSec);
    st.lost = static_cast<std::uint64_t>(lost_per_s_) * seconds;
    return st;
  }

 private:
  std::string id_;
  std::vector<std::string> wheels_;
  Clock* clock_;
  int lost_per_s_ = 0;
  int step_back_every_ = 0;
  int step_back_hold_ = 1;
  TimeNs step_back_ns_ = 0;
  TimeNs t0_ = 0;
};

void register_test_backends() {
  static bool done = false;
  if (done) return;
  done = true;
  register_builtin_components();
  hal::BackendRegistry::instance().add_encoders(
      "constant", "test wheels at 1 rad/s", [](Params& p, const hal::DeviceContext& ctx) {
        auto wheels = p.require<std::vector<std::string>>("wheels");
        const int lost = p.get<int>("lost_per_s", 0, {.min = 0, .doc = "frames the bus loses per second"});
        const int back = p.get<int>("step_back_every", 0, {.min = 0, .doc = "reads between two that step back"});
        const double step = p.get<double>("step_back_s_at_2s", 0.0, {.unit = "s", .min = 0.0});
        const int hold = p.get<int>("step_back_hold", 1, {.min = 1, .doc = "reads the older sample stays the newest"});
        return std::make_unique<ConstantEncoders>(ctx.id, wheels, ctx.clock, lost, back, step, hold);
      });
}

const char* kGood = R"(name: test_rover
dds: {enabled: false}
devices:
  encoders:
    wheels: {backend: constant, wheels: [left, right]}
rate_groups:
  - name: io
    rate_hz: 100
    members: [joints]
  - name: health
    period_ms: 1000
    members: [health]
components:
  joints: {type: joint_state_publisher, encoders: wheels}
  health: {type: health}
)";

std::string load_error(const std::string& yaml) {
  register_test_backends();
  try {
    auto app = Application::load(Params::load_string(yaml, "rover.yaml"), {.sim_time = true});
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "<no error>";
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) s.replace(pos, from.size(), to);
  return s;
}

}  // namespace

TEST(ConfigErrors, GoodConfigLoads) {
  EXPECT_EQ(load_error(kGood), "<no error>");
}

TEST(ConfigErrors, MalformedYaml) {
  EXPECT_EQ(load_error("name: x\nrate_groups: [\n  {name: a\n"),
            "rover.yaml:4:1: malformed YAML: end of map flow not found");
}

TEST(ConfigErrors, NegativePeriod) {
  EXPECT_EQ(load_error(replace(kGood, "period_ms: 1000", "period_ms: -5")),
            "rover.yaml:11:16: rate_groups[1].period_ms: value must be > 0 (got -5)");
}

TEST(ConfigErrors, UnknownTopLevelKeySuggestsTheRightOne) {
  EXPECT_EQ(load_error(std::string(kGood) + "rate_group: []\n"),
            "rover.yaml:16:1: rate_group: unknown key (did you mean 'rate_groups'?)");
}

TEST(ConfigErrors, UnknownComponentParameter) {
  EXPECT_EQ(load_error(replace(kGood, "encoders: wheels}", "encoders: wheels, stale_timout_s: 2}")),
            "rover.yaml:14:59: components.joints.stale_timout_s: unknown key (did you mean 'stale_timeout_s'?)");
}

TEST(ConfigErrors, UnknownComponentType) {
  const std::string e = load_error(replace(kGood, "type: joint_state_publisher", "type: joint_state_publsher"));
  EXPECT_EQ(e.rfind("rover.yaml:14:18: components.joints.type: unknown component type 'joint_state_publsher' "
                    "(did you mean 'joint_state_publisher'?); available:",
                    0),
            0u)
      << e;
}

TEST(ConfigErrors, UnknownBackend) {
  const std::string e = load_error(replace(kGood, "backend: constant", "backend: constnt"));
  EXPECT_EQ(e.rfind("rover.yaml:5:23: devices.encoders.wheels.backend: unknown encoder backend 'constnt' "
                    "(did you mean 'constant'?)",
                    0),
            0u)
      << e;
}

TEST(ConfigErrors, MissingDevice) {
  EXPECT_EQ(load_error(replace(kGood, "encoders: wheels}", "encoders: wheel}")),
            "rover.yaml:14:51: components.joints.encoders: no encoder set named 'wheel' in devices "
            "(did you mean 'wheels'?)");
}

TEST(ConfigErrors, WrongType) {
  EXPECT_EQ(load_error(replace(kGood, "rate_hz: 100", "rate_hz: fast")),
            "rover.yaml:8:14: rate_groups[0].rate_hz: expected a number, got 'fast'");
}

TEST(ConfigErrors, MemberThatIsNotAComponent) {
  EXPECT_EQ(load_error(replace(kGood, "members: [joints]", "members: [joints, jionts]")),
            "rover.yaml:9:14: rate_groups[0].members: unknown component 'jionts' (did you mean 'joints'?)");
}

TEST(ConfigErrors, ComponentInTwoGroups) {
  EXPECT_EQ(load_error(replace(kGood, "members: [health]", "members: [health, joints]")),
            "rover.yaml:12:14: rate_groups[1].members: component 'joints' is already a member of rate group 'io'");
}

TEST(ConfigErrors, UnscheduledComponent) {
  EXPECT_EQ(load_error(std::string(kGood) + "  spare: {type: health}\n"),
            "rover.yaml:16:10: components.spare: component 'spare' is not a member of any rate group");
}

TEST(ConfigErrors, RateAndPeriodBothGiven) {
  EXPECT_EQ(load_error(replace(kGood, "rate_hz: 100", "rate_hz: 100\n    period_ms: 10")),
            "rover.yaml:7:5: rate_groups[0]: give exactly one of rate_hz or period_ms");
}

TEST(ConfigErrors, BadChoice) {
  EXPECT_EQ(
      load_error(replace(kGood, "rate_hz: 100", "rate_hz: 100\n    overrun: catchup")),
      "rover.yaml:9:14: rate_groups[0].overrun: 'catchup' is not one of skip|catch_up (did you mean 'catch_up'?)");
}

TEST(ConfigErrors, MissingFile) {
  try {
    Params::load_file("/nonexistent/rover.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/rover.yaml: cannot open configuration file (No such file or directory)");
  }
}

TEST(ConfigErrors, DevicesDirectoriesAndHugeFilesAreNotRead) {
  // `--config /dev/zero` used to be read until memory ran out.
  for (const char* path : {"/dev/zero", "/tmp"}) {
    try {
      Params::load_file(path);
      ADD_FAILURE() << path;
    } catch (const ConfigError& e) {
      EXPECT_EQ(std::string(e.what()),
                std::string(path) + ": not a regular file (a device, FIFO or directory), not a configuration file");
    }
  }
  const std::string big = ::testing::TempDir() + "regolith_big.yaml";
  {
    std::ofstream out(big, std::ios::binary);
    const std::string line(1023, '#');
    for (int i = 0; i < 17 * 1024; ++i) out << line << '\n';
  }
  try {
    Params::load_file(big);
    ADD_FAILURE() << big;
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), big + ": 17825792 bytes, more than the 16777216 a configuration file may have");
  }
  std::remove(big.c_str());
}

/// Loads `yaml` on the simulated clock and runs it for 10 s (start to stop).
auto run_ten_seconds(const std::string& yaml) {
  register_test_backends();
  auto app = Application::load(Params::load_string(yaml, "rover.yaml"), {.sim_time = true});
  std::atomic<bool> stop{false};
  app->start();
  app->run(10 * kNsPerSec, stop);
  app->stop();
  return app;
}

TEST(Application, SimulatedRunPublishesJointStatesAndHealth) {
  auto app = run_ten_seconds(kGood);
  // Every encoder device is read through the plausibility check (one for every backend).
  EXPECT_NE(dynamic_cast<const hal::PlausibleEncoders*>(app->context().find<hal::WheelEncoders>("wheels")), nullptr);
  auto& joints = app->context().channel<JointStateSample>("joint_states");
  auto& health = app->context().channel<HealthSnapshot>("health/snapshot");

  const auto& groups = app->view().groups;
  EXPECT_EQ(groups[0]->counters().cycles, 1001u);  // 100 Hz for 10 s, both ends inclusive
  EXPECT_EQ(groups[1]->counters().cycles, 11u);
  EXPECT_EQ(groups[0]->counters().slips, 0u);

  auto js = joints.acquire();
  ASSERT_TRUE(js);
  EXPECT_EQ(js->count, 2u);
  EXPECT_NEAR(js->position[0], 10.0, 1e-9);  // 1 rad/s for 10 s
  EXPECT_NEAR(js->velocity[1], 1.0, 1e-6);

  auto h = health.acquire();
  ASSERT_TRUE(h);
  EXPECT_TRUE(h->all_critical_ok);
  ASSERT_EQ(h->count, 2u + 2u + 1u);  // 2 groups, 2 components, 1 encoder set
  EXPECT_STREQ(h->entries[2].name.data(), "joints");
  EXPECT_STREQ(h->entries[2].group.data(), "io");
  EXPECT_EQ(h->entries[2].level, Level::kOk);
  EXPECT_EQ(h->entries[2].heartbeat, 1001u);
  EXPECT_EQ(h->entries[4].kind, HealthEntry::Kind::kEncoders);
}

/// Runs kGood on the simulated clock with `wheel_options` added to its test encoders, reading the
/// joint_states channel every 10 ms for 3 s: `read` gets each sample (null when there is none).
/// Returns the joint state publisher's diagnostics at the end.
template <typename Read>
std::map<std::string, std::string> read_joint_states_for_three_seconds(const std::string& wheel_options, Read read) {
  register_test_backends();
  auto app = Application::load(
      Params::load_string(replace(kGood, "wheels: [left, right]}", "wheels: [left, right], " + wheel_options + "}"),
                          "rover.yaml"),
      {.sim_time = true});
  auto& joints = app->context().channel<JointStateSample>("joint_states");
  std::atomic<bool> stop{false};
  app->start();
  for (int k = 0; k < 300; ++k) {
    app->run(10 * kNsPerMs, stop);
    auto js = joints.acquire();
    read(js ? &*js : nullptr);
  }
  app->stop();
  return regolith::testing::diagnostics_of(*app, "joints");
}

TEST(Application, JointStatesNeverGoBackWhenTheDevicesNewestSampleDoes) {
  // The encoders' newest usable sample is 30 ms older in every 5th period: what a rejected newest
  // frame (the plausibility check walks back to an accepted one) or a clock step gives. The
  // published joint states keep their order: stamps and each wheel's angle never decrease (the
  // hardware test saw a published sample 10 ms older than the one before it).
  TimeNs last_stamp = 0;
  std::array<double, 2> last_angle{-1.0, -1.0};
  int samples = 0, back = 0;
  const auto diag = read_joint_states_for_three_seconds("step_back_every: 5", [&](const JointStateSample* js) {
    if (!js) return;
    ++samples;
    back += js->stamp < last_stamp ? 1 : 0;
    last_stamp = js->stamp;
    for (std::size_t w = 0; w < 2; ++w) {
      back += js->position[w] < last_angle[w] ? 1 : 0;
      last_angle[w] = js->position[w];
    }
  });
  EXPECT_GT(samples, 250);
  EXPECT_EQ(back, 0);
  EXPECT_NEAR(last_angle[0], 3.0, 0.05);  // 1 rad/s for 3 s: still moving
  // Each wheel held at its published sample in the 60 periods of 300 (100 Hz) that stepped back.
  EXPECT_EQ(diag.at("samples_out_of_order"), "120");
  EXPECT_EQ(diag.at("clock_steps"), "0");
  EXPECT_EQ(diag.at("wheel_clock_steps"), "0");
}

TEST(Application, AWheelSampleHeldBackIsCountedOnceHoweverManyCyclesItStaysTheNewest) {
  // The older sample stays the device's newest for 3 of every 5 periods: each wheel is held at its
  // published angle in all three, and each such sample counts once (59 samples per wheel).
  int samples = 0, back = 0;
  TimeNs last_stamp = 0;
  const auto diag =
      read_joint_states_for_three_seconds("step_back_every: 5, step_back_hold: 3", [&](const JointStateSample* js) {
        if (!js) return;
        ++samples;
        back += js->stamp < last_stamp ? 1 : 0;
        last_stamp = js->stamp;
      });
  EXPECT_GT(samples, 250);
  EXPECT_EQ(back, 0);
  EXPECT_EQ(diag.at("samples_out_of_order"), "118");
  EXPECT_EQ(diag.at("clock_steps"), "0");
}

TEST(InputTimeout, TwoFramePeriodsPlusTheSlackAndAnUnknownRateCountsAsOneHertz) {
  const auto timeout = [](const std::string& yaml, double rate_hz) {
    Params p = Params::load_string(yaml, "c.yaml");
    return to_seconds(read_input_timeout(p, rate_hz, 1.0));
  };
  EXPECT_DOUBLE_EQ(timeout("{}", 5.0), 1.4);
  EXPECT_DOUBLE_EQ(timeout("{}", 0.01), 21.0);  // rates below 0.1 Hz count as 0.1 Hz
  // A camera that does not report its rate (libcamera's default mode, an unopened device): was 21 s,
  // so a front camera's outage went unflagged for 21 s.
  EXPECT_DOUBLE_EQ(timeout("{}", 0.0), 3.0);
  EXPECT_DOUBLE_EQ(timeout("{input_timeout_s: 0.25}", 0.0), 0.25);
}

TEST(Application, JointStatesFollowTheClockWhenItStepsBackForGood) {
  // A step back by more than the stale timeout (0.5 s) is the clock itself (a time sync), not a
  // rejected sample: from 2 s on, the encoders' stamps are 1.5 s earlier for good. joint_states go
  // on from there (one step back, then newer every cycle) instead of holding the last angle until
  // the old time comes back.
  TimeNs last = 0;
  int newer = 0, older = 0, missing = 0;
  double angle = 0.0;
  const auto diag = read_joint_states_for_three_seconds("step_back_s_at_2s: 1.5", [&](const JointStateSample* js) {
    if (!js) {
      ++missing;
      return;
    }
    if (last != 0 && js->stamp > last) ++newer;
    if (last != 0 && js->stamp < last) ++older;
    last = js->stamp;
    angle = js->position[0];
  });
  EXPECT_EQ(missing, 0);
  EXPECT_EQ(older, 1);            // the clock's step
  EXPECT_GT(newer, 280);          // every other cycle a newer sample, before and after it
  EXPECT_NEAR(angle, 1.5, 0.05);  // 3 s of turning at 1 rad/s, read on a clock 1.5 s behind
  EXPECT_EQ(diag.at("clock_steps"), "1");
  EXPECT_EQ(diag.at("wheel_clock_steps"), "2") << "each wheel's stamps stepped back once";
  EXPECT_EQ(diag.at("samples_out_of_order"), "0");
}

TEST(Application, ASimulatedOverrunSlipsItsOwnGroupOnlyAndHealthNamesIt) {
  // cpu_load under the simulated clock: 15 ms of simulated execution time in every 50th cycle of
  // the 100 Hz io group. Each such cycle ends 5 ms past the next release: one slip, one skipped
  // release; the 1 Hz health group starts late by at most 15 ms and never slips.
  auto app = run_ten_seconds(replace(replace(kGood, "members: [joints]", "members: [joints, drill]"),
                                     "  health: {type: health}",
                                     "  health: {type: health}\n  drill: {type: cpu_load, busy_ms: 15, every: 50}"));
  auto& health = app->context().channel<HealthSnapshot>("health/snapshot");
  const auto& groups = app->view().groups;
  const auto io = groups[0]->counters(), hl = groups[1]->counters();
  const auto kv = regolith::testing::diagnostics_of(*app, "drill");
  ASSERT_EQ(kv.size(), 1u);
  ASSERT_EQ(kv.begin()->first, "busy_cycles");
  const std::uint64_t busy = std::stoull(kv.begin()->second);
  EXPECT_EQ(busy, (io.cycles + 49) / 50) << "the first cycle, then every 50th";
  EXPECT_GE(busy, 19u);
  EXPECT_EQ(io.slips, busy) << "one missed release per injected overrun";
  EXPECT_EQ(io.cycles + io.skipped, 1001u) << "every release of 10 s at 100 Hz either ran or was skipped";
  EXPECT_EQ(io.skipped, busy);
  EXPECT_EQ(hl.slips, 0u) << "the health group only started late";
  EXPECT_EQ(hl.cycles, 11u);
  auto h = health.acquire();
  ASSERT_TRUE(h);
  // The last report (slips in every second): the group warns, and the culprit is the drill, by its
  // simulated execution time (its wall time is nil).
  using K = HealthEntry::Kind;
  const HealthEntry* group = rt::health_entry(*h, "io", K::kRateGroup);
  const HealthEntry* drill = rt::health_entry(*h, "drill", K::kComponent);
  const HealthEntry* joints = rt::health_entry(*h, "joints", K::kComponent);
  ASSERT_TRUE(group && drill && joints);
  EXPECT_EQ(group->level, Level::kWarn);
  EXPECT_EQ(group->slips, io.slips);
  EXPECT_EQ(drill->level, Level::kWarn);
  EXPECT_STREQ(drill->message, "overruns its rate group's period");
  EXPECT_EQ(joints->level, Level::kOk) << "the other member of the group is not blamed";
}

TEST(Application, SlipsFromALateStartNameNoMemberOfTheGroupThatSlipped) {
  // A 10 Hz group whose drill is busy 35 ms of every 100 ms cycle (never late itself) delays the
  // 100 Hz io group under the simulated executor's one thread, as a host that deschedules the
  // process or another thread on the same CPU would in real time. io's slips are then all late
  // starts: the group warns and says so, and `joints`, which costs nothing, is not blamed.
  const std::string yaml = replace(
      replace(kGood, "  - name: health\n", "  - name: slow\n    rate_hz: 10\n    members: [drill]\n  - name: health\n"),
      "  health: {type: health}", "  health: {type: health}\n  drill: {type: cpu_load, busy_ms: 35, every: 1}");
  auto app = run_ten_seconds(yaml);
  const auto& groups = app->view().groups;
  const auto io = groups[0]->counters(), slow = groups[1]->counters();
  // At a shared release io (listed first) runs, then the drill until +35 ms: io's next release
  // starts then, and two more (+20, +30 ms) have passed. Two per drill cycle; the last one (at 10 s)
  // has no io release after it within the run.
  EXPECT_EQ(io.slips, 200u);
  EXPECT_EQ(io.late_start_slips, io.slips);
  EXPECT_EQ(slow.slips, 0u);
  auto h = app->context().channel<HealthSnapshot>("health/snapshot").acquire();
  ASSERT_TRUE(h);
  using K = HealthEntry::Kind;
  const HealthEntry* group = rt::health_entry(*h, "io", K::kRateGroup);
  ASSERT_TRUE(group);
  EXPECT_EQ(group->level, Level::kWarn);
  EXPECT_STREQ(group->message, "cycle slips since last report: started late (CPU taken outside the group)");
  EXPECT_EQ(group->late_start_slips, io.late_start_slips);
  for (const char* name : {"joints", "drill"}) {
    const HealthEntry* e = rt::health_entry(*h, name, K::kComponent);
    ASSERT_TRUE(e) << name;
    EXPECT_EQ(e->level, Level::kOk) << name << ": " << e->message;
  }
}

TEST(Application, HealthWarnsWhileABusLosesFramesAndCountsThem) {
  // An encoder set whose receive queue overflows (EncoderStats::lost, e.g. SocketCAN at full bus
  // load): its health entry carries the count and warns in every report in which it grew.
  auto app = run_ten_seconds(replace(kGood, "wheels: [left, right]}", "wheels: [left, right], lost_per_s: 3}"));
  auto& health = app->context().channel<HealthSnapshot>("health/snapshot");
  auto h = health.acquire();
  ASSERT_TRUE(h);
  ASSERT_EQ(h->entries[4].kind, HealthEntry::Kind::kEncoders);
  EXPECT_EQ(h->entries[4].lost, 30u);
  EXPECT_EQ(h->entries[4].level, Level::kWarn);
  EXPECT_STREQ(h->entries[4].message, "frames lost since last report (receive queue overflowed)");
  EXPECT_TRUE(h->all_critical_ok) << "lost frames are a warning, not a reason to stop the watchdog";
}

// ROS time: on the system clock, message stamps are CLOCK_REALTIME (the process clock plus the
// offset the application measures and refreshes); under --sim-time they are the simulated time.
TEST(RosTime, RealClockStampsAreWallClockTimeAndSimulatedStampsAreSimulatedTime) {
  register_test_backends();
  {
    auto app = Application::load(Params::load_string(kGood, "rover.yaml"), {});
    app->start();
    timespec rt{};
    const TimeNs mono = monotonic_now();
    clock_gettime(CLOCK_REALTIME, &rt);
    const TimeNs real = static_cast<TimeNs>(rt.tv_sec) * kNsPerSec + rt.tv_nsec;
    EXPECT_LT(std::abs(to_ros_time(mono) - real), 10 * kNsPerMs);
    EXPECT_GT(to_ros_time(mono), TimeNs{1'700'000'000} * kNsPerSec);  // after 2023: a date, not an uptime
    app->stop();
  }
  {
    auto app = Application::load(Params::load_string(kGood, "rover.yaml"), {.sim_time = true});
    app->start();
    const TimeNs t = app->clock().now();
    EXPECT_EQ(to_ros_time(t), t);
    app->stop();
  }
}
