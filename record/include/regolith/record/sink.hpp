#pragma once
// MessageSink: where a recorder's messages go, so that several recorders write one MCAP file (the
// DDS recorder's topics and the HAL recorder's device inputs in `regolith run --record`).
// Implementations are thread-safe.
#include <cstdint>
#include <map>
#include <span>
#include <string>

namespace regolith::record {

class MessageSink {
 public:
  virtual ~MessageSink() = default;
  /// A channel for `topic` with the ros2msg schema of `ros_type` (e.g. "sensor_msgs/msg/Image")
  /// and cdr message encoding; the schema is written once per type. Returns the channel id.
  virtual std::uint16_t add_cdr_channel(const std::string& topic, const std::string& ros_type,
                                        const std::map<std::string, std::string>& metadata) = 0;
  /// One message; `log_time` / `publish_time` in ns (MCAP: the recording's ROS time).
  virtual void write(std::uint16_t channel, std::uint32_t sequence, std::uint64_t log_time, std::uint64_t publish_time,
                     std::span<const std::uint8_t> data) = 0;
  virtual void add_metadata(const std::string& name, const std::map<std::string, std::string>& values) = 0;
};

}  // namespace regolith::record
