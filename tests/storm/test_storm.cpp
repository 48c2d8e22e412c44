// Fault storm in real time (issue 20): the deployment of tests/storm/storm_rover.yaml runs for 8 s
// of wall time on the real clock, with the systemd watchdog logic of `regolith run` driven the
// same way (SystemdNotifier::update after every slice of the run loop, its datagrams captured):
//   - the hub camera disconnects about every second (6 outages in 8 s), the wheel encoders give
//     50 % garbage angles and drop 20 % of their samples, and `burner` (cpu_load, critical) spins
//     80 ms of CPU in its 50 ms period from the first cycle, then stalls for 2.5 s at 4 s;
//   - every other rate group keeps its rate: at most 1 % of its cycles slip in io (100 Hz), sinkage,
//     terrain and health, beyond the cycles a stall of the whole process could cost (a watcher
//     thread that only sleeps measures them: a virtual machine's vCPU descheduled by its host
//     delays every thread at once, 25-90 ms seen on the 2-core development VM);
//   - the health snapshot names the culprit of the burn group's slips (the `burner` entry:
//     "overruns its rate group's period") and the camera outages;
//   - the watchdog is fed throughout the overruns, outages and garbage, withheld while the
//     critical component is really stuck (naming it), and fed again once it steps again.
#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <time.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "cli_support.hpp"
#include "diagnostics.hpp"
#include "regolith/core/params.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/wheel_encoders.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/context.hpp"
#include "regolith/runtime/health.hpp"
#include "regolith/runtime/rate_group.hpp"
#include "regolith/runtime/watchdog.hpp"

namespace regolith {
namespace {

struct Notification {
  TimeNs t = 0;  // since the start
  std::string text;
};

// A thread that only sleeps to absolute 1 ms deadlines: its lateness beyond 5 ms is a stall of the
// process by the scheduler or the host, which no rate group could have run through. `slips_for`
// bounds the releases of a group of that period those stalls can have cost: each stall covers
// gap / period releases plus one it may straddle.
class StallWatcher {
 public:
  StallWatcher() : thread_([this] { watch(); }) {}
  ~StallWatcher() { stop(); }
  void stop() {
    stop_.store(true);
    if (thread_.joinable()) thread_.join();
  }
  std::uint64_t slips_for(TimeNs period) const {
    std::uint64_t n = 0;
    for (const TimeNs gap : gaps_) n += static_cast<std::uint64_t>(gap / period) + 1;
    return n;
  }
  TimeNs worst() const { return gaps_.empty() ? 0 : *std::max_element(gaps_.begin(), gaps_.end()); }
  std::size_t stalls() const { return gaps_.size(); }

 private:
  void watch() {
    gaps_.reserve(4096);
    TimeNs next = monotonic_now();
    while (!stop_.load(std::memory_order_relaxed)) {
      next += kNsPerMs;
      const timespec ts{static_cast<time_t>(next / kNsPerSec), static_cast<long>(next % kNsPerSec)};
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
      }
      const TimeNs late = monotonic_now() - next;
      if (late > 5 * kNsPerMs && gaps_.size() < gaps_.capacity()) gaps_.push_back(late);
      if (late > 0) next += late;  // measure each stall once
    }
  }
  std::atomic<bool> stop_{false};
  std::vector<TimeNs> gaps_;
  std::thread thread_;
};

TEST(Storm, OtherGroupsKeepTheirRateTheCulpritIsNamedAndTheWatchdogStopsOnlyForTheStall) {
  if (std::thread::hardware_concurrency() < 2) GTEST_SKIP() << "needs 2 CPUs (one is burnt)";
  cli::register_everything();
  const std::string path = std::string(REGOLITH_SOURCE_DIR) + "/tests/storm/storm_rover.yaml";
  auto app = runtime::Application::load(Params::load_file(path), {.enable_dds = false});
  auto& health = app->context().channel<runtime::HealthSnapshot>("health/snapshot");

  TimeNs t0 = 0;
  std::vector<Notification> sent;
  runtime::SystemdNotifier notifier(
      [&](const std::string& text) {
        sent.push_back({monotonic_now() - t0, text});
        return true;
      },
      2 * kNsPerSec);
  bool named_culprit = false, camera_error = false;
  std::atomic<bool> stop{false};
  t0 = monotonic_now();
  StallWatcher watcher;
  app->start();
  while (monotonic_now() - t0 < 8 * kNsPerSec) {
    app->run(50 * kNsPerMs, stop);  // the slices of `regolith run`'s loop
    const auto snapshot = health.acquire();
    notifier.update(app->view(), snapshot ? &*snapshot : nullptr, app->clock().now());
    if (!snapshot) continue;
    const auto* burner = testing::health_entry(*snapshot, "burner", runtime::HealthEntry::Kind::kComponent);
    if (burner != nullptr && burner->level == runtime::Level::kWarn &&
        std::strcmp(burner->message, "overruns its rate group's period") == 0)
      named_culprit = true;
    const auto* cam = testing::health_entry(*snapshot, "wheel_cam", runtime::HealthEntry::Kind::kCamera);
    if (cam != nullptr && cam->level == runtime::Level::kError) camera_error = true;
  }
  app->stop();
  watcher.stop();
  std::printf("process stalls (a sleeping thread > 5 ms late): %zu, worst %.1f ms\n", watcher.stalls(),
              static_cast<double>(watcher.worst()) * 1e-6);

  // ---- rate groups: only the burnt one slips ----
  for (const runtime::RateGroup* g : app->view().groups) {
    const auto& c = g->counters();
    std::printf(
        "group %s: %llu cycles, %llu slips (%llu from a late start, %llu from a stall), wake-up latency max "
        "%.1f ms\n",
        g->config().name.c_str(), static_cast<unsigned long long>(c.cycles), static_cast<unsigned long long>(c.slips),
        static_cast<unsigned long long>(c.late_start_slips), static_cast<unsigned long long>(c.stall_slips),
        static_cast<double>(g->wakeup_latency().summary().max) * 1e-6);
    if (g->config().name == "burn") {
      EXPECT_GT(c.slips - c.late_start_slips - c.stall_slips, 20u)
          << "burn: 80 ms of CPU in every 50 ms period, its own overruns";
    } else {
      // The burnt group's overruns must not spread: a group that shared its thread or a lock with
      // `burner` would slip in most cycles. Cycles started late because the (virtual) machine
      // stalled the whole process are not that (seen: io 16 of 800 in bursts of up to 9, every
      // group's wake-up 40-90 ms late at the same moments, on a 2-core VM; 0 in most runs): those
      // the watcher saw are allowed, and 1 % of the cycles beyond them.
      const double expected = 8e9 / static_cast<double>(g->config().period);
      const auto stalled = static_cast<double>(watcher.slips_for(g->config().period));
      EXPECT_LE(static_cast<double>(c.slips), 0.01 * expected + stalled)
          << g->config().name << ": slips beyond scheduling noise (" << stalled << " explained by process stalls)";
      EXPECT_GT(static_cast<double>(c.cycles), 0.95 * expected) << g->config().name << " kept its rate";
    }
  }
  EXPECT_TRUE(named_culprit) << "no health snapshot named `burner` as the overrunning member";

  // ---- devices: outages counted and reported, garbage rejected ----
  for (hal::Device* d : app->context().all_devices()) {
    if (d->id() == "wheel_cam") {
      const auto st = dynamic_cast<hal::Camera*>(d)->stats();
      EXPECT_GE(st.faults, 5u);
      EXPECT_GE(st.recoveries + 1, st.faults);
    }
    if (d->id() == "wheels") {
      EXPECT_GT(dynamic_cast<hal::WheelEncoders*>(d)->stats().rejected, 500u);
    }
  }
  EXPECT_TRUE(camera_error) << "the health snapshot never showed the camera outage";

  // ---- the watchdog: fed through the storm, withheld only while the critical component is stuck ----
  // In notification order: the first "withheld" STATUS, then (update() feeds a healthy snapshot
  // before it says so) the feed of the first healthy snapshot and "STATUS=running ...".
  std::size_t withheld = sent.size(), resumed = sent.size();
  for (std::size_t i = 0; i < sent.size(); ++i) {
    if (sent[i].text.rfind("STATUS=watchdog withheld", 0) == 0) {
      if (withheld == sent.size()) withheld = i;
      EXPECT_NE(sent[i].text.find("component 'burner': no heartbeat: component stalled"), std::string::npos)
          << sent[i].text;
    } else if (withheld < sent.size() && resumed == sent.size() && sent[i].text.rfind("STATUS=running", 0) == 0) {
      resumed = i;
    }
  }
  ASSERT_LT(withheld, sent.size()) << "the watchdog was never withheld during the 2.5 s stall";
  ASSERT_LT(resumed, sent.size()) << "the watchdog never resumed after the stall";
  int fed_before = 0, fed_during = 0, fed_after = 0;
  for (std::size_t i = 0; i < sent.size(); ++i) {
    if (sent[i].text != "WATCHDOG=1") continue;
    if (i < withheld)
      ++fed_before;
    else if (i + 1 < resumed)
      ++fed_during;
    else
      ++fed_after;
  }
  EXPECT_GE(sent[withheld].t, 4 * kNsPerSec) << "withheld before the stall: overruns, outages or garbage stopped it";
  EXPECT_LE(sent[withheld].t, 5500 * kNsPerMs) << "the stall (at 4 s) took too long to be noticed";
  EXPECT_GE(sent[resumed].t, 6500 * kNsPerMs) << "resumed before the 2.5 s stall ended";
  EXPECT_GE(fed_before, 10) << "4 Hz health for 4 s, overruns and all";
  EXPECT_EQ(fed_during, 0);
  EXPECT_GE(fed_after, 1);
}

}  // namespace
}  // namespace regolith
