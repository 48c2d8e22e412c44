#pragma once
// Wheel-angle scripts shared by the "scripted" encoders and the synthetic wheel camera.
#include <memory>
#include <string>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/hal/registry.hpp"

namespace regolith::mocks::detail {

/// Angles (rad) of several wheels against time (s) from a CSV file "time_s,<wheel>,...",
/// linearly interpolated; held at the ends, or repeated (with the net rotation accumulated) when
/// looping. Problems throw ConfigError "file:line: problem".
class AngleProfile {
 public:
  /// `wanted`: wheel columns to take, in this order (empty = every column of the header).
  static AngleProfile load_csv(const std::string& file, const std::vector<std::string>& wanted, bool loop);
  const std::vector<std::string>& wheels() const { return wheels_; }
  double at(std::size_t wheel, double t_s) const;
  double duration() const { return times_.back() - times_.front(); }

 private:
  std::vector<std::string> wheels_;
  std::vector<double> times_;
  std::vector<std::vector<double>> angles_;  // [wheel][row]
  bool loop_ = false;
};

/// Constant speed per wheel (angle = initial + speed * t) or a CSV profile; t = seconds since start.
class ScriptedMotion {
 public:
  /// Reads speed_rad_s / initial_angle_rad or profile_csv (+ loop) from `p`.
  static ScriptedMotion from_params(Params& p, const hal::DeviceContext& ctx, std::vector<std::string> wheels);
  const std::vector<std::string>& wheels() const { return wheels_; }
  double angle(std::size_t wheel, double t_s) const;

 private:
  std::vector<std::string> wheels_;
  std::vector<double> speed_, initial_;
  std::shared_ptr<const AngleProfile> profile_;
};

}  // namespace regolith::mocks::detail
