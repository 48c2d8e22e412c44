// The event log: health snapshots -> events (HealthEvents), spdlog -> /rosout (RosoutSink, rate
// limited on the process clock), and a simulated run whose encoders fault and recover, read on
// /rosout by a DDS reader in the same process.
#include <atomic>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <spdlog/logger.h>
#include <spdlog/spdlog.h>

#include "../dds/dds_test_util.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/reader.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/event_log.hpp"

using namespace regolith;
using namespace regolith::runtime;
namespace rd = regolith::dds;
namespace tst = regolith::dds::testing;

namespace {

HealthEntry entry(HealthEntry::Kind kind, const char* name, Level level, const char* message, std::uint64_t slips = 0) {
  HealthEntry e;
  e.kind = kind;
  std::strncpy(e.name.data(), name, e.name.size() - 1);
  e.level = level;
  e.message = message;
  e.slips = slips;
  return e;
}

HealthSnapshot snapshot(std::initializer_list<HealthEntry> entries, TimeNs stamp) {
  HealthSnapshot s;
  s.stamp = stamp;
  for (const auto& e : entries) s.entries[s.count++] = e;
  return s;
}

struct Got {
  int level;
  std::string name, msg;
  TimeNs stamp;
};

std::vector<Got> take_all(rd::Reader<msgs::rcl_interfaces::Log>& r) {
  std::vector<Got> out;
  r.take(
      [&](const msgs::rcl_interfaces::Log& m, const dds_sample_info_t&) {
        out.push_back({m.level, m.name != nullptr ? m.name : "", m.msg != nullptr ? m.msg : "", rd::to_ns(m.stamp)});
      },
      1000);
  return out;
}

}  // namespace

TEST(HealthEvents, FaultsRecoveriesAndSlipsBecomeOneLineEach) {
  HealthEvents ev;
  using K = HealthEntry::Kind;
  auto e0 = ev.update(
      snapshot({entry(K::kRateGroup, "io", Level::kOk, "ok"), entry(K::kCamera, "front", Level::kOk, "running")}, 1));
  EXPECT_TRUE(e0.empty());
  auto e1 = ev.update(snapshot({entry(K::kRateGroup, "io", Level::kWarn, "cycle slips since last report", 3),
                                entry(K::kCamera, "front", Level::kError, "faulted")},
                               2));
  ASSERT_EQ(e1.size(), 3u);
  EXPECT_EQ(e1[0].text, "rate group io: cycle slips since last report");
  EXPECT_EQ(e1[0].severity, Event::Severity::kWarn);
  EXPECT_EQ(e1[1].text, "rate group io: 3 cycle slips (3 in total)");
  EXPECT_EQ(e1[2].text, "camera front: faulted");
  EXPECT_EQ(e1[2].severity, Event::Severity::kError);
  // Still faulted: nothing new; the slips stopped: the group recovers.
  auto e2 = ev.update(snapshot(
      {entry(K::kRateGroup, "io", Level::kOk, "ok", 3), entry(K::kCamera, "front", Level::kError, "faulted")}, 3));
  ASSERT_EQ(e2.size(), 1u);
  EXPECT_EQ(e2[0].text, "rate group io: recovered (ok)");
  EXPECT_EQ(e2[0].severity, Event::Severity::kInfo);
  auto e3 = ev.update(snapshot(
      {entry(K::kRateGroup, "io", Level::kOk, "ok", 3), entry(K::kCamera, "front", Level::kOk, "running")}, 4));
  ASSERT_EQ(e3.size(), 1u);
  EXPECT_EQ(e3[0].text, "camera front: recovered (running)");
  // Slips the group did not cause are told apart in the count: late starts and stalls.
  HealthEntry outside = entry(K::kRateGroup, "io", Level::kOk, "ok", 6);
  outside.late_start_slips = 1;
  outside.stall_slips = 2;
  auto e4 = ev.update(snapshot({outside, entry(K::kCamera, "front", Level::kOk, "running")}, 5));
  ASSERT_EQ(e4.size(), 1u);
  EXPECT_EQ(e4[0].text, "rate group io: 3 cycle slips (1 from a late start, 2 from a stall, 6 in total)");
  // A first snapshot reports errors at once; warnings (inputs not delivered yet at start-up)
  // only when the next snapshot still has them.
  HealthEvents late;
  auto f = late.update(snapshot(
      {entry(K::kComponent, "sfs", Level::kStale, "no heartbeat: component stalled"),
       entry(K::kComponent, "soil", Level::kWarn, "stale input"), entry(K::kImu, "body_imu", Level::kError, "faulted")},
      9));
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].text, "imu body_imu: faulted");
  auto g = late.update(
      snapshot({entry(K::kComponent, "sfs", Level::kStale, "no heartbeat: component stalled"),
                entry(K::kComponent, "soil", Level::kOk, "ok"), entry(K::kImu, "body_imu", Level::kError, "faulted")},
               10));
  ASSERT_EQ(g.size(), 1u);
  EXPECT_EQ(g[0].text, "component sfs: no heartbeat: component stalled");
  EXPECT_EQ(g[0].severity, Event::Severity::kWarn);
}

// 100 warnings in one instant: the burst (5) goes out, the rest are counted; one simulated second
// later the budget is back and the next record is preceded by "95 log messages suppressed".
TEST(RosoutSink, RateLimitedOnTheProcessClockWithASuppressedCount) {
  tst::use_loopback_config();
  const auto domain = tst::test_domain();
  rd::Participant pp({domain, tst::unique_ns()});
  rd::Reader<msgs::rcl_interfaces::Log> reader(pp, "/rosout", rd::find_topic("/rosout")->reader_qos());
  TimeNs now = 5 * kNsPerSec;
  auto sink = std::make_shared<RosoutSink>(
      pp, "test_rover", [&now] { return now; }, 10.0, 5.0);
  spdlog::logger log("event_log_test", sink);
  pp.start();
  ASSERT_TRUE(tst::eventually([&] {
    for (const auto& s : pp.stats())
      if (s.topic == "/rosout" && s.matched_readers > 0) return true;
    return false;
  }));
  for (int i = 0; i < 100; ++i) log.warn("camera front: faulted ({})", i);
  EXPECT_EQ(sink->published(), 5u);
  EXPECT_EQ(sink->suppressed_total(), 95u);
  now += kNsPerSec;
  log.error("encoders wheels: faulted");
  EXPECT_EQ(sink->published(), 7u);
  std::vector<Got> got;
  ASSERT_TRUE(tst::eventually([&] {
    for (auto& g : take_all(reader)) got.push_back(g);
    return got.size() >= 7u;
  }));
  ASSERT_EQ(got.size(), 7u);
  EXPECT_EQ(got[0].msg, "camera front: faulted (0)");
  EXPECT_EQ(got[0].level, 30);
  EXPECT_EQ(got[0].name, "test_rover");
  EXPECT_EQ(got[5].msg, "95 log messages suppressed (more than 10 per second)");
  EXPECT_EQ(got[6].msg, "encoders wheels: faulted");
  EXPECT_EQ(got[6].level, 40);
  EXPECT_EQ(got[6].stamp, to_ros_time(now));
  pp.stop();
}
