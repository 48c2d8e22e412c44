#pragma once
// ROS 2 topic naming on plain Cyclone DDS (frameworks.md section 5.2): relative
// names live under the robot namespace, absolute names ignore it, and the DDS
// topic is the fully qualified ROS name with its leading slash replaced by
// "rt/".
//   namespace "rover1", "joint_states"  -> ROS "/rover1/joint_states", DDS
//   "rt/rover1/joint_states" namespace "rover1", "/diagnostics"  -> ROS
//   "/diagnostics",         DDS "rt/diagnostics"
#include <string>
#include <string_view>

namespace regolith::dds {

/// Normalised namespace without leading / trailing slash ("/rover1/" ->
/// "rover1", "" -> ""). Throws std::invalid_argument naming the namespace when
/// a token breaks the ROS name rules (tokens of [A-Za-z0-9_], not starting with
/// a digit, no empty token).
std::string normalize_namespace(std::string_view ns);

/// Fully qualified ROS name of `topic` ("/rover1/joint_states"). Throws
/// std::invalid_argument for an empty name, a trailing slash, "//", a token
/// starting with a digit, or characters other than [A-Za-z0-9_/] ("~" and "{}"
/// substitutions are not supported).
std::string ros_topic_name(std::string_view ns, std::string_view topic);

/// DDS topic name on the wire: ros_topic_name() with the leading "/" replaced
/// by "rt/".
std::string wire_topic_name(std::string_view ns, std::string_view topic);

}  // namespace regolith::dds
