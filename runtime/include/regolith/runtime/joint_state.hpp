#pragma once
#include <array>
#include <cstdint>

#include "regolith/core/time.hpp"

namespace regolith::runtime {

inline constexpr std::size_t kMaxJoints = 16;

/// Wheel angles of one encoder set at one instant, on channel "joint_states" (fixed size: no
/// allocation on the real-time path). Names come from the encoder set's configuration.
struct JointStateSample {
  TimeNs stamp = 0;
  std::uint32_t count = 0;
  std::array<double, kMaxJoints> position{};  ///< rad (continuous)
  std::array<double, kMaxJoints> velocity{};  ///< rad/s
};

}  // namespace regolith::runtime
