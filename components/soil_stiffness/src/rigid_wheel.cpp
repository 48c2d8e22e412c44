#include "regolith/soil_stiffness/rigid_wheel.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "regolith/core/error.hpp"

namespace regolith::soil {
namespace {

[[noreturn]] void fail(const std::string& field, const std::string& what, double got) {
  std::ostringstream os;
  os << what << " (got " << got << ")";
  throw FieldError("", field, os.str());
}

void require_positive(const char* field, double v) {
  if (!std::isfinite(v) || v <= 0.0) fail(field, "must be a finite value > 0", v);
}

}  // namespace

void RoverConfig::validate() const {
  require_positive("mass_kg", mass_kg);
  if (wheel_count <= 0) fail("wheel_count", "must be > 0", wheel_count);
  require_positive("gravity_mps2", gravity_mps2);
  require_positive("wheel_width_m", wheel_width_m);
  require_positive("wheel_diameter_m", wheel_diameter_m);
  if (wheel_width_m > 10.0) fail("wheel_width_m", "must be <= 10 m", wheel_width_m);
  if (wheel_diameter_m > 20.0) fail("wheel_diameter_m", "must be <= 20 m", wheel_diameter_m);
}

double load_factor(double n, SinkageModel model) {
  if (!std::isfinite(n) || n < 0.0) fail("n", "sinkage exponent must be finite and >= 0", n);
  if (model == SinkageModel::kBekker) {
    if (n >= 3.0) fail("n", "Bekker rigid-wheel form needs n < 3", n);
    return (3.0 - n) / 3.0;
  }
  // B(n+1, 1/2) / 2 = Gamma(n+1) Gamma(1/2) / (2 Gamma(n+3/2))
  const double log_beta = std::lgamma(n + 1.0) + std::lgamma(0.5) - std::lgamma(n + 1.5);
  return 0.5 * std::exp(log_beta);
}

double sinkage_from_soil(double k, double n, double load_n, double width_m, double diameter_m, SinkageModel model) {
  require_positive("k", k);
  require_positive("load_n", load_n);
  require_positive("width_m", width_m);
  require_positive("diameter_m", diameter_m);
  const double f = load_factor(n, model);
  const double base = load_n / (f * width_m * k * std::sqrt(diameter_m));
  return std::pow(base, 2.0 / (2.0 * n + 1.0));
}

double stiffness_from_sinkage(double z_m, double n, double load_n, double width_m, double diameter_m,
                              SinkageModel model) {
  require_positive("z_m", z_m);
  require_positive("load_n", load_n);
  require_positive("width_m", width_m);
  require_positive("diameter_m", diameter_m);
  const double f = load_factor(n, model);
  return load_n / (f * width_m * std::sqrt(diameter_m) * std::pow(z_m, (2.0 * n + 1.0) / 2.0));
}

double fit_k_fixed_n(std::span<const SinkageSample> samples, double n, SinkageModel model) {
  if (samples.empty()) throw std::invalid_argument("samples: no sinkage samples to fit");
  double acc = 0.0;
  for (const auto& s : samples) {
    acc += std::log(stiffness_from_sinkage(s.z_m, n, s.load_n, s.width_m, s.diameter_m, model));
  }
  return std::exp(acc / static_cast<double>(samples.size()));
}

JointFit fit_joint(std::span<const SinkageSample> samples, SinkageModel model, double min_load_ratio) {
  JointFit r;
  if (samples.size() < 2) {
    std::snprintf(r.reason, sizeof r.reason, "need at least two sinkage samples");
    return r;
  }
  double xmin = std::numeric_limits<double>::infinity();
  double xmax = -xmin;
  double sx = 0.0, sy = 0.0;
  for (const auto& s : samples) {
    if (!(s.z_m > 0.0) || !(s.load_n > 0.0) || !(s.width_m > 0.0) || !(s.diameter_m > 0.0)) {
      std::snprintf(r.reason, sizeof r.reason, "sample with non-positive sinkage, load, width or diameter");
      return r;
    }
    const double x = std::log(s.load_n / (s.width_m * std::sqrt(s.diameter_m)));
    xmin = std::min(xmin, x);
    xmax = std::max(xmax, x);
    sx += x;
    sy += std::log(s.z_m);
  }
  if (xmax - xmin < std::log(min_load_ratio)) {
    std::snprintf(r.reason, sizeof r.reason, "need at least two distinct wheel loads (load ratio >= %.3g)",
                  min_load_ratio);
    return r;
  }
  const double cnt = static_cast<double>(samples.size());
  const double mx = sx / cnt, my = sy / cnt;
  double sxx = 0.0, sxy = 0.0;
  for (const auto& s : samples) {
    const double dx = std::log(s.load_n / (s.width_m * std::sqrt(s.diameter_m))) - mx;
    sxx += dx * dx;
    sxy += dx * (std::log(s.z_m) - my);
  }
  const double slope = sxy / sxx;  // s = 2/(2n+1)
  if (!(slope > 0.0)) {
    std::snprintf(r.reason, sizeof r.reason, "sinkage does not increase with load (slope %.4g)", slope);
    return r;
  }
  const double n = 1.0 / slope - 0.5;
  const double n_max = model == SinkageModel::kBekker ? 3.0 : 10.0;
  if (!(n >= 0.0 && n < n_max)) {
    std::snprintf(r.reason, sizeof r.reason, "fitted n = %.4g outside the model range", n);
    return r;
  }
  const double intercept = my - slope * mx;  // = -s ln(k f(n))
  const double k = std::exp(-intercept / slope) / load_factor(n, model);
  double ss = 0.0;
  for (const auto& s : samples) {
    const double x = std::log(s.load_n / (s.width_m * std::sqrt(s.diameter_m)));
    const double e = std::log(s.z_m) - (intercept + slope * x);
    ss += e * e;
  }
  r.ok = true;
  r.k = k;
  r.n = n;
  r.rms_log_residual = std::sqrt(ss / cnt);
  return r;
}

}  // namespace regolith::soil
