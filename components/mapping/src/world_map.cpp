#include "regolith/mapping/world_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include <opencv2/imgproc.hpp>

#include "regolith/common/fill.hpp"
#include "regolith/core/error.hpp"
#include "regolith/mapping/rock_tracker.hpp"

namespace regolith::mapping {
namespace {

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

constexpr int kMaxMedianRadius = 3;    // elevation_median_m, in cells
constexpr double kMaxBlurSigma = 4.0;  // hazard_blur_m, in cells

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw FieldError("mapping.map", field, why);
}

using common::fill;

enum Layer {
  kElevation,
  kVariance,
  kConfidence,
  kCount,
  kSlope,
  kRoughness,
  kStep,
  kTrav,
  kRelief,
  kShadow,
  kHazard,
  kEvidence,
  kRockHeight,
  kLayers
};

}  // namespace

void WorldMapParams::validate() const {
  auto pos = [](double v, const char* f) {
    if (!std::isfinite(v) || v <= 0) fail(f, "must be > 0");
  };
  pos(resolution_m, "resolution_m");
  pos(length_x_m, "length_x_m");
  pos(length_y_m, "length_y_m");
  pos(range_scale_m, "range_scale_m");
  pos(max_range_m, "max_range_m");
  pos(weight_full, "weight_full");
  pos(observation_sigma_m, "observation_sigma_m");
  pos(ground_sigma_m, "ground_sigma_m");
  pos(hazard_height_m, "hazard_height_m");
  pos(hazard_evidence_scale, "hazard_evidence_scale");
  if (!(hazard_relief_weight >= 0 && hazard_relief_weight <= 1)) fail("hazard_relief_weight", "must be in [0, 1]");
  pos(rock_min_height_m, "rock_min_height_m");
  if (!std::isfinite(shadow_spread_m) || shadow_spread_m < 0) fail("shadow_spread_m", "must be >= 0");
  if (!std::isfinite(min_weight) || min_weight < 0) fail("min_weight", "must be >= 0");
  if (!std::isfinite(hazard_min_weight) || hazard_min_weight < 0) fail("hazard_min_weight", "must be >= 0");
  if (!std::isfinite(rock_min_area_m2) || rock_min_area_m2 < 0) fail("rock_min_area_m2", "must be >= 0");
  if (!std::isfinite(sighting_radius_m) || sighting_radius_m <= 0) fail("sighting_radius_m", "must be > 0");
  if (!std::isfinite(rock_min_evidence) || rock_min_evidence <= 0) fail("rock_min_evidence", "must be > 0");
  if (!std::isfinite(rock_merge_m) || rock_merge_m < 0) fail("rock_merge_m", "must be >= 0");
  if (!std::isfinite(elevation_median_m) || elevation_median_m < 0) fail("elevation_median_m", "must be >= 0");
  if (!std::isfinite(hazard_blur_m) || hazard_blur_m < 0) fail("hazard_blur_m", "must be >= 0");
  if (!(rock_min_confidence >= 0 && rock_min_confidence < 1)) fail("rock_min_confidence", "must be in [0, 1)");
  if (rock_min_frames < 1) fail("rock_min_frames", "must be >= 1");
  if (max_rocks < 1 || max_rocks > 1 << 20) fail("max_rocks", "must be 1..1048576");
  if (length_x_m / resolution_m > 4096 || length_y_m / resolution_m > 4096)
    fail("resolution_m", "more than 4096 cells per side");
  if (length_x_m < 2 * resolution_m || length_y_m < 2 * resolution_m) fail("length_x_m", "below two cells");
}

const std::vector<std::string>& WorldMap::layer_names() {
  static const std::vector<std::string> names{"elevation",
                                              "elevation_variance",
                                              "confidence",
                                              "observed_count",
                                              "traversability_slope",
                                              "traversability_roughness",
                                              "traversability_step",
                                              "traversability",
                                              "relief",
                                              "shadow_height",
                                              "hazard",
                                              "rock_evidence",
                                              "rock_height"};
  return names;
}

WorldMap::WorldMap(const WorldMapParams& params, double cx, double cy) : p_((params.validate(), params)) {
  rows_ = static_cast<int>(std::lround(p_.length_y_m / p_.resolution_m));
  cols_ = static_cast<int>(std::lround(p_.length_x_m / p_.resolution_m));
  ox_ = cx - 0.5 * (cols_ - 1) * p_.resolution_m;
  oy_ = cy - 0.5 * (rows_ - 1) * p_.resolution_m;
  for (cv::Mat* m : {&wsum_, &mean_, &m2_}) m->create(rows_, cols_, CV_64F), fill(*m, 0.0);
  count_.create(rows_, cols_, CV_32F);
  fill(count_, 0.0f);
  for (cv::Mat* m : {&shadow_w_, &shadow_h_, &sight_w_, &sight_h_, &live_w_, &live_h_})
    m->create(rows_, cols_, CV_32F), fill(*m, 0.0f);
  tracks_.create(kTrackRows, p_.max_rocks, CV_32F);
  fill(tracks_, kNaNf);
  layers_.resize(kLayers);
  for (auto& m : layers_) m.create(rows_, cols_, CV_32F), fill(m, kNaNf);
  for (cv::Mat* m : {&scratch_, &scratch2_, &scratch3_, &ground_w_, &fill_w_}) m->create(rows_, cols_, CV_32F);
  mask_.create(rows_, cols_, CV_8U);
  line_.assign(static_cast<std::size_t>(std::max(rows_, cols_)), 0.0);
  line_w_ = line_;
  // traversability::compute_layers works on a GridMap whose layers share our memory.
  traversability::TraversabilityParams tp = p_.traversability;
  tp.set_grid({p_.resolution_m, rows_ * p_.resolution_m, cols_ * p_.resolution_m, 0.0, 0.0});
  p_.traversability = tp;
  static_cast<common::GridGeometry&>(trav_) = tp.grid();
  trav_.layers = {"elevation",           "confidence",    "traversability_slope", "traversability_roughness",
                  "traversability_step", "traversability"};
  trav_.data = {layers_[kElevation], layers_[kConfidence], layers_[kSlope],
                layers_[kRoughness], layers_[kStep],       layers_[kTrav]};
}

const cv::Mat& WorldMap::layer(std::string_view name) const {
  const auto& n = layer_names();
  for (std::size_t k = 0; k < n.size(); ++k)
    if (n[k] == name) return layers_[k];
  throw std::out_of_range("mapping: WorldMap has no layer '" + std::string(name) + "'");
}

void WorldMap::recenter(double x, double y, double margin_m) {
  const double cx = ox_ + 0.5 * (cols_ - 1) * p_.resolution_m, cy = oy_ + 0.5 * (rows_ - 1) * p_.resolution_m;
  int dj = 0, di = 0;
  if (std::abs(x - cx) > 0.5 * p_.length_x_m - margin_m) dj = static_cast<int>(std::lround((x - cx) / p_.resolution_m));
  if (std::abs(y - cy) > 0.5 * p_.length_y_m - margin_m) di = static_cast<int>(std::lround((y - cy) / p_.resolution_m));
  if (di == 0 && dj == 0) return;
  // New cell (i, j) = old cell (i + di, j + dj), `zero` where that is outside: in place, rows
  // visited away from their source row, each row's kept run moved with memmove (overlap-safe).
  const int keep_lo = std::max(0, -dj), keep_hi = std::min(cols_, cols_ - dj);  // new columns with a source
  auto shift = [&](cv::Mat& m, auto zero) {
    using T = decltype(zero);
    const int r0 = di >= 0 ? 0 : rows_ - 1, r1 = di >= 0 ? rows_ : -1, rs = di >= 0 ? 1 : -1;
    for (int i = r0; i != r1; i += rs) {
      T* d = m.ptr<T>(i);
      const int si = i + di;
      if (si < 0 || si >= rows_ || keep_lo >= keep_hi) {
        std::fill(d, d + cols_, zero);
        continue;
      }
      std::memmove(d + keep_lo, m.ptr<T>(si) + keep_lo + dj, static_cast<std::size_t>(keep_hi - keep_lo) * sizeof(T));
      std::fill(d, d + keep_lo, zero);
      std::fill(d + keep_hi, d + cols_, zero);
    }
  };
  for (cv::Mat* m : {&wsum_, &mean_, &m2_}) shift(*m, 0.0);
  shift(count_, 0.0f);
  shift(shadow_w_, 0.0f);
  shift(shadow_h_, 0.0f);
  shift(sight_w_, 0.0f);
  shift(sight_h_, 0.0f);
  shift(live_w_, 0.0f);
  shift(live_h_, 0.0f);
  for (auto& m : layers_) shift(m, kNaNf);
  ox_ += dj * p_.resolution_m;
  oy_ += di * p_.resolution_m;
}

int WorldMap::fuse(const traversability::GridMap& body, const Pose2& foot, double weight) {
  const std::size_t ke = body.layer_index("elevation"), kc = body.layer_index("confidence");
  const cv::Mat& e = body.data[ke];
  const cv::Mat& conf = body.data[kc];
  if (!foot.finite()) return 0;  // never fuse with a NaN pose
  // World bounding box of the body grid's corners.
  const double hx = 0.5 * body.length_x_m, hy = 0.5 * body.length_y_m;
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (double sx : {-1.0, 1.0})
    for (double sy : {-1.0, 1.0}) {
      const Eigen::Vector2d w = foot.apply(body.center_x_m + sx * hx, body.center_y_m + sy * hy);
      xmin = std::min(xmin, w.x()), xmax = std::max(xmax, w.x());
      ymin = std::min(ymin, w.y()), ymax = std::max(ymax, w.y());
    }
  const int j0 = std::max(0, static_cast<int>(std::floor((xmin - ox_) / p_.resolution_m)));
  const int j1 = std::min(cols_ - 1, static_cast<int>(std::ceil((xmax - ox_) / p_.resolution_m)));
  const int i0 = std::max(0, static_cast<int>(std::floor((ymin - oy_) / p_.resolution_m)));
  const int i1 = std::min(rows_ - 1, static_cast<int>(std::ceil((ymax - oy_) / p_.resolution_m)));
  const Pose2 inv = inverse(foot);
  const double c = std::cos(inv.yaw), s = std::sin(inv.yaw);
  const double x_top = body.center_x_m + hx, y_left = body.center_y_m + hy, br = body.resolution_m;
  const int nx = e.rows, ny = e.cols;
  const double r2max = p_.max_range_m * p_.max_range_m, inv_rs2 = 1.0 / (p_.range_scale_m * p_.range_scale_m);
  int updated = 0;
  for (int i = i0; i <= i1; ++i) {
    const double wy = oy_ + i * p_.resolution_m;
    for (int j = j0; j <= j1; ++j) {
      const double wx = ox_ + j * p_.resolution_m;
      const double bx = inv.x + c * wx - s * wy, by = inv.y + s * wx + c * wy;
      const int bi = static_cast<int>(std::floor((x_top - bx) / br)),
                bj = static_cast<int>(std::floor((y_left - by) / br));
      if (bi < 0 || bj < 0 || bi >= nx || bj >= ny) continue;
      const float z = e.at<float>(bi, bj);
      const float cf = conf.at<float>(bi, bj);
      const double r2 = bx * bx + by * by;
      if (!std::isfinite(z) || !(cf > 0.0f) || r2 > r2max) continue;
      add(i, j, z, weight * static_cast<double>(cf) / (1.0 + r2 * inv_rs2));
      ++updated;
    }
  }
  return updated;
}

void WorldMap::add(int i, int j, double z, double w) {
  // Running weighted mean and sum of squared deviations (West's weighted Welford update).
  double& ws = wsum_.at<double>(i, j);
  double& mu = mean_.at<double>(i, j);
  // A look far from what the cell already holds firmly is down-weighted (Cauchy-like): one bad
  // match does not pull a well-seen cell.
  if (p_.robust_sigma_m > 0 && ws > p_.weight_full) {
    const double spread = std::sqrt(m2_.at<double>(i, j) / ws) + p_.robust_sigma_m;
    const double u = (z - mu) / spread;
    w /= 1.0 + u * u;
  }
  const double nw = ws + w, d = z - mu;
  mu += d * w / nw;
  m2_.at<double>(i, j) += w * d * (z - mu);
  ws = nw;
  count_.at<float>(i, j) += 1.0f;
}

int WorldMap::fuse_points(const cv::Mat& x, const cv::Mat& y, const cv::Mat& z, const cv::Mat& w, const Pose2& foot) {
  if (!foot.finite()) return 0;
  const double c = std::cos(foot.yaw), s = std::sin(foot.yaw);
  const double r2max = p_.max_range_m * p_.max_range_m, inv_rs2 = 1.0 / (p_.range_scale_m * p_.range_scale_m);
  const double inv_res = 1.0 / p_.resolution_m;
  int updated = 0;
  for (int r = 0; r < z.rows; ++r) {
    const float* px = x.ptr<float>(r);
    const float* py = y.ptr<float>(r);
    const float* pz = z.ptr<float>(r);
    const float* pw = w.ptr<float>(r);
    for (int k = 0; k < z.cols; ++k) {
      if (!std::isfinite(pz[k]) || !(pw[k] > 0.0f) || !std::isfinite(px[k]) || !std::isfinite(py[k])) continue;
      const double bx = px[k], by = py[k], r2 = bx * bx + by * by;
      if (r2 > r2max) continue;
      const double wx = foot.x + c * bx - s * by, wy = foot.y + s * bx + c * by;
      const int j = static_cast<int>(std::lround((wx - ox_) * inv_res)),
                i = static_cast<int>(std::lround((wy - oy_) * inv_res));
      if (i < 0 || j < 0 || i >= rows_ || j >= cols_) continue;
      add(i, j, pz[k], static_cast<double>(pw[k]) / (1.0 + r2 * inv_rs2));
      ++updated;
    }
  }
  return updated;
}

int WorldMap::fuse_casters(const cv::Mat& x, const cv::Mat& y, const cv::Mat& h, const cv::Mat& w, const Pose2& foot) {
  if (!foot.finite()) return 0;
  const double c = std::cos(foot.yaw), s = std::sin(foot.yaw), inv_res = 1.0 / p_.resolution_m;
  const double r2max = p_.max_range_m * p_.max_range_m;
  int updated = 0;
  for (int r = 0; r < h.rows; ++r) {
    const float* px = x.ptr<float>(r);
    const float* py = y.ptr<float>(r);
    const float* ph = h.ptr<float>(r);
    const float* pw = w.ptr<float>(r);
    for (int k = 0; k < h.cols; ++k) {
      if (!std::isfinite(ph[k]) || !(pw[k] > 0.0f)) continue;
      const double bx = px[k], by = py[k];
      if (bx * bx + by * by > r2max) continue;
      const double wx = foot.x + c * bx - s * by, wy = foot.y + s * bx + c * by;
      const int j = static_cast<int>(std::lround((wx - ox_) * inv_res)),
                i = static_cast<int>(std::lround((wy - oy_) * inv_res));
      if (i < 0 || j < 0 || i >= rows_ || j >= cols_) continue;
      float& sw = shadow_w_.at<float>(i, j);
      float& sh = shadow_h_.at<float>(i, j);
      sh = (sh * sw + ph[k] * pw[k]) / (sw + pw[k]);
      sw += pw[k];
      ++updated;
    }
  }
  return updated;
}

void WorldMap::fuse_rock_tracks(const cv::Mat& closed, int n_closed, const cv::Mat& live, int n_live) {
  if (closed.rows < kTrackRows || live.rows < kTrackRows || closed.type() != CV_32F || live.type() != CV_32F) return;
  n_closed = std::clamp(n_closed, 0, closed.cols);
  n_live = std::clamp(n_live, 0, live.cols);
  paint_tracks(closed, n_closed, sight_w_, sight_h_);
  fill(live_w_, 0.0f);
  fill(live_h_, 0.0f);
  paint_tracks(live, n_live, live_w_, live_h_);
  // Closed tracks are kept (when full, a new one replaces the weakest kept if it is stronger);
  // the live ones follow them.
  const int cap = tracks_.cols;
  for (int k = 0; k < n_closed; ++k) {
    int slot = n_closed_;
    if (n_closed_ >= cap) {
      slot = 0;
      for (int c = 1; c < cap; ++c)
        if (tracks_.at<float>(kTrackScore, c) < tracks_.at<float>(kTrackScore, slot)) slot = c;
      if (!(closed.at<float>(kTrackScore, k) > tracks_.at<float>(kTrackScore, slot))) continue;
    } else {
      ++n_closed_;
    }
    for (int r = 0; r < kTrackRows; ++r) tracks_.at<float>(r, slot) = closed.at<float>(r, k);
  }
  n_live_ = std::min(n_live, cap - n_closed_);
  for (int k = 0; k < n_live_; ++k)
    for (int r = 0; r < kTrackRows; ++r) tracks_.at<float>(r, n_closed_ + k) = live.at<float>(r, k);
  for (int c = n_closed_ + n_live_; c < cap && !std::isnan(tracks_.at<float>(kTrackX, c)); ++c)
    for (int r = 0; r < kTrackRows; ++r) tracks_.at<float>(r, c) = kNaNf;
}

void WorldMap::paint_tracks(const cv::Mat& t, int n, cv::Mat& ew, cv::Mat& eh) {
  if (t.empty() || t.rows < kTrackRows || t.type() != CV_32F) return;
  const double inv_res = 1.0 / p_.resolution_m, s0 = p_.sighting_radius_m, floor2 = 0.25 * s0 * s0;
  for (int k = 0; k < std::min(n, t.cols); ++k) {
    const auto v = [&](TrackRow r) { return static_cast<double>(t.at<float>(r, k)); };
    const double x = v(kTrackX), y = v(kTrackY), h = v(kTrackHeight), w = v(kTrackWidth), score = v(kTrackScore);
    const double spread2 = std::max(floor2, 0.0625 * w * w);
    const double sxx = v(kTrackSxx) + spread2, sxy = v(kTrackSxy), syy = v(kTrackSyy) + spread2;
    const double det = sxx * syy - sxy * sxy;
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(h) || !std::isfinite(w) || !(score > 0) || !(det > 0))
      continue;
    // Gaussian of the covariance, peak = score x min(1, s0^2 / sqrt(det)); reach 3 sigma.
    const double ixx = syy / det, ixy = -sxy / det, iyy = sxx / det;
    const double peak = score * std::min(1.0, s0 * s0 / std::sqrt(det));
    const double rx = 3.0 * std::sqrt(sxx), ry = 3.0 * std::sqrt(syy);
    const int j0 = std::max(0, static_cast<int>(std::floor((x - rx - ox_) * inv_res)));
    const int j1 = std::min(cols_ - 1, static_cast<int>(std::ceil((x + rx - ox_) * inv_res)));
    const int i0 = std::max(0, static_cast<int>(std::floor((y - ry - oy_) * inv_res)));
    const int i1 = std::min(rows_ - 1, static_cast<int>(std::ceil((y + ry - oy_) * inv_res)));
    for (int i = i0; i <= i1; ++i)
      for (int j = j0; j <= j1; ++j) {
        const double dx = ox_ + j * p_.resolution_m - x, dy = oy_ + i * p_.resolution_m - y;
        const double q = 0.5 * (ixx * dx * dx + 2.0 * ixy * dx * dy + iyy * dy * dy);
        if (q > 4.5) continue;
        const float e = static_cast<float>(peak * std::exp(-q));
        ew.at<float>(i, j) += e;
        eh.at<float>(i, j) += e * static_cast<float>(h);
      }
  }
}

// Normalised-convolution Gaussian (three box passes) of `src` with weights `w` (0 = unknown).
void WorldMap::smooth_known(const cv::Mat& src, const cv::Mat& w, cv::Mat& dst, double sigma_cells) {
  const int k =
      std::max(1, static_cast<int>(std::lround((std::sqrt(4.0 * sigma_cells * sigma_cells + 1.0) - 1.0) / 2.0)));
  // scratch2_ = src * w, scratch3_ = w; both blurred; dst = ratio.
  for (int i = 0; i < rows_; ++i)
    for (int j = 0; j < cols_; ++j) {
      const float ww = w.at<float>(i, j);
      scratch2_.at<float>(i, j) = ww > 0 ? src.at<float>(i, j) * ww : 0.0f;
      scratch3_.at<float>(i, j) = ww;
    }
  auto pass = [&](cv::Mat& m, bool along_rows) {
    const int n = along_rows ? cols_ : rows_, lines = along_rows ? rows_ : cols_;
    for (int l = 0; l < lines; ++l) {
      for (int q = 0; q < n; ++q)
        line_[static_cast<std::size_t>(q)] = along_rows ? m.at<float>(l, q) : m.at<float>(q, l);
      double acc = 0.0;
      for (int q = -k; q <= k; ++q) acc += (q >= 0 && q < n) ? line_[static_cast<std::size_t>(q)] : 0.0;
      for (int q = 0; q < n; ++q) {
        (along_rows ? m.at<float>(l, q) : m.at<float>(q, l)) = static_cast<float>(acc);
        const int add = q + k + 1, sub = q - k;
        if (add < n) acc += line_[static_cast<std::size_t>(add)];
        if (sub >= 0) acc -= line_[static_cast<std::size_t>(sub)];
      }
    }
  };
  for (int rep = 0; rep < 3; ++rep)
    for (cv::Mat* m : {&scratch2_, &scratch3_}) pass(*m, true), pass(*m, false);
  for (int i = 0; i < rows_; ++i)
    for (int j = 0; j < cols_; ++j) {
      const float ww = scratch3_.at<float>(i, j);
      dst.at<float>(i, j) = ww > 1e-6f ? scratch2_.at<float>(i, j) / ww : kNaNf;
    }
}

void WorldMap::finish() {
  cv::Mat& el = layers_[kElevation];
  cv::Mat& var = layers_[kVariance];
  cv::Mat& conf = layers_[kConfidence];
  cv::Mat& cnt = layers_[kCount];
  const double s0 = p_.observation_sigma_m * p_.observation_sigma_m;
  for (int i = 0; i < rows_; ++i)
    for (int j = 0; j < cols_; ++j) {
      const double w = wsum_.at<double>(i, j);
      const bool known = w > p_.min_weight;
      el.at<float>(i, j) = known ? static_cast<float>(mean_.at<double>(i, j)) : kNaNf;
      var.at<float>(i, j) = known ? static_cast<float>(m2_.at<double>(i, j) / w + s0 / w) : kNaNf;
      conf.at<float>(i, j) = known ? static_cast<float>(1.0 - std::exp(-w / p_.weight_full)) : 0.0f;
      const float n = count_.at<float>(i, j);
      cnt.at<float>(i, j) = n > 0 ? n : kNaNf;
    }
  median_of_known(el);
  // Small holes (cells up to ~fill_radius from seen ones: behind a rock, between two looks): how
  // near they are to seen cells (the smoothed confidence), for the fill below.
  if (p_.fill_radius_m > 0) {
    smooth_known(el, conf, scratch_, 0.5 * p_.fill_radius_m / p_.resolution_m);
    for (int i = 0; i < rows_; ++i)
      for (int j = 0; j < cols_; ++j)
        fill_w_.at<float>(i, j) = std::isfinite(el.at<float>(i, j)) ? 0.0f : scratch3_.at<float>(i, j);
  }
  // Relief above the smoothed local ground, and the hazard it makes: both from the cells seen
  // well enough (hazard_min_weight); a cell seen less has an elevation but no relief.
  for (int i = 0; i < rows_; ++i)
    for (int j = 0; j < cols_; ++j)
      ground_w_.at<float>(i, j) = wsum_.at<double>(i, j) > p_.hazard_min_weight ? conf.at<float>(i, j) : 0.0f;
  smooth_known(el, ground_w_, scratch_, p_.ground_sigma_m / p_.resolution_m);
  // A hole near seen cells takes the local ground there (not its neighbours' heights: the cells
  // hidden behind a rock would take the rock's top), with a lowered confidence; no relief or
  // hazard of its own (its ground weight stays 0).
  if (p_.fill_radius_m > 0)
    for (int i = 0; i < rows_; ++i)
      for (int j = 0; j < cols_; ++j) {
        const float w = fill_w_.at<float>(i, j), z = scratch_.at<float>(i, j);
        if (!(w > p_.fill_min_weight) || !std::isfinite(z)) continue;
        el.at<float>(i, j) = z;
        var.at<float>(i, j) = static_cast<float>(s0 / p_.fill_min_weight);
        conf.at<float>(i, j) = std::min(0.5f * w, 0.5f);
      }
  traversability::compute_layers(trav_, p_.traversability, trav_ws_);
  cv::Mat& relief = layers_[kRelief];
  cv::Mat& hazard = layers_[kHazard];
  cv::Mat& shadow = layers_[kShadow];
  // Caster heights spread over their neighbourhood (max filter of radius shadow_spread_m).
  const int sr = static_cast<int>(std::lround(p_.shadow_spread_m / p_.resolution_m));
  for (int i = 0; i < rows_; ++i)
    for (int j = 0; j < cols_; ++j) {
      float best = kNaNf;
      for (int a = std::max(0, i - sr); a <= std::min(rows_ - 1, i + sr); ++a)
        for (int b = std::max(0, j - sr); b <= std::min(cols_ - 1, j + sr); ++b)
          if (shadow_w_.at<float>(a, b) > 0.0f && (a - i) * (a - i) + (b - j) * (b - j) <= sr * sr &&
              !(best >= shadow_h_.at<float>(a, b)))
            best = shadow_h_.at<float>(a, b);
      shadow.at<float>(i, j) = best;
    }
  cv::Mat& ev_layer = layers_[kEvidence];
  cv::Mat& rock_h = layers_[kRockHeight];
  for (int i = 0; i < rows_; ++i)
    for (int j = 0; j < cols_; ++j) {
      const float e = evidence(i, j);
      ev_layer.at<float>(i, j) = e > 0.0f ? e : kNaNf;
      rock_h.at<float>(i, j) = e >= p_.rock_min_evidence ? evidence_height(i, j) / e : kNaNf;
    }
  for (int i = 0; i < rows_; ++i)
    for (int j = 0; j < cols_; ++j) {
      const float z = el.at<float>(i, j), g = scratch_.at<float>(i, j);
      const bool seen_enough = ground_w_.at<float>(i, j) > 0.0f;
      const float r = (seen_enough && std::isfinite(z) && std::isfinite(g)) ? z - g : kNaNf;
      relief.at<float>(i, j) = r;
      // Hazard = probability of an obstacle of hazard_height_m here: a noisy-OR of the cues, each
      // an independent chance of one: rocks sighted here (1 - exp(-evidence / scale), times their
      // mean sighted height over hazard_height_m), a cast shadow's caster height, and the parallax
      // relief, a weak cue on its own (hazard_relief_weight at full height, times the cell's
      // confidence: a relief from one faint look says less than one seen often and near). NaN
      // where no cue saw it.
      const float ev = evidence(i, j), sh = shadow.at<float>(i, j);
      if (!std::isfinite(r) && !(ev > 0.0f) && !std::isfinite(sh)) {
        hazard.at<float>(i, j) = kNaNf;
        continue;
      }
      const auto frac = [&](double height) { return std::clamp(height / p_.hazard_height_m, 0.0, 1.0); };
      const double p_sight =
          ev > 0.0f ? (1.0 - std::exp(-ev / p_.hazard_evidence_scale)) * frac(evidence_height(i, j) / ev) : 0.0;
      const double p_shadow = std::isfinite(sh) ? frac(sh) : 0.0;
      const double p_relief = std::isfinite(r) ? p_.hazard_relief_weight * conf.at<float>(i, j) * frac(r) : 0.0;
      hazard.at<float>(i, j) = static_cast<float>(1.0 - (1.0 - p_sight) * (1.0 - p_shadow) * (1.0 - p_relief));
    }
  blur_known(hazard);
}

void WorldMap::median_of_known(cv::Mat& el) {
  // whole cells, at most kMaxMedianRadius (a finer map than the metric size asks for gets the
  // largest window there is)
  const int r =
      static_cast<int>(std::min<long>(kMaxMedianRadius, std::lround(p_.elevation_median_m / p_.resolution_m)));
  if (r < 1) return;
  std::array<float, (2 * kMaxMedianRadius + 1) * (2 * kMaxMedianRadius + 1)> v{};
  for (int i = 0; i < rows_; ++i)
    for (int j = 0; j < cols_; ++j) {
      float& out = scratch_.at<float>(i, j);
      out = el.at<float>(i, j);
      if (!std::isfinite(out)) continue;
      std::size_t n = 0;
      for (int a = std::max(0, i - r); a <= std::min(rows_ - 1, i + r); ++a)
        for (int b = std::max(0, j - r); b <= std::min(cols_ - 1, j + r); ++b)
          if (const float z = el.at<float>(a, b); std::isfinite(z)) v[n++] = z;
      const auto mid = v.begin() + static_cast<std::ptrdiff_t>(n / 2);
      std::nth_element(v.begin(), mid, v.begin() + static_cast<std::ptrdiff_t>(n));
      out = *mid;
    }
  scratch_.copyTo(el);
}

void WorldMap::blur_known(cv::Mat& hazard) {
  const double sigma = std::min(kMaxBlurSigma, p_.hazard_blur_m / p_.resolution_m);  // cells, capped
  if (!(sigma > 0)) return;
  constexpr int kMaxR = static_cast<int>(2.0 * kMaxBlurSigma);
  const int r = std::min(kMaxR, static_cast<int>(std::ceil(2.0 * sigma - 1e-9)));
  std::array<double, 2 * kMaxR + 1> g{};
  for (int q = -r; q <= r; ++q) g[static_cast<std::size_t>(q + r)] = std::exp(-0.5 * q * q / (sigma * sigma));
  // Normalised convolution: the known cells' hazard (A) and their indicator (B), blurred along
  // the rows in place, then down the columns straight into the ratio, row by row (line_ and
  // line_w_ hold one output row's sums).
  cv::Mat& A = scratch2_;
  cv::Mat& B = scratch3_;
  for (int i = 0; i < rows_; ++i) {
    const float* hp = hazard.ptr<float>(i);
    float* ap = A.ptr<float>(i);
    float* bp = B.ptr<float>(i);
    for (int j = 0; j < cols_; ++j) {
      const bool known = std::isfinite(hp[j]);
      ap[j] = known ? hp[j] : 0.0f;
      bp[j] = known ? 1.0f : 0.0f;
    }
    for (float* row : {ap, bp}) {
      std::copy(row, row + cols_, line_.begin());
      for (int q = 0; q < cols_; ++q) {
        double acc = 0.0;
        for (int t = std::max(-r, -q); t <= std::min(r, cols_ - 1 - q); ++t)
          acc += g[static_cast<std::size_t>(t + r)] * line_[static_cast<std::size_t>(q + t)];
        row[q] = static_cast<float>(acc);
      }
    }
  }
  for (int i = 0; i < rows_; ++i) {
    std::fill(line_.begin(), line_.begin() + cols_, 0.0);
    std::fill(line_w_.begin(), line_w_.begin() + cols_, 0.0);
    for (int a = std::max(-r, -i); a <= std::min(r, rows_ - 1 - i); ++a) {
      const double ga = g[static_cast<std::size_t>(a + r)];
      const float* ap = A.ptr<float>(i + a);
      const float* bp = B.ptr<float>(i + a);
      for (int j = 0; j < cols_; ++j) {
        line_[static_cast<std::size_t>(j)] += ga * ap[j];
        line_w_[static_cast<std::size_t>(j)] += ga * bp[j];
      }
    }
    float* hp = hazard.ptr<float>(i);
    for (int j = 0; j < cols_; ++j)
      if (std::isfinite(hp[j]))
        hp[j] = static_cast<float>(
            std::clamp(line_[static_cast<std::size_t>(j)] / line_w_[static_cast<std::size_t>(j)], 0.0, 1.0));
  }
}

std::vector<MapRock> WorldMap::relief_rocks() const {
  // Object height per cell: the taller of relief and shadow height.
  cv::Mat relief(rows_, cols_, CV_32F);
  for (int i = 0; i < rows_; ++i)
    for (int j = 0; j < cols_; ++j) {
      const float r = layers_[kRelief].at<float>(i, j), sh = layers_[kShadow].at<float>(i, j);
      relief.at<float>(i, j) = std::isfinite(sh) && !(r >= sh) ? sh : r;
    }
  cv::Mat bin(rows_, cols_, CV_8U);
  const float thr = static_cast<float>(0.5 * p_.rock_min_height_m);
  for (int i = 0; i < rows_; ++i)
    for (int j = 0; j < cols_; ++j) bin.at<uchar>(i, j) = relief.at<float>(i, j) > thr ? 255 : 0;
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(bin, labels, stats, centroids, 8, CV_32S);
  std::vector<MapRock> out;
  std::vector<float> top(static_cast<std::size_t>(n), -1e30f);
  std::vector<cv::Point> at(static_cast<std::size_t>(n));
  const cv::Mat& conf = layers_[kConfidence];
  for (int i = 0; i < rows_; ++i)
    for (int j = 0; j < cols_; ++j) {
      const int l = labels.at<int>(i, j);
      if (l > 0 && relief.at<float>(i, j) > top[static_cast<std::size_t>(l)] &&
          (p_.rock_min_confidence <= 0 || conf.at<float>(i, j) >= p_.rock_min_confidence)) {
        top[static_cast<std::size_t>(l)] = relief.at<float>(i, j);
        at[static_cast<std::size_t>(l)] = {j, i};
      }
    }
  const double cell_area = p_.resolution_m * p_.resolution_m;
  for (int l = 1; l < n; ++l) {
    const double h = top[static_cast<std::size_t>(l)];
    const double area = stats.at<int>(l, cv::CC_STAT_AREA) * cell_area;
    if (h < p_.rock_min_height_m || area < p_.rock_min_area_m2) continue;
    MapRock r;
    const cv::Point2d c = cell_center(at[static_cast<std::size_t>(l)].y, at[static_cast<std::size_t>(l)].x);
    r.x_m = c.x;
    r.y_m = c.y;
    r.height_m = h;
    r.width_m = 2.0 * std::sqrt(area / 3.14159265358979323846);
    r.score = std::clamp(h / p_.hazard_height_m, 0.0, 1.0);
    r.cov_xx = r.cov_yy = 0.25 * p_.resolution_m * p_.resolution_m;
    out.push_back(r);
  }
  return out;
}

std::vector<MapRock> WorldMap::rocks() const {
  std::vector<MapRock> out;
  out.reserve(max_rock_candidates());
  rocks(out);
  return out;
}

std::size_t WorldMap::rocks(std::vector<MapRock>& out) const {
  out.clear();
  if (p_.rocks_from_relief)
    for (const MapRock& r : relief_rocks()) out.push_back(r);
  // Rocks tracked across frames: enough frames, evidence and height, inside the window.
  const double x0 = ox_ - 0.5 * p_.resolution_m, y0 = oy_ - 0.5 * p_.resolution_m;
  for (int k = 0; k < n_closed_ + n_live_; ++k) {
    const auto v = [&](TrackRow r) { return static_cast<double>(tracks_.at<float>(r, k)); };
    MapRock r;
    r.x_m = v(kTrackX);
    r.y_m = v(kTrackY);
    r.height_m = v(kTrackHeight);
    r.width_m = v(kTrackWidth);
    const double e = v(kTrackScore);
    if (!(v(kTrackFrames) >= p_.rock_min_frames) || !(e >= p_.rock_min_evidence) ||
        !(r.height_m >= p_.rock_min_height_m) ||
        !(r.x_m >= x0 && r.x_m < x0 + cols_ * p_.resolution_m && r.y_m >= y0 && r.y_m < y0 + rows_ * p_.resolution_m))
      continue;
    r.score = std::clamp(r.height_m / p_.hazard_height_m, 0.0, 1.0) * std::min(1.0, e / (2.0 * p_.rock_min_evidence));
    r.cov_xx = v(kTrackPosXx);
    r.cov_xy = v(kTrackPosXy);
    r.cov_yy = v(kTrackPosYy);
    r.id = std::isfinite(v(kTrackId)) ? std::lround(v(kTrackId)) : 0;
    out.push_back(r);
  }
  // One rock per place: the strongest of those closer than rock_merge_m (kept in place, in front),
  // under the oldest track number among them, so that a rock whose track was lost and reopened (or
  // that a second track also holds) keeps the number it was first reported with.
  std::sort(out.begin(), out.end(), [](const MapRock& a, const MapRock& b) { return a.score > b.score; });
  const auto older = [](long a, long b) { return a > 0 && (b <= 0 || a < b); };
  std::size_t kept = 0;
  for (std::size_t k = 0; k < out.size(); ++k) {
    std::size_t m = 0;
    while (m < kept && !(std::hypot(out[k].x_m - out[m].x_m, out[k].y_m - out[m].y_m) < p_.rock_merge_m)) ++m;
    if (m == kept)
      out[kept++] = out[k];
    else if (older(out[k].id, out[m].id))
      out[m].id = out[k].id;
  }
  out.resize(kept);
  return kept;
}

}  // namespace regolith::mapping
