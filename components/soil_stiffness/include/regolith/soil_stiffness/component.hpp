#pragma once
// Component wrapper "soil_stiffness" (rate group "soil", e.g. 0.5 Hz, on the rear camera): per
// cycle the newest rear frame not yet processed -> SoilStiffnessEstimator -> outputs
//   * channel "terrain/soil" (SoilStiffnessSample, below), stamped with the frame's capture time;
//   * channel "terrain/sinkage_layer" (SinkageLayer, sinkage_layer.hpp): the rut profiles in the
//     rover body frame for the terrain grid map's `sinkage` layer (rasterise_sinkage());
//   * DDS topic terrain/soil (regolith_msgs/SoilStiffness, state QoS, Outbox kLatest) when DDS is
//     enabled. A frame without an estimate is published explicitly: k = n = NaN, samples_used = 0,
//     soil_class "no_estimate" (the reason is in the channel sample and the component status).
// Parameters (units, defaults): components/soil_stiffness/README.md; parsing: config.hpp.
#include <cstdint>
#include <limits>

#include "regolith/core/time.hpp"
#include "regolith/soil_stiffness/sinkage_layer.hpp"
#include "regolith/soil_stiffness/track_analysis.hpp"

namespace regolith::soil {

/// Channel names (the first is also the DDS topic).
inline constexpr const char* kSoilChannel = "terrain/soil";
using common::kSinkageLayerChannel;  // payload: regolith/common/payloads.hpp

/// One processed rear frame, on channel "terrain/soil". Fixed size: no heap in the channel.
struct SoilStiffnessSample {
  TimeNs stamp = 0;            ///< capture time of the rear frame [ns, process clock]
  std::uint64_t sequence = 0;  ///< camera frame sequence number
  bool ok = false;             ///< false: no estimate, see `reason`
  char reason[192] = {};       ///< why there is no estimate (truncated SoilEstimate::reason)
  bool joint = false;          ///< n below comes from the joint fit (several loads) with the prior on n
  double k = std::numeric_limits<double>::quiet_NaN();        ///< reported k [N/m^(n+2)]
  double n = std::numeric_limits<double>::quiet_NaN();        ///< reported n [-]
  double k_sigma = std::numeric_limits<double>::quiet_NaN();  ///< 1-sigma (bootstrap and n's) [N/m^(n+2)]
  double n_sigma = std::numeric_limits<double>::quiet_NaN();  ///< 0 when n was fixed [-]
  double k_fixed = std::numeric_limits<double>::quiet_NaN();  ///< fixed-n estimate [N/m^(n+2)]
  double k_fixed_sigma = std::numeric_limits<double>::quiet_NaN();
  double n_fixed = 1.0;                                              ///< the fixed n used [-]
  double mean_sinkage_m = std::numeric_limits<double>::quiet_NaN();  ///< [m]
  std::uint32_t samples_used = 0;                                    ///< profile samples (rows x tracks) in the fit
  std::uint32_t tracks = 0;                                          ///< tracks measured
  SoilClass soil_class = SoilClass::kUnknown;
  double class_pressure_pa = std::numeric_limits<double>::quiet_NaN();  ///< p(z_ref) [Pa]
};

/// Registers component type "soil_stiffness" (idempotent).
void register_component();

}  // namespace regolith::soil
