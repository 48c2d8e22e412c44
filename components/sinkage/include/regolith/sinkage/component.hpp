#pragma once
// Component wrapper "wheel_sinkage": per camera frame, the wheel angle at the frame's capture time
// (interpolated from the WheelEncoders history), the sinkage estimator, and the outputs:
//   * channel "terrain/wheel_sinkage" (WheelSinkageSample, below) for other components;
//   * DDS topic terrain/wheel_sinkage (regolith_msgs/WheelSinkage, stamped with the capture time;
//     sinkage_m = NaN and confidence = 0 when the frame gave no valid result);
//   * optional overlay PNGs every N frames and, in bench-rig mode, a vision-vs-transducer CSV log,
//     both written by a non-real-time writer thread.
// Parameters, units and defaults: components/sinkage/README.md.
#include <cstdint>
#include <limits>

#include "regolith/core/params.hpp"
#include "regolith/core/time.hpp"
#include "regolith/sinkage/sinkage.hpp"

namespace regolith::sinkage {

/// Name of the shared channel (and of the DDS topic).
inline constexpr const char* kSinkageChannel = "terrain/wheel_sinkage";

/// Reasons found by the component before the estimator runs (counted in diagnostics()).
enum class EncoderProblem : std::uint8_t {
  kNone = 0,
  kMissing,  ///< no encoder sample at all yet
  kStale,    ///< newest sample older than encoder_timeout_s at the frame's capture time
  kNoAngle,  ///< angle_at(capture time) failed (outside the history / beyond extrapolation)
};
const char* to_string(EncoderProblem p);

/// One processed frame, on channel "terrain/wheel_sinkage".
struct WheelSinkageSample {
  TimeNs stamp = 0;            ///< capture time of the frame (ns, process clock)
  std::uint64_t sequence = 0;  ///< camera frame sequence number
  double encoder_angle_rad = std::numeric_limits<double>::quiet_NaN();  ///< at the capture time
  EncoderProblem encoder = EncoderProblem::kNone;
  double transducer_mm = std::numeric_limits<double>::quiet_NaN();  ///< bench rig: truth at capture time
  SinkageResult result;    ///< valid / sinkage_mm / confidence / per-leg details
  WheelGeometry geometry;  ///< the wheel in the image the result refers to (configured)
};

/// The algorithm part of a `wheel_sinkage` mapping: the `geometry` block (mandatory; hub_center_px,
/// leg_length_px and leg_width_px required) and the estimator keys. Both structs are validated;
/// errors are ConfigError at the offending key ("...geometry.leg_width_px: must be in ...").
struct AlgorithmConfig {
  WheelGeometry geometry;
  SinkageParams params;
};
AlgorithmConfig read_algorithm_config(Params& p);

/// Registers component type "wheel_sinkage" (idempotent).
void register_component();

}  // namespace regolith::sinkage
