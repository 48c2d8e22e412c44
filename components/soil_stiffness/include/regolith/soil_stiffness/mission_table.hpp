#pragma once
// Mission table (thesis Table 4.4 / 4.5 and Fig. 4.17 analogue): public vehicle data for
// Lunokhod 1 (Luna 17), the Apollo 15 LRV and Yutu (Chang'E-3), the lunar soil values they are
// compared with, and the p-z curves. Every number carries a source and a verified flag; see the
// component README for the table and the references.
#include <string>
#include <utility>
#include <vector>

#include "regolith/soil_stiffness/rigid_wheel.hpp"

namespace regolith::soil {

struct MissionEntry {
  std::string mission;            ///< e.g. "Luna 17"
  std::string vehicle;            ///< e.g. "Lunokhod 1"
  RoverConfig rover;              ///< mass, wheels, gravity, wheel b and D
  std::string vehicle_source;     ///< where mass / wheel data come from
  bool vehicle_verified = false;  ///< every vehicle number checked against the cited source here
  // "Traditional" soil values (Table 4.4 analogue): Lunar Sourcebook Bekker parameters,
  // k = k_c / b + k_phi with the vehicle's wheel width, n = 1.
  double k_c = 1400.0;      ///< cohesive modulus [N/m^(n+1)]
  double k_phi = 820000.0;  ///< frictional modulus [N/m^(n+2)]
  double n = 1.0;           ///< sinkage exponent [-]
  std::string soil_source;
  bool soil_verified = false;
  /// Reported static rut depth [m], NaN when no value could be sourced.
  double reported_sinkage_m = 0.0;
  std::string sinkage_source;
  bool sinkage_verified = false;

  /// Bernstein-Goriatchkin k of the traditional column for this vehicle [N/m^(n+2)].
  double k_traditional() const { return k_c / rover.wheel_width_m + k_phi; }
  /// Static sinkage the traditional (k, n) predict for this vehicle's wheel load [m].
  double predicted_sinkage_m(SinkageModel model = SinkageModel::kBekker) const;
  /// Image-method analogue (Table 4.5): k from the reported rut depth with n fixed [N/m^(n+2)];
  /// NaN when no rut depth is available.
  double k_from_reported_sinkage(SinkageModel model = SinkageModel::kBekker) const;
};

/// The three missions of the thesis comparison.
std::vector<MissionEntry> mission_table();

/// p = k z^n sampled at `count` points on [0, z_max] (pairs of z [m], p [Pa]).
std::vector<std::pair<double, double>> pz_curve(double k, double n, double z_max_m, int count = 64);

}  // namespace regolith::soil
