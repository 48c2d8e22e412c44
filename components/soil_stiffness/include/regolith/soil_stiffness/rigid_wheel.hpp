#pragma once
// Bernstein-Goriatchkin pressure-sinkage law p = k z^n and the static sinkage of a rigid wheel
// (Bekker). Framework-free; SI units throughout (N, m, Pa; k in N/m^(n+2)).
//
// Derivation (documented in the README, after Bekker 1969 and Wong, "Theory of Ground Vehicles",
// ch. 2): a rigid wheel of diameter D and width b resting on soil with static sinkage z0 touches
// the soil on its front arc. At horizontal distance x from the lowest point the local sinkage is
// z(x) = z0 - h with h = D/2 - sqrt(D^2/4 - x^2), i.e. x^2 = D h - h^2 ~= D h for z0 << D. Vertical
// equilibrium W = b * integral_0^l k z(x)^n dx, with dx = sqrt(D)/(2 sqrt(z0 - z)) dz, gives
//     W = (b k sqrt(D) / 2) * integral_0^z0 z^n (z0 - z)^(-1/2) dz
//       = (b k sqrt(D) / 2) * B(n+1, 1/2) * z0^((2n+1)/2)                       (kBeta, exact)
// Bekker's closed form keeps the first two terms of the series expansion of the integrand:
//     W = b k sqrt(D) * z0^((2n+1)/2) * (3 - n) / 3                             (kBekker)
// Both agree exactly for n = 0 and n = 1 and differ by < 7 % for 0.5 <= n <= 1.5.
#include <cmath>
#include <span>
#include <string>
#include <vector>

namespace regolith::soil {

/// Which closed form of the rigid-wheel load-sinkage integral to use.
enum class SinkageModel {
  kBekker,  ///< W = b k sqrt(D) z^((2n+1)/2) (3-n)/3  (spec section 8; valid for n < 3)
  kBeta,    ///< W = b k sqrt(D) z^((2n+1)/2) B(n+1, 1/2)/2  (exact for x^2 ~= D h)
};

/// Rover description for the sinkage relation. All fields SI.
struct RoverConfig {
  double mass_kg = 140.0;          ///< total rover mass [kg] (Yutu default)
  int wheel_count = 6;             ///< wheels sharing the load equally [-]
  double gravity_mps2 = 1.62;      ///< surface gravity [m/s^2] (Moon)
  double wheel_width_m = 0.15;     ///< wheel width b [m]
  double wheel_diameter_m = 0.30;  ///< wheel diameter D [m]

  /// Static vertical load per wheel W = M g / N_w [N].
  double wheel_load_n() const { return mass_kg * gravity_mps2 / wheel_count; }
  /// Throws std::invalid_argument naming the offending field (e.g. "wheel_count: must be > 0").
  void validate() const;
};

/// Load factor f(n) in W = f(n) b k sqrt(D) z^((2n+1)/2). Throws if n is outside the model's range.
double load_factor(double n, SinkageModel model = SinkageModel::kBekker);

/// Forward: static sinkage z [m] of a rigid wheel under load W [N] on soil (k, n).
double sinkage_from_soil(double k, double n, double load_n, double width_m, double diameter_m,
                         SinkageModel model = SinkageModel::kBekker);
/// Inverse for fixed n: k [N/m^(n+2)] that gives sinkage z [m] under load W [N].
double stiffness_from_sinkage(double z_m, double n, double load_n, double width_m, double diameter_m,
                              SinkageModel model = SinkageModel::kBekker);
/// Pressure p = k z^n [Pa].
inline double bg_pressure(double k, double n, double z_m);

/// One sinkage observation with the wheel that produced it.
struct SinkageSample {
  double z_m = 0.0;         ///< measured static sinkage [m]
  double load_n = 0.0;      ///< vertical wheel load [N]
  double width_m = 0.0;     ///< wheel width [m]
  double diameter_m = 0.0;  ///< wheel diameter [m]
};

/// Result of a joint (k, n) fit.
struct JointFit {
  bool ok = false;
  /// Why !ok (e.g. "need at least two distinct wheel loads"); a fixed buffer so that a fit never
  /// allocates (it runs inside the real-time step and in the bootstrap loop).
  char reason[128] = {};
  double k = 0.0;                 ///< [N/m^(n+2)]
  double n = 0.0;                 ///< [-]
  double rms_log_residual = 0.0;  ///< RMS of ln(z) residuals [-]
};

/// Joint least-squares fit of k and n from samples with at least two distinct values of
/// W / (b sqrt(D)) (different loads, wheels or passes). Regresses ln z on ln(W / (b sqrt D)):
/// ln z = s * ln(W/(b sqrt D)) - s * ln(k f(n)), with s = 2/(2n+1), i.e. the measured quantity is
/// the dependent variable (unbiased under sinkage noise). Closed form, no iteration beyond a
/// scalar solve for f(n) when the model is kBeta.
JointFit fit_joint(std::span<const SinkageSample> samples, SinkageModel model = SinkageModel::kBekker,
                   double min_load_ratio = 1.2);

/// Fixed-n estimate of k from samples: k from the geometric mean of the per-sample k values
/// (i.e. a least-squares fit in log space). Throws std::invalid_argument on empty input.
double fit_k_fixed_n(std::span<const SinkageSample> samples, double n, SinkageModel model = SinkageModel::kBekker);

inline double bg_pressure(double k, double n, double z_m) {
  return z_m <= 0.0 ? 0.0 : k * std::pow(z_m, n);
}

}  // namespace regolith::soil
