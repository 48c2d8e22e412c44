// libFuzzer target: the decoders of the HAL recording's messages (record/hal_messages.hpp), which
// `regolith replay` runs on every message of a recording: sensor_msgs/Image (hostile sizes and
// steps), JointState, Imu, Vector3Stamped. The first byte picks the decoder; the rest is the CDR
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
    switch (data[0] % 4) {
      case 0: {
        const auto d = regolith::record::decode_image(cdr);
        if (d.image.empty()) __builtin_trap();  // a decoded image always has pixels
        break;
      }
      case 1:
        (void)regolith::record::decode_wheel_angle(cdr);
        break;
      case 2:
        (void)regolith::record::decode_imu(cdr);
        break;
      default:
        (void)regolith::record::decode_attitude(cdr);
        break;
    }
  } catch (const std::out_of_range&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
