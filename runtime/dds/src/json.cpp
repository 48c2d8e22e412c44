#include "regolith/dds/json.hpp"

#include <cmath>

namespace regolith::dds {
namespace {

json str(const char* s) {
  return s == nullptr ? json("") : json(s);
}
json num(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

template <class Seq>
json numbers(const Seq& seq) {
  json a = json::array();
  for (std::uint32_t i = 0; i < seq._length; ++i) a.push_back(num(static_cast<double>(seq._buffer[i])));
  return a;
}
template <class Seq>
json strings(const Seq& seq) {
  json a = json::array();
  for (std::uint32_t i = 0; i < seq._length; ++i) a.push_back(str(seq._buffer[i]));
  return a;
}
template <class Seq>
json bools(const Seq& seq) {
  json a = json::array();
  for (std::uint32_t i = 0; i < seq._length; ++i) a.push_back(static_cast<bool>(seq._buffer[i]));
  return a;
}
template <class Seq>
json structs(const Seq& seq) {
  json a = json::array();
  for (std::uint32_t i = 0; i < seq._length; ++i) a.push_back(to_json(seq._buffer[i]));
  return a;
}

}  // namespace

json to_json(const msgs::builtin_interfaces::Time& m) {
  return {{"sec", m.sec}, {"nanosec", m.nanosec}};
}
json to_json(const msgs::std_msgs::Header& m) {
  return {{"stamp", to_json(m.stamp)}, {"frame_id", str(m.frame_id)}};
}
json to_json(const msgs::std_msgs::MultiArrayDimension& m) {
  return {{"label", str(m.label)}, {"size", m.size}, {"stride", m.stride}};
}
json to_json(const msgs::std_msgs::MultiArrayLayout& m) {
  return {{"dim", structs(m.dim)}, {"data_offset", m.data_offset}};
}
json to_json(const msgs::std_msgs::Float32MultiArray& m) {
  return {{"layout", to_json(m.layout)}, {"data", numbers(m.data)}};
}
json to_json(const msgs::geometry_msgs::Point& m) {
  return {{"x", num(m.x)}, {"y", num(m.y)}, {"z", num(m.z)}};
}
json to_json(const msgs::geometry_msgs::Quaternion& m) {
  return {{"x", num(m.x)}, {"y", num(m.y)}, {"z", num(m.z)}, {"w", num(m.w)}};
}
json to_json(const msgs::geometry_msgs::Pose& m) {
  return {{"position", to_json(m.position)}, {"orientation", to_json(m.orientation)}};
}
json to_json(const msgs::geometry_msgs::Pose2D& m) {
  return {{"x", num(m.x)}, {"y", num(m.y)}, {"theta", num(m.theta)}};
}
json to_json(const msgs::geometry_msgs::PoseWithCovariance& m) {
  json cov = json::array();
  for (double c : m.covariance) cov.push_back(num(c));
  return {{"pose", to_json(m.pose)}, {"covariance", cov}};
}
json to_json(const msgs::geometry_msgs::Vector3& m) {
  return {{"x", num(m.x)}, {"y", num(m.y)}, {"z", num(m.z)}};
}
json to_json(const msgs::geometry_msgs::Twist& m) {
  return {{"linear", to_json(m.linear)}, {"angular", to_json(m.angular)}};
}
json to_json(const msgs::geometry_msgs::TwistWithCovariance& m) {
  json cov = json::array();
  for (double c : m.covariance) cov.push_back(num(c));
  return {{"twist", to_json(m.twist)}, {"covariance", cov}};
}
json to_json(const msgs::geometry_msgs::Transform& m) {
  return {{"translation", to_json(m.translation)}, {"rotation", to_json(m.rotation)}};
}
json to_json(const msgs::geometry_msgs::TransformStamped& m) {
  return {
      {"header", to_json(m.header)}, {"child_frame_id", str(m.child_frame_id)}, {"transform", to_json(m.transform)}};
}
json to_json(const msgs::tf2_msgs::TFMessage& m) {
  return {{"transforms", structs(m.transforms)}};
}
json to_json(const msgs::rosgraph_msgs::Clock& m) {
  return {{"clock", to_json(m.clock)}};
}
json to_json(const msgs::rcl_interfaces::Log& m) {
  return {{"stamp", to_json(m.stamp)},
          {"level", m.level},
          {"name", str(m.name)},
          {"msg", str(m.msg)},
          {"file", str(m.file)},
          {"function", str(m.function)},
          {"line", m.line}};
}
json to_json(const msgs::nav_msgs::Odometry& m) {
  return {{"header", to_json(m.header)},
          {"child_frame_id", str(m.child_frame_id)},
          {"pose", to_json(m.pose)},
          {"twist", to_json(m.twist)}};
}
json to_json(const msgs::sensor_msgs::Imu& m) {
  auto cov = [](const double(&c)[9]) {
    json a = json::array();
    for (double v : c) a.push_back(num(v));
    return a;
  };
  return {{"header", to_json(m.header)},
          {"orientation", to_json(m.orientation)},
          {"orientation_covariance", cov(m.orientation_covariance)},
          {"angular_velocity", to_json(m.angular_velocity)},
          {"angular_velocity_covariance", cov(m.angular_velocity_covariance)},
          {"linear_acceleration", to_json(m.linear_acceleration)},
          {"linear_acceleration_covariance", cov(m.linear_acceleration_covariance)}};
}
json to_json(const msgs::sensor_msgs::CompressedImage& m) {
  return {{"header", to_json(m.header)}, {"format", str(m.format)}, {"data", {{"bytes", m.data._length}}}};
}
json to_json(const msgs::sensor_msgs::JointState& m) {
  return {{"header", to_json(m.header)},
          {"name", strings(m.name)},
          {"position", numbers(m.position)},
          {"velocity", numbers(m.velocity)},
          {"effort", numbers(m.effort)}};
}
json to_json(const msgs::diagnostic_msgs::KeyValue& m) {
  return {{"key", str(m.key)}, {"value", str(m.value)}};
}
json to_json(const msgs::diagnostic_msgs::DiagnosticStatus& m) {
  return {{"level", m.level},
          {"name", str(m.name)},
          {"message", str(m.message)},
          {"hardware_id", str(m.hardware_id)},
          {"values", structs(m.values)}};
}
json to_json(const msgs::diagnostic_msgs::DiagnosticArray& m) {
  return {{"header", to_json(m.header)}, {"status", structs(m.status)}};
}
json to_json(const msgs::grid_map_msgs::GridMapInfo& m) {
  return {{"resolution", num(m.resolution)},
          {"length_x", num(m.length_x)},
          {"length_y", num(m.length_y)},
          {"pose", to_json(m.pose)}};
}
json to_json(const msgs::grid_map_msgs::GridMap& m) {
  return {{"header", to_json(m.header)},
          {"info", to_json(m.info)},
          {"layers", strings(m.layers)},
          {"basic_layers", strings(m.basic_layers)},
          {"data", structs(m.data)},
          {"outer_start_index", m.outer_start_index},
          {"inner_start_index", m.inner_start_index}};
}
json to_json(const msgs::vision_msgs::Point2D& m) {
  return {{"x", num(m.x)}, {"y", num(m.y)}};
}
json to_json(const msgs::vision_msgs::Pose2D& m) {
  return {{"position", to_json(m.position)}, {"theta", num(m.theta)}};
}
json to_json(const msgs::vision_msgs::BoundingBox2D& m) {
  return {{"center", to_json(m.center)}, {"size_x", num(m.size_x)}, {"size_y", num(m.size_y)}};
}
json to_json(const msgs::vision_msgs::ObjectHypothesis& m) {
  return {{"class_id", str(m.class_id)}, {"score", num(m.score)}};
}
json to_json(const msgs::vision_msgs::ObjectHypothesisWithPose& m) {
  return {{"hypothesis", to_json(m.hypothesis)}, {"pose", to_json(m.pose)}};
}
json to_json(const msgs::vision_msgs::Detection2D& m) {
  return {{"header", to_json(m.header)}, {"results", structs(m.results)}, {"bbox", to_json(m.bbox)}, {"id", str(m.id)}};
}
json to_json(const msgs::vision_msgs::Detection2DArray& m) {
  return {{"header", to_json(m.header)}, {"detections", structs(m.detections)}};
}
json to_json(const msgs::vision_msgs::BoundingBox3D& m) {
  return {{"center", to_json(m.center)}, {"size", to_json(m.size)}};
}
json to_json(const msgs::vision_msgs::Detection3D& m) {
  return {{"header", to_json(m.header)}, {"results", structs(m.results)}, {"bbox", to_json(m.bbox)}, {"id", str(m.id)}};
}
json to_json(const msgs::vision_msgs::Detection3DArray& m) {
  return {{"header", to_json(m.header)}, {"detections", structs(m.detections)}};
}
json to_json(const msgs::regolith_msgs::WheelSinkage& m) {
  return {{"header", to_json(m.header)},
          {"wheel_names", strings(m.wheel_names)},
          {"sinkage_m", numbers(m.sinkage_m)},
          {"confidence", numbers(m.confidence)}};
}
json to_json(const msgs::regolith_msgs::SoilStiffness& m) {
  return {{"header", to_json(m.header)},
          {"k", num(m.k)},
          {"n", num(m.n)},
          {"k_sigma", num(m.k_sigma)},
          {"n_sigma", num(m.n_sigma)},
          {"mean_sinkage_m", num(m.mean_sinkage_m)},
          {"samples_used", m.samples_used},
          {"soil_class", str(m.soil_class)}};
}
json to_json(const msgs::regolith_msgs::RockArray& m) {
  return {{"header", to_json(m.header)},
          {"detections", structs(m.detections)},
          {"ground_range_m", numbers(m.ground_range_m)},
          {"lateral_offset_m", numbers(m.lateral_offset_m)},
          {"width_m", numbers(m.width_m)},
          {"height_m", numbers(m.height_m)},
          {"hazard", bools(m.hazard)}};
}

}  // namespace regolith::dds
