#include "regolith/terrain_scene/drive.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace regolith::terrain_scene {
namespace {

void require(bool ok, const std::string& field, const std::string& why) {
  if (!ok) throw std::invalid_argument("drive: " + field + ": " + why);
}

}  // namespace

void DrivePath::validate() const {
  require(std::isfinite(start_x_m) && std::isfinite(start_y_m) && std::isfinite(start_yaw_rad), "start",
          "must be finite");
  require(std::isfinite(speed_m_s) && speed_m_s >= 0 && speed_m_s <= 10, "speed_m_s", "must be in [0, 10]");
  require(std::isfinite(turn_radius_m) && (turn_radius_m == 0.0 || std::abs(turn_radius_m) >= 0.5), "turn_radius_m",
          "must be 0 (straight) or at least 0.5 m in magnitude");
  require(std::isfinite(duration_s) && duration_s >= 0, "duration_s", "must be >= 0");
}

double DrivePath::driven_time(double t_s) const {
  return std::clamp(t_s, 0.0, duration_s);
}

DrivePose DrivePath::pose_at(double t_s) const {
  const double t = driven_time(t_s);
  const double s = speed_m_s * t;       // arc length
  double fx = s, fy = 0.0, dyaw = 0.0;  // in the start frame
  if (turn_radius_m != 0.0) {
    dyaw = s / turn_radius_m;
    fx = turn_radius_m * std::sin(dyaw);
    fy = turn_radius_m * (1.0 - std::cos(dyaw));
  }
  const double c = std::cos(start_yaw_rad), sn = std::sin(start_yaw_rad);
  return {start_x_m + c * fx - sn * fy, start_y_m + sn * fx + c * fy, start_yaw_rad + dyaw};
}

cv::Vec2d DrivePath::velocity_at(double t_s) const {
  if (t_s < 0.0 || t_s >= duration_s) return {0.0, 0.0};
  return {speed_m_s, yaw_rate()};
}

double DrivePath::wheel_distance(double y_m, double t_s) const {
  return (speed_m_s - yaw_rate() * y_m) * driven_time(t_s);
}

cv::Vec4d DrivePath::bounds() const {
  double x0 = start_x_m, x1 = start_x_m, y0 = start_y_m, y1 = start_y_m;
  const int n = 200;
  for (int k = 1; k <= n; ++k) {
    const DrivePose p = pose_at(duration_s * k / n);
    x0 = std::min(x0, p.x_m), x1 = std::max(x1, p.x_m);
    y0 = std::min(y0, p.y_m), y1 = std::max(y1, p.y_m);
  }
  return {x0, y0, x1, y1};
}

Terrain make_drive_tile(const DrivePath& path, const DriveTileParams& tile) {
  path.validate();
  require(std::isfinite(tile.margin_m) && tile.margin_m >= 1.0, "margin_m", "must be >= 1 m");
  require(std::isfinite(tile.rocks_per_m2) && tile.rocks_per_m2 >= 0 && tile.rocks_per_m2 <= 10, "rocks_per_m2",
          "must be in [0, 10]");
  require(tile.craters >= 0 && tile.craters <= 50, "craters", "must be in [0, 50]");
  require(std::isfinite(tile.keep_clear_m) && tile.keep_clear_m >= 0, "keep_clear_m", "must be >= 0");
  const cv::Vec4d b = path.bounds();
  SceneParams sp;
  sp.seed = tile.seed;
  sp.resolution_m = tile.resolution_m;
  sp.fractal_rms_m = tile.fractal_rms_m;
  sp.fractal_beta = tile.fractal_beta;
  sp.x_min_m = b[0] - tile.margin_m;
  sp.x_max_m = b[2] + tile.margin_m;
  // Symmetric in y (the scene places objects within |y| <= place_y_abs_max).
  const double ya = std::max(std::abs(b[1]), std::abs(b[3])) + tile.margin_m;
  sp.y_min_m = -ya;
  sp.y_max_m = ya;
  // Objects where the camera looks: within margin - 1 m of the path's box.
  sp.place_x_min_m = b[0] - tile.margin_m + 1.0;
  sp.place_x_max_m = b[2] + tile.margin_m - 1.0;
  sp.place_y_abs_max_m = ya - 1.0;
  const double area = (sp.place_x_max_m - sp.place_x_min_m) * 2.0 * sp.place_y_abs_max_m;
  sp.num_rocks = static_cast<int>(std::lround(tile.rocks_per_m2 * area));
  sp.rock_radius_min_m = tile.rock_radius_min_m;
  sp.rock_radius_max_m = tile.rock_radius_max_m;
  sp.num_craters = tile.craters;
  sp.crater_radius_min_m = tile.crater_radius_min_m;
  sp.crater_radius_max_m = tile.crater_radius_max_m;
  // The wheels drive on clear ground: keep objects off the path (sampled every 0.2 m).
  const double len = path.speed_m_s * path.duration_s;
  const int n = std::max(1, static_cast<int>(std::ceil(len / 0.2)));
  for (int k = 0; k <= n; ++k) {
    const DrivePose p = path.pose_at(path.duration_s * k / n);
    sp.keep_clear_points.emplace_back(p.x_m, p.y_m);
  }
  sp.keep_clear_m = tile.keep_clear_m;
  return Terrain(sp);
}

}  // namespace regolith::terrain_scene
