#pragma once
// JSON rendering of every message type (one object per sample, field names as
// in ROS). Used by `regolith echo`. NaN / infinity render as null (JSON has no
// NaN).
#include <nlohmann/json.hpp>

#include "regolith/msgs/types.hpp"

namespace regolith::dds {

using nlohmann::json;

json to_json(const msgs::builtin_interfaces::Time& m);
json to_json(const msgs::std_msgs::Header& m);
json to_json(const msgs::std_msgs::MultiArrayDimension& m);
json to_json(const msgs::std_msgs::MultiArrayLayout& m);
json to_json(const msgs::std_msgs::Float32MultiArray& m);
json to_json(const msgs::geometry_msgs::Point& m);
json to_json(const msgs::geometry_msgs::Quaternion& m);
json to_json(const msgs::geometry_msgs::Vector3& m);
json to_json(const msgs::sensor_msgs::Imu& m);
/// The encoded bytes are not printed: `data` renders as {"bytes": N}.
json to_json(const msgs::sensor_msgs::CompressedImage& m);
json to_json(const msgs::geometry_msgs::Pose& m);
json to_json(const msgs::geometry_msgs::Pose2D& m);
json to_json(const msgs::geometry_msgs::PoseWithCovariance& m);
json to_json(const msgs::geometry_msgs::Twist& m);
json to_json(const msgs::geometry_msgs::TwistWithCovariance& m);
json to_json(const msgs::nav_msgs::Odometry& m);
json to_json(const msgs::geometry_msgs::Transform& m);
json to_json(const msgs::geometry_msgs::TransformStamped& m);
json to_json(const msgs::tf2_msgs::TFMessage& m);
json to_json(const msgs::rosgraph_msgs::Clock& m);
json to_json(const msgs::rcl_interfaces::Log& m);
json to_json(const msgs::sensor_msgs::JointState& m);
json to_json(const msgs::diagnostic_msgs::KeyValue& m);
json to_json(const msgs::diagnostic_msgs::DiagnosticStatus& m);
json to_json(const msgs::diagnostic_msgs::DiagnosticArray& m);
json to_json(const msgs::grid_map_msgs::GridMapInfo& m);
json to_json(const msgs::grid_map_msgs::GridMap& m);
json to_json(const msgs::vision_msgs::Point2D& m);
json to_json(const msgs::vision_msgs::Pose2D& m);
json to_json(const msgs::vision_msgs::BoundingBox2D& m);
json to_json(const msgs::vision_msgs::ObjectHypothesis& m);
json to_json(const msgs::vision_msgs::ObjectHypothesisWithPose& m);
json to_json(const msgs::vision_msgs::Detection2D& m);
json to_json(const msgs::vision_msgs::Detection2DArray& m);
json to_json(const msgs::vision_msgs::BoundingBox3D& m);
json to_json(const msgs::vision_msgs::Detection3D& m);
json to_json(const msgs::vision_msgs::Detection3DArray& m);
json to_json(const msgs::regolith_msgs::WheelSinkage& m);
json to_json(const msgs::regolith_msgs::SoilStiffness& m);
json to_json(const msgs::regolith_msgs::RockArray& m);

}  // namespace regolith::dds
