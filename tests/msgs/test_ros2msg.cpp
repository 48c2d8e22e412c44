// regolith::msgs::ros2msg_definition: the ros2msg schema text (rosbag2 / MCAP format) built from
// the embedded .msg files.
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "regolith/msgs/ros2msg.hpp"

namespace {

std::size_t count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (auto p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

const std::string kSep(80, '=');

}  // namespace

TEST(Ros2Msg, JointStateHasEveryDependencyOnce) {
  const std::string def = regolith::msgs::ros2msg_definition("sensor_msgs/msg/JointState");
  EXPECT_EQ(def.rfind(std::string(regolith::msgs::ros2msg_text("sensor_msgs/JointState")), 0), 0u);
  EXPECT_EQ(count(def, "MSG: std_msgs/Header\n"), 1u);
  EXPECT_EQ(count(def, "MSG: builtin_interfaces/Time\n"), 1u);
  EXPECT_EQ(count(def, kSep + "\nMSG: "), 2u);
  EXPECT_NE(def.find("float64[] position"), std::string::npos);
  // Header comes before Time (breadth first, like rosbag2).
  EXPECT_LT(def.find("MSG: std_msgs/Header"), def.find("MSG: builtin_interfaces/Time"));
}

TEST(Ros2Msg, RelativeNamesResolveInTheOwnPackageAndRepeatsAreListedOnce) {
  const std::string def = regolith::msgs::ros2msg_definition("regolith_msgs/msg/RockArray");
  for (const char* dep :
       {"vision_msgs/Detection2D", "vision_msgs/ObjectHypothesisWithPose", "vision_msgs/BoundingBox2D",
        "vision_msgs/Pose2D", "vision_msgs/Point2D", "vision_msgs/ObjectHypothesis", "geometry_msgs/PoseWithCovariance",
        "geometry_msgs/Pose", "geometry_msgs/Point", "geometry_msgs/Quaternion", "std_msgs/Header",
        "builtin_interfaces/Time"}) {
    EXPECT_EQ(count(def, std::string("MSG: ") + dep + "\n"), 1u) << dep;
  }
  EXPECT_EQ(count(def, kSep + "\nMSG: "), 12u);
  const std::string diag = regolith::msgs::ros2msg_definition("diagnostic_msgs/DiagnosticArray");
  EXPECT_EQ(count(diag, "MSG: diagnostic_msgs/KeyValue\n"), 1u);  // `KeyValue[] values`
  const std::string gm = regolith::msgs::ros2msg_definition("grid_map_msgs/msg/GridMap");
  EXPECT_EQ(count(gm, "MSG: std_msgs/MultiArrayDimension\n"), 1u);
  EXPECT_EQ(count(gm, "MSG: grid_map_msgs/GridMapInfo\n"), 1u);
}

TEST(Ros2Msg, EveryEmbeddedTypeResolvesAndUnknownTypesThrow) {
  const auto types = regolith::msgs::ros2msg_types();
  EXPECT_EQ(types.size(), 47u);
  for (auto t : types) EXPECT_NO_THROW(regolith::msgs::ros2msg_definition(t)) << t;
  EXPECT_EQ(regolith::msgs::ros2msg_definition("builtin_interfaces/msg/Time"),
            std::string(regolith::msgs::ros2msg_text("builtin_interfaces/Time")));
  EXPECT_THROW(regolith::msgs::ros2msg_definition("sensor_msgs/msg/PointCloud2"), std::invalid_argument);
  EXPECT_THROW(regolith::msgs::ros2msg_definition("nonsense"), std::invalid_argument);
  EXPECT_TRUE(regolith::msgs::ros2msg_text("sensor_msgs/msg/PointCloud2").empty());
}
