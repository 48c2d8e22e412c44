#pragma once
// The table of topics regolith publishes (names relative to the robot namespace
// unless they start with "/"), their ROS types and QoS class, plus the generic
// `echo` used by `regolith echo`.
#include <cstddef>
#include <functional>
#include <iosfwd>
#include <span>
#include <string_view>

#include <dds/dds.h>

#include "regolith/dds/json.hpp"
#include "regolith/dds/participant.hpp"

namespace regolith::dds {

enum class TopicClass { kState, kStream, kDiagnostics };

struct TopicInfo {
  std::string_view name;      ///< "joint_states", "terrain/grid_map", "/diagnostics"
  std::string_view ros_type;  ///< "sensor_msgs/msg/JointState"
  TopicClass cls;
  const dds_topic_descriptor_t* descriptor;
  json (*to_json)(const void* sample);
  /// Writer profile our publishers use for this topic.
  QosProfile writer_qos() const;
  /// Reader profile `echo` uses: compatible with our writers and with ROS
  /// defaults; transient-local for state topics so a late reader still gets the
  /// latched map.
  QosProfile reader_qos() const;
};

/// Every known topic, in a fixed order.
std::span<const TopicInfo> known_topics();
/// Looks `name` up: "joint_states", "/joint_states" style relative/absolute
/// spellings of the same entry are accepted ("diagnostics" finds
/// "/diagnostics"). nullptr when unknown.
const TopicInfo* find_topic(std::string_view name);
/// "joint_states  sensor_msgs/msg/JointState  stream\n..." for `regolith echo
/// --list`.
std::string list_topics(const Participant* p = nullptr);

struct EchoOptions {
  std::size_t count = 0;                       ///< stop after this many samples (0 = no limit)
  TimeNs timeout_ns = 0;                       ///< stop after this long without reaching count (0 = never)
  bool best_effort = false;                    ///< best-effort reader (matches ROS sensor-data publishers too)
  std::function<bool()> keep_going = nullptr;  ///< polled every 100 ms; return false to stop (Ctrl-C)
  /// Add "received" (ROS time, CLOCK_REALTIME, when the sample was taken) and, for a sample with a
  /// header, "delay_ms" = received - header.stamp (as `ros2 topic delay`).
  bool receipt_time = false;
};

/// Subscribes to `topic` (from known_topics()), prints every sample as one JSON
/// line on `out` until a stop condition holds; returns the number of samples
/// printed. Throws std::invalid_argument for an unknown topic, listing the
/// known ones.
std::size_t echo(Participant& p, std::string_view topic, const EchoOptions& opt, std::ostream& out);

/// Adds "received" {sec, nanosec} and, when the sample has header.stamp, "delay_ms" (received -
/// stamp, both ROS time) to an echoed sample.
void add_receipt_time(nlohmann::json& sample, TimeNs received_ns);

}  // namespace regolith::dds
