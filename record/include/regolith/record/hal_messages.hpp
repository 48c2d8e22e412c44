#pragma once
// The CDR messages of the HAL recording (hal_recorder.hpp) and their decoders for replay.
// Encoders reuse the caller's buffer (no allocation once it is large enough); decoders throw
// std::out_of_range ("CDR: ...") or std::invalid_argument on a damaged or foreign message.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "regolith/core/rover.hpp"
#include "regolith/core/time.hpp"
#include "regolith/hal/can.hpp"
#include "regolith/hal/imu.hpp"

namespace regolith::record {

/// sensor_msgs/Image of a mono8 / bgr8 frame, stamped `stamp` (process clock).
void encode_image(std::vector<std::uint8_t>& out, TimeNs stamp, const std::string& frame_id, const cv::Mat& image);
/// sensor_msgs/JointState with one joint: `wheel` at `angle` rad (NaN: no value), stamped `stamp`.
void encode_wheel_angle(std::vector<std::uint8_t>& out, TimeNs stamp, const std::string& wheel, double angle);
/// sensor_msgs/Imu of a sample (orientation = the attitude as a quaternion; covariances all zero:
/// "unknown" as the message defines it). Stamp = the sample's, process clock.
void encode_imu(std::vector<std::uint8_t>& out, const hal::ImuSample& s, const std::string& frame_id);
/// geometry_msgs/Vector3Stamped (x, y, z) = (roll, pitch, yaw) [rad] at `stamp`.
void encode_attitude(std::vector<std::uint8_t>& out, TimeNs stamp, const Attitude& a);

/// A raw CAN frame: can_msgs/Frame for a classic frame, ros2_socketcan_msgs/FdFrame for a CAN FD
/// one (frame.fd), stamped with its receive time (process clock).
void encode_can_frame(std::vector<std::uint8_t>& out, const hal::CanFrame& frame, const std::string& frame_id);
/// The frame back from either message (`fd`: the payload is an FdFrame); stamp = the header's.
hal::CanFrame decode_can_frame(std::span<const std::uint8_t> cdr, bool fd);

struct DecodedImage {
  TimeNs stamp = 0;
  std::string frame_id;
  cv::Mat image;  ///< CV_8UC1 (mono8) or CV_8UC3 (bgr8), owning its pixels
};
DecodedImage decode_image(std::span<const std::uint8_t> cdr);

struct DecodedWheelAngle {
  TimeNs stamp = 0;
  std::string wheel;
  double angle = 0.0;
};
DecodedWheelAngle decode_wheel_angle(std::span<const std::uint8_t> cdr);

hal::ImuSample decode_imu(std::span<const std::uint8_t> cdr);

struct DecodedAttitude {
  TimeNs stamp = 0;
  std::string frame_id;  ///< as written (the recorder writes "")
  Attitude a;
};
DecodedAttitude decode_attitude(std::span<const std::uint8_t> cdr);

}  // namespace regolith::record
