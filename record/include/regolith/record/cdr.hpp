#pragma once
// Plain CDR (XCDR1, little-endian, encapsulation 00 01 00 00), the payload encoding of ROS 2
// messages on DDS and in MCAP files ("cdr"). For the few message types regolith writes without a
// DDS writer (the HAL recording: sensor_msgs/Image, JointState, Imu, geometry_msgs/Vector3Stamped).
// Alignment is relative to the first byte after the 4-byte encapsulation header, as on the wire.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace regolith::record {

/// Appends to a caller-owned buffer; once its capacity is large enough (reserve at configure
/// time), writing a message of the same shape allocates nothing.
class CdrWriter {
 public:
  /// Clears `out` and writes the encapsulation header.
  explicit CdrWriter(std::vector<std::uint8_t>& out);

  void u8(std::uint8_t v) { raw(&v, 1); }
  void u32(std::uint32_t v) { aligned(&v, 4); }
  void i32(std::int32_t v) { aligned(&v, 4); }
  void f64(double v) { aligned(&v, 8); }
  /// u32 length including the terminating NUL, the characters, the NUL.
  void string(std::string_view s);
  /// sequence<uint8>: u32 count, the bytes.
  void bytes(const void* data, std::size_t n);
  /// sequence<double>.
  void f64_sequence(std::span<const double> v);
  /// builtin_interfaces/Time + frame_id: a std_msgs/Header.
  void header(std::int64_t stamp_ns, std::string_view frame_id);

 private:
  void raw(const void* p, std::size_t n);
  void aligned(const void* p, std::size_t n);
  std::vector<std::uint8_t>& out_;
};

/// Reads a CDR payload; every read checks the bounds and throws std::out_of_range ("CDR: ...")
/// past the end, so a damaged recording gives an error, never a crash.
class CdrReader {
 public:
  /// Checks the encapsulation header (little-endian plain CDR only).
  explicit CdrReader(std::span<const std::uint8_t> payload);

  std::uint8_t u8();
  std::uint32_t u32();
  std::int32_t i32();
  double f64();
  std::string string();
  /// sequence<uint8> without copying: a view into the payload.
  std::span<const std::uint8_t> bytes();
  std::vector<double> f64_sequence();
  /// A std_msgs/Header: the stamp in ns (sec * 1e9 + nanosec) and frame_id.
  std::int64_t header(std::string* frame_id = nullptr);

 private:
  const std::uint8_t* need(std::size_t n, std::size_t align);
  std::span<const std::uint8_t> p_;
  std::size_t pos_ = 4;
};

}  // namespace regolith::record
