// Unit tests of the DDS layer that need no participant: ROS naming, QoS
// profiles, sample pre-allocation helpers, the type table and the JSON
// rendering of every message type.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dds_test_util.hpp"
#include "regolith/core/error.hpp"
#include "regolith/dds/discovery.hpp"
#include "regolith/dds/json.hpp"
#include "regolith/dds/naming.hpp"
#include "regolith/dds/qos.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/dds/types.hpp"

namespace rd = regolith::dds;
namespace m = regolith::msgs;
using regolith::dds::testing::cstr;
using regolith::dds::testing::view;

// ---- naming
// ---------------------------------------------------------------------------------
TEST(DdsNaming, RelativeNameUnderNamespace) {
  EXPECT_EQ(rd::wire_topic_name("rover1", "joint_states"), "rt/rover1/joint_states");
  EXPECT_EQ(rd::ros_topic_name("rover1", "joint_states"), "/rover1/joint_states");
  EXPECT_EQ(rd::wire_topic_name("rover1", "terrain/grid_map"), "rt/rover1/terrain/grid_map");
  EXPECT_EQ(rd::wire_topic_name("/fleet/rover1/", "terrain/soil"), "rt/fleet/rover1/terrain/soil");
}
TEST(DdsNaming, AbsoluteNameIgnoresNamespace) {
  EXPECT_EQ(rd::wire_topic_name("rover1", "/diagnostics"), "rt/diagnostics");
  EXPECT_EQ(rd::ros_topic_name("rover1", "/diagnostics"), "/diagnostics");
}
TEST(DdsNaming, EmptyNamespace) {
  EXPECT_EQ(rd::wire_topic_name("", "joint_states"), "rt/joint_states");
  EXPECT_EQ(rd::wire_topic_name("/", "joint_states"), "rt/joint_states");
  EXPECT_EQ(rd::normalize_namespace("/rover1/"), "rover1");
}
TEST(DdsNaming, InvalidNamesNameTheProblem) {
  auto msg = [](auto f) {
    try {
      f();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_EQ(msg([] { rd::wire_topic_name("rover1", ""); }), "topic name: empty");
  EXPECT_EQ(msg([] { rd::wire_topic_name("rover1", "terrain//map"); }),
            "topic name 'terrain//map': empty token (\"//\" or a trailing \"/\")");
  EXPECT_EQ(msg([] { rd::wire_topic_name("rover1", "terrain/"); }),
            "topic name 'terrain/': empty token (\"//\" or a trailing \"/\")");
  EXPECT_EQ(msg([] { rd::wire_topic_name("rover1", "2d_map"); }),
            "topic name '2d_map': token '2d_map' starts with a digit");
  EXPECT_EQ(msg([] { rd::wire_topic_name("rover1", "joint-states"); }),
            "topic name 'joint-states': character '-' not allowed (only "
            "[A-Za-z0-9_/])");
  EXPECT_EQ(msg([] { rd::wire_topic_name("rover 1", "joint_states"); }),
            "namespace 'rover 1': character ' ' not allowed (only [A-Za-z0-9_/])");
  EXPECT_EQ(msg([] { rd::wire_topic_name("rover1", "~/private"); }),
            "topic name '~/private': character '~' not allowed (only [A-Za-z0-9_/])");
}

// ---- QoS
// ------------------------------------------------------------------------------------
TEST(DdsQos, Presets) {
  const auto state = rd::QosProfile::state(500 * regolith::kNsPerMs);
  EXPECT_EQ(state.reliability, rd::Reliability::kReliable);
  EXPECT_EQ(state.durability, rd::Durability::kTransientLocal);
  EXPECT_EQ(state.depth, 1);
  EXPECT_EQ(state.describe(), "reliable keep_last(1) transient_local deadline 500 ms");
  const auto stream = rd::QosProfile::stream(5);
  EXPECT_EQ(stream.durability, rd::Durability::kVolatile);
  EXPECT_EQ(stream.describe(), "reliable keep_last(5) volatile");
  EXPECT_EQ(rd::QosProfile::diagnostics().describe(), "reliable keep_last(10) volatile");
  const auto r = rd::QosProfile::reader(rd::Reliability::kBestEffort, rd::Durability::kTransientLocal, 1);
  EXPECT_EQ(r.deadline_ns, 0);
  EXPECT_EQ(r.describe(), "best_effort keep_last(1) transient_local");
}
TEST(DdsQos, ReaderQosNeverCarriesADeadline) {
  auto p = rd::QosProfile::state(100 * regolith::kNsPerMs);
  const rd::Qos w(p, rd::Qos::For::kWriter);
  const rd::Qos r(p, rd::Qos::For::kReader);
  dds_duration_t d = 0;
  ASSERT_TRUE(dds_qget_deadline(w.get(), &d));
  EXPECT_EQ(d, 100 * regolith::kNsPerMs);
  EXPECT_FALSE(dds_qget_deadline(r.get(), &d));  // not set: infinite
  dds_durability_kind_t dk{};
  ASSERT_TRUE(dds_qget_durability(r.get(), &dk));
  EXPECT_EQ(dk, DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_history_kind_t hk{};
  int32_t depth = 0;
  ASSERT_TRUE(dds_qget_history(w.get(), &hk, &depth));
  EXPECT_EQ(hk, DDS_HISTORY_KEEP_LAST);
  EXPECT_EQ(depth, 1);
}
TEST(DdsQos, ValidateNamesField) {
  auto p = rd::QosProfile::stream(0);
  EXPECT_THROW(
      {
        try {
          p.validate();
        } catch (const std::invalid_argument& e) {
          EXPECT_STREQ(e.what(), "QosProfile.depth: must be >= 1 (got 0)");
          throw;
        }
      },
      std::invalid_argument);
  p = rd::QosProfile::state(-5);
  EXPECT_THROW(p.validate(), std::invalid_argument);
}

// ---- sample helpers
// -------------------------------------------------------------------------
TEST(DdsSample, CopyStringTruncates) {
  char* s = rd::alloc_string(4);
  EXPECT_STREQ(s, "");
  EXPECT_TRUE(rd::copy_string(s, 4, "abcd"));
  EXPECT_STREQ(s, "abcd");
  EXPECT_FALSE(rd::copy_string(s, 4, "abcdef"));
  EXPECT_STREQ(s, "abcd");
  EXPECT_TRUE(rd::copy_string(s, 4, ""));
  EXPECT_STREQ(s, "");
  dds_free(s);
}
TEST(DdsSample, FormatNumbers) {
  char* s = rd::alloc_string(16);
  EXPECT_TRUE(rd::format_double(s, 16, 0.25));
  EXPECT_STREQ(s, "0.25");
  EXPECT_TRUE(rd::format_double(s, 16, 1.0 / 3.0));  // shortest form needs 18 chars -> 6 digits
  EXPECT_STREQ(s, "0.333333");
  EXPECT_TRUE(rd::format_int(s, 16, -1234));
  EXPECT_STREQ(s, "-1234");
  EXPECT_FALSE(rd::format_int(s, 3, 123456));
  EXPECT_STREQ(s, "?");
  dds_free(s);
}
TEST(DdsSample, TimeConversion) {
  m::builtin_interfaces::Time t{};
  rd::set_time(t, 12 * regolith::kNsPerSec + 345);
  EXPECT_EQ(t.sec, 12);
  EXPECT_EQ(t.nanosec, 345u);
  rd::set_time(t, -1);  // one nanosecond before the epoch
  EXPECT_EQ(t.sec, -1);
  EXPECT_EQ(t.nanosec, 999'999'999u);
  EXPECT_EQ(rd::to_ns(t), -1);
}
TEST(DdsSample, ReserveJointStateAndFree) {
  m::sensor_msgs::JointState js{};
  rd::reserve(js, {.joints = 4, .name_capacity = 8, .frame_id_capacity = 16});
  EXPECT_EQ(js.name._maximum, 4u);
  EXPECT_EQ(js.name._length, 0u);
  EXPECT_EQ(js.position._maximum, 4u);
  EXPECT_TRUE(js.velocity._release);
  ASSERT_NE(js.name._buffer[3], nullptr);
  EXPECT_TRUE(rd::set_length(js.position, 4));
  EXPECT_FALSE(rd::set_length(js.velocity, 5));
  EXPECT_EQ(js.velocity._length, 4u);
  rd::free_contents(rd::MsgTraits<m::sensor_msgs::JointState>::descriptor(), &js);
  EXPECT_EQ(js.name._buffer, nullptr);
  EXPECT_EQ(js.header.frame_id, nullptr);
}
TEST(DdsSample, ReserveGridMapLayout) {
  m::grid_map_msgs::GridMap g{};
  rd::reserve(g, {.layers = 2, .basic_layers = 1, .size_x = 3, .size_y = 5});
  ASSERT_EQ(g.data._maximum, 2u);
  const auto& l = g.data._buffer[1].layout;
  ASSERT_EQ(l.dim._length, 2u);
  EXPECT_STREQ(l.dim._buffer[0].label, "column_index");
  EXPECT_EQ(l.dim._buffer[0].size, 5u);
  EXPECT_EQ(l.dim._buffer[0].stride, 15u);
  EXPECT_STREQ(l.dim._buffer[1].label, "row_index");
  EXPECT_EQ(l.dim._buffer[1].size, 3u);
  EXPECT_EQ(l.dim._buffer[1].stride, 3u);
  EXPECT_EQ(g.data._buffer[1].data._length, 15u);
  EXPECT_EQ(g.info.pose.orientation.w, 1.0);
  rd::free_contents(rd::MsgTraits<m::grid_map_msgs::GridMap>::descriptor(), &g);
}

// ---- type table
// -----------------------------------------------------------------------------
template <class Msg>
void expect_type(const char* dds_name, const char* ros_name) {
  const dds_topic_descriptor_t* d = rd::MsgTraits<Msg>::descriptor();
  EXPECT_STREQ(d->m_typename, dds_name);
  EXPECT_EQ(rd::MsgTraits<Msg>::ros_type, ros_name);
  EXPECT_EQ(d->m_nkeys, 0u) << dds_name << " must be keyless";
  EXPECT_EQ(d->m_size, sizeof(Msg));
}
TEST(DdsTypes, RosWireTypeNamesAndKeyless) {
  expect_type<m::builtin_interfaces::Time>("builtin_interfaces::msg::dds_::Time_", "builtin_interfaces/msg/Time");
  expect_type<m::std_msgs::Header>("std_msgs::msg::dds_::Header_", "std_msgs/msg/Header");
  expect_type<m::std_msgs::MultiArrayDimension>("std_msgs::msg::dds_::MultiArrayDimension_",
                                                "std_msgs/msg/MultiArrayDimension");
  expect_type<m::std_msgs::MultiArrayLayout>("std_msgs::msg::dds_::MultiArrayLayout_", "std_msgs/msg/MultiArrayLayout");
  expect_type<m::std_msgs::Float32MultiArray>("std_msgs::msg::dds_::Float32MultiArray_",
                                              "std_msgs/msg/Float32MultiArray");
  expect_type<m::geometry_msgs::Point>("geometry_msgs::msg::dds_::Point_", "geometry_msgs/msg/Point");
  expect_type<m::geometry_msgs::Quaternion>("geometry_msgs::msg::dds_::Quaternion_", "geometry_msgs/msg/Quaternion");
  expect_type<m::geometry_msgs::Pose>("geometry_msgs::msg::dds_::Pose_", "geometry_msgs/msg/Pose");
  expect_type<m::geometry_msgs::Pose2D>("geometry_msgs::msg::dds_::Pose2D_", "geometry_msgs/msg/Pose2D");
  expect_type<m::geometry_msgs::PoseWithCovariance>("geometry_msgs::msg::dds_::PoseWithCovariance_",
                                                    "geometry_msgs/msg/PoseWithCovariance");
  expect_type<m::sensor_msgs::JointState>("sensor_msgs::msg::dds_::JointState_", "sensor_msgs/msg/JointState");
  expect_type<m::diagnostic_msgs::KeyValue>("diagnostic_msgs::msg::dds_::KeyValue_", "diagnostic_msgs/msg/KeyValue");
  expect_type<m::diagnostic_msgs::DiagnosticStatus>("diagnostic_msgs::msg::dds_::DiagnosticStatus_",
                                                    "diagnostic_msgs/msg/DiagnosticStatus");
  expect_type<m::diagnostic_msgs::DiagnosticArray>("diagnostic_msgs::msg::dds_::DiagnosticArray_",
                                                   "diagnostic_msgs/msg/DiagnosticArray");
  expect_type<m::grid_map_msgs::GridMapInfo>("grid_map_msgs::msg::dds_::GridMapInfo_", "grid_map_msgs/msg/GridMapInfo");
  expect_type<m::grid_map_msgs::GridMap>("grid_map_msgs::msg::dds_::GridMap_", "grid_map_msgs/msg/GridMap");
  expect_type<m::vision_msgs::Point2D>("vision_msgs::msg::dds_::Point2D_", "vision_msgs/msg/Point2D");
  expect_type<m::vision_msgs::Pose2D>("vision_msgs::msg::dds_::Pose2D_", "vision_msgs/msg/Pose2D");
  expect_type<m::vision_msgs::BoundingBox2D>("vision_msgs::msg::dds_::BoundingBox2D_", "vision_msgs/msg/BoundingBox2D");
  expect_type<m::vision_msgs::ObjectHypothesis>("vision_msgs::msg::dds_::ObjectHypothesis_",
                                                "vision_msgs/msg/ObjectHypothesis");
  expect_type<m::vision_msgs::ObjectHypothesisWithPose>("vision_msgs::msg::dds_::ObjectHypothesisWithPose_",
                                                        "vision_msgs/msg/ObjectHypothesisWithPose");
  expect_type<m::vision_msgs::Detection2D>("vision_msgs::msg::dds_::Detection2D_", "vision_msgs/msg/Detection2D");
  expect_type<m::vision_msgs::Detection2DArray>("vision_msgs::msg::dds_::Detection2DArray_",
                                                "vision_msgs/msg/Detection2DArray");
  expect_type<m::regolith_msgs::WheelSinkage>("regolith_msgs::msg::dds_::WheelSinkage_",
                                              "regolith_msgs/msg/WheelSinkage");
  expect_type<m::regolith_msgs::SoilStiffness>("regolith_msgs::msg::dds_::SoilStiffness_",
                                               "regolith_msgs/msg/SoilStiffness");
  expect_type<m::regolith_msgs::RockArray>("regolith_msgs::msg::dds_::RockArray_", "regolith_msgs/msg/RockArray");
  expect_type<m::geometry_msgs::Twist>("geometry_msgs::msg::dds_::Twist_", "geometry_msgs/msg/Twist");
  expect_type<m::geometry_msgs::TwistWithCovariance>("geometry_msgs::msg::dds_::TwistWithCovariance_",
                                                     "geometry_msgs/msg/TwistWithCovariance");
  expect_type<m::nav_msgs::Odometry>("nav_msgs::msg::dds_::Odometry_", "nav_msgs/msg/Odometry");
}
TEST(DdsTopics, TableLookupAndList) {
  ASSERT_NE(rd::find_topic("joint_states"), nullptr);
  EXPECT_EQ(rd::find_topic("joint_states")->ros_type, "sensor_msgs/msg/JointState");
  ASSERT_NE(rd::find_topic("diagnostics"), nullptr);
  EXPECT_EQ(rd::find_topic("diagnostics")->name, "/diagnostics");
  EXPECT_EQ(rd::find_topic("/terrain/grid_map")->ros_type, "grid_map_msgs/msg/GridMap");
  EXPECT_EQ(rd::find_topic("terrain/rocks")->ros_type, "regolith_msgs/msg/RockArray");
  EXPECT_EQ(rd::find_topic("terrain/wheel_sinkage")->ros_type, "regolith_msgs/msg/WheelSinkage");
  EXPECT_EQ(rd::find_topic("terrain/soil")->ros_type, "regolith_msgs/msg/SoilStiffness");
  EXPECT_EQ(rd::find_topic("odom")->ros_type, "nav_msgs/msg/Odometry");
  EXPECT_EQ(rd::find_topic("odom/wheel")->ros_type, "nav_msgs/msg/Odometry");
  EXPECT_EQ(rd::find_topic("terrain/world_map")->ros_type, "grid_map_msgs/msg/GridMap");
  EXPECT_EQ(rd::find_topic("terrain/world_map")->cls, rd::TopicClass::kState);
  EXPECT_EQ(rd::find_topic("terrain/world_rocks")->ros_type, "vision_msgs/msg/Detection3DArray");
  EXPECT_EQ(rd::find_topic("terrain/world_rocks")->cls, rd::TopicClass::kState);
  EXPECT_EQ(rd::find_topic("camera/image_raw"), nullptr);
  EXPECT_EQ(rd::find_topic("/tf")->ros_type, "tf2_msgs/msg/TFMessage");
  EXPECT_EQ(rd::find_topic("tf_static")->cls, rd::TopicClass::kState);
  EXPECT_EQ(rd::find_topic("/clock")->ros_type, "rosgraph_msgs/msg/Clock");
  EXPECT_EQ(rd::find_topic("/rosout")->ros_type, "rcl_interfaces/msg/Log");
  EXPECT_EQ(rd::known_topics().size(), 17u);
  // State topics are latched for late readers; readers never ask for a
  // deadline.
  for (const auto& t : rd::known_topics()) {
    EXPECT_EQ(t.reader_qos().deadline_ns, 0) << t.name;
    if (t.cls == rd::TopicClass::kState) {
      EXPECT_EQ(t.writer_qos().durability, rd::Durability::kTransientLocal) << t.name;
      EXPECT_EQ(t.reader_qos().durability, rd::Durability::kTransientLocal) << t.name;
    } else {
      EXPECT_EQ(t.reader_qos().durability, rd::Durability::kVolatile) << t.name;
    }
  }
  const std::string list = rd::list_topics();
  EXPECT_NE(list.find("terrain/grid_map"), std::string::npos);
  EXPECT_NE(list.find("grid_map_msgs/msg/GridMap"), std::string::npos);
  EXPECT_NE(list.find("/diagnostics"), std::string::npos);
}

// ---- JSON
// -----------------------------------------------------------------------------------
TEST(DdsJson, CompressedImageShowsItsFormatAndSizeNotItsBytes) {
  EXPECT_EQ(rd::find_topic("preview/rocks/compressed")->ros_type, "sensor_msgs/msg/CompressedImage");
  EXPECT_EQ(rd::find_topic("preview/sinkage/compressed")->cls, rd::TopicClass::kStream);
  m::sensor_msgs::CompressedImage im{};
  rd::reserve(im, 1000, 16, 32);
  EXPECT_EQ(im.data._maximum, 1000u);
  rd::copy_string(im.format, 16, "jpeg");
  rd::copy_string(im.header.frame_id, 32, "front_optical_frame");
  im.header.stamp = {12, 500};
  EXPECT_TRUE(rd::set_length(im.data, 3));
  im.data._buffer[0] = 0xFF;
  EXPECT_FALSE(rd::set_length(im.data, 1001));  // clamped to the reserved capacity
  const auto j = rd::to_json(im);
  EXPECT_EQ(j["format"], "jpeg");
  EXPECT_EQ(j["header"]["frame_id"], "front_optical_frame");
  EXPECT_EQ(j["data"]["bytes"], 1000);
  rd::free_contents(rd::MsgTraits<m::sensor_msgs::CompressedImage>::descriptor(), &im);
}

TEST(DdsJson, TransformsClockAndLog) {
  m::tf2_msgs::TFMessage tf{};
  rd::reserve(tf, 2, 16);
  rd::set_length(tf.transforms, 1);
  auto& t = tf.transforms._buffer[0];
  t.header.stamp = {5, 7};
  rd::copy_string(t.header.frame_id, 16, "base_link");
  rd::copy_string(t.child_frame_id, 16, "front_link");
  t.transform.translation = {0.1, 0.0, 0.5};
  const auto j = rd::to_json(tf);
  ASSERT_EQ(j["transforms"].size(), 1u);
  EXPECT_EQ(j["transforms"][0]["header"]["frame_id"], "base_link");
  EXPECT_EQ(j["transforms"][0]["child_frame_id"], "front_link");
  EXPECT_EQ(j["transforms"][0]["transform"]["translation"]["z"], 0.5);
  EXPECT_EQ(j["transforms"][0]["transform"]["rotation"]["w"], 1.0);
  rd::free_contents(rd::MsgTraits<m::tf2_msgs::TFMessage>::descriptor(), &tf);

  m::rosgraph_msgs::Clock c{};
  c.clock = {12, 34};
  EXPECT_EQ(rd::to_json(c)["clock"]["sec"], 12);

  m::rcl_interfaces::Log log{};
  rd::reserve(log, 8, 8);
  log.level = 30;
  EXPECT_FALSE(rd::copy_string(log.msg, 8, "camera front: faulted"));  // cut to the capacity
  const auto lj = rd::to_json(log);
  EXPECT_EQ(lj["level"], 30);
  EXPECT_EQ(lj["msg"], "camera f");
  rd::free_contents(rd::MsgTraits<m::rcl_interfaces::Log>::descriptor(), &log);
}

TEST(DdsJson, JointState) {
  m::sensor_msgs::JointState js{};
  js.header.stamp = {3, 500};
  js.header.frame_id = cstr("base_link");
  std::vector<char*> names = {cstr("wheel_fl"), cstr("wheel_fr")};
  std::vector<double> pos = {0.5, -1.25}, vel = {2.0, std::numeric_limits<double>::quiet_NaN()}, eff;
  view(js.name, names);
  view(js.position, pos);
  view(js.velocity, vel);
  view(js.effort, eff);
  const auto j = rd::to_json(js);
  EXPECT_EQ(j.dump(), R"({"effort":[],"header":{"frame_id":"base_link","stamp":{"nanosec":500,"sec":3}},)"
                      R"("name":["wheel_fl","wheel_fr"],"position":[0.5,-1.25],"velocity":[2.0,null]})");
}
TEST(DdsJson, DiagnosticArray) {
  m::diagnostic_msgs::DiagnosticArray a{};
  a.header.frame_id = cstr("");
  std::vector<m::diagnostic_msgs::KeyValue> kv = {{cstr("max_exec_us"), cstr("812")}, {cstr("cycle_slips"), cstr("0")}};
  std::vector<m::diagnostic_msgs::DiagnosticStatus> st(1);
  st[0].level = m::diagnostic_msgs::kWarn;
  st[0].name = cstr("sfs: timing");
  st[0].message = cstr("slow");
  st[0].hardware_id = cstr("cam0");
  view(st[0].values, kv);
  view(a.status, st);
  const auto j = rd::to_json(a);
  EXPECT_EQ(j["status"][0]["level"], 1);
  EXPECT_EQ(j["status"][0]["name"], "sfs: timing");
  EXPECT_EQ(j["status"][0]["hardware_id"], "cam0");
  EXPECT_EQ(j["status"][0]["values"][0]["key"], "max_exec_us");
  EXPECT_EQ(j["status"][0]["values"][1]["value"], "0");
  EXPECT_EQ(j["status"][0]["message"], "slow");
}
TEST(DdsJson, GridMap) {
  m::grid_map_msgs::GridMap g{};
  rd::reserve(g, {.layers = 1, .basic_layers = 1, .size_x = 2, .size_y = 2});
  rd::set_length(g.layers, 1);
  rd::copy_string(g.layers._buffer[0], 32, "elevation");
  rd::set_length(g.basic_layers, 1);
  rd::copy_string(g.basic_layers._buffer[0], 32, "elevation");
  rd::set_length(g.data, 1);
  g.data._buffer[0].data._buffer[0] = 1.5f;
  g.data._buffer[0].data._buffer[3] = std::numeric_limits<float>::quiet_NaN();
  g.info.resolution = 0.05;
  g.info.length_x = 0.1;
  g.info.pose.position.x = 2.0;
  g.outer_start_index = 0;
  const auto j = rd::to_json(g);
  EXPECT_EQ(j["layers"][0], "elevation");
  EXPECT_EQ(j["basic_layers"][0], "elevation");
  EXPECT_EQ(j["info"]["resolution"], 0.05);
  EXPECT_EQ(j["info"]["pose"]["position"]["x"], 2.0);
  EXPECT_EQ(j["info"]["pose"]["orientation"]["w"], 1.0);
  EXPECT_EQ(j["data"][0]["layout"]["dim"][0]["label"], "column_index");
  EXPECT_EQ(j["data"][0]["layout"]["dim"][1]["stride"], 2);
  EXPECT_EQ(j["data"][0]["data"][0], 1.5);
  EXPECT_TRUE(j["data"][0]["data"][3].is_null());  // NaN = unknown cell
  EXPECT_EQ(j["data"][0]["data"].size(), 4u);
  EXPECT_EQ(j["inner_start_index"], 0);
  rd::free_contents(rd::MsgTraits<m::grid_map_msgs::GridMap>::descriptor(), &g);
}
TEST(DdsJson, Detection2DArrayAndRocks) {
  m::vision_msgs::Detection2D d{};
  d.header.frame_id = cstr("camera_optical_frame");
  d.id = cstr("rock7");
  d.bbox.center.position = {320.5, 240.25};
  d.bbox.center.theta = 0.0;
  d.bbox.size_x = 40;
  d.bbox.size_y = 22;
  std::vector<m::vision_msgs::ObjectHypothesisWithPose> res(1);
  res[0].hypothesis.class_id = cstr("rock");
  res[0].hypothesis.score = 0.875;
  res[0].pose.pose.position = {1.0, 2.0, 3.0};
  res[0].pose.pose.orientation.w = 1.0;
  res[0].pose.covariance[35] = 0.5;
  view(d.results, res);
  std::vector<m::vision_msgs::Detection2D> dets = {d};
  m::vision_msgs::Detection2DArray arr{};
  arr.header.frame_id = cstr("camera_optical_frame");
  view(arr.detections, dets);
  auto j = rd::to_json(arr);
  EXPECT_EQ(j["detections"][0]["id"], "rock7");
  EXPECT_EQ(j["detections"][0]["bbox"]["center"]["position"]["x"], 320.5);
  EXPECT_EQ(j["detections"][0]["bbox"]["size_y"], 22.0);
  EXPECT_EQ(j["detections"][0]["results"][0]["hypothesis"]["class_id"], "rock");
  EXPECT_EQ(j["detections"][0]["results"][0]["hypothesis"]["score"], 0.875);
  EXPECT_EQ(j["detections"][0]["results"][0]["pose"]["pose"]["position"]["z"], 3.0);
  EXPECT_EQ(j["detections"][0]["results"][0]["pose"]["covariance"].size(), 36u);
  EXPECT_EQ(j["detections"][0]["results"][0]["pose"]["covariance"][35], 0.5);

  m::regolith_msgs::RockArray rocks{};
  rocks.header.frame_id = cstr("base_link");
  view(rocks.detections, dets);
  std::vector<double> range = {2.5}, lat = {-0.4}, w = {0.12}, h = {0.08};
  bool hz[1] = {true};
  view(rocks.ground_range_m, range);
  view(rocks.lateral_offset_m, lat);
  view(rocks.width_m, w);
  view(rocks.height_m, h);
  rocks.hazard._buffer = hz;
  rocks.hazard._length = rocks.hazard._maximum = 1;
  j = rd::to_json(rocks);
  EXPECT_EQ(j["ground_range_m"][0], 2.5);
  EXPECT_EQ(j["lateral_offset_m"][0], -0.4);
  EXPECT_EQ(j["width_m"][0], 0.12);
  EXPECT_EQ(j["height_m"][0], 0.08);
  EXPECT_EQ(j["hazard"][0], true);
  EXPECT_EQ(j["detections"][0]["results"][0]["hypothesis"]["class_id"], "rock");
}
TEST(DdsJson, SinkageSoilAndGeometry) {
  m::regolith_msgs::WheelSinkage s{};
  s.header.frame_id = cstr("base_link");
  std::vector<char*> names = {cstr("fl")};
  std::vector<double> z = {0.012}, c = {0.9};
  view(s.wheel_names, names);
  view(s.sinkage_m, z);
  view(s.confidence, c);
  auto j = rd::to_json(s);
  EXPECT_EQ(j["wheel_names"][0], "fl");
  EXPECT_EQ(j["sinkage_m"][0], 0.012);
  EXPECT_EQ(j["confidence"][0], 0.9);

  m::regolith_msgs::SoilStiffness soil{};
  soil.header.frame_id = cstr("base_link");
  soil.k = 8.2e5;
  soil.n = 1.1;
  soil.k_sigma = 1e4;
  soil.n_sigma = 0.05;
  soil.mean_sinkage_m = 0.015;
  soil.samples_used = 120;
  soil.soil_class = cstr("loose_sand");
  j = rd::to_json(soil);
  EXPECT_EQ(j["k"], 8.2e5);
  EXPECT_EQ(j["n"], 1.1);
  EXPECT_EQ(j["k_sigma"], 1e4);
  EXPECT_EQ(j["n_sigma"], 0.05);
  EXPECT_EQ(j["mean_sinkage_m"], 0.015);
  EXPECT_EQ(j["samples_used"], 120);
  EXPECT_EQ(j["soil_class"], "loose_sand");

  m::geometry_msgs::Pose2D p{1.0, -2.0, 0.5};
  EXPECT_EQ(rd::to_json(p).dump(), R"({"theta":0.5,"x":1.0,"y":-2.0})");
  m::std_msgs::Float32MultiArray f{};
  std::vector<float> fd = {0.5f, -1.0f};
  view(f.data, fd);
  EXPECT_EQ(rd::to_json(f)["data"].dump(), "[0.5,-1.0]");
  m::std_msgs::Header h{{-1, 999999999u}, nullptr};
  EXPECT_EQ(rd::to_json(h).dump(), R"({"frame_id":"","stamp":{"nanosec":999999999,"sec":-1}})");
}

// ROS_DOMAIN_ID: the default domain of the deployment's `dds.domain` and of `regolith echo`.
TEST(DdsUnit, DefaultDomainFollowsRosDomainId) {
  const char* saved = std::getenv("ROS_DOMAIN_ID");
  const std::string keep = saved ? saved : "";
  setenv("ROS_DOMAIN_ID", "42", 1);
  EXPECT_EQ(rd::default_domain_id(), 42);
  setenv("ROS_DOMAIN_ID", "", 1);
  EXPECT_EQ(rd::default_domain_id(), 0);
  // A value ROS 2 refuses is an error naming the variable, not a silent domain 0 beside other runs.
  for (const char* bad : {"not-a-number", "500", "-1", "4x"}) {
    setenv("ROS_DOMAIN_ID", bad, 1);
    try {
      (void)rd::default_domain_id();
      ADD_FAILURE() << bad << " accepted";
    } catch (const regolith::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("ROS_DOMAIN_ID='" + std::string(bad) + "'"), std::string::npos) << e.what();
    }
  }
  unsetenv("ROS_DOMAIN_ID");
  EXPECT_EQ(rd::default_domain_id(), 0);
  if (saved) setenv("ROS_DOMAIN_ID", keep.c_str(), 1);
}

// The ROS 2 discovery variables, read as ROS 2 reads them (Iron's range and static peers,
// Humble's ROS_LOCALHOST_ONLY), and the Cyclone XML rmw_cyclonedds makes of them.
TEST(DdsUnit, DiscoveryRangeFromTheRos2Environment) {
  const char* names[] = {"ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS", "ROS_LOCALHOST_ONLY"};
  std::vector<std::pair<std::string, std::string>> saved;
  for (const char* n : names)
    if (const char* v = std::getenv(n)) saved.emplace_back(n, v);
  for (const char* n : names) unsetenv(n);
  using R = rd::DiscoveryRange;
  EXPECT_EQ(rd::discovery_from_environment(), rd::DiscoveryOptions{});  // SUBNET, no peers
  setenv("ROS_LOCALHOST_ONLY", "1", 1);
  EXPECT_EQ(rd::discovery_from_environment().range, R::kLocalhost);
  setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF", 1);  // the range wins over Humble's variable
  EXPECT_EQ(rd::discovery_from_environment().range, R::kOff);
  unsetenv("ROS_LOCALHOST_ONLY");
  for (auto [text, range] :
       {std::pair{"SUBNET", R::kSubnet}, {"LOCALHOST", R::kLocalhost}, {"SYSTEM_DEFAULT", R::kSystemDefault}}) {
    setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", text, 1);
    EXPECT_EQ(rd::discovery_from_environment().range, range) << text;
    EXPECT_STREQ(rd::to_string(range), text);
  }
  setenv("ROS_STATIC_PEERS", " 192.168.1.7; rover2.local ;;", 1);
  EXPECT_EQ(rd::discovery_from_environment().static_peers, (std::vector<std::string>{"192.168.1.7", "rover2.local"}));
  auto refused = [](const char* name, const char* value, const std::string& says) {
    setenv(name, value, 1);
    try {
      (void)rd::discovery_from_environment();
      ADD_FAILURE() << name << "=" << value << " accepted";
    } catch (const regolith::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
    unsetenv(name);
  };
  refused("ROS_AUTOMATIC_DISCOVERY_RANGE", "localhost", "ROS_AUTOMATIC_DISCOVERY_RANGE='localhost': must be SUBNET");
  refused("ROS_LOCALHOST_ONLY", "yes", "ROS_LOCALHOST_ONLY='yes': must be 0 or 1");
  refused("ROS_STATIC_PEERS", "a;b\"/><x", "ROS_STATIC_PEERS: 'b\"/><x' is not a host name or address");
  for (const char* n : names) unsetenv(n);
  for (const auto& [n, v] : saved) setenv(n.c_str(), v.c_str(), 1);

  // The XML, as rmw_cyclonedds writes it for the same variables.
  EXPECT_EQ(rd::discovery_config({}, 7), "");
  EXPECT_EQ(rd::discovery_config({R::kSystemDefault, {"10.0.0.2"}}, 7), "");
  EXPECT_EQ(rd::discovery_config({R::kLocalhost, {}}, 7),
            "<CycloneDDS><Domain><General><AllowMulticast>false</AllowMulticast></General><Discovery>"
            "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>"
            "<Peers><Peer address=\"localhost\"/></Peers></Discovery></Domain></CycloneDDS>");
  EXPECT_EQ(rd::discovery_config({R::kSubnet, {"10.0.0.2"}}, 7),
            "<CycloneDDS><Domain><Discovery><ParticipantIndex>auto</ParticipantIndex>"
            "<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex><Peers><Peer address=\"10.0.0.2\"/></Peers>"
            "</Discovery></Domain></CycloneDDS>");
  EXPECT_EQ(
      rd::discovery_config({R::kOff, {"10.0.0.2"}}, 4242),
      "<CycloneDDS><Domain><General><AllowMulticast>false</AllowMulticast></General><Discovery>"
      "<ParticipantIndex>none</ParticipantIndex><Tag>ros_discovery_off_4242</Tag></Discovery></Domain></CycloneDDS>");
}

// Header stamps are ROS time: the process clock plus the measured realtime offset.
TEST(DdsUnit, HeaderStampsAreRosTime) {
  regolith::ros_time_offset().store(regolith::measure_realtime_offset());
  regolith::msgs::builtin_interfaces::Time t{};
  rd::set_stamp(t, regolith::monotonic_now());
  EXPECT_LT(std::abs(static_cast<double>(t.sec) - static_cast<double>(std::time(nullptr))), 2.0);
  regolith::ros_time_offset().store(0);
  rd::set_stamp(t, 5 * regolith::kNsPerSec);
  EXPECT_EQ(t.sec, 5);
}

TEST(DdsEcho, ReceiptTimeAndDelayFromTheHeaderStamp) {
  // `regolith echo --delay`: received (ROS time) and received - header.stamp in ms.
  nlohmann::json s = {{"header", {{"stamp", {{"sec", 100}, {"nanosec", 900'000'000}}}, {"frame_id", "odom"}}}};
  regolith::dds::add_receipt_time(s, 101 * regolith::kNsPerSec + 12'500'000);
  EXPECT_EQ(s["received"]["sec"], 101);
  EXPECT_EQ(s["received"]["nanosec"], 12'500'000);
  EXPECT_DOUBLE_EQ(s["delay_ms"].get<double>(), 112.5);
  // no header (e.g. /clock): the receipt time only
  nlohmann::json c = {{"clock", {{"sec", 1}, {"nanosec", 0}}}};
  regolith::dds::add_receipt_time(c, 5 * regolith::kNsPerSec);
  EXPECT_EQ(c["received"]["sec"], 5);
  EXPECT_FALSE(c.contains("delay_ms"));
}
