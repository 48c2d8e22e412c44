#include "regolith/track_scene/track_scene.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace regolith::track_scene {
namespace {

constexpr double kPi = 3.14159265358979323846;

void check(bool ok, const char* field, const char* what, double got) {
  if (ok) return;
  std::ostringstream os;
  os << field << ": " << what << " (got " << got << ")";
  throw std::invalid_argument(os.str());
}

struct Basis {
  double xc[3], yc[3], zc[3];
};

Basis camera_basis(double pitch) {
  const double s = std::sin(pitch), c = std::cos(pitch);
  return {{0.0, -1.0, 0.0}, {-s, 0.0, -c}, {c, 0.0, -s}};
}

}  // namespace

void TrackSceneParams::validate() const {
  check(camera.width > 0 && camera.height > 0, "camera.width/height", "must be > 0", camera.width);
  check(camera.fx > 0 && camera.fy > 0, "camera.fx/fy", "must be > 0", camera.fx);
  check(camera.mount_height_m > 0, "camera.mount_height_m", "must be > 0", camera.mount_height_m);
  check(camera.pitch_rad > 0 && camera.pitch_rad < kPi / 2, "camera.pitch_rad", "must be in (0, pi/2)",
        camera.pitch_rad);
  check(sun.elevation_rad > 0 && sun.elevation_rad <= kPi / 2, "sun.elevation_rad", "must be in (0, pi/2]",
        sun.elevation_rad);
  check(std::isfinite(sun.azimuth_rad), "sun.azimuth_rad", "must be finite", sun.azimuth_rad);
  check(k > 0 && std::isfinite(k), "k", "must be > 0", k);
  check(n >= 0 && n < 3, "n", "must be in [0, 3)", n);
  check(wheel_width_m > 0, "wheel_width_m", "must be > 0", wheel_width_m);
  check(wheel_diameter_m > 0, "wheel_diameter_m", "must be > 0", wheel_diameter_m);
  for (const auto& t : tracks) check(t.load_n > 0, "tracks[].load_n", "must be > 0", t.load_n);
  check(wall_slope_rad > 0.05 && wall_slope_rad < kPi / 2, "wall_slope_rad", "must be in (0.05, pi/2)", wall_slope_rad);
  check(std::abs(k_variation) < 0.9, "k_variation", "must satisfy |a| < 0.9", k_variation);
  check(variation_wavelength_m > 0, "variation_wavelength_m", "must be > 0", variation_wavelength_m);
  check(x_max_m > x_min_m && x_min_m >= 0, "x_min_m/x_max_m", "need 0 <= x_min < x_max", x_min_m);
  check(y_half_width_m > 0, "y_half_width_m", "must be > 0", y_half_width_m);
  check(grid_res_m > 0 && grid_res_m < 0.1, "grid_res_m", "must be in (0, 0.1)", grid_res_m);
  check((x_max_m - x_min_m) / grid_res_m * 2 * y_half_width_m / grid_res_m < 5e7, "grid_res_m",
        "height field too large", grid_res_m);
  check(edge_smoothing_m >= 0, "edge_smoothing_m", "must be >= 0", edge_smoothing_m);
  check(albedo > 0 && albedo <= 1, "albedo", "must be in (0, 1]", albedo);
  check(albedo_texture >= 0 && albedo_texture < 0.5, "albedo_texture", "must be in [0, 0.5)", albedo_texture);
  check(noise_dn >= 0, "noise_dn", "must be >= 0", noise_dn);
  check(gain_dn > 0, "gain_dn", "must be > 0", gain_dn);
}

double rut_depth(double k, double n, double load_n, double width_m, double diameter_m) {
  // W = b k sqrt(D) z^((2n+1)/2) (3-n)/3  =>  z = [3 W / ((3-n) b k sqrt(D))]^(2/(2n+1))
  return std::pow(3.0 * load_n / ((3.0 - n) * width_m * k * std::sqrt(diameter_m)), 2.0 / (2.0 * n + 1.0));
}

double TrackTruth::sinkage_at(double x) const {
  if (x_m.empty()) return 0.0;
  if (x <= x_m.front()) return sinkage_m.front();
  if (x >= x_m.back()) return sinkage_m.back();
  const auto it = std::upper_bound(x_m.begin(), x_m.end(), x);
  const std::size_t i = static_cast<std::size_t>(it - x_m.begin());
  const double t = (x - x_m[i - 1]) / (x_m[i] - x_m[i - 1]);
  return sinkage_m[i - 1] + t * (sinkage_m[i] - sinkage_m[i - 1]);
}

double TrackScene::height_at(double x, double y) const {
  const double fr = (x - x0_m) / res_m, fc = (y - y0_m) / res_m;
  if (fr < 0 || fc < 0 || fr > height.rows - 1.001 || fc > height.cols - 1.001) return 0.0;
  const int r = static_cast<int>(fr), c = static_cast<int>(fc);
  const double a = fr - r, b = fc - c;
  const float* p0 = height.ptr<float>(r);
  const float* p1 = height.ptr<float>(r + 1);
  return (1 - a) * ((1 - b) * p0[c] + b * p0[c + 1]) + a * ((1 - b) * p1[c] + b * p1[c + 1]);
}

bool project(const CameraModel& cam, double x, double y, double z, double& u, double& v) {
  const Basis B = camera_basis(cam.pitch_rad);
  const double d[3] = {x, y, z - cam.mount_height_m};
  const double xc = d[0] * B.xc[0] + d[1] * B.xc[1] + d[2] * B.xc[2];
  const double yc = d[0] * B.yc[0] + d[1] * B.yc[1] + d[2] * B.yc[2];
  const double zc = d[0] * B.zc[0] + d[1] * B.zc[1] + d[2] * B.zc[2];
  if (zc <= 1e-9) return false;
  u = cam.cx + cam.fx * xc / zc;
  v = cam.cy + cam.fy * yc / zc;
  return true;
}

TrackScene generate_track_scene(const TrackSceneParams& p) {
  p.validate();
  TrackScene s;
  s.params = p;
  s.res_m = p.grid_res_m;
  s.x0_m = p.x_min_m;
  s.y0_m = -p.y_half_width_m;
  const int rows = static_cast<int>(std::ceil((p.x_max_m - p.x_min_m) / p.grid_res_m)) + 1;
  const int cols = static_cast<int>(std::ceil(2.0 * p.y_half_width_m / p.grid_res_m)) + 1;
  s.height = cv::Mat(rows, cols, CV_32F, cv::Scalar(0));

  // --- ruts and truth profiles
  const double tan_wall = std::tan(p.wall_slope_rad);
  auto k_at = [&](double x) {
    return p.k * (1.0 + p.k_variation * std::sin(2.0 * kPi * x / p.variation_wavelength_m));
  };
  for (const auto& t : p.tracks) {
    TrackTruth tt;
    tt.lateral_m = t.lateral_m;
    tt.load_n = t.load_n;
    tt.mean_sinkage_m = rut_depth(p.k, p.n, t.load_n, p.wheel_width_m, p.wheel_diameter_m);
    for (int r = 0; r < rows; ++r) {
      const double x = s.x0_m + r * s.res_m;
      const double z = rut_depth(k_at(x), p.n, t.load_n, p.wheel_width_m, p.wheel_diameter_m);
      tt.x_m.push_back(x);
      tt.sinkage_m.push_back(z);
      const double half = 0.5 * p.wheel_width_m;
      const double reach = half + z / tan_wall;
      const int c0 = std::max(0, static_cast<int>(std::floor((t.lateral_m - reach - s.y0_m) / s.res_m)));
      const int c1 = std::min(cols - 1, static_cast<int>(std::ceil((t.lateral_m + reach - s.y0_m) / s.res_m)));
      float* row = s.height.ptr<float>(r);
      for (int c = c0; c <= c1; ++c) {
        const double u = std::abs(s.y0_m + c * s.res_m - t.lateral_m);
        double h = 0.0;
        if (u <= half)
          h = -z;
        else if (u < reach)
          h = -z + (u - half) * tan_wall;
        row[c] = std::min(row[c], static_cast<float>(h));
      }
    }
    s.truth.push_back(std::move(tt));
  }
  if (p.edge_smoothing_m > 0.0) {
    const double sigma = p.edge_smoothing_m / p.grid_res_m;
    cv::GaussianBlur(s.height, s.height, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
  }
  double hmin = 0.0, hmax = 0.0;
  cv::minMaxLoc(s.height, &hmin, &hmax);

  // --- albedo texture (attached to the ground)
  cv::RNG rng(p.seed);
  cv::Mat tex(rows, cols, CV_32F);
  rng.fill(tex, cv::RNG::NORMAL, 0.0, 1.0);
  const double ts = std::max(0.5, p.texture_scale_m / p.grid_res_m);
  cv::GaussianBlur(tex, tex, cv::Size(0, 0), ts, ts, cv::BORDER_REFLECT);
  cv::Scalar mean, sd;
  cv::meanStdDev(tex, mean, sd);
  tex = (tex - mean[0]) * (p.albedo_texture / std::max(1e-12, sd[0]));
  tex += 1.0;

  // --- ray cast
  const CameraModel& cam = p.camera;
  const Basis B = camera_basis(cam.pitch_rad);
  const double ce = std::cos(p.sun.elevation_rad);
  const double sun[3] = {ce * std::cos(p.sun.azimuth_rad), ce * std::sin(p.sun.azimuth_rad),
                         std::sin(p.sun.elevation_rad)};
  const double h = cam.mount_height_m;
  const double ztop = hmax + 1e-4, zbot = hmin - 1e-4;
  auto tex_at = [&](double x, double y) {
    const double fr = (x - s.x0_m) / s.res_m, fc = (y - s.y0_m) / s.res_m;
    const int r = std::clamp(static_cast<int>(std::lround(fr)), 0, rows - 1);
    const int c = std::clamp(static_cast<int>(std::lround(fc)), 0, cols - 1);
    return static_cast<double>(tex.at<float>(r, c));
  };
  s.image = cv::Mat(cam.height, cam.width, CV_8U);
  cv::Mat noise(cam.height, cam.width, CV_32F);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, p.noise_dn);
  for (int v = 0; v < cam.height; ++v) {
    auto* out = s.image.ptr<unsigned char>(v);
    const float* nz = noise.ptr<float>(v);
    for (int u = 0; u < cam.width; ++u) {
      const double a = (u - cam.cx) / cam.fx, b = (v - cam.cy) / cam.fy;
      const double d[3] = {B.xc[0] * a + B.yc[0] * b + B.zc[0], B.xc[1] * a + B.yc[1] * b + B.zc[1],
                           B.xc[2] * a + B.yc[2] * b + B.zc[2]};
      if (d[2] >= -1e-6) {  // at or above the horizon: black sky
        out[u] = 0;
        continue;
      }
      double t0 = (h - ztop) / -d[2];
      const double t1 = (h - zbot) / -d[2];
      const double horiz = std::hypot(d[0], d[1]);
      const double dt = 0.5 * s.res_m / std::max(1e-9, horiz);
      double thit = t1;
      double tprev = t0;
      for (double t = t0; t <= t1 + dt; t += dt) {
        const double tt = std::min(t, t1);
        const double z = h + tt * d[2];
        if (z <= s.height_at(tt * d[0], tt * d[1])) {
          double lo = tprev, hi = tt;
          for (int it = 0; it < 12; ++it) {
            const double m = 0.5 * (lo + hi);
            if (h + m * d[2] <= s.height_at(m * d[0], m * d[1]))
              hi = m;
            else
              lo = m;
          }
          thit = hi;
          break;
        }
        tprev = tt;
        t0 = tt;
      }
      const double X = thit * d[0], Y = thit * d[1];
      const double e = s.res_m;
      const double hx = (s.height_at(X + e, Y) - s.height_at(X - e, Y)) / (2 * e);
      const double hy = (s.height_at(X, Y + e) - s.height_at(X, Y - e)) / (2 * e);
      const double nn = std::sqrt(1.0 + hx * hx + hy * hy);
      const double cosi = std::max(0.0, (-hx * sun[0] - hy * sun[1] + sun[2]) / nn);
      const double dn = p.gain_dn * p.albedo * tex_at(X, Y) * cosi + nz[u];
      out[u] = cv::saturate_cast<unsigned char>(dn);
    }
  }
  return s;
}

}  // namespace regolith::track_scene
