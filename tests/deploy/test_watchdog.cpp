// systemd watchdog gating (runtime/include/regolith/runtime/watchdog.hpp) under
// the simulated clock: a deployment with a critical component and the health
// monitor is driven cycle by cycle, with the `regolith run` loop's 100 ms
// slices calling SystemdNotifier::update(). A fake systemd records every
// notification with its (simulated) time. A stalled rate group is modelled by
// no longer running its cycles while the other groups go on, as when its thread
// blocks.
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "regolith/core/params.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/health.hpp"
#include "regolith/runtime/watchdog.hpp"
#include "temp_dir.hpp"

using namespace regolith;
using namespace regolith::runtime;

namespace {

// A component the deployment declares critical: its health gates the watchdog.
class CriticalWorker final : public Component {
 public:
  void configure(Params&, Context&) override {}
  void step(const CycleInfo&) override {}
  bool critical() const override { return true; }
};

void register_test_components() {
  static const bool done = [] {
    register_builtin_components();
    ComponentRegistry::instance().add("test_critical_worker", "does nothing; critical",
                                      [] { return std::make_unique<CriticalWorker>(); });
    return true;
  }();
  (void)done;
}

constexpr const char* kDeployment = R"(name: watchdog_test
dds: {enabled: false}
rate_groups:
  - {name: control, rate_hz: 50, members: [worker]}
  - {name: monitor, rate_hz: 1, members: [health]}
components:
  worker: {type: test_critical_worker}
  health: {type: health, stall_cycles: 3}
)";

struct Message {
  TimeNs at;
  std::string state;
};

// The application, a fake systemd, and the run loop of `regolith run` on the
// simulated clock.
class Rover {
 public:
  explicit Rover(TimeNs watchdog_sec)
      : notifier_(
            [this](const std::string& s) {
              sent_.push_back({clock().now(), s});
              return true;
            },
            watchdog_sec) {
    register_test_components();
    app_ = Application::load(Params::load_string(kDeployment, "watchdog_test.yaml"),
                             {.sim_time = true, .enable_dds = false, .open_devices = false});
    app_->start();
    health_ = &app_->context().channel<HealthSnapshot>("health/snapshot");
  }

  SimClock& clock() { return static_cast<SimClock&>(app_->clock()); }
  RateGroup& group(const std::string& name) {
    for (RateGroup* g : app_->view().groups)
      if (g->config().name == name) return *g;
    throw std::runtime_error("no group " + name);
  }
  void stall(const std::string& group_name) { stalled_.insert(&group(group_name)); }
  void resume(const std::string& group_name) { stalled_.erase(&group(group_name)); }

  // Run `seconds` of simulated time in 100 ms slices, releasing every
  // non-stalled group in release order (ties: listed first), and calling
  // update() after each slice like the run loop does.
  void run(double seconds) {
    const TimeNs end = clock().now() + from_seconds(seconds);
    while (clock().now() < end) {
      const TimeNs slice_end = std::min(end, clock().now() + 100 * kNsPerMs);
      for (;;) {
        RateGroup* next = nullptr;
        for (RateGroup* g : app_->view().groups) {
          if (stalled_.count(g)) continue;
          if (next == nullptr || g->next_release() < next->next_release()) next = g;
        }
        if (next == nullptr || next->next_release() > slice_end) break;
        clock().sleep_until(next->next_release());
        next->run_cycle(clock());
      }
      clock().sleep_until(slice_end);
      auto lease = health_->acquire();
      notifier_.update(app_->view(), lease ? &*lease : nullptr, clock().now());
    }
  }

  std::vector<TimeNs> feed_times() const {
    std::vector<TimeNs> t;
    for (const auto& m : sent_)
      if (m.state == "WATCHDOG=1") t.push_back(m.at);
    return t;
  }
  // The longest time systemd would have waited for WATCHDOG=1 between `from`
  // and now.
  TimeNs longest_gap_since(TimeNs from) {
    TimeNs last = from, gap = 0;
    for (TimeNs t : feed_times()) {
      if (t < from) continue;
      gap = std::max(gap, t - last);
      last = t;
    }
    return std::max(gap, clock().now() - last);
  }
  std::vector<std::string> statuses() const {
    std::vector<std::string> s;
    for (const auto& m : sent_)
      if (m.state.rfind("STATUS=", 0) == 0) s.push_back(m.state.substr(7));
    return s;
  }

  SystemdNotifier& notifier() { return notifier_; }
  const std::vector<Message>& sent() const { return sent_; }

 private:
  std::vector<Message> sent_;
  SystemdNotifier notifier_;
  std::unique_ptr<Application> app_;
  LatestPool<HealthSnapshot>* health_ = nullptr;
  std::set<RateGroup*> stalled_;
};

constexpr TimeNs kWatchdogSec = 5 * kNsPerSec;

}  // namespace

TEST(Watchdog, ReadyOnceEveryGroupRanThenFedOncePerHealthyHealthCycle) {
  Rover r(kWatchdogSec);
  r.run(10.0);
  ASSERT_FALSE(r.sent().empty());
  EXPECT_EQ(r.sent().front().state, "READY=1");
  EXPECT_EQ(r.sent().front().at,
            kNsPerSec + 100 * kNsPerMs);  // end of the first 100 ms slice
  EXPECT_EQ(std::count_if(r.sent().begin(), r.sent().end(), [](const Message& m) { return m.state == "READY=1"; }), 1);
  // Health ran at t = 1, 2, ..., 11 s (the last slice ends at 11 s and includes
  // that release): one feed per snapshot, never two for the same snapshot
  // although update() ran 100 times.
  EXPECT_EQ(r.group("monitor").counters().cycles, 11u);
  EXPECT_EQ(r.notifier().feeds(), 11u);
  EXPECT_EQ(r.notifier().withheld(), 0u);
  // First feed with READY at 1.1 s (end of the first slice), then one every
  // second.
  EXPECT_EQ(r.feed_times().front(), kNsPerSec + 100 * kNsPerMs);
  EXPECT_EQ(r.feed_times().back(), 11 * kNsPerSec);
  EXPECT_EQ(r.longest_gap_since(kNsPerSec), kNsPerSec);
  EXPECT_EQ(r.statuses().back(), "running: 2 rate groups, 2 components");
  EXPECT_TRUE(r.notifier().healthy());
}

TEST(Watchdog, StalledCriticalComponentStopsTheFeedingUntilItRecovers) {
  Rover r(kWatchdogSec);
  r.run(5.0);  // health at 1..6 s: 6 feeds
  ASSERT_EQ(r.notifier().feeds(), 6u);
  const TimeNs stall_at = r.clock().now();  // 6.0 s
  ASSERT_EQ(stall_at, 6 * kNsPerSec);
  r.stall("control");
  r.run(10.0);  // health at 7..16 s
  // stall_cycles = 3: the 1st and 2nd health cycles after the stall (7, 8 s)
  // still see the worker as fresh (heartbeat unchanged for 1, 2 cycles); from
  // the 3rd (9 s) on it is reported stalled.
  EXPECT_EQ(r.notifier().feeds(), 8u);
  EXPECT_EQ(r.notifier().withheld(), 8u);  // 9..16 s
  EXPECT_EQ(r.feed_times().back(), 8 * kNsPerSec);
  EXPECT_FALSE(r.notifier().healthy());
  EXPECT_EQ(r.statuses().back(), "watchdog withheld: component 'worker': no heartbeat: component stalled");
  // systemd would have fired: no WATCHDOG=1 for longer than WatchdogSec.
  EXPECT_GT(r.longest_gap_since(stall_at), kWatchdogSec);
  EXPECT_EQ(r.clock().now() - r.feed_times().back(), 8 * kNsPerSec);

  // The worker's thread resumes: the next health cycle sees its heartbeat move
  // again.
  r.resume("control");
  const TimeNs resumed_at = r.clock().now();
  r.run(3.0);
  EXPECT_EQ(r.notifier().feeds(), 11u);  // 17, 18, 19 s
  EXPECT_TRUE(r.notifier().healthy());
  EXPECT_EQ(r.statuses().back(), "running: 2 rate groups, 2 components");
  EXPECT_LE(r.longest_gap_since(resumed_at + kNsPerSec), kNsPerSec);
}

TEST(Watchdog, StalledHealthMonitorStopsTheFeedingAndSaysSo) {
  Rover r(kWatchdogSec);
  r.run(3.0);  // health at 1..4 s
  ASSERT_EQ(r.notifier().feeds(), 4u);
  r.stall("monitor");
  r.run(8.0);
  // The last snapshot (4 s) stays all_critical_ok = true, but it is not new:
  // never fed again.
  EXPECT_EQ(r.notifier().feeds(), 4u);
  EXPECT_EQ(r.notifier().withheld(), 0u);
  EXPECT_EQ(r.longest_gap_since(4 * kNsPerSec), 8 * kNsPerSec);
  const auto st = r.statuses();
  ASSERT_GE(st.size(), 2u);
  // Reported once, at the first update after the silence exceeded 3 health
  // periods (7.1 s).
  EXPECT_EQ(st.back(),
            "watchdog withheld: health monitor silent for 3.1 s "
            "(health rate group stalled)");
  EXPECT_EQ(
      std::count_if(st.begin(), st.end(), [](const std::string& s) { return s.find("silent") != std::string::npos; }),
      1);
}

TEST(Watchdog, TickFeedsOnlyFreshHealthySnapshots) {
  std::vector<std::string> sent;
  SystemdNotifier n(
      [&](const std::string& s) {
        sent.push_back(s);
        return true;
      },
      kWatchdogSec);
  HealthSnapshot s;
  EXPECT_FALSE(n.tick(nullptr));
  s.stamp = 10;
  EXPECT_TRUE(n.tick(s));
  EXPECT_FALSE(n.tick(s));  // same snapshot again: not fresh
  s.stamp = 5;
  EXPECT_FALSE(n.tick(s));  // older
  s.stamp = 20;
  s.all_critical_ok = false;
  EXPECT_FALSE(n.tick(s));
  EXPECT_FALSE(n.tick(s));
  s.stamp = 30;
  s.all_critical_ok = true;
  EXPECT_TRUE(n.tick(s));
  EXPECT_EQ(sent, (std::vector<std::string>{"WATCHDOG=1", "WATCHDOG=1"}));
  EXPECT_EQ(n.feeds(), 2u);
  EXPECT_EQ(n.withheld(), 1u);
  EXPECT_EQ(n.last_fed_stamp(), 30);

  SystemdNotifier no_watchdog(
      [&](const std::string& s2) {
        sent.push_back(s2);
        return true;
      },
      0);
  s.stamp = 40;
  EXPECT_FALSE(no_watchdog.tick(s));
  EXPECT_EQ(sent.size(), 2u);
}

TEST(Watchdog, DescribeNamesEveryUnhealthyCriticalComponent) {
  HealthSnapshot s;
  s.count = 3;
  auto set = [&](std::size_t i, const char* name, bool critical, Level level, const char* msg) {
    std::snprintf(s.entries[i].name.data(), kNameLen, "%s", name);
    s.entries[i].critical = critical;
    s.entries[i].level = level;
    s.entries[i].message = msg;
  };
  set(0, "sinkage", true, Level::kStale, "no heartbeat: component stalled");
  set(1, "saliency", false, Level::kError,
      "component in error state");  // not critical: ignored
  set(2, "health", true, Level::kError, "component in error state");
  EXPECT_EQ(SystemdNotifier::describe(s), "");  // all_critical_ok still true
  s.all_critical_ok = false;
  EXPECT_EQ(SystemdNotifier::describe(s),
            "component 'sinkage': no heartbeat: component stalled; component "
            "'health': component in error state");
}

// The real transport: the sd_notify datagram protocol to $NOTIFY_SOCKET, and
// WatchdogSec from $WATCHDOG_USEC / $WATCHDOG_PID, exactly as systemd sets them
// for a Type=notify service.
TEST(Watchdog, RealNotifierTalksToNotifySocket) {
  unsetenv("NOTIFY_SOCKET");
  EXPECT_FALSE(SystemdNotifier().active());

  const regolith::testing::TempDir dir("notify");  // removed whatever the outcome
  const std::string path = dir.file("notify");
  const int fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof(addr.sun_path), "%s", path.c_str());
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
  timeval tv{2, 0};  // a missing datagram fails the test instead of hanging it
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));

  setenv("NOTIFY_SOCKET", path.c_str(), 1);
  setenv("WATCHDOG_USEC", "4000000", 1);
  setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  SystemdNotifier n;
  ASSERT_TRUE(n.active());
  EXPECT_EQ(n.watchdog_interval(), 4 * kNsPerSec);
  n.ready();
  HealthSnapshot s;
  s.stamp = 123;
  EXPECT_TRUE(n.tick(s));
  n.status("watchdog withheld: component 'x': stalled");
  n.stopping();
  std::vector<std::string> got;
  char buf[512];
  for (int i = 0; i < 4; ++i) {
    const ssize_t k = recv(fd, buf, sizeof(buf), 0);
    ASSERT_GT(k, 0) << "datagram " << i << " missing";
    got.emplace_back(buf, static_cast<std::size_t>(k));
  }
  EXPECT_EQ(got, (std::vector<std::string>{"READY=1", "WATCHDOG=1", "STATUS=watchdog withheld: component 'x': stalled",
                                           "STOPPING=1\nSTATUS=stopping"}));

  // A watchdog meant for another process (WATCHDOG_PID differs) is not ours.
  setenv("WATCHDOG_PID", "1", 1);
  EXPECT_EQ(SystemdNotifier().watchdog_interval(), 0);
  close(fd);
  unsetenv("NOTIFY_SOCKET");
}
