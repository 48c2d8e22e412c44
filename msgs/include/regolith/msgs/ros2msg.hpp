#pragma once
// The ROS 2 `.msg` definitions of every type regolith puts on the wire (msgs/ros2/definitions and
// msgs/ros2/regolith_msgs, embedded at build time), and the full `ros2msg` schema text MCAP,
// Foxglove and rosbag2 expect: the type's own text, then per dependency (transitively, each once,
// breadth first) a line of 80 '=', a line `MSG: pkg/Type` and that type's text.
// Target regolith::ros2msg (standard library only: no DDS), usable by record/ and runtime/dds.
#include <string>
#include <string_view>
#include <vector>

namespace regolith::msgs {

/// "sensor_msgs/msg/JointState" or "sensor_msgs/JointState" -> "sensor_msgs/JointState";
/// empty when `ros_type` is not of either form.
std::string ros2msg_short_name(std::string_view ros_type);

/// The type's own .msg text as shipped (comments included); empty when unknown.
std::string_view ros2msg_text(std::string_view ros_type);

/// The complete schema text (own text + every dependency). Throws std::invalid_argument naming
/// the type when it or one of its dependencies is unknown.
std::string ros2msg_definition(std::string_view ros_type);

/// Every embedded type as "pkg/Type", sorted.
std::vector<std::string_view> ros2msg_types();

}  // namespace regolith::msgs
