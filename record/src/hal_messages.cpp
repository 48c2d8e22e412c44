#include "regolith/record/hal_messages.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "regolith/record/cdr.hpp"

namespace regolith::record {

void encode_image(std::vector<std::uint8_t>& out, TimeNs stamp, const std::string& frame_id, const cv::Mat& image) {
  CdrWriter w(out);
  w.header(stamp, frame_id);
  w.u32(static_cast<std::uint32_t>(image.rows));
  w.u32(static_cast<std::uint32_t>(image.cols));
  w.string(image.channels() == 1 ? "mono8" : "bgr8");
  w.u8(0);
  const std::size_t step = static_cast<std::size_t>(image.cols) * image.elemSize();
  w.u32(static_cast<std::uint32_t>(step));
  if (image.isContinuous()) {
    w.bytes(image.data, step * static_cast<std::size_t>(image.rows));
  } else {
    w.u32(static_cast<std::uint32_t>(step * static_cast<std::size_t>(image.rows)));
    for (int r = 0; r < image.rows; ++r) out.insert(out.end(), image.ptr(r), image.ptr(r) + step);
  }
}

void encode_wheel_angle(std::vector<std::uint8_t>& out, TimeNs stamp, const std::string& wheel, double angle) {
  CdrWriter w(out);
  w.header(stamp, "");
  w.u32(1);
  w.string(wheel);
  w.f64_sequence(std::span<const double>(&angle, 1));
  w.u32(0);  // velocity
  w.u32(0);  // effort
}

void encode_imu(std::vector<std::uint8_t>& out, const hal::ImuSample& s, const std::string& frame_id) {
  CdrWriter w(out);
  w.header(s.stamp, frame_id);
  const hal::Quaternion q = hal::to_quaternion(s.attitude);
  for (double v : {q.x, q.y, q.z, q.w}) w.f64(v);
  for (int i = 0; i < 9; ++i) w.f64(0.0);
  for (double v : {s.angular_velocity.x, s.angular_velocity.y, s.angular_velocity.z}) w.f64(v);
  for (int i = 0; i < 9; ++i) w.f64(0.0);
  for (double v : {s.linear_acceleration.x, s.linear_acceleration.y, s.linear_acceleration.z}) w.f64(v);
  for (int i = 0; i < 9; ++i) w.f64(0.0);
}

void encode_attitude(std::vector<std::uint8_t>& out, TimeNs stamp, const Attitude& a) {
  CdrWriter w(out);
  w.header(stamp, "");
  w.f64(a.roll_rad);
  w.f64(a.pitch_rad);
  w.f64(a.yaw_rad);
}

void encode_can_frame(std::vector<std::uint8_t>& out, const hal::CanFrame& f, const std::string& frame_id) {
  CdrWriter w(out);
  w.header(f.stamp, frame_id);
  w.u32(f.id);
  if (f.fd) {
    w.u8(f.extended ? 1 : 0);
    w.u8(f.error ? 1 : 0);
    const std::uint8_t len = std::min<std::uint8_t>(f.len, 64);
    w.u8(len);
    w.bytes(f.data.data(), len);
  } else {
    w.u8(f.remote ? 1 : 0);
    w.u8(f.extended ? 1 : 0);
    w.u8(f.error ? 1 : 0);
    w.u8(std::min<std::uint8_t>(f.len, 8));
    for (int i = 0; i < 8; ++i) w.u8(f.data[static_cast<std::size_t>(i)]);  // uint8[8]: no length
  }
}

hal::CanFrame decode_can_frame(std::span<const std::uint8_t> cdr, bool fd) {
  CdrReader r(cdr);
  hal::CanFrame f;
  f.stamp = r.header();
  f.id = r.u32();
  f.fd = fd;
  if (fd) {
    f.extended = r.u8() != 0;
    f.error = r.u8() != 0;
    const std::uint8_t len = r.u8();
    const std::span<const std::uint8_t> data = r.bytes();
    if (len > 64 || data.size() > 64 || data.size() < len)
      throw std::invalid_argument("CAN FD frame: len " + std::to_string(len) + " with " + std::to_string(data.size()) +
                                  " data bytes (at most 64)");
    f.len = len;
    std::copy_n(data.data(), len, f.data.data());
  } else {
    f.remote = r.u8() != 0;
    f.extended = r.u8() != 0;
    f.error = r.u8() != 0;
    f.len = r.u8();
    if (f.len > 8) throw std::invalid_argument("CAN frame: dlc " + std::to_string(f.len) + " (at most 8)");
    for (int i = 0; i < 8; ++i) f.data[static_cast<std::size_t>(i)] = r.u8();
  }
  if (f.id > (f.extended || f.error ? 0x1FFFFFFFU : 0x7FFU))
    throw std::invalid_argument("CAN frame: identifier " + std::to_string(f.id) + " out of range");
  return f;
}

DecodedImage decode_image(std::span<const std::uint8_t> cdr) {
  CdrReader r(cdr);
  DecodedImage d;
  d.stamp = r.header(&d.frame_id);
  const std::uint32_t height = r.u32(), width = r.u32();
  const std::string encoding = r.string();
  r.u8();
  const std::uint32_t step = r.u32();
  const std::span<const std::uint8_t> data = r.bytes();
  int type = 0;
  if (encoding == "mono8") {
    type = CV_8UC1;
  } else if (encoding == "bgr8") {
    type = CV_8UC3;
  } else {
    throw std::invalid_argument("image encoding '" + encoding + "' (mono8 and bgr8 are replayed)");
  }
  const std::size_t row = static_cast<std::size_t>(width) * (type == CV_8UC1 ? 1 : 3);
  if (height == 0 || width == 0 || height > 65535 || width > 65535 || step < row ||
      data.size() < static_cast<std::size_t>(step) * height)
    throw std::invalid_argument("image " + std::to_string(width) + "x" + std::to_string(height) + ", step " +
                                std::to_string(step) + ": " + std::to_string(data.size()) + " bytes of pixels");
  d.image.create(static_cast<int>(height), static_cast<int>(width), type);
  for (std::uint32_t y = 0; y < height; ++y)
    std::copy_n(data.data() + static_cast<std::size_t>(y) * step, row, d.image.ptr(static_cast<int>(y)));
  return d;
}

DecodedWheelAngle decode_wheel_angle(std::span<const std::uint8_t> cdr) {
  CdrReader r(cdr);
  DecodedWheelAngle d;
  d.stamp = r.header();
  if (r.u32() != 1) throw std::invalid_argument("a wheel-angle message names one joint");
  d.wheel = r.string();
  const std::vector<double> p = r.f64_sequence();
  if (p.size() != 1) throw std::invalid_argument("a wheel-angle message has one position");
  d.angle = p[0];
  return d;
}

hal::ImuSample decode_imu(std::span<const std::uint8_t> cdr) {
  CdrReader r(cdr);
  hal::ImuSample s;
  s.stamp = r.header();
  const double x = r.f64(), y = r.f64(), z = r.f64(), w = r.f64();
  // R = Rz(yaw) Ry(pitch) Rx(roll) from the unit quaternion.
  s.attitude.roll_rad = std::atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
  s.attitude.pitch_rad = std::asin(std::clamp(2 * (w * y - z * x), -1.0, 1.0));
  s.attitude.yaw_rad = std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
  for (int i = 0; i < 9; ++i) r.f64();
  s.angular_velocity = {r.f64(), r.f64(), r.f64()};
  for (int i = 0; i < 9; ++i) r.f64();
  s.linear_acceleration = {r.f64(), r.f64(), r.f64()};
  return s;
}

DecodedAttitude decode_attitude(std::span<const std::uint8_t> cdr) {
  CdrReader r(cdr);
  DecodedAttitude d;
  d.stamp = r.header(&d.frame_id);
  d.a.roll_rad = r.f64();
  d.a.pitch_rad = r.f64();
  d.a.yaw_rad = r.f64();
  return d;
}

}  // namespace regolith::record
