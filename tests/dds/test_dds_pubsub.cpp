// DDS integration tests inside one process: every message type written and read
// back through Cyclone (writer + reader in the same domain, unique namespace),
// the Outbox counters, the allocation-free RT path, offered-deadline events,
// latched state for late readers and `echo`.
#include <algorithm>
#include <cstdlib>
#include <functional>
#include <limits>
#include <new>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dds_test_util.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/reader.hpp"
#include "regolith/dds/topics.hpp"

// allocation counter: regolith::testing::thread_allocations() (every operator new on this thread)
#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new

namespace rd = regolith::dds;
namespace m = regolith::msgs;
namespace tst = regolith::dds::testing;
using regolith::kNsPerMs;
using regolith::kNsPerSec;

namespace {

class DdsPubSub : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { tst::use_loopback_config(); }
  void SetUp() override {
    pp_ = std::make_unique<rd::Participant>(rd::ParticipantConfig{tst::test_domain(), tst::unique_ns()});
  }
  // Takes exactly one sample of type Msg from `r` (waiting up to 5 s) and hands
  // it to `check`.
  template <class Msg, class F>
  void expect_one(rd::Reader<Msg>& r, F&& check) {
    std::size_t got = 0;
    ASSERT_TRUE(tst::eventually([&] {
      r.wait(10 * kNsPerMs);
      got += r.take([&](const Msg& s, const dds_sample_info_t&) { check(s); });
      return got > 0;
    }));
    EXPECT_EQ(got, 1u);
  }
  std::unique_ptr<rd::Participant> pp_;
};

void fill_joint_state(m::sensor_msgs::JointState& js, regolith::TimeNs t, double base) {
  rd::set_time(js.header.stamp, t);
  rd::copy_string(js.header.frame_id, 32, "base_link");
  static const char* const kNames[4] = {"wheel_fl", "wheel_fr", "wheel_rl", "wheel_rr"};
  rd::set_length(js.name, 4);
  rd::set_length(js.position, 4);
  rd::set_length(js.velocity, 4);
  rd::set_length(js.effort, 0);
  for (std::uint32_t i = 0; i < 4; ++i) {
    rd::copy_string(js.name._buffer[i], 32, kNames[i]);
    js.position._buffer[i] = base + 0.1 * i;
    js.velocity._buffer[i] = -base;
  }
}

}  // namespace

TEST_F(DdsPubSub, TopicNameOnTheWire) {
  const dds_entity_t tp = pp_->topic("joint_states", rd::MsgTraits<m::sensor_msgs::JointState>::descriptor());
  char name[256];
  ASSERT_GT(dds_get_name(tp, name, sizeof name), 0);  // returns the length
  EXPECT_EQ(std::string(name), "rt/" + pp_->ns() + "/joint_states");
  const dds_entity_t diag =
      pp_->topic("/diagnostics", rd::MsgTraits<m::diagnostic_msgs::DiagnosticArray>::descriptor());
  ASSERT_GT(dds_get_name(diag, name, sizeof name), 0);
  EXPECT_STREQ(name, "rt/diagnostics");
  char type[256];
  ASSERT_GT(dds_get_type_name(tp, type, sizeof type), 0);
  EXPECT_STREQ(type, "sensor_msgs::msg::dds_::JointState_");
  // Same name, another type: refused with both type names in the message.
  try {
    pp_->topic("joint_states", rd::MsgTraits<m::regolith_msgs::WheelSinkage>::descriptor());
    FAIL() << "no exception";
  } catch (const rd::DdsError& e) {
    EXPECT_NE(std::string(e.what()).find("sensor_msgs::msg::dds_::JointState_"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("regolith_msgs::msg::dds_::WheelSinkage_"), std::string::npos);
  }
}

TEST_F(DdsPubSub, JointStateRoundTripThroughOutbox) {
  rd::Reader<m::sensor_msgs::JointState> r(*pp_, "joint_states", rd::find_topic("joint_states")->reader_qos());
  auto box = pp_->make_outbox<m::sensor_msgs::JointState>(
      "joint_states", rd::QosProfile::stream(10), {},
      [](m::sensor_msgs::JointState& js) { rd::reserve(js, {.joints = 4}); });
  ASSERT_TRUE(tst::eventually([&] { return box->matched_readers() == 1; }));
  auto* js = box->begin();
  ASSERT_NE(js, nullptr);
  fill_joint_state(*js, 7 * kNsPerSec + 250, 1.5);
  box->commit();
  EXPECT_EQ(pp_->flush_all(), 1u);
  expect_one(r, [](const m::sensor_msgs::JointState& s) {
    EXPECT_EQ(s.header.stamp.sec, 7);
    EXPECT_EQ(s.header.stamp.nanosec, 250u);
    EXPECT_STREQ(s.header.frame_id, "base_link");
    ASSERT_EQ(s.name._length, 4u);
    EXPECT_STREQ(s.name._buffer[2], "wheel_rl");
    ASSERT_EQ(s.position._length, 4u);
    EXPECT_DOUBLE_EQ(s.position._buffer[3], 1.8);
    EXPECT_DOUBLE_EQ(s.velocity._buffer[0], -1.5);
    EXPECT_EQ(s.effort._length, 0u);
  });
  EXPECT_EQ(box->published(), 1u);
  EXPECT_EQ(box->dropped(), 0u);
}

TEST_F(DdsPubSub, DiagnosticArrayRoundTripWithPublisherThread) {
  rd::Reader<m::diagnostic_msgs::DiagnosticArray> r(*pp_, "/diagnostics", rd::find_topic("diagnostics")->reader_qos());
  auto box = pp_->make_outbox<m::diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", rd::QosProfile::diagnostics(), {}, [](m::diagnostic_msgs::DiagnosticArray& a) {
        rd::reserve(a, {.statuses = 2, .values_per_status = 3, .string_capacity = 48});
      });
  pp_->start();
  ASSERT_TRUE(tst::eventually([&] { return box->matched_readers() == 1; }));
  auto* a = box->begin();
  ASSERT_NE(a, nullptr);
  rd::set_time(a->header.stamp, 42 * kNsPerSec);
  rd::set_length(a->status, 2);
  auto& s0 = a->status._buffer[0];
  s0.level = m::diagnostic_msgs::kWarn;
  rd::copy_string(s0.name, 48, "sfs: timing");
  rd::copy_string(s0.message, 48, "2 cycle slips");
  rd::copy_string(s0.hardware_id, 48, "rate_group_fast");
  rd::set_length(s0.values, 3);
  rd::copy_string(s0.values._buffer[0].key, 48, "max_exec_us");
  rd::format_double(s0.values._buffer[0].value, 48, 812.5);
  rd::copy_string(s0.values._buffer[1].key, 48, "cycle_slips");
  rd::format_int(s0.values._buffer[1].value, 48, 2);
  rd::copy_string(s0.values._buffer[2].key, 48, "period_ms");
  rd::format_int(s0.values._buffer[2].value, 48, 10);
  auto& s1 = a->status._buffer[1];
  s1.level = m::diagnostic_msgs::kStale;
  rd::copy_string(s1.name, 48, "encoders: input");
  rd::copy_string(s1.message, 48, "stale");
  rd::set_length(s1.values, 0);
  box->commit();
  expect_one(r, [](const m::diagnostic_msgs::DiagnosticArray& s) {
    EXPECT_EQ(s.header.stamp.sec, 42);
    ASSERT_EQ(s.status._length, 2u);
    EXPECT_EQ(s.status._buffer[0].level, 1);
    EXPECT_STREQ(s.status._buffer[0].name, "sfs: timing");
    EXPECT_STREQ(s.status._buffer[0].message, "2 cycle slips");
    EXPECT_STREQ(s.status._buffer[0].hardware_id, "rate_group_fast");
    ASSERT_EQ(s.status._buffer[0].values._length, 3u);
    EXPECT_STREQ(s.status._buffer[0].values._buffer[0].value, "812.5");
    EXPECT_STREQ(s.status._buffer[0].values._buffer[1].value, "2");
    EXPECT_STREQ(s.status._buffer[0].values._buffer[2].key, "period_ms");
    EXPECT_EQ(s.status._buffer[1].level, 3);
    EXPECT_EQ(s.status._buffer[1].values._length, 0u);
  });
  pp_->stop();
  EXPECT_EQ(box->published(), 1u);
  EXPECT_NE(pp_->summary().find("/diagnostics published 1 dropped 0"), std::string::npos) << pp_->summary();
}

TEST_F(DdsPubSub, GridMapLatchedForLateReader) {
  auto box = pp_->make_outbox<m::grid_map_msgs::GridMap>(
      "terrain/grid_map", rd::QosProfile::state(), {.mode = rd::OutboxMode::kLatest, .slots = 3},
      [](m::grid_map_msgs::GridMap& g) { rd::reserve(g, {.layers = 2, .basic_layers = 1, .size_x = 4, .size_y = 3}); });
  auto* g = box->begin();
  ASSERT_NE(g, nullptr);
  rd::set_time(g->header.stamp, 5 * kNsPerSec);
  rd::copy_string(g->header.frame_id, 32, "odom");
  g->info.resolution = 0.1;
  g->info.length_x = 0.4;
  g->info.length_y = 0.3;
  g->info.pose.position.x = 1.25;
  rd::set_length(g->layers, 2);
  rd::copy_string(g->layers._buffer[0], 32, "elevation");
  rd::copy_string(g->layers._buffer[1], 32, "traversability");
  rd::set_length(g->basic_layers, 1);
  rd::copy_string(g->basic_layers._buffer[0], 32, "elevation");
  rd::set_length(g->data, 2);
  for (std::uint32_t i = 0; i < 12; ++i) {
    g->data._buffer[0].data._buffer[i] = 0.01f * static_cast<float>(i);
    g->data._buffer[1].data._buffer[i] = 1.0f;
  }
  g->data._buffer[1].data._buffer[5] = std::numeric_limits<float>::quiet_NaN();
  box->commit();
  EXPECT_EQ(pp_->flush_all(), 1u);
  // The reader is created after the write: transient-local delivers the latched
  // map.
  rd::Reader<m::grid_map_msgs::GridMap> r(*pp_, "terrain/grid_map", rd::find_topic("terrain/grid_map")->reader_qos());
  expect_one(r, [](const m::grid_map_msgs::GridMap& s) {
    EXPECT_EQ(s.header.stamp.sec, 5);
    EXPECT_STREQ(s.header.frame_id, "odom");
    EXPECT_DOUBLE_EQ(s.info.resolution, 0.1);
    EXPECT_DOUBLE_EQ(s.info.length_y, 0.3);
    EXPECT_DOUBLE_EQ(s.info.pose.position.x, 1.25);
    EXPECT_DOUBLE_EQ(s.info.pose.orientation.w, 1.0);
    ASSERT_EQ(s.layers._length, 2u);
    EXPECT_STREQ(s.layers._buffer[1], "traversability");
    EXPECT_STREQ(s.basic_layers._buffer[0], "elevation");
    ASSERT_EQ(s.data._length, 2u);
    ASSERT_EQ(s.data._buffer[0].data._length, 12u);
    EXPECT_FLOAT_EQ(s.data._buffer[0].data._buffer[11], 0.11f);
    EXPECT_TRUE(std::isnan(s.data._buffer[1].data._buffer[5]));
    EXPECT_STREQ(s.data._buffer[0].layout.dim._buffer[0].label, "column_index");
    EXPECT_EQ(s.data._buffer[0].layout.dim._buffer[0].size, 3u);
    EXPECT_EQ(s.data._buffer[0].layout.dim._buffer[1].size, 4u);
    EXPECT_EQ(s.outer_start_index, 0);
  });
}

TEST_F(DdsPubSub, SinkageSoilAndRocksRoundTrip) {
  rd::Reader<m::regolith_msgs::WheelSinkage> rs(*pp_, "terrain/wheel_sinkage",
                                                rd::find_topic("terrain/wheel_sinkage")->reader_qos());
  rd::Reader<m::regolith_msgs::SoilStiffness> rk(*pp_, "terrain/soil", rd::find_topic("terrain/soil")->reader_qos());
  rd::Reader<m::regolith_msgs::RockArray> rr(*pp_, "terrain/rocks", rd::find_topic("terrain/rocks")->reader_qos());
  auto sink = pp_->make_outbox<m::regolith_msgs::WheelSinkage>(
      "terrain/wheel_sinkage", rd::QosProfile::stream(), {},
      [](m::regolith_msgs::WheelSinkage& s) { rd::reserve(s, {.wheels = 2}); });
  auto soil = pp_->make_outbox<m::regolith_msgs::SoilStiffness>(
      "terrain/soil", rd::QosProfile::state(), {.mode = rd::OutboxMode::kLatest, .slots = 3},
      [](m::regolith_msgs::SoilStiffness& s) { rd::reserve(s, rd::SoilStiffnessCapacity{}); });
  auto rocks = pp_->make_outbox<m::regolith_msgs::RockArray>(
      "terrain/rocks", rd::QosProfile::stream(), {},
      [](m::regolith_msgs::RockArray& a) { rd::reserve(a, {.rocks = 4, .hypotheses = 1}); });

  auto* s = sink->begin();
  ASSERT_NE(s, nullptr);
  rd::set_length(s->wheel_names, 2);
  rd::copy_string(s->wheel_names._buffer[0], 32, "wheel_fl");
  rd::copy_string(s->wheel_names._buffer[1], 32, "wheel_fr");
  rd::set_length(s->sinkage_m, 2);
  s->sinkage_m._buffer[0] = 0.012;
  s->sinkage_m._buffer[1] = 0.020;
  rd::set_length(s->confidence, 2);
  s->confidence._buffer[0] = 0.9;
  s->confidence._buffer[1] = 0.4;
  sink->commit();

  auto* k = soil->begin();
  ASSERT_NE(k, nullptr);
  k->k = 8.2e5;
  k->n = 1.1;
  k->k_sigma = 2e4;
  k->n_sigma = 0.07;
  k->mean_sinkage_m = 0.016;
  k->samples_used = 240;
  rd::copy_string(k->soil_class, 32, "dry_sand");
  soil->commit();

  auto* a = rocks->begin();
  ASSERT_NE(a, nullptr);
  rd::copy_string(a->header.frame_id, 32, "base_link");
  rd::set_length(a->detections, 1);
  auto& d = a->detections._buffer[0];
  rd::copy_string(d.id, 32, "r1");
  d.bbox.center.position = {100.5, 200.25};
  d.bbox.center.theta = 0.1;
  d.bbox.size_x = 30;
  d.bbox.size_y = 12;
  rd::set_length(d.results, 1);
  rd::copy_string(d.results._buffer[0].hypothesis.class_id, 32, "rock");
  d.results._buffer[0].hypothesis.score = 0.75;
  d.results._buffer[0].pose.pose.position = {2.5, -0.4, 0.0};
  d.results._buffer[0].pose.covariance[0] = 0.01;
  for (auto* seq : {&a->ground_range_m, &a->lateral_offset_m, &a->width_m, &a->height_m}) rd::set_length(*seq, 1);
  a->ground_range_m._buffer[0] = 2.5;
  a->lateral_offset_m._buffer[0] = -0.4;
  a->width_m._buffer[0] = 0.15;
  a->height_m._buffer[0] = 0.09;
  rd::set_length(a->hazard, 1);
  a->hazard._buffer[0] = true;
  rocks->commit();
  ASSERT_TRUE(tst::eventually(
      [&] { return sink->matched_readers() == 1 && soil->matched_readers() == 1 && rocks->matched_readers() == 1; }));
  EXPECT_EQ(pp_->flush_all(), 3u);

  expect_one(rs, [](const m::regolith_msgs::WheelSinkage& v) {
    ASSERT_EQ(v.wheel_names._length, 2u);
    EXPECT_STREQ(v.wheel_names._buffer[1], "wheel_fr");
    EXPECT_DOUBLE_EQ(v.sinkage_m._buffer[1], 0.020);
    EXPECT_DOUBLE_EQ(v.confidence._buffer[0], 0.9);
  });
  expect_one(rk, [](const m::regolith_msgs::SoilStiffness& v) {
    EXPECT_DOUBLE_EQ(v.k, 8.2e5);
    EXPECT_DOUBLE_EQ(v.n, 1.1);
    EXPECT_DOUBLE_EQ(v.k_sigma, 2e4);
    EXPECT_DOUBLE_EQ(v.n_sigma, 0.07);
    EXPECT_DOUBLE_EQ(v.mean_sinkage_m, 0.016);
    EXPECT_EQ(v.samples_used, 240u);
    EXPECT_STREQ(v.soil_class, "dry_sand");
  });
  expect_one(rr, [](const m::regolith_msgs::RockArray& v) {
    ASSERT_EQ(v.detections._length, 1u);
    const auto& dd = v.detections._buffer[0];
    EXPECT_STREQ(dd.id, "r1");
    EXPECT_DOUBLE_EQ(dd.bbox.center.position.y, 200.25);
    EXPECT_DOUBLE_EQ(dd.bbox.center.theta, 0.1);
    EXPECT_DOUBLE_EQ(dd.bbox.size_x, 30.0);
    ASSERT_EQ(dd.results._length, 1u);
    EXPECT_STREQ(dd.results._buffer[0].hypothesis.class_id, "rock");
    EXPECT_DOUBLE_EQ(dd.results._buffer[0].hypothesis.score, 0.75);
    EXPECT_DOUBLE_EQ(dd.results._buffer[0].pose.pose.position.y, -0.4);
    EXPECT_DOUBLE_EQ(dd.results._buffer[0].pose.covariance[0], 0.01);
    EXPECT_DOUBLE_EQ(v.ground_range_m._buffer[0], 2.5);
    EXPECT_DOUBLE_EQ(v.lateral_offset_m._buffer[0], -0.4);
    EXPECT_DOUBLE_EQ(v.width_m._buffer[0], 0.15);
    EXPECT_DOUBLE_EQ(v.height_m._buffer[0], 0.09);
    ASSERT_EQ(v.hazard._length, 1u);
    EXPECT_TRUE(v.hazard._buffer[0]);
  });
}

// Types without an outbox helper, written with a plain writer from stack-built
// samples.
TEST_F(DdsPubSub, Detection2DArrayAndGeometryRoundTrip) {
  using Arr = m::vision_msgs::Detection2DArray;
  rd::Reader<Arr> r(*pp_, "detections", rd::QosProfile::reader(rd::Reliability::kReliable, rd::Durability::kVolatile));
  rd::Reader<m::geometry_msgs::Pose2D> rp(
      *pp_, "pose2d", rd::QosProfile::reader(rd::Reliability::kBestEffort, rd::Durability::kVolatile));
  const rd::Qos wq(rd::QosProfile::stream(), rd::Qos::For::kWriter);
  const dds_entity_t w =
      dds_create_writer(pp_->handle(), pp_->topic("detections", rd::MsgTraits<Arr>::descriptor()), wq.get(), nullptr);
  const dds_entity_t wp = dds_create_writer(
      pp_->handle(), pp_->topic("pose2d", rd::MsgTraits<m::geometry_msgs::Pose2D>::descriptor()), wq.get(), nullptr);
  ASSERT_GT(w, 0);
  ASSERT_GT(wp, 0);
  std::vector<m::vision_msgs::ObjectHypothesisWithPose> res(2);
  res[0].hypothesis.class_id = tst::cstr("rock");
  res[0].hypothesis.score = 0.6;
  res[1].hypothesis.class_id = tst::cstr("shadow");
  res[1].hypothesis.score = 0.3;
  res[1].pose.pose.orientation = {0.0, 0.0, 0.7071, 0.7071};
  std::vector<m::vision_msgs::Detection2D> dets(1);
  dets[0].header.frame_id = tst::cstr("cam");
  dets[0].id = tst::cstr("7");
  dets[0].bbox = {{{64.0, 48.0}, 0.25}, 10.0, 20.0};
  tst::view(dets[0].results, res);
  Arr arr{};
  arr.header.stamp = {11, 12};
  arr.header.frame_id = tst::cstr("cam");
  tst::view(arr.detections, dets);
  ASSERT_EQ(dds_write(w, &arr), DDS_RETCODE_OK);
  const m::geometry_msgs::Pose2D p{1.0, 2.0, -0.5};
  ASSERT_EQ(dds_write(wp, &p), DDS_RETCODE_OK);
  expect_one(r, [](const Arr& v) {
    EXPECT_EQ(v.header.stamp.nanosec, 12u);
    ASSERT_EQ(v.detections._length, 1u);
    const auto& d = v.detections._buffer[0];
    EXPECT_STREQ(d.id, "7");
    EXPECT_STREQ(d.header.frame_id, "cam");
    EXPECT_DOUBLE_EQ(d.bbox.center.position.x, 64.0);
    EXPECT_DOUBLE_EQ(d.bbox.center.theta, 0.25);
    EXPECT_DOUBLE_EQ(d.bbox.size_y, 20.0);
    ASSERT_EQ(d.results._length, 2u);
    EXPECT_STREQ(d.results._buffer[1].hypothesis.class_id, "shadow");
    EXPECT_DOUBLE_EQ(d.results._buffer[1].hypothesis.score, 0.3);
    EXPECT_DOUBLE_EQ(d.results._buffer[1].pose.pose.orientation.w, 0.7071);
  });
  expect_one(rp, [](const m::geometry_msgs::Pose2D& v) {
    EXPECT_DOUBLE_EQ(v.x, 1.0);
    EXPECT_DOUBLE_EQ(v.y, 2.0);
    EXPECT_DOUBLE_EQ(v.theta, -0.5);
  });
}

TEST_F(DdsPubSub, OutboxCountsDroppedAndSuperseded) {
  auto fifo = pp_->make_outbox<m::sensor_msgs::JointState>(
      "joint_states", rd::QosProfile::stream(), {.mode = rd::OutboxMode::kFifo, .slots = 2},
      [](m::sensor_msgs::JointState& js) { rd::reserve(js, {.joints = 4}); });
  // No publisher thread: both slots end up pending, the third begin() finds
  // none free.
  for (int i = 0; i < 2; ++i) {
    auto* js = fifo->begin();
    ASSERT_NE(js, nullptr);
    fill_joint_state(*js, i, 0.0);
    fifo->commit();
  }
  EXPECT_EQ(fifo->begin(), nullptr);
  EXPECT_EQ(fifo->dropped(), 1u);
  EXPECT_FALSE(fifo->idle());
  EXPECT_EQ(pp_->flush_all(), 2u);
  EXPECT_TRUE(fifo->idle());
  EXPECT_EQ(fifo->published(), 2u);
  EXPECT_EQ(fifo->committed(), 2u);

  auto latest = pp_->make_outbox<m::regolith_msgs::SoilStiffness>(
      "terrain/soil", rd::QosProfile::state(), {.mode = rd::OutboxMode::kLatest, .slots = 4},
      [](m::regolith_msgs::SoilStiffness& s) { rd::reserve(s, rd::SoilStiffnessCapacity{}); });
  for (int i = 0; i < 3; ++i) {
    auto* s = latest->begin();
    ASSERT_NE(s, nullptr);
    s->samples_used = static_cast<std::uint32_t>(i);
    latest->commit();
  }
  EXPECT_EQ(pp_->flush_all(), 1u);  // only the newest is written
  EXPECT_EQ(latest->published(), 1u);
  EXPECT_EQ(latest->dropped(), 2u);
  // abandon() returns the slot: all 4 are usable again.
  for (int i = 0; i < 4; ++i) {
    ASSERT_NE(latest->begin(), nullptr);
    latest->abandon();
  }
  EXPECT_EQ(latest->dropped(), 2u);
  const auto stats = pp_->stats();
  ASSERT_EQ(stats.size(), 2u);
  EXPECT_EQ(stats[0].topic, "/" + pp_->ns() + "/joint_states");
  EXPECT_EQ(stats[0].ros_type, "sensor_msgs/msg/JointState");
  EXPECT_EQ(stats[1].dropped, 2u);
}

TEST_F(DdsPubSub, OutboxRtPathDoesNotAllocate) {
  rd::Reader<m::sensor_msgs::JointState> r(*pp_, "joint_states", rd::find_topic("joint_states")->reader_qos());
  auto box = pp_->make_outbox<m::sensor_msgs::JointState>(
      "joint_states", rd::QosProfile::stream(), {.mode = rd::OutboxMode::kFifo, .slots = 8},
      [](m::sensor_msgs::JointState& js) { rd::reserve(js, {.joints = 4}); });
  pp_->start();
  ASSERT_TRUE(tst::eventually([&] { return box->matched_readers() == 1; }));
  {  // the counter is live: one new, one count
    const std::size_t b = regolith::testing::thread_allocations();
    auto* probe = new int(1);
    EXPECT_EQ(regolith::testing::thread_allocations() - b, 1u);
    delete probe;
  }
  constexpr int kSamples = 200;
  std::size_t news = 0;
  int committed = 0;
  for (int i = 0; i < kSamples; ++i) {
    const std::size_t before = regolith::testing::thread_allocations();
    auto* js = box->begin();  // the RT side: begin, fill, commit
    if (js != nullptr) {
      fill_joint_state(*js, i * 10 * kNsPerMs, 0.01 * i);
      rd::format_double(js->header.frame_id, 32, 0.5 * i);
      rd::copy_string(js->header.frame_id, 32, "base_link");
      box->commit();
      ++committed;
    }
    news += regolith::testing::thread_allocations() - before;
    if (i % 8 == 7) {
      ASSERT_TRUE(pp_->drain(5 * kNsPerSec));  // not RT: lets the publisher keep up
    }
  }
  EXPECT_EQ(news, 0u);
  ASSERT_TRUE(pp_->drain(5 * kNsPerSec));
  EXPECT_EQ(committed, kSamples);
  EXPECT_EQ(box->published(), static_cast<std::uint64_t>(kSamples));
  EXPECT_EQ(box->dropped(), 0u);
  // and the reader saw them all, in order
  std::size_t got = 0;
  double last = -1.0;
  bool ordered = true;
  ASSERT_TRUE(tst::eventually([&] {
    r.wait(10 * kNsPerMs);
    got += r.take(
        [&](const m::sensor_msgs::JointState& s, const dds_sample_info_t&) {
          ordered = ordered && s.position._buffer[0] > last;
          last = s.position._buffer[0];
        },
        1000);
    return got >= 10;  // keep-last 100 on the reader: the newest ones are there
  }));
  EXPECT_TRUE(ordered);
  EXPECT_DOUBLE_EQ(last, 0.01 * (kSamples - 1));
  pp_->stop();
}

TEST_F(DdsPubSub, OfferedDeadlineMissedIsCounted) {
  auto box = pp_->make_outbox<m::regolith_msgs::SoilStiffness>(
      "terrain/soil", rd::QosProfile::state(20 * kNsPerMs), {.mode = rd::OutboxMode::kLatest, .slots = 3},
      [](m::regolith_msgs::SoilStiffness& s) { rd::reserve(s, rd::SoilStiffnessCapacity{}); });
  rd::Reader<m::regolith_msgs::SoilStiffness> r(*pp_, "terrain/soil", rd::find_topic("terrain/soil")->reader_qos());
  ASSERT_TRUE(tst::eventually([&] { return box->matched_readers() == 1; }));  // compatible: no requested deadline
  box->begin();
  box->commit();
  pp_->flush_all();
  EXPECT_EQ(box->published(), 1u);
  // No further writes: the 20 ms offered deadline expires and the listener
  // counts it.
  EXPECT_TRUE(tst::eventually([&] { return box->deadline_missed() >= 1; }));
}

TEST_F(DdsPubSub, EchoPrintsJsonLines) {
  auto box = pp_->make_outbox<m::sensor_msgs::JointState>(
      "joint_states", rd::QosProfile::stream(), {},
      [](m::sensor_msgs::JointState& js) { rd::reserve(js, {.joints = 4}); });
  pp_->start();
  std::ostringstream out;
  std::thread writer([&] {
    // Writes once the echo reader has matched (echo creates it), then 3
    // samples.
    tst::eventually([&] { return box->matched_readers() == 1; });
    for (int i = 0; i < 3; ++i) {
      auto* js = box->begin();
      fill_joint_state(*js, (i + 1) * kNsPerSec, 0.5 * i);
      box->commit();
    }
  });
  const std::size_t n = rd::echo(*pp_, "joint_states", {.count = 3, .timeout_ns = 10 * kNsPerSec}, out);
  writer.join();
  EXPECT_EQ(n, 3u);
  std::istringstream lines(out.str());
  std::string line;
  int i = 0;
  while (std::getline(lines, line)) {
    const auto j = nlohmann::json::parse(line);
    EXPECT_EQ(j["header"]["stamp"]["sec"], i + 1);
    EXPECT_EQ(j["name"][3], "wheel_rr");
    EXPECT_DOUBLE_EQ(j["position"][0].get<double>(), 0.5 * i);
    ++i;
  }
  EXPECT_EQ(i, 3);
  try {
    rd::echo(*pp_, "camera/image_raw", {.count = 1}, out);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "unknown topic 'camera/image_raw' (known: joint_states, imu, "
              "diagnostics, terrain/grid_map, "
              "terrain/rocks, terrain/wheel_sinkage, terrain/soil, odom, "
              "odom/wheel, terrain/world_map, terrain/world_rocks, tf, tf_static, clock, rosout, "
              "preview/rocks/compressed, preview/sinkage/compressed)");
  }
}

TEST_F(DdsPubSub, EchoTimesOutWithoutPublisher) {
  std::ostringstream out;
  EXPECT_EQ(rd::echo(*pp_, "terrain/wheel_sinkage", {.count = 1, .timeout_ns = 200 * kNsPerMs}, out), 0u);
  EXPECT_EQ(out.str(), "");
  int polls = 0;
  EXPECT_EQ(rd::echo(*pp_, "diagnostics", {.keep_going = [&] { return ++polls < 3; }}, out), 0u);
  EXPECT_EQ(polls, 3);
}

TEST(DdsParticipant, BadConfigNamesField) {
  try {
    rd::Participant p(rd::ParticipantConfig{300, "rover1"});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "dds.domain: must be in [0, 232] (got 300)");
  }
  EXPECT_THROW(rd::Participant(rd::ParticipantConfig{0, "rover-1"}), std::invalid_argument);
}

// The ROS 2 graph entry (issue 21): an observer in the same domain, as `ros2 node list` would,
// reads ros_discovery_info and finds this participant as one node with its publishers.
TEST_F(DdsPubSub, AnnouncesOneRosNodeWithItsWritersAndReadersOnRosDiscoveryInfo) {
  using Info = m::rmw_dds_common::ParticipantEntitiesInfo;
  auto js = pp_->make_outbox<m::sensor_msgs::JointState>(
      "joint_states", rd::QosProfile::stream(10), {},
      [](m::sensor_msgs::JointState& s) { rd::reserve(s, {.joints = 4}); });
  auto diag = pp_->make_outbox<m::diagnostic_msgs::DiagnosticArray>("/diagnostics", rd::QosProfile::diagnostics(), {},
                                                                    [](m::diagnostic_msgs::DiagnosticArray&) {});
  EXPECT_EQ(pp_->announce_node("9 test-node"), "/" + pp_->ns() + "/_9_test_node");  // made a ROS name

  // The observer: another participant, a transient-local reader (the announcement came first).
  const dds_entity_t obs = dds_create_participant(pp_->domain_id(), nullptr, nullptr);
  ASSERT_GT(obs, 0);
  const dds_entity_t tp =
      dds_create_topic(obs, rd::MsgTraits<Info>::descriptor(), "ros_discovery_info", nullptr, nullptr);
  ASSERT_GT(tp, 0);
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
  const dds_entity_t rd_ = dds_create_reader(obs, tp, q, nullptr);
  dds_delete_qos(q);
  ASSERT_GT(rd_, 0);

  const auto own = rd::Participant::gid_of(pp_->handle());
  // The node as this participant announced it last, once `done` holds for it.
  struct Node {
    std::string ns, name;
    std::vector<std::array<std::uint8_t, 24>> writers, readers;
  };
  const auto gids = [](const auto& seq) {
    std::vector<std::array<std::uint8_t, 24>> out;
    for (std::uint32_t k = 0; k < seq._length; ++k) {
      std::array<std::uint8_t, 24> g{};
      std::copy_n(seq._buffer[k].data, 24, g.begin());
      out.push_back(g);
    }
    return out;
  };
  const auto announced = [&](const std::function<bool(const Node&)>& done) {
    Node last;
    bool seen = false;
    const bool ok = tst::eventually([&] {
      void* buf[4] = {};
      dds_sample_info_t info[4];
      const int n = dds_take(rd_, buf, info, 4, 4);
      for (int i = 0; i < n; ++i) {
        if (!info[i].valid_data) continue;
        const auto* s = static_cast<const Info*>(buf[i]);
        if (!std::equal(own.begin(), own.end(), s->gid.data)) continue;  // other test processes
        EXPECT_EQ(s->node_entities_info_seq._length, 1u);
        if (s->node_entities_info_seq._length < 1) continue;
        const auto& node = s->node_entities_info_seq._buffer[0];
        last = {node.node_namespace, node.node_name, gids(node.writer_gid_seq), gids(node.reader_gid_seq)};
        seen = true;
      }
      if (n > 0) dds_return_loan(rd_, buf, n);
      return seen && done(last);
    });
    EXPECT_TRUE(ok) << "last announcement: " << last.writers.size() << " writers, " << last.readers.size()
                    << " readers";
    return last;
  };

  Node node = announced([](const Node&) { return true; });
  EXPECT_EQ(node.ns, "/" + pp_->ns());
  EXPECT_EQ(node.name, "_9_test_node");
  EXPECT_EQ(node.readers.size(), 0u);
  ASSERT_EQ(node.writers.size(), 2u);
  EXPECT_EQ(node.writers[0], rd::Participant::gid_of(js->writer()));
  EXPECT_EQ(node.writers[1], rd::Participant::gid_of(diag->writer()));
  // the gid is the GUID (16 bytes: prefix + entity id), zero-padded; the participant's prefix is
  // every writer's prefix
  EXPECT_TRUE(std::all_of(own.begin() + 16, own.end(), [](std::uint8_t b) { return b == 0; }));
  EXPECT_TRUE(std::equal(own.begin(), own.begin() + 12, node.writers[0].begin()));

  // A writer made after the announcement (a recorder or the live view starting later) is listed
  // without another call: the node is published again with three writers.
  auto late = pp_->make_outbox<m::diagnostic_msgs::DiagnosticArray>("late_diagnostics", rd::QosProfile::diagnostics(),
                                                                    {}, [](m::diagnostic_msgs::DiagnosticArray&) {});
  node = announced([](const Node& n) { return n.writers.size() == 3; });
  ASSERT_EQ(node.writers.size(), 3u);
  EXPECT_EQ(node.name, "_9_test_node");
  EXPECT_EQ(node.writers[2], rd::Participant::gid_of(late->writer()));

  // Subscriptions are the node's readers (as `ros2 node info` lists them): one made now is
  // announced with its gid, and dropped from the node again when it goes.
  {
    rd::Reader<m::sensor_msgs::JointState> sub(*pp_, "joint_states", rd::QosProfile::stream(10));
    node = announced([](const Node& n) { return n.readers.size() == 1; });
    ASSERT_EQ(node.readers.size(), 1u);
    EXPECT_EQ(node.readers[0], rd::Participant::gid_of(sub.subscription().reader()));
    EXPECT_EQ(node.writers.size(), 3u) << "the writers stay listed";
  }
  node = announced([](const Node& n) { return n.readers.empty(); });
  EXPECT_EQ(node.writers.size(), 3u);
  dds_delete(obs);
}
