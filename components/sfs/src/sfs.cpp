#include "regolith/sfs/sfs.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

#include <opencv2/core.hpp>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/core/error.hpp"

namespace regolith::sfs {
namespace {

constexpr double kPi = 3.14159265358979323846;

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw FieldError("sfs", field, why);
}

void check_gray(const cv::Mat& gray) {
  if (gray.empty()) fail("image", "empty image");
  if (gray.channels() != 1) fail("image", "expected one channel (grey), got " + std::to_string(gray.channels()));
  if (gray.depth() != CV_8U && gray.depth() != CV_32F)
    fail("image",
         "expected CV_8U (0..255) or CV_32F (0..1); 16-bit and other depths are not "
         "accepted (got depth " +
             std::to_string(gray.depth()) + ")");
  if (gray.rows < 8 || gray.cols < 8) fail("image", "smaller than 8x8 pixels");
  if (gray.depth() == CV_32F && !cv::checkRange(gray)) fail("image", "contains NaN/Inf");
}

// Value at quantile `q` of E over mask (E assumed in [0, 2]); histogram based, no allocation.
double masked_quantile(const cv::Mat& e, const cv::Mat& mask, double q) {
  constexpr int kBins = 2048;
  // One pass: each bin's count and the sum of its values (in scan order), then the bin that holds
  // the quantile; the estimate is the mean of that bin's values (exact for a uniform image).
  std::array<int, kBins> hist{};
  std::array<double, kBins> sums{};
  long n = 0;
  for (int r = 0; r < e.rows; ++r) {
    const float* pe = e.ptr<float>(r);
    const uchar* pm = mask.ptr<uchar>(r);
    for (int c = 0; c < e.cols; ++c) {
      if (!pm[c]) continue;
      const auto b = static_cast<size_t>(std::clamp(static_cast<int>(pe[c] * (kBins / 2.0f)), 0, kBins - 1));
      ++hist[b];
      sums[b] += static_cast<double>(pe[c]);
      ++n;
    }
  }
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  const double target = q * static_cast<double>(n);
  long acc = 0;
  int bin = kBins - 1;
  for (int b = 0; b < kBins; ++b) {
    acc += hist[static_cast<size_t>(b)];
    if (static_cast<double>(acc) >= target) {
      bin = b;
      break;
    }
  }
  const long m = hist[static_cast<size_t>(bin)];
  const double sum = sums[static_cast<size_t>(bin)];
  return m > 0 ? sum / static_cast<double>(m) : (bin + 0.5) / (kBins / 2.0);
}

// Fills a continuous or strided Mat of float / double / uchar with v without allocating
// (cv::Mat::setTo converts the scalar through a heap buffer).
template <class T>
void fill(cv::Mat& m, T v) {
  for (int r = 0; r < m.rows; ++r) {
    T* p = m.ptr<T>(r);
    std::fill(p, p + m.cols * m.channels(), v);
  }
}

double zc_poly(double x) {
  // Zheng-Chellappa: mu1 / sqrt(mu2) as a function of cos(slant) (spec 2.5).
  const double c[8] = {0.5577, 0.6240, 0.1882, -0.6514, -0.5345, 0.9282, 0.3476, -0.4984};
  double v = 0.0, p = 1.0;
  for (double k : c) {
    v += k * p;
    p *= x;
  }
  return v;
}

// Tsai-Shah solves in the oriented frame, where the light's tilt lies in the first quadrant (its
// backward differences then run downstream of the light): the cv::flip code that takes an image
// there and back, 2 for none.
int orienting_flip(const LightDirection& l) {
  const bool flip_x = std::cos(l.tilt_rad) < 0, flip_y = std::sin(l.tilt_rad) < 0;
  return flip_x && flip_y ? -1 : (flip_x ? 1 : (flip_y ? 0 : 2));
}

void orient(const cv::Mat& src, cv::Mat& dst, int flip) {
  if (flip == 2)
    src.copyTo(dst);
  else
    cv::flip(src, dst, flip);
}

// Height (up) = -depth, taken from the oriented frame back to the image frame (`scratch` holds the
// flipped depth).
void height_from_oriented_depth(const cv::Mat& z, int flip, cv::Mat& scratch, cv::Mat& height) {
  if (flip == 2) {
    z.convertTo(height, CV_32F, -1.0);
  } else {
    cv::flip(z, scratch, flip);
    scratch.convertTo(height, CV_32F, -1.0);
  }
}

}  // namespace

cv::Vec3d LightDirection::vector() const {
  return {std::cos(tilt_rad) * std::sin(slant_rad), std::sin(tilt_rad) * std::sin(slant_rad), std::cos(slant_rad)};
}

void LightDirection::validate(const std::string& what) const {
  if (!std::isfinite(slant_rad) || !std::isfinite(tilt_rad)) fail(what, "slant/tilt must be finite");
  if (slant_rad < 0.0 || slant_rad >= kPi / 2)
    fail(what + ".slant_rad", "must be in [0, pi/2) (got " + number_text(slant_rad) +
                                  "); a light at or below the image plane cannot shade it");
}

const char* to_string(Method m) {
  switch (m) {
    case Method::kTsaiShah: return "tsai_shah";
    case Method::kPentland: return "pentland";
    case Method::kBichselPentland: return "bichsel_pentland";
  }
  return "unknown";
}

Method method_from_string(const std::string& name) {
  if (name == "tsai_shah") return Method::kTsaiShah;
  if (name == "pentland") return Method::kPentland;
  if (name == "bichsel_pentland") return Method::kBichselPentland;
  fail("method", "unknown method '" + name + "' (expected tsai_shah, pentland, bichsel_pentland)");
}

// ------------------------------------------------------------------------------------------
// Vignetting
void Vignetting::validate() const {
  if (!std::isfinite(a2) || !std::isfinite(a4) || !std::isfinite(a6)) fail("vignetting.a2/a4/a6", "must be finite");
  if (!std::isfinite(cx_frac) || !std::isfinite(cy_frac) || cx_frac < 0 || cx_frac > 1 || cy_frac < 0 || cy_frac > 1)
    fail("vignetting.cx_frac/cy_frac", "must be in [0, 1]");
  if (!flat_field.empty()) {
    if (flat_field.channels() != 1) fail("vignetting.flat_field", "must be one channel");
    double mn, mx;
    cv::minMaxLoc(flat_field, &mn, &mx);
    if (!(mn > 0.0)) fail("vignetting.flat_field", "must be strictly positive everywhere");
  }
}

cv::Mat Vignetting::gain_map(cv::Size size) const {
  cv::Mat g(size, CV_32F);
  if (!flat_field.empty()) {
    cv::Mat f;
    flat_field.convertTo(f, CV_32F);
    if (f.size() != size) cv::resize(f, f, size, 0, 0, cv::INTER_AREA);
    const double m = cv::mean(f)[0];
    f.convertTo(g, CV_32F, 1.0 / m);
    return g;
  }
  const double cx = cx_frac * (size.width - 1), cy = cy_frac * (size.height - 1);
  const double hd = std::hypot(size.width / 2.0, size.height / 2.0);
  for (int r = 0; r < size.height; ++r) {
    float* p = g.ptr<float>(r);
    for (int c = 0; c < size.width; ++c) {
      const double rr = std::hypot(c - cx, r - cy) / hd, r2 = rr * rr;
      p[c] = static_cast<float>(1.0 + a2 * r2 + a4 * r2 * r2 + a6 * r2 * r2 * r2);
    }
  }
  return g;
}

VignettingFit fit_vignetting_polynomial(const cv::Mat& flatfield, double cx_frac, double cy_frac) {
  if (flatfield.empty()) fail("flatfield", "empty image");
  if (!std::isfinite(cx_frac) || !std::isfinite(cy_frac) || cx_frac < 0 || cx_frac > 1 || cy_frac < 0 || cy_frac > 1)
    fail("cx_frac/cy_frac", "must be in [0, 1]");
  cv::Mat g = flatfield;
  if (g.channels() == 3)
    cv::cvtColor(flatfield, g, cv::COLOR_BGR2GRAY);
  else if (g.channels() != 1)
    fail("flatfield", "expected 1 or 3 channels");
  double sat;
  switch (g.depth()) {
    case CV_8U: sat = 0.98 * 255.0; break;
    case CV_16U: sat = 0.98 * 65535.0; break;
    case CV_32F: sat = std::numeric_limits<double>::infinity(); break;
    default: fail("flatfield", "expected CV_8U, CV_16U or CV_32F");
  }
  cv::Mat f;
  g.convertTo(f, CV_64F);
  const int step = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(f.total()) / 200000.0)));
  const double cx = cx_frac * (f.cols - 1), cy = cy_frac * (f.rows - 1);
  const double hd = std::hypot(f.cols / 2.0, f.rows / 2.0);
  cv::Matx44d ata = cv::Matx44d::zeros();
  cv::Vec4d atb(0, 0, 0, 0);
  long n = 0;
  for (int r = 0; r < f.rows; r += step)
    for (int c = 0; c < f.cols; c += step) {
      const double v = f.at<double>(r, c);
      if (!std::isfinite(v) || v <= 0.0 || v >= sat) continue;
      const double rr = std::hypot(c - cx, r - cy) / hd, r2 = rr * rr;
      const cv::Vec4d a(1.0, r2, r2 * r2, r2 * r2 * r2);
      ata += a * a.t();
      atb += a * v;
      ++n;
    }
  if (n < 16) fail("flatfield", "fewer than 16 usable (unsaturated, positive) pixels");
  cv::Vec4d x;
  if (!cv::solve(ata, atb, x, cv::DECOMP_SVD) || !(x[0] > 0))
    fail("flatfield", "polynomial fit failed (degenerate or non-positive centre brightness)");
  VignettingFit out;
  out.f0 = x[0];
  out.model.enabled = true;
  out.model.a2 = x[1] / x[0];
  out.model.a4 = x[2] / x[0];
  out.model.a6 = x[3] / x[0];
  out.model.cx_frac = cx_frac;
  out.model.cy_frac = cy_frac;
  double ss = 0.0;
  long m = 0;
  for (int r = 0; r < f.rows; r += step)
    for (int c = 0; c < f.cols; c += step) {
      const double v = f.at<double>(r, c);
      if (!std::isfinite(v) || v <= 0.0 || v >= sat) continue;
      const double rr = std::hypot(c - cx, r - cy) / hd, r2 = rr * rr;
      const double model = 1.0 + out.model.a2 * r2 + out.model.a4 * r2 * r2 + out.model.a6 * r2 * r2 * r2;
      ss += (v / out.f0 - model) * (v / out.f0 - model);
      ++m;
    }
  out.rms_residual = std::sqrt(ss / static_cast<double>(m));
  return out;
}

void correct_vignetting(const cv::Mat& src, const Vignetting& v, cv::Mat& dst) {
  if (src.empty() || src.type() != CV_32FC1) fail("image", "correct_vignetting needs CV_32FC1");
  v.validate();
  const cv::Mat g = v.gain_map(src.size());
  cv::divide(src, g, dst);
}

// ------------------------------------------------------------------------------------------
void SfsParams::validate() const {
  if (method != Method::kTsaiShah && method != Method::kPentland && method != Method::kBichselPentland)
    fail("method", "unknown value");
  if (iterations < 1 || iterations > 100000) fail("iterations", "must be in 1..100000");
  if (!std::isfinite(tolerance) || tolerance < 0) fail("tolerance", "must be >= 0");
  if (!std::isfinite(wn) || wn < 0) fail("wn", "must be >= 0");
  if (!std::isfinite(s0) || s0 <= 0) fail("s0", "must be > 0");
  if (!std::isfinite(step_damping) || step_damping <= 0 || step_damping > 1) fail("step_damping", "must be in (0, 1]");
  if (!std::isfinite(max_step) || max_step <= 0) fail("max_step", "must be > 0");
  if (tsai_shah_newton_iterations < 1 || tsai_shah_newton_iterations > 1000)
    fail("tsai_shah_newton_iterations", "must be in 1..1000");
  if (tsai_shah_scheme != TsaiShahScheme::kMarching && tsai_shah_scheme != TsaiShahScheme::kJacobi)
    fail("tsai_shah_scheme", "unknown value");
  if (!std::isfinite(tsai_shah_leak_px) || (tsai_shah_leak_px != 0.0 && tsai_shah_leak_px < 1.0))
    fail("tsai_shah_leak_px", "must be 0 (off) or >= 1 px");
  if (!std::isfinite(tsai_shah_max_gradient) || tsai_shah_max_gradient <= 0)
    fail("tsai_shah_max_gradient", "must be > 0");
  if (!std::isfinite(saturation_level) || saturation_level <= 0 || saturation_level > 1.0)
    fail("saturation_level", "must be in (0, 1]");
  if (!std::isfinite(shadow_level) || shadow_level < 0 || shadow_level >= saturation_level)
    fail("shadow_level", "must be in [0, saturation_level)");
  if (!std::isfinite(min_light_confidence) || min_light_confidence < 0 || min_light_confidence > 1)
    fail("min_light_confidence", "must be in [0, 1]");
  if (!std::isfinite(pentland_min_denominator) || pentland_min_denominator <= 0)
    fail("pentland_min_denominator", "must be > 0");
  if (!std::isfinite(bichsel_singular_tolerance) || bichsel_singular_tolerance <= 0 || bichsel_singular_tolerance >= 1)
    fail("bichsel_singular_tolerance", "must be in (0, 1)");
  vignetting.validate();
}

// ------------------------------------------------------------------------------------------
// Light estimation
LightEstimate estimate_light(const cv::Mat& gray, bool refine, const cv::Mat& mask) {
  check_gray(gray);
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != gray.size()))
    fail("mask", "must be CV_8UC1 of the image size");
  cv::Mat e;
  if (gray.depth() == CV_8U)
    gray.convertTo(e, CV_32F, 1.0 / 255.0);
  else
    e = gray;
  double mu1 = 0, mu2 = 0, sx = 0, sy = 0, jxx = 0, jyy = 0, jxy = 0;
  long n = 0, ng = 0;
  for (int r = 1; r < e.rows - 1; ++r)
    for (int c = 1; c < e.cols - 1; ++c) {
      if (!mask.empty() && !mask.at<uchar>(r, c)) continue;
      const double v = static_cast<double>(e.at<float>(r, c));
      mu1 += v;
      mu2 += v * v;
      ++n;
      const double ex = 0.5 * static_cast<double>(e.at<float>(r, c + 1) - e.at<float>(r, c - 1));
      const double ey = 0.5 * static_cast<double>(e.at<float>(r + 1, c) - e.at<float>(r - 1, c));
      const double g = std::hypot(ex, ey);
      jxx += ex * ex;
      jyy += ey * ey;
      jxy += ex * ey;
      if (g > 1e-6) {
        sx += ex / g;
        sy += ey / g;
        ++ng;
      }
    }
  if (n < 16) fail("image", "fewer than 16 valid pixels for light estimation");
  mu1 /= static_cast<double>(n);
  mu2 /= static_cast<double>(n);
  LightEstimate out;
  // Tilt (Lee-Rosenfeld): direction of the mean normalised brightness gradient; its length
  // (0..1, the coherence of the gradient directions) drives the confidence.
  (void)jxx;
  (void)jyy;
  (void)jxy;
  const double mx = ng ? sx / static_cast<double>(ng) : 0.0, my = ng ? sy / static_cast<double>(ng) : 0.0;
  const double tilt = std::atan2(my, mx);
  const double coherence = std::hypot(mx, my);
  const double gamma2 = 6 * kPi * kPi * mu2 - 48 * mu1 * mu1;
  double slant = 0.0, albedo = 0.0;
  if (gamma2 > 0) {
    const double gamma = std::sqrt(gamma2);
    albedo = gamma / kPi;
    slant = std::acos(std::clamp(4 * mu1 / gamma, -1.0, 1.0));
  }
  if (refine && mu2 > 0) {
    const double target = mu1 / std::sqrt(mu2);
    double best = 1e9, best_s = slant;
    for (int k = 0; k <= 900; ++k) {
      const double s = k * (kPi / 2) / 900.0;
      const double d = std::abs(target - zc_poly(std::cos(s)));
      if (d < best) {
        best = d;
        best_s = s;
      }
    }
    slant = best_s;
  }
  slant = std::min(slant, kPi / 2 - 1e-3);
  out.light.slant_rad = slant;
  out.light.tilt_rad = std::remainder(tilt, 2 * kPi);
  out.albedo = albedo;
  // Slants near 0 leave the tilt undefined and make SfS return a flat map.
  const double slant_factor = std::clamp((slant - 0.05) / 0.25, 0.0, 1.0);
  out.confidence = std::clamp(coherence / 0.1, 0.0, 1.0) * slant_factor;
  return out;
}

// ------------------------------------------------------------------------------------------
ShapeFromShading::ShapeFromShading(SfsParams params) : params_(std::move(params)) {
  params_.validate();
}

void ShapeFromShading::prepare(const cv::Mat& gray) {
  check_gray(gray);
  const cv::Size sz = gray.size();
  if (gray.depth() == CV_8U)
    gray.convertTo(e_, CV_32F, 1.0 / 255.0);
  else
    gray.copyTo(e_);
  // Mask on the raw (uncorrected) brightness: saturation and deep shadow are sensor facts.
  mask_.create(sz, CV_8U);
  const float sat = static_cast<float>(params_.saturation_level);
  const float shd = static_cast<float>(params_.shadow_level);
  for (int r = 0; r < sz.height; ++r) {
    const float* pe = e_.ptr<float>(r);
    uchar* pm = mask_.ptr<uchar>(r);
    for (int c = 0; c < sz.width; ++c) pm[c] = (pe[c] < sat && pe[c] > shd) ? 255 : 0;
  }
  if (params_.vignetting.enabled) {
    if (gain_.size() != sz) gain_ = params_.vignetting.gain_map(sz);
    cv::divide(e_, gain_, e_);
  }
}

void ShapeFromShading::compute(const cv::Mat& gray, const std::optional<LightDirection>& light, SfsResult& out) {
  prepare(gray);
  LightDirection l;
  if (light) {
    light->validate("light");
    l = *light;
    out.light_estimated = false;
    out.light_confidence = 1.0;
  } else {
    if (!params_.estimate_light) fail("light", "no light direction supplied and estimate_light is false");
    const LightEstimate est = estimate_light(e_, params_.zheng_chellappa_refine, mask_);
    l = est.light;
    out.light_estimated = true;
    out.light_confidence = est.confidence;
    if (est.confidence < params_.min_light_confidence) {
      out.status = SfsStatus::kUnreliableLight;
      out.light = l;
      out.height.create(e_.size(), CV_32F);
      fill(out.height, std::numeric_limits<float>::quiet_NaN());
      out.valid.create(e_.size(), CV_8U);
      fill<uchar>(out.valid, 0);
      out.iterations = 0;
      out.final_mean_update = 0;
      return;
    }
  }
  out.status = SfsStatus::kSolved;
  out.light = l;
  // Albedo normalisation: the median valid pixel is taken to be locally flat ground,
  // E_flat = cos(slant). Keeps E = I otherwise.
  if (params_.normalise_albedo) {
    const double med = masked_quantile(e_, mask_, 0.5);
    if (!(med > 0)) {
      out.height.create(e_.size(), CV_32F);
      fill(out.height, std::numeric_limits<float>::quiet_NaN());
      mask_.copyTo(out.valid);
      fill<uchar>(out.valid, 0);
      out.iterations = 0;
      out.final_mean_update = 0;
      return;
    }
    e_.convertTo(e_, CV_32F, std::cos(l.slant_rad) / med);
  }
  switch (params_.method) {
    case Method::kTsaiShah: tsai_shah(l, out); break;
    case Method::kPentland: pentland(l, out); break;
    case Method::kBichselPentland: bichsel_pentland(l, out); break;
  }
  // Relative heights: zero mean over valid pixels; invalid pixels keep their (interpolated) value.
  // (Plain loop: cv::subtract with a Scalar allocates a temporary.)
  const float m = static_cast<float>(cv::mean(out.height, out.valid)[0]);
  for (int r = 0; r < out.height.rows; ++r) {
    float* ph = out.height.ptr<float>(r);
    for (int c = 0; c < out.height.cols; ++c) ph[c] -= m;
  }
}

// Tsai-Shah linear SfS (spec 2.4) in an oriented copy of the image: columns/rows are mirrored so
// that the light's image-plane direction points towards +x/+y, which is what backward differences
// need. Jacobi update (all of Z^n from Z^{n-1}) as in the reference. Default step: damped and
// clamped Newton (the reference's Kalman gain is available via kalman_gain = true).
void ShapeFromShading::tsai_shah(const LightDirection& l, SfsResult& out) {
  if (params_.tsai_shah_scheme == TsaiShahScheme::kMarching) {
    tsai_shah_marching(l, out);
    return;
  }
  const double tx = std::abs(std::cos(l.tilt_rad)), ty = std::abs(std::sin(l.tilt_rad));
  const float ps = static_cast<float>(tx * std::tan(l.slant_rad));
  const float qs = static_cast<float>(ty * std::tan(l.slant_rad));
  const int flip = orienting_flip(l);
  orient(e_, work_e_, flip);
  const cv::Size sz = e_.size();
  z_.create(sz, CV_32F);
  fill(z_, 0.0f);
  z_new_.create(sz, CV_32F);
  const bool kalman = params_.kalman_gain;
  const bool gs = params_.gauss_seidel;
  if (kalman) {
    s_.create(sz, CV_32F);
    fill(s_, static_cast<float>(params_.s0));
  }
  const float wn = static_cast<float>(params_.wn);
  const float damp = static_cast<float>(params_.step_damping);
  const float maxs = static_cast<float>(params_.max_step);
  const float norm_s = std::sqrt(1.0f + ps * ps + qs * qs);
  int it = 0;
  double mean_upd = 0.0;
  for (it = 1; it <= params_.iterations; ++it) {
    double sum = 0.0;
    for (int r = 0; r < sz.height; ++r) {
      const float* pe = work_e_.ptr<float>(r);
      const float* pz = z_.ptr<float>(r);
      const float* pzu = z_.ptr<float>(r > 0 ? r - 1 : 0);
      float* pn = gs ? z_.ptr<float>(r) : z_new_.ptr<float>(r);
      float* psv = kalman ? s_.ptr<float>(r) : nullptr;
      float row_sum = 0.0f;
      for (int c = 0; c < sz.width; ++c) {
        const float z = pz[c];
        const float p = c > 0 ? z - pz[c - 1] : 0.0f;
        const float q = r > 0 ? z - pzu[c] : 0.0f;
        const float pq = 1.0f + p * p + q * q;
        const float npq = std::sqrt(pq);
        const float num = 1.0f + p * ps + q * qs;
        const float rr = std::max(0.0f, num / (npq * norm_s));
        const float f = pe[c] - rr;
        const float drdz = (ps + qs) / (npq * norm_s) - (p + q) * num / (pq * npq * norm_s);
        float dz = 0.0f;
        if (kalman) {
          const float dfdz = -drdz;
          const float k = psv[c] * dfdz / (wn + dfdz * psv[c] * dfdz);
          psv[c] = (1.0f - k * dfdz) * psv[c];
          dz = -k * f;
        } else if (std::abs(drdz) > 1e-4f) {
          dz = std::clamp(damp * f / drdz, -maxs, maxs);
        }
        // Z is depth: a pixel brighter than the model (f > 0) must turn towards the light.
        pn[c] = z + dz;
        row_sum += std::abs(dz);
      }
      sum += static_cast<double>(row_sum);
    }
    if (!gs) std::swap(z_, z_new_);
    mean_upd = sum / static_cast<double>(sz.area());
    if (mean_upd < params_.tolerance) break;
  }
  out.iterations = std::min(it, params_.iterations);
  out.final_mean_update = mean_upd;
  height_from_oriented_depth(z_, flip, z_new_, out.height);
  mask_.copyTo(out.valid);
}

// Tsai-Shah, marching scheme. With backward differences in the light-oriented frame, pixel (r, c)'s
// brightness equation involves only Z(r, c) and its upstream neighbours Z(r, c-1), Z(r-1, c): the
// discrete system is (nonlinear) lower-triangular. The reference Jacobi update therefore needs
// about rows + cols iterations just to carry information across the image (one pixel per
// iteration), which is why it looked "stuck" at 200 iterations. A raster sweep that solves each
// pixel's scalar equation with Newton's method (upstream values already final) gives the exact
// solution of the same discretisation in one pass. The integration memory is limited by a leak
// (upstream values scaled by 1 - 1/leak) so integrated noise does not drift.
namespace {

// The constants of one marching solve (light, bounds, Newton limits).
struct MarchSetup {
  float lam, ps, qs, norm_s, maxs, tol, gmax, black, inv_lin, fct, fst, fcs;
  int max_it;
};

// One pixel's scalar equation E = R(p(t), q(t)) with p = t - zl, q = t - zu (the upstream depths
// zl, zu already leaked; has_l / has_u false on the first column / row). Returns Z; `k_used` the
// Newton iterations, `last` the final |step| (0 when no step was taken).
inline float march_pixel(const MarchSetup& m, float e_raw, bool masked, bool has_l, bool has_u, float zl, float zu,
                         int& k_used, float& last) {
  k_used = 0;
  last = 0.0f;
  if (!has_l && !has_u) return 0.0f;
  const float wa = has_l ? 1.0f : 0.0f, wb = has_u ? 1.0f : 0.0f;
  const float e = std::min(e_raw, 1.0f);
  // Linear (Pentland-like) initial guess, then Newton on f(t) = E - R(p(t), q(t)).
  const float wsum = wa * m.fct + wb * m.fst;
  // Black pixels (no data, sky, deep cast shadow) carry no shading information: continue flat.
  // Other masked pixels (attached shadow, saturation) are still solved: the gradient bound keeps
  // them sane, and they hold the steep faces of rocks.
  if (masked && e_raw < m.black) return wsum > 1e-6f ? (wa * m.fct * zl + wb * m.fst * zu) / wsum : 0.5f * (zl + zu);
  float t = wsum > 1e-6f ? ((e - m.fcs) * m.inv_lin * (m.fct + m.fst) + wa * m.fct * zl + wb * m.fst * zu) / wsum
                         : 0.5f * (zl + zu);
  // f(t) = E - R(p(t), q(t)) and dR/dt.
  auto eval = [&](float tt, float& drdt) {
    const float p = wa * (tt - zl), q = wb * (tt - zu);
    const float pq = 1.0f + p * p + q * q;
    const float npq = std::sqrt(pq);
    const float num = 1.0f + p * m.ps + q * m.qs;
    const float inv = 1.0f / (npq * m.norm_s);
    const float drdp = m.ps * inv - p * num * inv / pq;
    const float drdq = m.qs * inv - q * num * inv / pq;
    drdt = wa * drdp + wb * drdq;
    return e - std::max(0.0f, num * inv);
  };
  // Bound the backward differences to |p|, |q| <= gmax (steeper than ~63 deg is not recoverable
  // from shading: grazing and near-maximum brightness are ill-conditioned).
  const float lo = std::max(has_l ? zl - m.gmax : -1e30f, has_u ? zu - m.gmax : -1e30f);
  const float hi = std::max(lo, std::min(has_l ? zl + m.gmax : 1e30f, has_u ? zu + m.gmax : 1e30f));
  t = std::clamp(t, lo, hi);
  float drdt = 0.0f;
  float f = eval(t, drdt);
  int k = 0;
  for (k = 1; k <= m.max_it; ++k) {
    if (drdt < 1e-4f) break;  // at the reflectance maximum along t (or flat)
    float dz = std::clamp(f / drdt, -m.maxs, m.maxs);
    // Backtracking: accept the step only if |f| decreases. When E exceeds the largest reflectance
    // reachable along t (no root), this settles at the maximum.
    float d_new = 0.0f, f_new = f;
    bool improved = false;
    for (int h = 0; h < 6; ++h, dz *= 0.5f) {
      dz = std::clamp(t + dz, lo, hi) - t;
      f_new = eval(t + dz, d_new);
      // Stay on the branch through flat ground where R increases with t (drdt > 0 in the oriented
      // frame); the far branch (past the reflectance maximum) is the spurious root.
      if (std::abs(f_new) < std::abs(f) && d_new > 0.0f) {
        improved = true;
        break;
      }
    }
    if (!improved) {
      last = 0.0f;
      break;
    }
    t += dz;
    f = f_new;
    drdt = d_new;
    last = std::abs(dz);
    if (last < m.tol) break;
  }
  k_used = std::min(k, m.max_it);
  return t;
}

// One row of the march, the scalar reference: left to right, each pixel after its left neighbour.
void march_row(const MarchSetup& m, const cv::Mat& e, const cv::Mat& mask, cv::Mat& z, int r, int& max_used,
               double& sum_last) {
  const float* pe = e.ptr<float>(r);
  const uchar* pm = mask.ptr<uchar>(r);
  const float* pzu = r > 0 ? z.ptr<float>(r - 1) : nullptr;
  float* pz = z.ptr<float>(r);
  for (int c = 0; c < e.cols; ++c) {
    const bool has_l = c > 0, has_u = pzu != nullptr;
    const float zl = has_l ? m.lam * pz[c - 1] : 0.0f, zu = has_u ? m.lam * pzu[c] : 0.0f;
    int k = 0;
    float last = 0.0f;
    pz[c] = march_pixel(m, pe[c], pm[c] == 0, has_l, has_u, zl, zu, k, last);
    max_used = std::max(max_used, k);
    sum_last += static_cast<double>(last);
  }
}

#if CV_SIMD128
using V4 = cv::v_float32x4;

// N 128-bit vectors in lockstep: 4 N rows, N independent chains of square roots and divisions
// for the processor to overlap (one vector's chain alone leaves it waiting on each result).
template <int N>
struct VN {
  V4 v[N];
  static constexpr int nlanes = N * V4::nlanes;
};
template <class F, int... I>
VN<sizeof...(I)> lanewise_impl(F&& f, std::integer_sequence<int, I...>) {
  return VN<sizeof...(I)>{{f(I)...}};
}
template <int N, class F>
VN<N> lanewise(F&& f) {
  return lanewise_impl(f, std::make_integer_sequence<int, N>{});
}
template <int N>
VN<N> operator+(const VN<N>& x, const VN<N>& y) {
  return lanewise<N>([&](int i) { return x.v[i] + y.v[i]; });
}
template <int N>
VN<N> operator-(const VN<N>& x, const VN<N>& y) {
  return lanewise<N>([&](int i) { return x.v[i] - y.v[i]; });
}
template <int N>
VN<N> operator*(const VN<N>& x, const VN<N>& y) {
  return lanewise<N>([&](int i) { return x.v[i] * y.v[i]; });
}
template <int N>
VN<N> operator/(const VN<N>& x, const VN<N>& y) {
  return lanewise<N>([&](int i) { return x.v[i] / y.v[i]; });
}
template <int N>
VN<N> operator&(const VN<N>& x, const VN<N>& y) {
  return lanewise<N>([&](int i) { return x.v[i] & y.v[i]; });
}
template <int N>
VN<N> operator|(const VN<N>& x, const VN<N>& y) {
  return lanewise<N>([&](int i) { return x.v[i] | y.v[i]; });
}
template <int N>
VN<N> operator~(const VN<N>& x) {
  return lanewise<N>([&](int i) { return ~x.v[i]; });
}
template <int N>
VN<N> operator<(const VN<N>& x, const VN<N>& y) {
  return lanewise<N>([&](int i) { return x.v[i] < y.v[i]; });
}
template <int N>
VN<N> operator>(const VN<N>& x, const VN<N>& y) {
  return lanewise<N>([&](int i) { return x.v[i] > y.v[i]; });
}
template <int N>
VN<N> vmin(const VN<N>& x, const VN<N>& y) {
  return lanewise<N>([&](int i) { return cv::v_min(x.v[i], y.v[i]); });
}
template <int N>
VN<N> vmax(const VN<N>& x, const VN<N>& y) {
  return lanewise<N>([&](int i) { return cv::v_max(x.v[i], y.v[i]); });
}
template <int N>
VN<N> vselect(const VN<N>& m, const VN<N>& x, const VN<N>& y) {
  return lanewise<N>([&](int i) { return cv::v_select(m.v[i], x.v[i], y.v[i]); });
}
template <int N>
VN<N> vsqrt(const VN<N>& x) {
  return lanewise<N>([&](int i) { return cv::v_sqrt(x.v[i]); });
}
template <int N>
VN<N> vabs(const VN<N>& x) {
  return lanewise<N>([&](int i) { return cv::v_abs(x.v[i]); });
}
template <int N>
bool vany(const VN<N>& x) {
  V4 m = x.v[0];
  for (int i = 1; i < N; ++i) m = m | x.v[i];
  return cv::v_check_any(m);
}
template <class W>
W vload(const float* p) {
  return lanewise<W::nlanes / V4::nlanes>([&](int i) { return cv::v_load(p + i * V4::nlanes); });
}
template <int N>
void vstore(float* p, const VN<N>& x) {
  for (int i = 0; i < N; ++i) cv::v_store(p + i * V4::nlanes, x.v[i]);
}
template <class W>
W vsplat(float x) {
  return lanewise<W::nlanes / V4::nlanes>([&](int) { return cv::v_setall_f32(x); });
}
// Lanes moved up by one: lane 0 = x, lane j = v's lane j - 1.
template <int N>
VN<N> shift_in(float x, const VN<N>& v) {
  return lanewise<N>(
      [&](int i) { return cv::v_extract<V4::nlanes - 1>(i == 0 ? cv::v_setall_f32(x) : v.v[i - 1], v.v[i]); });
}

// W::nlanes rows of the march in the lanes of 128-bit vectors (SSE2 on x86-64, NEON on arm64),
// a skewed wavefront: lane j solves row r0 + j at column s - j, whose upstream pixels (same row,
// column - 1; row above, same column) were solved at step s - 1. A lane's
// left neighbour is its own previous result and its upper neighbour the previous result of lane
// j - 1 (lane 0 reads the row above the band), so the band's state stays in registers. The lanes
// run march_pixel's operations in the same order (IEEE add, multiply, divide and square root, each
// exact as in the scalar code), with masks where march_pixel branches: lanes that finished, or
// whose backtracking found its step, wait for the others.
template <class W>
void march_rows_simd(const MarchSetup& m, const cv::Mat& e, const cv::Mat& mask, cv::Mat& z, int r0, int& max_used,
                     double& sum_last) {
  constexpr int K = W::nlanes;
  const int cols = e.cols;
  const float* pe[K];
  const uchar* pm[K];
  float* pz[K];
  for (int j = 0; j < K; ++j) {
    pe[j] = e.ptr<float>(r0 + j);
    pm[j] = mask.ptr<uchar>(r0 + j);
    pz[j] = z.ptr<float>(r0 + j);
  }
  const float* above = r0 > 0 ? z.ptr<float>(r0 - 1) : nullptr;
  const W zero = vsplat<W>(0.0f), one = vsplat<W>(1.0f), half = vsplat<W>(0.5f);
  const W lam = vsplat<W>(m.lam), ps = vsplat<W>(m.ps), qs = vsplat<W>(m.qs), norm_s = vsplat<W>(m.norm_s);
  const W fct = vsplat<W>(m.fct), fst = vsplat<W>(m.fst), fcs = vsplat<W>(m.fcs), inv_lin = vsplat<W>(m.inv_lin);
  const W gmax = vsplat<W>(m.gmax), lin_gain = vsplat<W>(m.fct + m.fst), tol = vsplat<W>(m.tol);
  const W black = vsplat<W>(m.black), maxs = vsplat<W>(m.maxs), neg_maxs = vsplat<W>(-m.maxs);
  const W big = vsplat<W>(1e30f), neg_big = vsplat<W>(-1e30f), tiny_w = vsplat<W>(1e-6f), flat_d = vsplat<W>(1e-4f);
  W prev = zero;  // each lane's last result: its next left neighbour, and lane j + 1's upper one
  alignas(16) float buf_e[K], buf_m[K], buf_l[K], buf_u[K], buf_v[K], out[K], lasts[K];
  for (int j = 0; j < K; ++j) buf_u[j] = r0 + j > 0 ? 1.0f : 0.0f;
  const W wb = vload<W>(buf_u), has_u = wb > zero;
  for (int s = 0; s < cols + K - 1; ++s) {
    for (int j = 0; j < K; ++j) {
      const int c = s - j;
      const bool in = c >= 0 && c < cols;
      buf_v[j] = in ? 1.0f : 0.0f;
      buf_e[j] = in ? pe[j][c] : 0.0f;
      buf_m[j] = in && pm[j][c] == 0 ? 1.0f : 0.0f;
      buf_l[j] = in && c > 0 ? 1.0f : 0.0f;
    }
    const W wa = vload<W>(buf_l), valid = vload<W>(buf_v) > zero, has_l = wa > zero;
    const W e_raw = vload<W>(buf_e), masked = vload<W>(buf_m) > zero;
    // Upstream depths, leaked: left = this lane's previous result; up = lane j - 1's (lane 0: the row above).
    const W zl = vselect(has_l, lam * prev, zero);
    const W zu = vselect(has_u, lam * shift_in(above != nullptr && s < cols ? above[s] : 0.0f, prev), zero);
    const W e_v = vmin(e_raw, one);
    const W wsum = wa * fct + wb * fst;
    const W has_w = wsum > tiny_w;
    const W mid = half * (zl + zu);
    const W black_z = vselect(has_w, (wa * fct * zl + wb * fst * zu) / wsum, mid);
    const W lin = ((e_v - fcs) * inv_lin * lin_gain + wa * fct * zl + wb * fst * zu) / wsum;
    const W lo = vmax(vselect(has_l, zl - gmax, neg_big), vselect(has_u, zu - gmax, neg_big));
    const W hi = vmax(lo, vmin(vselect(has_l, zl + gmax, big), vselect(has_u, zu + gmax, big)));
    W t = vmin(vmax(vselect(has_w, lin, mid), lo), hi);
    auto eval = [&](const W& tt, W& drdt) {
      const W p = wa * (tt - zl), q = wb * (tt - zu);
      const W pq = one + p * p + q * q;
      const W npq = vsqrt(pq);
      const W num = one + p * ps + q * qs;
      const W inv = one / (npq * norm_s);
      const W drdp = ps * inv - p * num * inv / pq;
      const W drdq = qs * inv - q * num * inv / pq;
      drdt = wa * drdp + wb * drdq;
      return e_v - vmax(zero, num * inv);
    };
    const W first = ~(has_l | has_u);
    const W is_black = masked & (e_raw < black);
    W active = valid & ~first & ~is_black;
    W drdt = zero, last = zero;
    W f = eval(t, drdt);
    for (int k = 1; k <= m.max_it && vany(active); ++k) {
      max_used = std::max(max_used, k);
      active = active & ~(drdt < flat_d);  // at the reflectance maximum along t (or flat)
      if (!vany(active)) break;
      W dz = vmin(vmax(f / drdt, neg_maxs), maxs);
      W searching = active, step = zero, f_new = f, d_new = drdt;
      for (int h = 0; h < 6 && vany(searching); ++h) {
        dz = vmin(vmax(t + dz, lo), hi) - t;
        W dn = zero;
        const W fn = eval(t + dz, dn);
        const W ok = searching & (vabs(fn) < vabs(f)) & (dn > zero);
        step = vselect(ok, dz, step);
        f_new = vselect(ok, fn, f_new);
        d_new = vselect(ok, dn, d_new);
        searching = searching & ~ok;
        dz = dz * half;
      }
      const W improved = active & ~searching;
      last = vselect(active, vselect(improved, vabs(step), zero), last);
      t = vselect(improved, t + step, t);
      f = vselect(improved, f_new, f);
      drdt = vselect(improved, d_new, drdt);
      active = improved & ~(last < tol);
    }
    prev = vselect(first, zero, vselect(is_black, black_z, t));
    vstore(out, prev);
    vstore(lasts, vselect(valid, last, zero));
    for (int j = 0; j < K; ++j) {
      const int c = s - j;
      if (c < 0 || c >= cols) continue;
      pz[j][c] = out[j];
      sum_last += static_cast<double>(lasts[j]);
    }
  }
}
#endif

}  // namespace

void ShapeFromShading::tsai_shah_marching(const LightDirection& l, SfsResult& out) {
  const double ct = std::abs(std::cos(l.tilt_rad)), st = std::abs(std::sin(l.tilt_rad));
  const double ss = std::sin(l.slant_rad), cs = std::cos(l.slant_rad);
  const int flip = orienting_flip(l);
  orient(e_, work_e_, flip);
  orient(mask_, work_mask_, flip);
  const cv::Size sz = e_.size();
  z_.create(sz, CV_32F);
  z_new_.create(sz, CV_32F);
  if (ss < 1e-3) {  // light along the line of sight: shading carries no gradient information
    fill(z_, 0.0f);
    out.iterations = 0;
    out.final_mean_update = 0.0;
  } else {
    MarchSetup m{};
    m.lam = params_.tsai_shah_leak_px > 0 ? static_cast<float>(1.0 - 1.0 / params_.tsai_shah_leak_px) : 1.0f;
    m.ps = static_cast<float>(ct * std::tan(l.slant_rad));
    m.qs = static_cast<float>(st * std::tan(l.slant_rad));
    m.norm_s = std::sqrt(1.0f + m.ps * m.ps + m.qs * m.qs);
    m.maxs = static_cast<float>(params_.max_step) * 4.0f;
    m.tol = static_cast<float>(params_.tolerance);
    m.gmax = static_cast<float>(params_.tsai_shah_max_gradient);
    m.max_it = params_.tsai_shah_newton_iterations;
    m.black = params_.tsai_shah_skip_black ? static_cast<float>(0.5 * params_.shadow_level) : -1.0f;
    m.inv_lin = static_cast<float>(1.0 / (ss * (ct + st)));
    m.fct = static_cast<float>(ct);
    m.fst = static_cast<float>(st);
    m.fcs = static_cast<float>(cs);
    int max_used = 0;
    double sum_last = 0.0;
    int r = 0;
#if CV_SIMD128
    if (params_.tsai_shah_simd) {
      // Two vectors per step measured fastest (640x480 ortho frames, one core: scalar 20.5 ms,
      // one vector 14.5, two 8.0-8.6, three 8.9-10.1, four 9.3-10.2: more lanes wait longer for
      // the slowest one's backtracking).
      using Wide = VN<2>;
      using Narrow = VN<1>;
      for (; r + Wide::nlanes <= sz.height; r += Wide::nlanes)
        march_rows_simd<Wide>(m, work_e_, work_mask_, z_, r, max_used, sum_last);
      for (; r + Narrow::nlanes <= sz.height; r += Narrow::nlanes)
        march_rows_simd<Narrow>(m, work_e_, work_mask_, z_, r, max_used, sum_last);
    }
#endif
    for (; r < sz.height; ++r) march_row(m, work_e_, work_mask_, z_, r, max_used, sum_last);
    out.iterations = max_used;
    out.final_mean_update = sum_last / static_cast<double>(sz.area());
  }
  height_from_oriented_depth(z_, flip, z_new_, out.height);
  mask_.copyTo(out.valid);
}

// Pentland linear SfS (spec 2.6): E - mean ~ sin(slant) (cos(tilt) Zx + sin(tilt) Zy) with Z
// depth. In the Fourier domain F_E = i sin(slant) (w1 cos(tilt) + w2 sin(tilt)) F_Z =: D F_Z;
// solved with a Tikhonov-regularised inverse F_Z = conj(D) F_E / (|D|^2 + eps^2) (eps =
// pentland_min_denominator), which zeroes the DC term and frequencies orthogonal to the light.
void ShapeFromShading::pentland(const LightDirection& l, SfsResult& out) {
  const cv::Size sz = e_.size();
  const int R = cv::getOptimalDFTSize(sz.height), C = cv::getOptimalDFTSize(sz.width);
  const int Ch = C / 2 + 1;  // the half spectrum of a real array
  const bool new_size = fft_.rows() != R || fft_.cols() != C;
  fft_.resize(R, C);  // plans and buffers: first frame of a size only
  if (new_size || last_tilt_ != l.tilt_rad || last_slant_ != l.slant_rad) {
    // conj(D) / (|D|^2 + eps^2) = -i d / (d^2 + eps^2), D = i d: purely imaginary, stored as its
    // imaginary part over the half spectrum (w1 = 2 pi c / C >= 0 there).
    filt_re_.create(R, Ch, CV_32F);
    const double ct = std::cos(l.tilt_rad), st = std::sin(l.tilt_rad), ss = std::sin(l.slant_rad);
    const double eps2 = params_.pentland_min_denominator * params_.pentland_min_denominator;
    for (int r = 0; r < R; ++r) {
      const double w2 = 2 * kPi * (r <= R / 2 ? r : r - R) / R;
      float* pf = filt_re_.ptr<float>(r);
      for (int c = 0; c < Ch; ++c) {
        const double w1 = 2 * kPi * c / C;
        const double d = ss * (w1 * ct + w2 * st);
        pf[c] = static_cast<float>(-d / (d * d + eps2));
      }
    }
    last_tilt_ = l.tilt_rad;
    last_slant_ = l.slant_rad;
  }
  // Zero-mean E (the mean over valid pixels; masked pixels keep their brightness unless
  // pentland_fill_masked, then they get the mean) into the zero-padded real buffer.
  const double mean = cv::mean(e_, mask_)[0];
  cv::Mat real = fft_.real();
  fill(real, 0.0f);
  for (int r = 0; r < sz.height; ++r) {
    const float* pe = e_.ptr<float>(r);
    const uchar* pm = mask_.ptr<uchar>(r);
    float* pt = real.ptr<float>(r);
    for (int c = 0; c < sz.width; ++c)
      pt[c] = (pm[c] || !params_.pentland_fill_masked) ? static_cast<float>(static_cast<double>(pe[c]) - mean) : 0.0f;
  }
  fft_.forward();
  // F_Z = (i f) F_E: (a + i b) i f = -b f + i a f.
  cv::Mat spec = fft_.spectrum();
  for (int r = 0; r < R; ++r) {
    cv::Vec2f* ps = spec.ptr<cv::Vec2f>(r);
    const float* pf = filt_re_.ptr<float>(r);
    for (int c = 0; c < Ch; ++c) {
      const float a = ps[c][0], b = ps[c][1];
      ps[c] = cv::Vec2f(-b * pf[c], a * pf[c]);
    }
  }
  fft_.inverse();
  real(cv::Rect(0, 0, sz.width, sz.height)).convertTo(out.height, CV_32F, -1.0 / (static_cast<double>(R) * C));
  out.iterations = 1;
  out.final_mean_update = 0.0;
  mask_.copyTo(out.valid);
}

// Bichsel-Pentland minimum-downhill propagation (spec 2.6), own formulation: singular points
// (E >= 1 - tol after normalisation) are local maxima at height 0; every other pixel takes
//   H(x) = max over 8 neighbours n of [ H(n) - len(n) * drop_n(E(x)) ]
// where drop_n(E) is the smallest slope m >= 0 such that a surface descending along the step
// from n to x with slope m (gradient parallel to the step) has Lambertian brightness E. The
// table drop_n(E) is precomputed per light for 256 brightness levels. Raster sweeps alternate
// over the four scan orders until the mean height change is below `tolerance`.
void ShapeFromShading::bichsel_pentland(const LightDirection& l, SfsResult& out) {
  const cv::Size sz = e_.size();
  constexpr int kLevels = 256;
  static const int dr8[8] = {-1, -1, -1, 0, 0, 1, 1, 1};
  static const int dc8[8] = {-1, 0, 1, -1, 1, -1, 0, 1};
  std::array<std::array<float, kLevels>, 8> drop{};
  const cv::Vec3d s = l.vector();
  constexpr int kSteps = 2000;  // slopes m = 0.005 j, j = 1..kSteps (up to 10)
  for (int k = 0; k < 8; ++k) {
    // Step direction w from the neighbour to the pixel; the surface is assumed to descend along
    // w with slope m >= 0 (gradient parallel to the step): E(m) = (m w.s_xy + s_z)/sqrt(1+m^2).
    // drop = smallest m whose brightness crosses E ("minimum downhill"), infinite if none: for
    // level e, the first step j where E(m_j) >= e differs from E(m_{j-1}) >= e (E(m_0) = s_z),
    // found at m_j - 0.0025. One walk over the steps serves every level: the comparison flips
    // between j - 1 and j exactly for the levels with min(E_{j-1}, E_j) < e <= max(E_{j-1}, E_j),
    // and each is checked with that same comparison (as E - e >= 0: the same sign in IEEE).
    const double wx = -dc8[k], wy = -dr8[k];
    const double wl = std::hypot(wx, wy);
    const double ws = (wx * s[0] + wy * s[1]) / wl;
    auto& dk = drop[static_cast<size_t>(k)];
    std::array<bool, kLevels> done{};
    const auto level_e = [](int lev) { return (lev + 0.5) / kLevels; };
    for (int lev = 0; lev < kLevels; ++lev) {
      dk[static_cast<size_t>(lev)] = std::numeric_limits<float>::infinity();
      if (std::abs(s[2] - level_e(lev)) < 0.5 / kLevels) {
        dk[static_cast<size_t>(lev)] = 0.0f;
        done[static_cast<size_t>(lev)] = true;
      }
    }
    double prev = s[2];
    for (int j = 1; j <= kSteps; ++j) {
      const double m = j * 0.005;
      const double cur = (m * ws + s[2]) / std::sqrt(1 + m * m);
      const double lo = std::min(prev, cur), hi = std::max(prev, cur);
      if (!(lo < hi)) {  // no level between them (or not a number)
        prev = cur;
        continue;
      }
      // candidate levels: e in (lo, hi], widened by one level each way, then checked exactly
      const double first = std::floor(lo * kLevels - 0.5) - 1.0, last = std::ceil(hi * kLevels - 0.5) + 1.0;
      const int l0 = static_cast<int>(std::clamp(first, 0.0, kLevels - 1.0));
      const int l1 = static_cast<int>(std::clamp(last, 0.0, kLevels - 1.0));
      for (int lev = l0; lev <= l1; ++lev) {
        const double e = level_e(lev);
        if (done[static_cast<size_t>(lev)] || ((cur - e >= 0) == (prev - e >= 0))) continue;
        dk[static_cast<size_t>(lev)] = static_cast<float>((m - 0.0025) * wl);
        done[static_cast<size_t>(lev)] = true;
      }
      prev = cur;
    }
  }
  z_.create(sz, CV_32F);
  z_new_.create(sz, CV_32F);  // used as a quantised-level image (float storage)
  const float tol = static_cast<float>(1.0 - params_.bichsel_singular_tolerance);
  constexpr float kLow = -1e10f;
  double emax = 0.0;
  cv::minMaxLoc(e_, nullptr, &emax, nullptr, nullptr, mask_);
  const float sing = static_cast<float>(std::min(static_cast<double>(tol), emax - params_.bichsel_singular_tolerance));
  for (int r = 0; r < sz.height; ++r) {
    const float* pe = e_.ptr<float>(r);
    const uchar* pm = mask_.ptr<uchar>(r);
    float* pz = z_.ptr<float>(r);
    float* pl = z_new_.ptr<float>(r);
    for (int c = 0; c < sz.width; ++c) {
      pl[c] = static_cast<float>(std::clamp(static_cast<int>(pe[c] * kLevels), 0, kLevels - 1));
      pz[c] = (pm[c] && pe[c] >= sing) ? 0.0f : kLow;
    }
  }
  int it = 0;
  double mean_upd = 0.0;
  for (it = 1; it <= params_.iterations; ++it) {
    const bool rev_r = (it & 1) == 0, rev_c = (it & 2) != 0;
    double sum = 0.0;
    for (int i = 0; i < sz.height; ++i) {
      const int r = rev_r ? sz.height - 1 - i : i;
      float* pz = z_.ptr<float>(r);
      const float* pl = z_new_.ptr<float>(r);
      const float* nrow[3] = {r > 0 ? z_.ptr<float>(r - 1) : nullptr, pz,
                              r + 1 < sz.height ? z_.ptr<float>(r + 1) : nullptr};
      for (int j = 0; j < sz.width; ++j) {
        const int c = rev_c ? sz.width - 1 - j : j;
        const auto lev = static_cast<size_t>(pl[c]);
        float best = pz[c];
        for (int k = 0; k < 8; ++k) {
          const int rn = r + dr8[k], cn = c + dc8[k];
          if (rn < 0 || cn < 0 || rn >= sz.height || cn >= sz.width) continue;
          const float hn = nrow[1 + dr8[k]][cn];
          if (hn <= kLow) continue;
          best = std::max(best, hn - drop[static_cast<size_t>(k)][lev]);
        }
        if (best > pz[c]) {
          if (pz[c] > kLow)
            sum += static_cast<double>(best - pz[c]);
          else
            sum += 1.0;
          pz[c] = best;
        }
      }
    }
    mean_upd = sum / static_cast<double>(sz.area());
    if (mean_upd < params_.tolerance && it >= 4) break;
  }
  out.iterations = std::min(it, params_.iterations);
  out.final_mean_update = mean_upd;
  z_.copyTo(out.height);
  mask_.copyTo(out.valid);
  for (int r = 0; r < sz.height; ++r) {
    float* ph = out.height.ptr<float>(r);
    uchar* pv = out.valid.ptr<uchar>(r);
    for (int c = 0; c < sz.width; ++c)
      if (ph[c] <= kLow) {
        ph[c] = 0.0f;
        pv[c] = 0;
      }
  }
}

SfsResult shape_from_shading(const cv::Mat& gray, const std::optional<LightDirection>& light, const SfsParams& params) {
  ShapeFromShading s(params);
  SfsResult r;
  s.compute(gray, light, r);
  if (r.status == SfsStatus::kUnreliableLight) throw std::runtime_error(unreliable_light_message(r, params));
  return r;
}

std::string unreliable_light_message(const SfsResult& r, const SfsParams& params) {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "sfs: the sun's direction could not be told from the image (estimate's confidence %.2f, "
                "min_light_confidence %.2f) and shape from shading needs it; supply the sun direction",
                r.light_confidence, params.min_light_confidence);
  return buf;
}

cv::Mat render_lambertian(const cv::Mat& height, const LightDirection& light) {
  if (height.empty() || height.type() != CV_32FC1) fail("height", "must be non-empty CV_32FC1");
  light.validate("light");
  const cv::Vec3d s = light.vector();
  cv::Mat img(height.size(), CV_32F);
  for (int r = 0; r < height.rows; ++r) {
    const float* p0 = height.ptr<float>(r);
    const float* p1 = height.ptr<float>(std::min(r + 1, height.rows - 1));
    float* o = img.ptr<float>(r);
    for (int c = 0; c < height.cols; ++c) {
      const int cn = std::min(c + 1, height.cols - 1);
      const double hx = static_cast<double>(p0[cn] - p0[c]);
      const double hy = static_cast<double>(p1[c] - p0[c]);
      const double n = std::sqrt(1 + hx * hx + hy * hy);
      o[c] = static_cast<float>(std::max(0.0, (-hx * s[0] - hy * s[1] + s[2]) / n));
    }
  }
  return img;
}

}  // namespace regolith::sfs
