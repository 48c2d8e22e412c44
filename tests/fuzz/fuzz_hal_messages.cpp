// libFuzzer target: the decoders of the HAL recording's messages (record/hal_messages.hpp), which
// `regolith replay` runs on every message of a recording: sensor_msgs/Image (hostile sizes and
// steps), JointState, Imu, Vector3Stamped, can_msgs/Frame and ros2_socketcan_msgs/FdFrame (the raw CAN
// frames `regolith log export` turns into a candump log). The first byte picks the decoder; the rest is the CDR
// payload. Errors must be std::out_of_range / std::invalid_argument, never a crash or a huge
// allocation.
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>

#include "regolith/record/hal_messages.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::span<const std::uint8_t> cdr(data + 1, size - 1);
  try {
    switch (data[0] % 6) {
      case 0: {
        const auto d = regolith::record::decode_image(cdr);
        if (d.image.empty()) __builtin_trap();  // a decoded image always has pixels
        break;
      }
      case 1: (void)regolith::record::decode_wheel_angle(cdr); break;
      case 2: (void)regolith::record::decode_imu(cdr); break;
      case 3: (void)regolith::record::decode_attitude(cdr); break;
      default: {
        const bool fd = data[0] % 6 == 5;
        const auto f = regolith::record::decode_can_frame(cdr, fd);
        if (f.len > (fd ? 64 : 8)) __builtin_trap();  // a decoded frame's payload fits its kind
        break;
      }
    }
  } catch (const std::out_of_range&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
