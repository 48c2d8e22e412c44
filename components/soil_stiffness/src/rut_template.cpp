#include "regolith/soil_stiffness/rut_template.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "regolith/core/error.hpp"

namespace regolith::soil {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kFineStep = 0.0005;  ///< surface sampling of a template [m]

void need(bool ok, const char* field, const char* what, double got) {
  if (!ok) throw FieldError("", field, std::string(what) + " (got " + number_text(got) + ")");
}

// Huber loss, branch-free (h = min(|r|, k): h (|r| - h / 2), i.e. r^2 / 2 within k, linear beyond)
// so that loops over it vectorise.
double huber(double r, double k) {
  const double a = std::abs(r), h = std::min(a, k);
  return h * (a - 0.5 * h);
}

}  // namespace

void RutShape::validate() const {
  need(std::isfinite(wall_slope_rad) && wall_slope_rad > 0.05 && wall_slope_rad < 1.5, "wall_slope_rad",
       "must be in (0.05, 1.5) rad", wall_slope_rad);
  need(std::isfinite(berm_ratio) && berm_ratio >= 0 && berm_ratio < 2, "berm_ratio", "must be in [0, 2)", berm_ratio);
  need(std::isfinite(berm_offset) && berm_offset >= -1 && berm_offset < 5, "berm_offset", "must be in [-1, 5)",
       berm_offset);
  need(std::isfinite(berm_half_width) && berm_half_width > 0 && berm_half_width < 5, "berm_half_width",
       "must be in (0, 5)", berm_half_width);
}

void RutTemplateParams::validate() const {
  need(std::isfinite(max_sinkage_m) && max_sinkage_m > 0 && max_sinkage_m <= 0.5, "max_sinkage_m",
       "must be in (0, 0.5] m", max_sinkage_m);
  need(std::isfinite(sinkage_step_m) && sinkage_step_m > 0 && max_sinkage_m / sinkage_step_m <= 1000, "sinkage_step_m",
       "must be > 0 and give at most 1000 hypotheses", sinkage_step_m);
  need(std::isfinite(centre_search_m) && centre_search_m >= 0 && centre_search_m <= 0.3, "centre_search_m",
       "must be in [0, 0.3] m", centre_search_m);
  need(std::isfinite(centre_step_m) && centre_step_m > 0 && centre_search_m / centre_step_m <= 200, "centre_step_m",
       "must be > 0 and give at most 401 offsets", centre_step_m);
  need(std::isfinite(sample_step_m) && sample_step_m >= 0.0005 && sample_step_m <= 0.05, "sample_step_m",
       "must be in [0.0005, 0.05] m", sample_step_m);
  need(std::isfinite(huber_dn) && huber_dn > 0, "huber_dn", "must be > 0", huber_dn);
  need(min_valid_fraction > 0 && min_valid_fraction <= 1, "min_valid_fraction", "must be in (0, 1]",
       min_valid_fraction);
}

double RutTemplateFit::ambient_from_shadow(double shadow_dn, double flat_dn, double sun_elevation_rad) {
  if (!(shadow_dn > 0) || !(flat_dn > shadow_dn)) return 0.0;
  return shadow_dn * std::sin(sun_elevation_rad) / (flat_dn - shadow_dn);
}

RutTemplateFit::RutTemplateFit(const direct_depth::CameraModel& camera, double wheel_width_m, const RutShape& shape,
                               const RutTemplateParams& params, int max_rows)
    : geometry_(camera),
      H_(camera.mount_height_m),
      b_(wheel_width_m),
      shape_(shape),
      p_(params),
      max_rows_(std::max(1, max_rows)) {
  shape_.validate();
  p_.validate();
  need(std::isfinite(b_) && b_ > 0, "wheel_width_m", "must be > 0", b_);
  nz_ = static_cast<int>(std::floor(p_.max_sinkage_m / p_.sinkage_step_m + 1e-9)) + 1;
  nc_ = 2 * static_cast<int>(std::lround(p_.centre_search_m / p_.centre_step_m)) + 1;
  const double zmax = p_.max_sinkage_m;
  half_samp_ = 0.5 * b_ + zmax / std::tan(shape_.wall_slope_rad) +
               (shape_.berm_offset + 0.5 * shape_.berm_half_width) * b_ + 0.01;
  nsamp_ = 2 * static_cast<int>(std::lround(half_samp_ / p_.sample_step_m)) + 1;
  half_fine_ = half_samp_ + p_.centre_search_m + 0.05 + zmax + shape_.berm_half_width * b_;
  fine_step_ = kFineStep;
  nfine_ = 2 * static_cast<int>(std::lround(half_fine_ / fine_step_)) + 1;
  fine_h_.resize(static_cast<std::size_t>(nfine_));
  fine_b_.resize(static_cast<std::size_t>(nfine_));
  prefix_.resize(static_cast<std::size_t>(nz_) * static_cast<std::size_t>(nfine_));
  obs_.resize(static_cast<std::size_t>(nsamp_));
  obs_n_.resize(static_cast<std::size_t>(nsamp_));
  px_x_.resize(static_cast<std::size_t>(max_rows_) * static_cast<std::size_t>(nsamp_));
  px_y_.resize(px_x_.size());
  foot_.resize(static_cast<std::size_t>(max_rows_));
  sse_.resize(static_cast<std::size_t>(nz_) * static_cast<std::size_t>(nc_));
  const double r = p_.centre_step_m / p_.sample_step_m;
  if (std::abs(r - std::round(r)) < 1e-9 && std::round(r) >= 1.0) {
    lattice_r_ = static_cast<int>(std::lround(r));
    lattice_n_ = nsamp_ + lattice_r_ * (nc_ - 1);
    lattice_.resize(static_cast<std::size_t>(nz_) * static_cast<std::size_t>(lattice_n_));
  }
}

double RutTemplateFit::profile_height(double z, double d) const {
  if (z <= 0.0) return 0.0;
  const double ad = std::abs(d), hb = 0.5 * b_;
  if (ad <= hb) return -z;
  // the wall rises at the repose angle until it meets the berm; the berm is a raised-cosine bump
  // of height berm_ratio z centred berm_offset b outside the wall's top edge
  const double tan_w = std::tan(shape_.wall_slope_rad);
  const double wall = -z + (ad - hb) * tan_w;
  const double centre = hb + z / tan_w + shape_.berm_offset * b_;
  const double half = shape_.berm_half_width * b_;
  const double x = (ad - centre) / half;
  const double c = std::abs(x) < 1.0 ? std::cos(0.5 * 3.14159265358979323846 * x) : 0.0;
  return std::min(wall, shape_.berm_ratio * z * c * c);
}

// For every depth hypothesis: the brightness of the surface along the cross-section (shading, cast
// and self shadows, ambient), mapped to the ground lateral the camera sees it at and integrated,
// so that a pixel footprint's mean is a difference of two prefix values.
void RutTemplateFit::build_templates(const RutLight& light, double lateral_m) {
  built_ = true;
  built_light_ = light;
  built_lateral_ = lateral_m;
  const double el = light.sun.elevation_rad, az = light.sun.azimuth_rad;
  const double sz = std::sin(el), sy = std::cos(el) * std::sin(az);
  const double a = std::max(0.0, light.ambient);
  const double gain = light.flat_dn / (sz + a);
  const bool cast = std::abs(sy) > 1e-6;
  const double t = cast ? sz / std::abs(sy) : 0.0;
  for (int k = 0; k < nz_; ++k) {
    const double z = k * p_.sinkage_step_m;
    for (int m = 0; m < nfine_; ++m)
      fine_h_[static_cast<std::size_t>(m)] = profile_height(z, -half_fine_ + m * fine_step_);
    // cast shadows: a point is dark when terrain on its sun side rises above the ray to the sun
    if (cast) {
      double run = -std::numeric_limits<double>::infinity();
      const int step = sy > 0 ? -1 : 1;  // scan from the sun side
      for (int m = sy > 0 ? nfine_ - 1 : 0; m >= 0 && m < nfine_; m += step) {
        const double d = -half_fine_ + m * fine_step_;
        const double q = fine_h_[static_cast<std::size_t>(m)] - (sy > 0 ? d : -d) * t;
        fine_b_[static_cast<std::size_t>(m)] = run > q + 1e-12 ? 0.0 : 1.0;  // lit flag for now
        run = std::max(run, q);
      }
    } else {
      std::fill(fine_b_.begin(), fine_b_.end(), 1.0);
    }
    for (int m = 0; m < nfine_; ++m) {
      const int m0 = std::max(0, m - 1), m1 = std::min(nfine_ - 1, m + 1);
      const double g =
          (fine_h_[static_cast<std::size_t>(m1)] - fine_h_[static_cast<std::size_t>(m0)]) / ((m1 - m0) * fine_step_);
      const double ns = (sz - g * sy) / std::sqrt(1.0 + g * g);
      const double lit = fine_b_[static_cast<std::size_t>(m)];
      fine_b_[static_cast<std::size_t>(m)] = gain * (lit * std::max(0.0, ns) + a);
    }
    // perspective: the surface point (y, h) is seen where its ray meets the ground, y H / (H - h);
    // hidden points (the mapping running backwards) add nothing. Resampled onto the uniform grid.
    double* P = prefix_.data() + static_cast<std::size_t>(k) * static_cast<std::size_t>(nfine_);
    const double flat = light.flat_dn;
    auto ground_of = [&](int m) {
      const double y = lateral_m - half_fine_ + m * fine_step_;
      return y * H_ / (H_ - fine_h_[static_cast<std::size_t>(m)]) - lateral_m;
    };
    double y_prev = ground_of(0), c_prev = 0.0, b_prev = fine_b_[0];
    // integral origin at offset -half_fine_ (flat ground before the first sample)
    c_prev = (y_prev + half_fine_) * flat;
    int q = 0;
    const double u0 = -half_fine_;
    while (q < nfine_ && u0 + q * fine_step_ <= y_prev) {
      P[q] = (u0 + q * fine_step_ + half_fine_) * flat;
      ++q;
    }
    for (int m = 1; m < nfine_ && q < nfine_; ++m) {
      const double y = ground_of(m), bm = fine_b_[static_cast<std::size_t>(m)];
      if (y <= y_prev) continue;  // hidden behind what was already seen
      const double c = c_prev + 0.5 * (bm + b_prev) * (y - y_prev);
      while (q < nfine_ && u0 + q * fine_step_ <= y) {
        const double w = (u0 + q * fine_step_ - y_prev) / (y - y_prev);
        P[q] = c_prev + w * (c - c_prev);
        ++q;
      }
      y_prev = y;
      c_prev = c;
      b_prev = bm;
    }
    for (; q < nfine_; ++q) P[q] = c_prev + (u0 + q * fine_step_ - y_prev) * flat;
  }
}

double RutTemplateFit::predict(const RutLight& light, double lateral_m, double z_m, double offset_m) {
  const bool same = built_ && light.sun.azimuth_rad == built_light_.sun.azimuth_rad &&
                    light.sun.elevation_rad == built_light_.sun.elevation_rad &&
                    light.flat_dn == built_light_.flat_dn && light.ambient == built_light_.ambient &&
                    lateral_m == built_lateral_;
  if (!same) build_templates(light, lateral_m);
  const int k = std::clamp(static_cast<int>(std::lround(z_m / p_.sinkage_step_m)), 0, nz_ - 1);
  const double* P = prefix_.data() + static_cast<std::size_t>(k) * static_cast<std::size_t>(nfine_);
  return footprint_mean(P, offset_m, 2.0 * fine_step_, light.saturation_dn);
}

double RutTemplateFit::footprint_mean(const double* P, double u, double f, double saturation_dn) const {
  auto at = [&](double v) {
    const double x = std::clamp((v + half_fine_) / fine_step_, 0.0, nfine_ - 1.0);
    const int i = std::min(nfine_ - 2, static_cast<int>(x));
    return P[i] + (x - i) * (P[i + 1] - P[i]);
  };
  return std::min(saturation_dn, (at(u + 0.5 * f) - at(u - 0.5 * f)) / f);
}

void RutTemplateFit::fill_lattice(double f, double saturation_dn) {
  // lattice point m = j - r c (shifted by r (nc - 1) to start at 0) is the ground offset
  // u = (j - nsamp/2) sample_step - (c - nc/2) centre_step = (m - nsamp/2 + r (nc/2)) sample_step
  const int r = lattice_r_;
  for (int k = 0; k < nz_; ++k) {
    const double* P = prefix_.data() + static_cast<std::size_t>(k) * static_cast<std::size_t>(nfine_);
    double* T = lattice_.data() + static_cast<std::size_t>(k) * static_cast<std::size_t>(lattice_n_);
    for (int i = 0; i < lattice_n_; ++i) {
      const int m = i - r * (nc_ - 1);
      T[i] = footprint_mean(P, (m - nsamp_ / 2 + r * (nc_ / 2)) * p_.sample_step_m, f, saturation_dn);
    }
  }
}

double RutTemplateFit::window_cost(int k, int c, double f, double saturation_dn) const {
  // Huber cost of the window's observations against hypothesis k shifted by offset c.
  if (lattice_r_ > 0) {
    const double* T = lattice_.data() + static_cast<std::size_t>(k) * static_cast<std::size_t>(lattice_n_) +
                      static_cast<std::size_t>(lattice_r_ * (nc_ - 1 - c));
    // samples without an observation add 0; four partial sums so that the loop vectorises
    const double* o = obs_.data();
    const double* w = obs_n_.data();
    double acc[4] = {0.0, 0.0, 0.0, 0.0};
    int j = 0;
    for (; j + 4 <= nsamp_; j += 4)
      for (int q = 0; q < 4; ++q) acc[q] += w[j + q] != 0.0 ? huber(o[j + q] - T[j + q], p_.huber_dn) : 0.0;
    for (; j < nsamp_; ++j) acc[0] += w[j] != 0.0 ? huber(o[j] - T[j], p_.huber_dn) : 0.0;
    return (acc[0] + acc[1]) + (acc[2] + acc[3]);
  }
  double s = 0.0;
  const double* P = prefix_.data() + static_cast<std::size_t>(k) * static_cast<std::size_t>(nfine_);
  const double shift = (c - nc_ / 2) * p_.centre_step_m;
  for (int j = 0; j < nsamp_; ++j) {
    if (obs_n_[static_cast<std::size_t>(j)] == 0.0) continue;
    const double u = (j - nsamp_ / 2) * p_.sample_step_m - shift;
    s += huber(obs_[static_cast<std::size_t>(j)] - footprint_mean(P, u, f, saturation_dn), p_.huber_dn);
  }
  return s;
}

double RutTemplateFit::fit(const cv::Mat& grey, const RutLight& light, double lateral_m, const double* ranges_m,
                           int count, int window, double* depth_m) {
  if (grey.empty() || grey.type() != CV_8UC1) throw std::invalid_argument("rut template fit: expected a CV_8UC1 image");
  count = std::min(count, max_rows_);
  window = std::max(1, window);
  build_templates(light, lateral_m);
  unmeasurable_ = 0;
  const int W = grey.cols, Hh = grey.rows;
  // where each cross-section's samples fall in the image, and each row's pixel footprint
  for (int i = 0; i < count; ++i) {
    double* xs = px_x_.data() + static_cast<std::size_t>(i) * static_cast<std::size_t>(nsamp_);
    double* ys = px_y_.data() + static_cast<std::size_t>(i) * static_cast<std::size_t>(nsamp_);
    for (int j = 0; j < nsamp_; ++j) {
      const double off = (j - nsamp_ / 2) * p_.sample_step_m;
      const auto px = geometry_.project(ranges_m[i], lateral_m + off, 0.0);
      const bool in = px && px->x >= 0 && px->y >= 0 && px->x <= W - 1 && px->y <= Hh - 1;
      xs[j] = in ? px->x : kNaN;
      ys[j] = in ? px->y : kNaN;
    }
    const auto l = geometry_.project(ranges_m[i], lateral_m + 0.05, 0.0);
    const auto r = geometry_.project(ranges_m[i], lateral_m - 0.05, 0.0);
    foot_[static_cast<std::size_t>(i)] = l && r && std::abs(l->x - r->x) > 1e-6 ? 0.1 / std::abs(l->x - r->x) : kNaN;
  }
  double centre_acc = 0.0;
  int centre_n = 0;
  for (int i0 = 0; i0 < count; i0 += window) {
    const int i1 = std::min(count, i0 + window);
    std::fill(obs_.begin(), obs_.end(), 0.0);
    std::fill(obs_n_.begin(), obs_n_.end(), 0.0);
    double foot = 0.0;
    int nfoot = 0;
    for (int i = i0; i < i1; ++i) {
      const double* xs = px_x_.data() + static_cast<std::size_t>(i) * static_cast<std::size_t>(nsamp_);
      const double* ys = px_y_.data() + static_cast<std::size_t>(i) * static_cast<std::size_t>(nsamp_);
      for (int j = 0; j < nsamp_; ++j) {
        if (!std::isfinite(xs[j])) continue;
        const int x0 = std::min(W - 2, static_cast<int>(xs[j])), y0 = std::min(Hh - 2, static_cast<int>(ys[j]));
        const double ax = xs[j] - x0, ay = ys[j] - y0;
        const unsigned char* r0 = grey.ptr<unsigned char>(y0) + x0;
        const unsigned char* r1 = grey.ptr<unsigned char>(y0 + 1) + x0;
        obs_[static_cast<std::size_t>(j)] +=
            (1 - ay) * ((1 - ax) * r0[0] + ax * r0[1]) + ay * ((1 - ax) * r1[0] + ax * r1[1]);
        obs_n_[static_cast<std::size_t>(j)] += 1.0;
      }
      if (std::isfinite(foot_[static_cast<std::size_t>(i)])) {
        foot += foot_[static_cast<std::size_t>(i)];
        ++nfoot;
      }
    }
    int valid = 0;
    for (int j = 0; j < nsamp_; ++j) {
      auto& o = obs_[static_cast<std::size_t>(j)];
      auto& n = obs_n_[static_cast<std::size_t>(j)];
      if (2.0 * n >= i1 - i0) {
        o /= n;
        ++valid;
      } else {
        n = 0.0;
      }
    }
    if (valid < p_.min_valid_fraction * nsamp_ || nfoot == 0) {
      for (int i = i0; i < i1; ++i) depth_m[i] = kNaN;
      continue;
    }
    // the template's pixel footprint: the camera's pixel and the bilinear sampling of the image
    const double f = std::max(2.0 * fine_step_, std::hypot(foot / nfoot, p_.sample_step_m));
    int best_k = 0, best_c = 0;
    double best = std::numeric_limits<double>::infinity();
    if (lattice_r_ > 0) fill_lattice(f, light.saturation_dn);
    for (int k = 0; k < nz_; ++k) {
      for (int c = 0; c < nc_; ++c) {
        const double s = window_cost(k, c, f, light.saturation_dn);
        sse_[static_cast<std::size_t>(k) * static_cast<std::size_t>(nc_) + static_cast<std::size_t>(c)] = s;
        if (s < best) {
          best = s;
          best_k = k;
          best_c = c;
        }
      }
    }
    double z = best_k * p_.sinkage_step_m;
    if (best_k > 0 && best_k + 1 < nz_) {
      const auto at = [&](int k) {
        return sse_[static_cast<std::size_t>(k) * static_cast<std::size_t>(nc_) + static_cast<std::size_t>(best_c)];
      };
      const double ym = at(best_k - 1), y0 = at(best_k), yp = at(best_k + 1);
      const double den = ym - 2.0 * y0 + yp;
      if (den > 0) z += std::clamp(0.5 * (ym - yp) / den, -0.5, 0.5) * p_.sinkage_step_m;
    }
    // Measurable only if the residual rises clearly on both sides of the best depth (30 %, at
    // least 3 mm, away): a rut in full shadow, or deeper than max_sinkage_m, fits many depths
    // equally well. Noise from the best fit's residual; the rise must be worth chi^2 = 9.
    auto best_over_c = [&](int k) {
      double m = std::numeric_limits<double>::infinity();
      for (int c = 0; c < nc_; ++c)
        m = std::min(m,
                     sse_[static_cast<std::size_t>(k) * static_cast<std::size_t>(nc_) + static_cast<std::size_t>(c)]);
      return m;
    };
    const double step_z = std::max(0.003, 0.3 * z);
    const int k_hi = static_cast<int>(std::ceil((z + step_z) / p_.sinkage_step_m));
    const int k_lo = static_cast<int>(std::floor((z - step_z) / p_.sinkage_step_m));
    const double sigma2 = 2.0 * best / std::max(1, valid);
    const double rise = 9.0 * 0.5 * sigma2;
    const bool upper_ok = k_hi < nz_ && best_over_c(k_hi) - best >= rise;
    const bool lower_ok = k_lo < 0 || best_over_c(k_lo) - best >= rise;
    if (!upper_ok || !lower_ok) {
      for (int i = i0; i < i1; ++i) depth_m[i] = kNaN;
      ++unmeasurable_;
      continue;
    }
    for (int i = i0; i < i1; ++i) depth_m[i] = z;
    centre_acc += (best_c - nc_ / 2) * p_.centre_step_m;
    ++centre_n;
  }
  return lateral_m + (centre_n > 0 ? centre_acc / centre_n : 0.0);
}

}  // namespace regolith::soil
