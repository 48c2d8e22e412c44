#include "regolith/terrain_scene/terrain_scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>

namespace regolith::terrain_scene {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void require(bool ok, const std::string& field, const std::string& why) {
  if (!ok) throw std::invalid_argument("terrain_scene: " + field + ": " + why);
}

bool finite_all(std::initializer_list<double> v) {
  for (double x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

// Spectral synthesis: white noise -> FFT -> filter |f|^(-beta/2) -> IFFT, scaled to rms.
cv::Mat fractal(int rows, int cols, double res, double beta, double min_wavelength, double rms, std::mt19937_64& rng) {
  cv::Mat out(rows, cols, CV_32F, cv::Scalar(0));
  if (rms <= 0.0) return out;
  const int R = cv::getOptimalDFTSize(rows), C = cv::getOptimalDFTSize(cols);
  cv::Mat noise(R, C, CV_32F);
  std::normal_distribution<float> nd(0.0f, 1.0f);
  for (int r = 0; r < R; ++r)
    for (int c = 0; c < C; ++c) noise.at<float>(r, c) = nd(rng);
  cv::Mat spec;
  cv::dft(noise, spec, cv::DFT_COMPLEX_OUTPUT);
  const double fmax = 1.0 / min_wavelength;  // cycles per metre
  for (int r = 0; r < R; ++r) {
    const double fr = (r <= R / 2 ? r : r - R) / (R * res);
    for (int c = 0; c < C; ++c) {
      const double fc = (c <= C / 2 ? c : c - C) / (C * res);
      const double f = std::sqrt(fr * fr + fc * fc);
      double g = 0.0;
      if (f > 0.0 && f <= fmax) g = std::pow(f, -beta / 2.0);
      auto& v = spec.at<cv::Vec2f>(r, c);
      v[0] = static_cast<float>(v[0] * g);
      v[1] = static_cast<float>(v[1] * g);
    }
  }
  cv::Mat back;
  cv::dft(spec, back, cv::DFT_INVERSE | cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
  back(cv::Rect(0, 0, cols, rows)).copyTo(out);
  cv::Scalar mean, sd;
  cv::meanStdDev(out, mean, sd);
  if (sd[0] > 0) out = (out - mean[0]) * (rms / sd[0]);
  return out;
}

cv::Matx33d rot_z(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {c, -s, 0, s, c, 0, 0, 0, 1};
}

}  // namespace

void SceneParams::validate() const {
  require(std::isfinite(resolution_m) && resolution_m > 0, "resolution_m", "must be > 0");
  require(finite_all({x_min_m, x_max_m, y_min_m, y_max_m}) && x_max_m > x_min_m && y_max_m > y_min_m,
          "x_min_m/x_max_m/y_min_m/y_max_m", "must be finite with max > min");
  require((x_max_m - x_min_m) / resolution_m < 20000 && (y_max_m - y_min_m) / resolution_m < 20000, "resolution_m",
          "grid larger than 20000 cells per side");
  // A scene holds ~20 bytes per cell (heights, normals, albedo, rock ids): 2^26 cells is ~1.3 GB.
  // (A 92 x 52 m drive tile at 5 mm, within the per-side bound, took 4 GB and 24 s to start.)
  const double cells = std::floor((x_max_m - x_min_m) / resolution_m) * std::floor((y_max_m - y_min_m) / resolution_m);
  require(cells <= 67108864.0, "resolution_m",
          "grid of " + std::to_string(static_cast<long long>(cells)) + " cells, more than a scene may hold (2^26)");
  require(std::isfinite(fractal_rms_m) && fractal_rms_m >= 0, "fractal_rms_m", "must be >= 0");
  require(std::isfinite(fractal_beta) && fractal_beta > 0 && fractal_beta < 6, "fractal_beta", "must be in (0, 6)");
  require(std::isfinite(fractal_min_wavelength_m) && fractal_min_wavelength_m > 0, "fractal_min_wavelength_m",
          "must be > 0");
  require(num_rocks >= 0, "num_rocks", "must be >= 0");
  require(num_craters >= 0, "num_craters", "must be >= 0");
  require(finite_all({rock_radius_min_m, rock_radius_max_m}) && rock_radius_min_m > 0 &&
              rock_radius_max_m >= rock_radius_min_m,
          "rock_radius_min_m/rock_radius_max_m", "need 0 < min <= max");
  require(finite_all({rock_height_ratio_min, rock_height_ratio_max}) && rock_height_ratio_min > 0 &&
              rock_height_ratio_max >= rock_height_ratio_min,
          "rock_height_ratio_min/max", "need 0 < min <= max");
  require(finite_all({crater_radius_min_m, crater_radius_max_m}) && crater_radius_min_m > 0 &&
              crater_radius_max_m >= crater_radius_min_m,
          "crater_radius_min_m/crater_radius_max_m", "need 0 < min <= max");
  require(std::isfinite(crater_depth_ratio) && crater_depth_ratio >= 0, "crater_depth_ratio", "must be >= 0");
  require(finite_all({place_x_min_m, place_x_max_m, place_y_abs_max_m}) && place_x_max_m >= place_x_min_m &&
              place_y_abs_max_m >= 0,
          "place_x_min_m/place_x_max_m/place_y_abs_max_m", "need max >= min, y >= 0");
}

cv::Vec3d Sun::vector() const {
  return {std::cos(elevation_rad) * std::cos(azimuth_rad), std::cos(elevation_rad) * std::sin(azimuth_rad),
          std::sin(elevation_rad)};
}

Terrain::Terrain(const SceneParams& p) {
  p.validate();
  res_ = p.resolution_m;
  x_max_ = p.x_max_m;
  y_max_ = p.y_max_m;
  const int rows = static_cast<int>(std::floor((p.x_max_m - p.x_min_m) / res_)) + 1;
  const int cols = static_cast<int>(std::floor((p.y_max_m - p.y_min_m) / res_)) + 1;
  std::mt19937_64 rng(p.seed);
  height_ = fractal(rows, cols, res_, p.fractal_beta, p.fractal_min_wavelength_m, p.fractal_rms_m, rng);
  std::uniform_real_distribution<double> ux(p.place_x_min_m, p.place_x_max_m);
  std::uniform_real_distribution<double> uy(-p.place_y_abs_max_m, p.place_y_abs_max_m);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  auto clear = [&p](double x, double y, double radius) {
    for (const cv::Point2d& q : p.keep_clear_points)
      if (std::hypot(x - q.x, y - q.y) < radius + p.keep_clear_m) return false;
    return true;
  };

  for (int k = 0; k < p.num_craters; ++k) {
    Crater c;
    bool placed = false;
    for (int attempt = 0; attempt < 100 && !placed; ++attempt) {
      c.x_m = ux(rng);
      c.y_m = uy(rng);
      c.radius_m = p.crater_radius_min_m + u01(rng) * (p.crater_radius_max_m - p.crater_radius_min_m);
      placed = clear(c.x_m, c.y_m, 1.3 * c.radius_m);
    }
    if (!placed) continue;
    c.depth_m = p.crater_depth_ratio * c.radius_m;
    craters_.push_back(c);
    // Parabolic bowl inside the rim, raised rim decaying outside (rim height 0.2 depth).
    const double ext = 2.0 * c.radius_m;
    const int r0 = std::max(0, static_cast<int>((x_max_ - c.x_m - ext) / res_));
    const int r1 = std::min(rows - 1, static_cast<int>((x_max_ - c.x_m + ext) / res_) + 1);
    const int c0 = std::max(0, static_cast<int>((y_max_ - c.y_m - ext) / res_));
    const int c1 = std::min(cols - 1, static_cast<int>((y_max_ - c.y_m + ext) / res_) + 1);
    for (int r = r0; r <= r1; ++r)
      for (int cc = c0; cc <= c1; ++cc) {
        const double x = x_max_ - r * res_, y = y_max_ - cc * res_;
        const double d = std::hypot(x - c.x_m, y - c.y_m) / c.radius_m;
        double dz;
        if (d < 1.0)
          dz = c.depth_m * (1.2 * d * d - 1.0);
        else
          dz = 0.2 * c.depth_m * std::exp(-(d - 1.0) * (d - 1.0) / 0.08);
        height_.at<float>(r, cc) += static_cast<float>(dz);
      }
  }
  for (int k = 0; k < p.num_rocks; ++k) {
    Rock rk;
    bool placed = false;
    for (int attempt = 0; attempt < 100 && !placed; ++attempt) {
      rk.x_m = ux(rng);
      rk.y_m = uy(rng);
      const double rad = p.rock_radius_min_m + u01(rng) * (p.rock_radius_max_m - p.rock_radius_min_m);
      const double elong = 0.8 + 0.4 * u01(rng);
      rk.radius_x_m = rad * elong;
      rk.radius_y_m = rad / elong;
      rk.height_m = rad * (p.rock_height_ratio_min + u01(rng) * (p.rock_height_ratio_max - p.rock_height_ratio_min));
      placed = clear(rk.x_m, rk.y_m, std::max(rk.radius_x_m, rk.radius_y_m));
    }
    if (placed) rocks_.push_back(rk);
  }
  // Rocks on top of the terrain: z = base + h sqrt(1 - ex^2 - ey^2); base = terrain at the centre
  // (so the rock height above its local ground is exact), taking the max with the terrain.
  for (auto& rk : rocks_) {
    const double base = height_at(rk.x_m, rk.y_m);
    rk.base_z_m = std::isfinite(base) ? base : 0.0;
    const double ext = std::max(rk.radius_x_m, rk.radius_y_m) + res_;
    const int r0 = std::max(0, static_cast<int>((x_max_ - rk.x_m - ext) / res_));
    const int r1 = std::min(rows - 1, static_cast<int>((x_max_ - rk.x_m + ext) / res_) + 1);
    const int c0 = std::max(0, static_cast<int>((y_max_ - rk.y_m - ext) / res_));
    const int c1 = std::min(cols - 1, static_cast<int>((y_max_ - rk.y_m + ext) / res_) + 1);
    for (int r = r0; r <= r1; ++r)
      for (int cc = c0; cc <= c1; ++cc) {
        const double ex = (x_max_ - r * res_ - rk.x_m) / rk.radius_x_m;
        const double ey = (y_max_ - cc * res_ - rk.y_m) / rk.radius_y_m;
        const double q = 1.0 - ex * ex - ey * ey;
        if (q <= 0) continue;
        const double z = rk.base_z_m + rk.height_m * std::sqrt(q);
        float& h = height_.at<float>(r, cc);
        h = std::max(h, static_cast<float>(z));
      }
  }
  finish();
}

Terrain::Terrain(const cv::Mat& height_m, double resolution_m, double x_max_m, double y_max_m) {
  require(!height_m.empty() && height_m.type() == CV_32FC1, "height_m", "must be non-empty CV_32FC1");
  require(cv::checkRange(height_m), "height_m", "contains NaN/Inf");
  require(std::isfinite(resolution_m) && resolution_m > 0, "resolution_m", "must be > 0");
  require(finite_all({x_max_m, y_max_m}), "x_max_m/y_max_m", "must be finite");
  height_ = height_m.clone();
  res_ = resolution_m;
  x_max_ = x_max_m;
  y_max_ = y_max_m;
  finish();
}

void Terrain::finish() {
  double mn, mx;
  cv::minMaxLoc(height_, &mn, &mx);
  h_max_ = mx;
}

double Terrain::height_at(double x, double y) const {
  const double fr = (x_max_ - x) / res_, fc = (y_max_ - y) / res_;
  if (!(fr >= 0 && fc >= 0 && fr <= height_.rows - 1 && fc <= height_.cols - 1)) return kNaN;
  const int r = std::min(static_cast<int>(fr), height_.rows - 2);
  const int c = std::min(static_cast<int>(fc), height_.cols - 2);
  const double a = fr - r, b = fc - c;
  const float* p0 = height_.ptr<float>(r);
  const float* p1 = height_.ptr<float>(r + 1);
  return (1 - a) * ((1 - b) * p0[c] + b * p0[c + 1]) + a * ((1 - b) * p1[c] + b * p1[c + 1]);
}

cv::Vec3d Terrain::normal_at(double x, double y) const {
  const double d = res_;
  double hx = (height_at(x + d, y) - height_at(x - d, y)) / (2 * d);
  double hy = (height_at(x, y + d) - height_at(x, y - d)) / (2 * d);
  if (!std::isfinite(hx)) hx = 0;
  if (!std::isfinite(hy)) hy = 0;
  cv::Vec3d n(-hx, -hy, 1.0);
  return n / cv::norm(n);
}

namespace {

void post_process(cv::Mat& img, const RenderOptions& opt) {
  if (opt.vignetting) {
    const double cx = (img.cols - 1) / 2.0, cy = (img.rows - 1) / 2.0;
    const double hd = std::hypot(img.cols / 2.0, img.rows / 2.0);
    for (int r = 0; r < img.rows; ++r) {
      float* p = img.ptr<float>(r);
      for (int c = 0; c < img.cols; ++c) {
        const double rr = std::hypot(c - cx, r - cy) / hd, r2 = rr * rr;
        p[c] = static_cast<float>(p[c] * (1.0 + opt.a2 * r2 + opt.a4 * r2 * r2 + opt.a6 * r2 * r2 * r2));
      }
    }
  }
  if (opt.noise_sigma > 0) {
    std::mt19937_64 rng(opt.noise_seed);
    std::normal_distribution<double> nd(0.0, opt.noise_sigma);
    for (int r = 0; r < img.rows; ++r) {
      float* p = img.ptr<float>(r);
      for (int c = 0; c < img.cols; ++c) p[c] = static_cast<float>(p[c] + nd(rng));
    }
  }
  cv::max(img, 0.0, img);
  cv::min(img, 1.0, img);
}

void check_options(const RenderOptions& o) {
  require(std::isfinite(o.albedo) && o.albedo > 0 && o.albedo <= 1, "albedo", "must be in (0, 1]");
  require(std::isfinite(o.noise_sigma) && o.noise_sigma >= 0, "noise_sigma", "must be >= 0");
  require(finite_all({o.a2, o.a4, o.a6}), "a2/a4/a6", "must be finite");
}

}  // namespace

cv::Mat render_ortho_height(const cv::Mat& h, double slant, double tilt, const RenderOptions& opt) {
  require(!h.empty() && h.type() == CV_32FC1, "height_px", "must be non-empty CV_32FC1");
  require(std::isfinite(slant) && slant >= 0 && slant < CV_PI / 2, "slant_rad", "must be in [0, pi/2)");
  require(std::isfinite(tilt), "tilt_rad", "must be finite");
  check_options(opt);
  const cv::Vec3d s(std::cos(tilt) * std::sin(slant), std::sin(tilt) * std::sin(slant), std::cos(slant));
  cv::Mat img(h.size(), CV_32F);
  for (int r = 0; r < h.rows; ++r) {
    const float* pm = h.ptr<float>(std::max(r - 1, 0));
    const float* p0 = h.ptr<float>(r);
    const float* pp = h.ptr<float>(std::min(r + 1, h.rows - 1));
    const double dr = (r > 0 && r < h.rows - 1) ? 2.0 : 1.0;
    float* o = img.ptr<float>(r);
    for (int c = 0; c < h.cols; ++c) {
      const int cm = std::max(c - 1, 0), cp = std::min(c + 1, h.cols - 1);
      const double hx = (p0[cp] - p0[cm]) / static_cast<double>(cp - cm);
      const double hy = (pp[c] - pm[c]) / dr;
      const double n = std::sqrt(1 + hx * hx + hy * hy);
      o[c] = static_cast<float>(opt.albedo * std::max(0.0, (-hx * s[0] - hy * s[1] + s[2]) / n));
    }
  }
  if (opt.cast_shadows) {
    // March towards the sun in pixel units; height rises by cot(slant) per pixel travelled.
    const double rise = std::cos(slant) / std::max(std::sin(slant), 1e-9);
    const double dx = std::cos(tilt), dy = std::sin(tilt);
    for (int r = 0; r < h.rows; ++r)
      for (int c = 0; c < h.cols; ++c) {
        const double z0 = h.at<float>(r, c);
        for (double t = 1.0; t < 4000.0; t += 1.0) {
          const int rr = static_cast<int>(std::lround(r + dy * t)), cc = static_cast<int>(std::lround(c + dx * t));
          if (rr < 0 || cc < 0 || rr >= h.rows || cc >= h.cols) break;
          if (h.at<float>(rr, cc) > z0 + rise * t) {
            img.at<float>(r, c) = 0.f;
            break;
          }
        }
      }
  }
  post_process(img, opt);
  return img;
}

cv::Vec2d ortho_light(const Sun& sun) {
  const cv::Vec3d d = sun.vector();
  // image x = world -y, image y = world -x, third = world z.
  const double sx = -d[1], sy = -d[0], sz = d[2];
  return {std::acos(std::clamp(sz, -1.0, 1.0)), std::atan2(sy, sx)};
}

OrthoImage render_ortho(const Terrain& t, const Sun& sun, const RenderOptions& opt) {
  require(std::isfinite(sun.elevation_rad) && sun.elevation_rad > 0 && sun.elevation_rad <= CV_PI / 2,
          "sun.elevation_rad", "must be in (0, pi/2]");
  OrthoImage o;
  o.height_px = t.height() / t.resolution();
  const cv::Vec2d l = ortho_light(sun);
  o.light_slant_rad = l[0];
  o.light_tilt_rad = l[1];
  o.image = render_ortho_height(o.height_px, l[0], l[1], opt);
  return o;
}

void CameraPose::validate() const {
  require(finite_all({fx, fy}) && fx > 0 && fy > 0, "camera.fx/fy", "must be > 0");
  require(finite_all({cx, cy}), "camera.cx/cy", "must be finite");
  require(width > 0 && height > 0 && width <= 8192 && height <= 8192, "camera.width/height", "must be in 1..8192");
  require(finite_all({x_m, y_m, yaw_rad, roll_rad}), "camera.x_m/y_m/yaw_rad/roll_rad", "must be finite");
  require(std::isfinite(height_m) && height_m > 0, "camera.height_m", "must be > 0");
  require(std::isfinite(pitch_rad) && std::abs(pitch_rad) < CV_PI / 2, "camera.pitch_rad", "must be in (-pi/2, pi/2)");
}

cv::Matx33d CameraPose::world_from_optical() const {
  const cv::Matx33d b0(0, 0, 1, -1, 0, 0, 0, -1, 0);  // optical -> body (no pitch/roll)
  const double ca = std::cos(pitch_rad), sa = std::sin(pitch_rad);
  const cv::Matx33d pitch(ca, 0, sa, 0, 1, 0, -sa, 0, ca);
  return rot_z(yaw_rad) * pitch * b0 * rot_z(roll_rad);
}

cv::Vec2d camera_light(const CameraPose& cam, const Sun& sun) {
  const cv::Vec3d s_opt = cam.world_from_optical().t() * sun.vector();
  const double sx = s_opt[0], sy = s_opt[1], sz = -s_opt[2];
  return {std::acos(std::clamp(sz, -1.0, 1.0)), std::atan2(sy, sx)};
}

CameraImage render_camera(const Terrain& t, const CameraPose& cam, const Sun& sun, const RenderOptions& opt) {
  cam.validate();
  check_options(opt);
  require(std::isfinite(sun.elevation_rad) && sun.elevation_rad > 0, "sun.elevation_rad", "must be > 0");
  CameraImage out;
  const int W = cam.width, H = cam.height;
  out.image.create(H, W, CV_32F);
  out.range_m.create(H, W, CV_32F);
  out.lateral_m.create(H, W, CV_32F);
  out.hit_z_m.create(H, W, CV_32F);
  out.rock_id.create(H, W, CV_32S);
  const cv::Matx33d R = cam.world_from_optical();
  const cv::Vec3d sunv = sun.vector();
  const cv::Vec3d o(cam.x_m, cam.y_m, cam.height_m);
  const double cy_ = std::cos(cam.yaw_rad), sy_ = std::sin(cam.yaw_rad);
  const double hmax = t.max_height(), res = t.resolution();
  const float nanf = std::numeric_limits<float>::quiet_NaN();
  const auto& rocks = t.rocks();
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) {
      cv::Vec3d d = R * cv::Vec3d((c - cam.cx) / cam.fx, (r - cam.cy) / cam.fy, 1.0);
      d /= cv::norm(d);
      float val = 0.f, rng = nanf, lat = nanf, hz = nanf;
      int rid = -1;
      if (d[2] < -1e-9) {
        // Start where the ray crosses z = hmax (cannot hit earlier).
        double s = o[2] > hmax ? (o[2] - hmax) / -d[2] : 0.0;
        const double horiz = std::sqrt(d[0] * d[0] + d[1] * d[1]);
        const double sin_dep = -d[2];
        double s_prev = s;
        bool hit = false;
        for (int it = 0; it < 20000; ++it) {
          const cv::Vec3d p = o + s * d;
          const double hz_here = t.height_at(p[0], p[1]);
          if (!std::isfinite(hz_here)) break;
          const double gap = p[2] - hz_here;
          if (gap <= 0) {
            hit = true;
            break;
          }
          s_prev = s;
          // Safe step assuming terrain slopes below 2 (63 deg); never below half a cell.
          s += std::max(0.5 * res / std::max(horiz, 1e-6) * 1.0, gap / (sin_dep + 2.0 * horiz));
        }
        if (hit) {
          double a = s_prev, b = s;
          for (int k = 0; k < 30; ++k) {
            const double m = 0.5 * (a + b);
            const cv::Vec3d p = o + m * d;
            if (p[2] - t.height_at(p[0], p[1]) > 0)
              a = m;
            else
              b = m;
          }
          const cv::Vec3d p = o + b * d;
          const cv::Vec3d n = t.normal_at(p[0], p[1]);
          double e = opt.albedo * std::max(0.0, n.dot(sunv));
          if (opt.cast_shadows && e > 0) {
            const double sh = t.height_at(p[0], p[1]);
            for (double u = 2 * res; u < 30.0; u += res) {
              const cv::Vec3d q = cv::Vec3d(p[0], p[1], sh) + u * sunv;
              if (q[2] > hmax) break;
              const double hq = t.height_at(q[0], q[1]);
              if (!std::isfinite(hq)) break;
              if (hq > q[2]) {
                e = 0;
                break;
              }
            }
          }
          val = static_cast<float>(e);
          const double dx = p[0] - o[0], dy = p[1] - o[1];
          rng = static_cast<float>(dx * cy_ + dy * sy_);
          lat = static_cast<float>(-dx * sy_ + dy * cy_);
          hz = static_cast<float>(p[2]);
          for (size_t k = 0; k < rocks.size(); ++k) {
            const double ex = (p[0] - rocks[k].x_m) / rocks[k].radius_x_m;
            const double ey = (p[1] - rocks[k].y_m) / rocks[k].radius_y_m;
            if (ex * ex + ey * ey < 1.0 && p[2] > rocks[k].base_z_m + 0.02 * rocks[k].height_m) {
              rid = static_cast<int>(k);
              break;
            }
          }
        }
      }
      out.image.at<float>(r, c) = val;
      out.range_m.at<float>(r, c) = rng;
      out.lateral_m.at<float>(r, c) = lat;
      out.hit_z_m.at<float>(r, c) = hz;
      out.rock_id.at<int>(r, c) = rid;
    }
  // Rock boxes from the per-pixel rock ids (visible pixels only).
  std::vector<cv::Rect> boxes(rocks.size());
  std::vector<bool> seen(rocks.size(), false);
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) {
      const int id = out.rock_id.at<int>(r, c);
      if (id < 0) continue;
      if (!seen[id]) {
        boxes[id] = cv::Rect(c, r, 1, 1);
        seen[id] = true;
      } else {
        boxes[id] |= cv::Rect(c, r, 1, 1);
      }
    }
  for (size_t k = 0; k < rocks.size(); ++k)
    if (seen[k]) {
      PixelBox pb;
      pb.rock_index = static_cast<int>(k);
      pb.box = boxes[k];
      pb.fully_inside = pb.box.x > 0 && pb.box.y > 0 && pb.box.br().x < W && pb.box.br().y < H;
      out.rock_boxes.push_back(pb);
    }
  post_process(out.image, opt);
  const cv::Vec2d l = camera_light(cam, sun);
  out.light_slant_rad = l[0];
  out.light_tilt_rad = l[1];
  return out;
}

cv::Mat to_u8(const cv::Mat& image01) {
  require(!image01.empty() && image01.type() == CV_32FC1, "image", "must be non-empty CV_32FC1");
  cv::Mat u8;
  image01.convertTo(u8, CV_8U, 255.0);
  return u8;
}

}  // namespace regolith::terrain_scene
