#include "regolith/traversability/traversability.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

#include "regolith/common/fill.hpp"
#include "regolith/core/error.hpp"

namespace regolith::traversability {
namespace {

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw FieldError("traversability", field, why);
}

using common::fill;

void check_pos(double v, const char* name) {
  if (!std::isfinite(v) || v <= 0) fail(name, "must be > 0");
}

// (Re)shapes `out` for the parameters; allocates only when the geometry changes.
void ensure_grid(GridMap& out, const TraversabilityParams& p, int nx, int ny) {
  out.resolution_m = p.resolution_m;
  out.length_x_m = nx * p.resolution_m;
  out.length_y_m = ny * p.resolution_m;
  out.center_x_m = p.center_x_m;
  out.center_y_m = p.center_y_m;
  const auto& names = layer_names();
  if (out.layers != names) out.layers = names;
  if (out.data.size() != names.size()) out.data.resize(names.size());
  for (auto& m : out.data) m.create(nx, ny, CV_32F);
}

}  // namespace

std::size_t GridMap::layer_index(std::string_view name) const {
  for (std::size_t k = 0; k < layers.size(); ++k)
    if (layers[k] == name) return k;
  throw std::out_of_range("traversability: GridMap has no layer '" + std::string(name) + "'");
}

void export_column_major(const GridMap& map, std::size_t k, float* out, std::size_t n) {
  if (k >= map.data.size()) fail("layer", "index " + std::to_string(k) + " out of range");
  const cv::Mat& m = map.data[k];
  if (m.type() != CV_32FC1) fail("layer " + map.layers.at(k), "must be CV_32FC1");
  if (out == nullptr || n != m.total())
    fail("out", "buffer must hold size_x * size_y = " + std::to_string(m.total()) + " floats");
  const int rows = m.rows;
  for (int i = 0; i < rows; ++i) {
    const float* p = m.ptr<float>(i);
    for (int j = 0; j < m.cols; ++j)
      out[static_cast<std::size_t>(i) + static_cast<std::size_t>(j) * static_cast<std::size_t>(rows)] = p[j];
  }
}

std::vector<float> export_column_major(const GridMap& map, std::size_t k) {
  if (k >= map.data.size()) fail("layer", "index " + std::to_string(k) + " out of range");
  std::vector<float> v(map.data[k].total());
  export_column_major(map, k, v.data(), v.size());
  return v;
}

void TraversabilityParams::validate() const {
  check_pos(resolution_m, "resolution_m");
  check_pos(length_x_m, "length_x_m");
  check_pos(length_y_m, "length_y_m");
  if (length_x_m / resolution_m > 4096 || length_y_m / resolution_m > 4096)
    fail("length_x_m/length_y_m", "more than 4096 cells per side");
  if (!std::isfinite(center_x_m) || !std::isfinite(center_y_m)) fail("center_x_m/center_y_m", "must be finite");
  if (!std::isfinite(detrend_sigma_px) || detrend_sigma_px < 0) fail("detrend_sigma_px", "must be >= 0");
  if (!std::isfinite(height_gain)) fail("height_gain", "must be finite");
  check_pos(max_range_m, "max_range_m");
  if (!std::isfinite(critical_slope_rad) || critical_slope_rad <= 0 || critical_slope_rad >= CV_PI / 2)
    fail("critical_slope_rad", "must be in (0, pi/2)");
  check_pos(critical_step_m, "critical_step_m");
  check_pos(critical_roughness_m, "critical_roughness_m");
  check_pos(slope_radius_m, "slope_radius_m");
  check_pos(step_radius_m, "step_radius_m");
  for (double w : {weight_slope, weight_step, weight_roughness})
    if (!std::isfinite(w) || w < 0) fail("weight_slope/weight_step/weight_roughness", "must be >= 0");
  if (!(weight_slope + weight_step + weight_roughness > 0))
    fail("weight_slope/weight_step/weight_roughness", "at least one must be > 0");
  check_pos(full_confidence_points, "full_confidence_points");
  check_pos(rectify_resolution_m, "rectify_resolution_m");
  if (length_x_m / rectify_resolution_m > 4096 || length_y_m / rectify_resolution_m > 4096)
    fail("rectify_resolution_m", "more than 4096 rectified cells per side");
  if (!std::isfinite(ground_detrend_sigma_m) || ground_detrend_sigma_m < 0)
    fail("ground_detrend_sigma_m", "must be >= 0");
  try {
    ground_sfs.validate();
  } catch (const std::invalid_argument& e) {
    fail("ground_sfs", e.what());
  }
}

TraversabilityMapper::TraversabilityMapper(const direct_depth::DirectDepth& depth, const TraversabilityParams& params)
    : depth_(depth), p_((params.validate(), params)), ground_solver_(p_.ground_sfs) {
  nx_ = static_cast<int>(std::lround(p_.length_x_m / p_.resolution_m));
  ny_ = static_cast<int>(std::lround(p_.length_y_m / p_.resolution_m));
  nx_ = std::max(nx_, 1);
  ny_ = std::max(ny_, 1);
  const cv::Size sz(depth_.model().width, depth_.model().height);
  metric_.create(sz, CV_32F);
  blur_.create(sz, CV_32F);
  tmp_.create(sz, CV_32F);
  sum_.create(nx_, ny_, CV_64F);
  count_.create(nx_, ny_, CV_32F);

  // Ground rectification over the map's extent (rows along -x, columns along -y, as the grid).
  direct_depth::RectifiedGrid rg;
  rg.resolution_m = p_.rectify_resolution_m;
  rg.rows = std::max(1, static_cast<int>(std::lround(nx_ * p_.resolution_m / rg.resolution_m)));
  rg.cols = std::max(1, static_cast<int>(std::lround(ny_ * p_.resolution_m / rg.resolution_m)));
  rg.x_far_m = p_.center_x_m + 0.5 * nx_ * p_.resolution_m;
  rg.y_left_m = p_.center_y_m + 0.5 * ny_ * p_.resolution_m;
  rg.max_range_m = p_.max_range_m;
  rectifier_.emplace(depth_, rg);
  const int rx = rg.rows, ry = rg.cols;
  rect_gray_.create(rx, ry, CV_8U);
  rect_height_.create(rx, ry, CV_32F);
  rect_blur_.create(rx, ry, CV_32F);
  rect_mask_.create(rx, ry, CV_8U);
  line_.assign(static_cast<std::size_t>(std::max({sz.width, sz.height, rx, ry})), 0.0);
  column_sums_.assign(line_.size(), 0.0);
  plane_.assign(static_cast<std::size_t>(std::max(sz.area(), rx * ry)), 0.0);
}

void TraversabilityMapper::check_image(const cv::Mat& m, const cv::Mat& valid, const char* what) const {
  const cv::Size sz(depth_.model().width, depth_.model().height);
  if (m.empty()) fail(what, "empty image");
  if (m.type() != CV_32FC1) fail(what, "must be CV_32FC1");
  if (m.size() != sz)
    fail(what, "size " + std::to_string(m.cols) + "x" + std::to_string(m.rows) + " differs from the camera model " +
                   std::to_string(sz.width) + "x" + std::to_string(sz.height));
  if (!valid.empty() && (valid.type() != CV_8UC1 || valid.size() != sz))
    fail("valid", "must be empty or CV_8UC1 of the image size");
}

cv::Vec3d sun_in_body(const direct_depth::CameraModel& m, const ImageLight& l) {
  // Sun in the image frame (x right, y down, z towards the viewer) -> optical (z forward) ->
  // body (x forward, y left, z up), with the rotation conventions of direct_depth.
  const cv::Vec3d s_opt(std::cos(l.tilt_rad) * std::sin(l.slant_rad), std::sin(l.tilt_rad) * std::sin(l.slant_rad),
                        -std::cos(l.slant_rad));
  const double cr = std::cos(m.roll_rad), sr = std::sin(m.roll_rad);
  const cv::Matx33d roll(cr, -sr, 0, sr, cr, 0, 0, 0, 1);
  const cv::Matx33d b0(0, 0, 1, -1, 0, 0, 0, -1, 0);
  const double ca = std::cos(m.pitch_rad), sa = std::sin(m.pitch_rad);
  const cv::Matx33d pitch(ca, 0, sa, 0, 1, 0, -sa, 0, ca);
  return pitch * b0 * roll * s_opt;
}

ImageLight image_light(const direct_depth::CameraModel& m, const cv::Vec3d& sun_body) {
  // The rotation of sun_in_body transposed: body -> image frame.
  const double cr = std::cos(m.roll_rad), sr = std::sin(m.roll_rad);
  const cv::Matx33d roll(cr, -sr, 0, sr, cr, 0, 0, 0, 1);
  const cv::Matx33d b0(0, 0, 1, -1, 0, 0, 0, -1, 0);
  const double ca = std::cos(m.pitch_rad), sa = std::sin(m.pitch_rad);
  const cv::Matx33d pitch(ca, 0, sa, 0, 1, 0, -sa, 0, ca);
  const double n = cv::norm(sun_body);
  const cv::Vec3d s = (pitch * b0 * roll).t() * (n > 0 ? sun_body / n : sun_body);
  return {std::acos(std::clamp(-s[2], -1.0, 1.0)), std::atan2(s[1], s[0])};
}

double sun_elevation(const direct_depth::CameraModel& m, const ImageLight& l) {
  return std::asin(std::clamp(sun_in_body(m, l)[2], -1.0, 1.0));
}

ImageLight ground_light(const direct_depth::CameraModel& m, const ImageLight& l) {
  const cv::Vec3d s = sun_in_body(m, l);
  if (!(s[2] > 0.0)) return {std::numeric_limits<double>::quiet_NaN(), 0.0};
  // Rectified image axes: columns = body -y, rows = body -x, third = up.
  return {std::acos(std::clamp(s[2], -1.0, 1.0)), std::atan2(-s[0], -s[1])};
}

// Three passes of a running box filter of half-width k (separable): ~Gaussian of sigma
// sqrt(3 * ((2k+1)^2 - 1) / 12). Border: clamped. Uses line_, column_sums_ and plane_ (sized in the
// constructor). The column pass runs down all columns at once, row by row (contiguous memory),
// with each column's sums in the same order as a pass along it.
void TraversabilityMapper::smooth(const cv::Mat& src, cv::Mat& dst, double sigma_px) {
  // Half-width at most 2^24 (a sigma of 1e9 px looped 2e9 times per line at configure: a hang).
  const double kd = std::round((std::sqrt(4.0 * sigma_px * sigma_px + 1.0) - 1.0) / 2.0);
  const int k = static_cast<int>(std::clamp(kd, 1.0, static_cast<double>(1 << 24)));
  src.copyTo(dst);
  const int W = dst.cols, H = dst.rows;
  const double inv = 1.0 / (2 * k + 1);
  auto row_pass = [&](float* base, int n) {
    for (int i = 0; i < n; ++i) line_[static_cast<std::size_t>(i)] = static_cast<double>(base[i]);
    double acc = 0.0;
    if (k < n) {
      for (int i = -k; i <= k; ++i) acc += line_[static_cast<std::size_t>(std::clamp(i, 0, n - 1))];
    } else {  // a window wider than the line: k clamped copies of each end plus the line, O(n)
      for (int i = 0; i < n; ++i) acc += line_[static_cast<std::size_t>(i)];
      acc += k * line_[0] + (k - n + 1) * line_[static_cast<std::size_t>(n - 1)];
    }
    // The window slides: in at i + k + 1, out at i - k, both clamped to the line; the middle run,
    // where neither clamps, without the clamps (the same sums).
    const double* l = line_.data();
    const int mid_begin = std::min(k, n), mid_end = std::max(mid_begin, n - k - 1);
    int i = 0;
    for (; i < mid_begin; ++i) {
      base[i] = static_cast<float>(acc * inv);
      acc += l[std::min(i + k + 1, n - 1)] - l[0];
    }
    for (; i < mid_end; ++i) {
      base[i] = static_cast<float>(acc * inv);
      acc += l[i + k + 1] - l[i - k];
    }
    for (; i < n; ++i) {
      base[i] = static_cast<float>(acc * inv);
      acc += l[std::min(i + k + 1, n - 1)] - l[std::max(i - k, 0)];
    }
  };
  double* acc = column_sums_.data();
  auto col = [&](int r) { return plane_.data() + static_cast<std::ptrdiff_t>(r) * W; };  // row r as doubles
  auto add_row = [&](const double* x) {
    for (int c = 0; c < W; ++c) acc[c] += x[c];
  };
  for (int rep = 0; rep < 3; ++rep) {
    for (int r = 0; r < H; ++r) row_pass(dst.ptr<float>(r), W);
    for (int r = 0; r < H; ++r) {
      const float* d = dst.ptr<float>(r);
      double* x = col(r);
      for (int c = 0; c < W; ++c) x[c] = static_cast<double>(d[c]);
    }
    std::fill(acc, acc + W, 0.0);
    if (k < H) {
      for (int i = -k; i <= k; ++i) add_row(col(std::clamp(i, 0, H - 1)));
    } else {
      for (int i = 0; i < H; ++i) add_row(col(i));
      for (int c = 0; c < W; ++c) acc[c] += k * col(0)[c] + (k - H + 1) * col(H - 1)[c];
    }
    for (int i = 0; i < H; ++i) {
      float* d = dst.ptr<float>(i);
      const double* in = col(std::min(i + k + 1, H - 1));
      const double* out = col(std::max(i - k, 0));
      for (int c = 0; c < W; ++c) {
        d[c] = static_cast<float>(acc[c] * inv);
        acc[c] += in[c] - out[c];
      }
    }
  }
}

void TraversabilityMapper::compute_from_sfs(const cv::Mat& height_px, const cv::Mat& valid, const ImageLight& light,
                                            GridMap& out) {
  check_image(height_px, valid, "height_px");
  const double el = sun_elevation(depth_.model(), light);
  if (!std::isfinite(light.slant_rad) || !std::isfinite(light.tilt_rad) || !(el > kMinSunElevationRad) ||
      !(light.slant_rad >= 0.0) || !(light.slant_rad < CV_PI / 2)) {
    fill(metric_, kNaNf);  // no usable shading: unknown everywhere
    compute_from_metric(metric_, valid, out);
    return;
  }
  if (p_.detrend_sigma_px > 0) {
    smooth(height_px, blur_, p_.detrend_sigma_px);
    for (int r = 0; r < metric_.rows; ++r) {  // plain loop: no temporaries
      const float* ph = height_px.ptr<float>(r);
      const float* pb = blur_.ptr<float>(r);
      float* pm = metric_.ptr<float>(r);
      for (int c = 0; c < metric_.cols; ++c) pm[c] = ph[c] - pb[c];
    }
  } else {
    height_px.copyTo(metric_);
  }
  // h = H * tan(slant) * tan(elevation) * L_g (see the header); L_g from the footprints.
  const double k = std::tan(light.slant_rad) * std::tan(el) * p_.height_gain;
  const double ct = std::abs(std::cos(light.tilt_rad)), st = std::abs(std::sin(light.tilt_rad));
  const cv::Mat& fl = depth_.footprint_lateral_map();
  const cv::Mat& fr = depth_.footprint_range_map();
  for (int r = 0; r < metric_.rows; ++r) {
    float* pm = metric_.ptr<float>(r);
    const float* pl = fl.ptr<float>(r);
    const float* pr = fr.ptr<float>(r);
    for (int c = 0; c < metric_.cols; ++c) {
      const double lg = std::hypot(ct * static_cast<double>(pl[c]), st * static_cast<double>(pr[c]));
      pm[c] = static_cast<float>(static_cast<double>(pm[c]) * k * lg);  // NaN where invalid
    }
  }
  compute_from_metric(metric_, valid, out);
}

void TraversabilityMapper::compute_from_image(const cv::Mat& gray, const ImageLight& light, GridMap& out) {
  const cv::Size sz(depth_.model().width, depth_.model().height);
  if (gray.empty()) fail("gray", "empty image");
  if (gray.type() != CV_8UC1) fail("gray", "must be CV_8UC1 (8-bit grey)");
  if (gray.size() != sz)
    fail("gray", "size " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                     " differs from the camera model " + std::to_string(sz.width) + "x" + std::to_string(sz.height));
  begin_grid(out);
  last_ground_light_ = ground_light(depth_.model(), light);
  // The image-frame slant may exceed 90 deg here (sun ahead of the camera): only the sun's
  // elevation above the ground matters for the rectified solve.
  const bool usable = std::isfinite(light.slant_rad) && std::isfinite(light.tilt_rad) &&
                      std::isfinite(last_ground_light_.slant_rad) && last_ground_light_.slant_rad < CV_PI / 2 - 0.01;
  fill(rect_height_, kNaNf);
  if (!usable || rectifier_->visible() < 16) {  // no usable shading or no ground in view: unknown everywhere
    fill(rect_gray_, uchar{0});
    finish_grid(out);
    return;
  }
  rectifier_->resample(gray, rect_gray_);  // precomputed table: no allocation (cv::remap allocates)
  // Cells outside the view get the median brightness of the seen ones (= flat ground for the
  // solver, whose albedo normalisation also takes the median as flat): no false edges.
  int hist[256] = {};
  for (int i = 0; i < rect_gray_.rows; ++i) {
    const uchar* g = rect_gray_.ptr<uchar>(i);
    const uchar* v = rectifier_->valid().ptr<uchar>(i);
    for (int j = 0; j < rect_gray_.cols; ++j)
      if (v[j]) ++hist[g[j]];
  }
  int median = 0;
  for (int acc = 0; median < 255 && (acc += hist[median]) * 2 < rectifier_->visible();) ++median;
  for (int i = 0; i < rect_gray_.rows; ++i) {
    uchar* g = rect_gray_.ptr<uchar>(i);
    const uchar* v = rectifier_->valid().ptr<uchar>(i);
    for (int j = 0; j < rect_gray_.cols; ++j)
      if (!v[j]) g[j] = static_cast<uchar>(median);
  }
  ground_solver_.compute(rect_gray_, sfs::LightDirection{last_ground_light_.slant_rad, last_ground_light_.tilt_rad},
                         ground_result_);
  // Heights: one unit per cell -> metres; drift removed; unknown outside the view / where masked.
  const double scale = p_.rectify_resolution_m * p_.height_gain;
  const cv::Mat& hs = ground_result_.height;
  if (p_.ground_detrend_sigma_m > 0) smooth(hs, rect_blur_, p_.ground_detrend_sigma_m / p_.rectify_resolution_m);
  for (int i = 0; i < rect_height_.rows; ++i) {
    const float* ph = hs.ptr<float>(i);
    const float* pb = p_.ground_detrend_sigma_m > 0 ? rect_blur_.ptr<float>(i) : nullptr;
    const uchar* v = rectifier_->valid().ptr<uchar>(i);
    const uchar* sv = ground_result_.valid.ptr<uchar>(i);
    float* pz = rect_height_.ptr<float>(i);
    uchar* pm = rect_mask_.ptr<uchar>(i);
    for (int j = 0; j < rect_height_.cols; ++j) {
      pm[j] = (v[j] && sv[j]) ? 255 : 0;
      if (v[j])
        pz[j] = static_cast<float>((static_cast<double>(ph[j]) - (pb ? static_cast<double>(pb[j]) : 0.0)) * scale);
    }
  }
  bin_points(rect_height_, rect_mask_, rectifier_->x_map(), rectifier_->y_map(), rectifier_->support(), out);
  finish_grid(out);
}

void TraversabilityMapper::compute_from_metric(const cv::Mat& height_m, const cv::Mat& valid, GridMap& out) {
  check_image(height_m, valid, "height_m");
  begin_grid(out);
  bin_points(height_m, valid, depth_.range_map(), depth_.lateral_map(), cv::Mat(), out);
  finish_grid(out);
}

void TraversabilityMapper::begin_grid(GridMap& out) {
  ensure_grid(out, p_, nx_, ny_);
  fill(sum_, 0.0);
  fill(count_, 0.0f);
}

void TraversabilityMapper::bin_points(const cv::Mat& z_m, const cv::Mat& valid, const cv::Mat& flat_x,
                                      const cv::Mat& flat_y, const cv::Mat& weight, GridMap& out) {
  const double h = depth_.model().mount_height_m;
  const double x0 = p_.center_x_m + 0.5 * out.length_x_m, y0 = p_.center_y_m + 0.5 * out.length_y_m;
  for (int r = 0; r < z_m.rows; ++r) {
    const float* pz = z_m.ptr<float>(r);
    const float* pr = flat_x.ptr<float>(r);
    const float* pl = flat_y.ptr<float>(r);
    const uchar* pv = valid.empty() ? nullptr : valid.ptr<uchar>(r);
    const float* pw = weight.empty() ? nullptr : weight.ptr<float>(r);
    for (int c = 0; c < z_m.cols; ++c) {
      if (pv && !pv[c]) continue;
      const double z = static_cast<double>(pz[c]);
      const double fr = static_cast<double>(pr[c]);
      if (!std::isfinite(z) || !std::isfinite(fr) || fr > p_.max_range_m) continue;
      if (z >= h) continue;  // above the camera: cannot lie on this downward ray
      const double k = 1.0 - z / h;
      const double x = fr * k, y = static_cast<double>(pl[c]) * k;
      const double fi = (x0 - x) / p_.resolution_m, fj = (y0 - y) / p_.resolution_m;
      if (!(fi >= 0 && fj >= 0 && fi < nx_ && fj < ny_)) continue;
      const int i = static_cast<int>(fi), j = static_cast<int>(fj);
      const float w = pw ? pw[c] : 1.0f;
      sum_.at<double>(i, j) += z * static_cast<double>(w);
      count_.at<float>(i, j) += w;
    }
  }
}

void TraversabilityMapper::finish_grid(GridMap& out) {
  cv::Mat& elev = out.data[0];
  cv::Mat& conf = out.data[5];
  const float full = static_cast<float>(p_.full_confidence_points);
  for (int i = 0; i < nx_; ++i)
    for (int j = 0; j < ny_; ++j) {
      const float n = count_.at<float>(i, j);
      elev.at<float>(i, j) = n > 0 ? static_cast<float>(sum_.at<double>(i, j) / static_cast<double>(n)) : kNaNf;
      conf.at<float>(i, j) = n > 0 ? std::min(1.0f, n / full) : 0.0f;
    }
  layers_from_elevation(out);
}

void TraversabilityMapper::layers_from_elevation(GridMap& out) {
  if (p_.traversability_layers) {
    compute_layers(out, p_, layer_ws_);
    return;
  }
  for (const char* name : {"traversability_slope", "traversability_roughness", "traversability_step", "traversability"})
    fill(out.data[out.layer_index(name)], kNaNf);
}

namespace {

// The half-width of the disc's row at offset di: the largest w with di^2 + w^2 <= r^2.
int disc_half_width(int r, int di) {
  const int q = r * r - di * di;
  int w = static_cast<int>(std::sqrt(static_cast<double>(q)));
  while (w * w > q) --w;
  while ((w + 1) * (w + 1) <= q) ++w;
  return w;
}

// Each row's running extreme over [j - w, j + w] (clipped to the row; NaN cells left out, an
// all-NaN window gives `none`), van Herk / Gil-Werman: blocks of 2w + 1, a forward and a backward
// scan in each, so the cost per cell does not grow with w. `better(a, b)`: a is more extreme.
template <class Better>
void sliding_row_extreme(const cv::Mat& e, int w, float none, Better better, cv::Mat& out, std::vector<float>& fwd,
                         std::vector<float>& bwd, std::vector<float>& row) {
  const int ny = e.cols, k = 2 * w + 1, len = ny + 2 * w;
  fwd.resize(static_cast<std::size_t>(len));
  bwd.resize(static_cast<std::size_t>(len));
  row.resize(static_cast<std::size_t>(len));
  for (int i = 0; i < e.rows; ++i) {
    const float* z = e.ptr<float>(i);
    for (int t = 0; t < len; ++t) {  // the row, `none` outside it and for NaN cells
      const int j = t - w;
      row[static_cast<std::size_t>(t)] = (j < 0 || j >= ny || !std::isfinite(z[j])) ? none : z[j];
    }
    const auto at = [&](int t) { return row[static_cast<std::size_t>(t)]; };
    for (int b0 = 0; b0 < len; b0 += k) {
      const int b1 = std::min(len, b0 + k) - 1;
      fwd[b0] = at(b0);
      for (int t = b0 + 1; t <= b1; ++t) {
        const float v = at(t);
        fwd[t] = better(v, fwd[t - 1]) ? v : fwd[t - 1];
      }
      bwd[b1] = at(b1);
      for (int t = b1 - 1; t >= b0; --t) {
        const float v = at(t);
        bwd[t] = better(v, bwd[t + 1]) ? v : bwd[t + 1];
      }
    }
    float* o = out.ptr<float>(i);
    for (int j = 0; j < ny; ++j) o[j] = better(bwd[j], fwd[j + k - 1]) ? bwd[j] : fwd[j + k - 1];
  }
}

// Highest and lowest finite elevation over the disc of radius r cells around every cell: the
// disc is its rows, row di spanning the columns j +- w(di); each distinct half-width's running
// row extremes are made once and folded into the rows they serve.
void disc_extremes(const cv::Mat& e, int r, LayerWorkspace& ws) {
  const float inf = std::numeric_limits<float>::infinity();
  ws.zmax.create(e.size(), CV_32F);
  ws.zmin.create(e.size(), CV_32F);
  ws.rowmax.create(e.size(), CV_32F);
  ws.rowmin.create(e.size(), CV_32F);
  fill(ws.zmax, -inf);
  fill(ws.zmin, inf);
  int made = -1;
  for (int di = 0; di <= r; ++di) {
    const int w = disc_half_width(r, di);
    if (w != made) {
      sliding_row_extreme(
          e, w, -inf, [](float a, float b) { return a > b; }, ws.rowmax, ws.block_fwd, ws.block_bwd, ws.block_row);
      sliding_row_extreme(
          e, w, inf, [](float a, float b) { return a < b; }, ws.rowmin, ws.block_fwd, ws.block_bwd, ws.block_row);
      made = w;
    }
    for (int side = 0; side < (di == 0 ? 1 : 2); ++side) {
      const int d = side == 0 ? di : -di;
      for (int i = std::max(0, -d); i < e.rows && i + d < e.rows; ++i) {
        const float* hmax = ws.rowmax.ptr<float>(i + d);
        const float* hmin = ws.rowmin.ptr<float>(i + d);
        float* zmax = ws.zmax.ptr<float>(i);
        float* zmin = ws.zmin.ptr<float>(i);
        for (int j = 0; j < e.cols; ++j) {
          zmax[j] = std::max(zmax[j], hmax[j]);
          zmin[j] = std::min(zmin[j], hmin[j]);
        }
      }
    }
  }
}

// Per row, running sums over the columns before j of (v, v j, v j^2, z, z j, z^2), v = 1 where the
// elevation is finite, z = its elevation less `zref` (0 where unknown): any row segment's sums are
// then two reads. zref, the grid's mean elevation, keeps the sums of squares well conditioned.
void row_prefix_sums(const cv::Mat& e, double zref, cv::Mat& prefix) {
  prefix.create(e.rows, e.cols + 1, CV_64FC(6));
  for (int i = 0; i < e.rows; ++i) {
    const float* z = e.ptr<float>(i);
    cv::Vec6d* P = prefix.ptr<cv::Vec6d>(i);
    P[0] = cv::Vec6d::all(0.0);
    for (int j = 0; j < e.cols; ++j) {
      cv::Vec6d add = cv::Vec6d::all(0.0);
      if (std::isfinite(z[j])) {
        const double jj = j, zz = static_cast<double>(z[j]) - zref;
        add = cv::Vec6d(1.0, jj, jj * jj, zz, zz * jj, zz * zz);
      }
      P[j + 1] = P[j] + add;
    }
  }
}

// Sums of a least-squares plane z = a + b x + c y over the known cells of a disc, with x, y the
// offsets from the disc's centre in metres.
struct PlaneSums {
  double s1 = 0, sx = 0, sy = 0, sz = 0, sxx = 0, syy = 0, sxy = 0, sxz = 0, syz = 0, szz = 0;
};

// The plane sums over the disc of radius r cells around every cell (i, j) of row i, one disc row
// di = -r..r at a time from the row prefix sums (the disc's half-widths are in `half`), for the
// whole grid row at once: `acc` holds the ten sums of each column, kPlaneSums arrays of `cols`. A
// disc row's segment with no known cell has sums of exactly 0 (equal prefix sums), so adding its
// terms adds zeros: every cell gets the same operations in the same order as a disc summed alone.
constexpr int kPlaneSums = 10;
void row_plane_sums(const cv::Mat& prefix, int i, int r, const std::vector<int>& half, double res,
                    std::vector<double>& acc) {
  const int rows = prefix.rows, cols = prefix.cols - 1;
  acc.assign(static_cast<std::size_t>(kPlaneSums) * static_cast<std::size_t>(cols), 0.0);
  double* s1 = acc.data();
  double *sx = s1 + cols, *sy = sx + cols, *sz = sy + cols, *sxx = sz + cols, *syy = sxx + cols;
  double *sxy = syy + cols, *sxz = sxy + cols, *syz = sxz + cols, *szz = syz + cols;
  for (int di = -r; di <= r; ++di) {
    const int ii = i + di;
    if (ii < 0 || ii >= rows) continue;
    const int w = half[static_cast<std::size_t>(std::abs(di))];
    const double x = di * res;
    const cv::Vec6d* P = prefix.ptr<cv::Vec6d>(ii);
    for (int j = 0; j < cols; ++j) {
      const int a = std::max(0, j - w), b = std::min(cols - 1, j + w);
      const cv::Vec6d S = P[b + 1] - P[a];
      const double jd = j;
      const double sum_dj = S[1] - jd * S[0];                          // sum of column offsets
      const double sum_dj2 = S[2] - 2.0 * jd * S[1] + jd * jd * S[0];  // of their squares
      const double sum_zdj = S[4] - jd * S[3];
      s1[j] += S[0];
      sx[j] += x * S[0];
      sy[j] += res * sum_dj;
      sz[j] += S[3];
      sxx[j] += x * x * S[0];
      syy[j] += res * res * sum_dj2;
      sxy[j] += x * res * sum_dj;
      sxz[j] += x * S[3];
      syz[j] += res * sum_zdj;
      szz[j] += S[5];
    }
  }
}

// Column j's sums out of row_plane_sums' arrays.
PlaneSums plane_sums_at(const std::vector<double>& acc, int cols, int j) {
  const auto at = [&](int k) {
    return acc[static_cast<std::size_t>(k) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(j)];
  };
  return PlaneSums{at(0), at(1), at(2), at(3), at(4), at(5), at(6), at(7), at(8), at(9)};
}

// The least-squares plane z = a + b dx + c dy from its normal equations (symmetric 3 x 3), by the
// adjugate: false when the system is singular (|det| <= 1e-18, collinear cells). Closed form
// instead of cv::solve, whose array wrapping cost more than the solve for every cell of a grid.
bool solve_plane(const PlaneSums& s, cv::Vec3d& sol) {
  const double a = s.s1, b = s.sx, c = s.sy, e = s.sxx, f = s.sxy, g = s.syy;
  const double c00 = e * g - f * f, c01 = c * f - b * g, c02 = b * f - c * e;
  const double det = a * c00 + b * c01 + c * c02;
  if (!(std::abs(det) > 1e-18)) return false;
  const double c11 = a * g - c * c, c12 = b * c - a * f, c22 = a * e - b * b;
  const double inv = 1.0 / det;
  sol[0] = (c00 * s.sz + c01 * s.sxz + c02 * s.syz) * inv;
  sol[1] = (c01 * s.sz + c11 * s.sxz + c12 * s.syz) * inv;
  sol[2] = (c02 * s.sz + c12 * s.sxz + c22 * s.syz) * inv;
  return true;
}

}  // namespace

void compute_layers(GridMap& map, const TraversabilityParams& p) {
  LayerWorkspace ws;
  compute_layers(map, p, ws);
}

void compute_layers(GridMap& map, const TraversabilityParams& p, LayerWorkspace& ws) {
  p.validate();
  const std::size_t ke = map.layer_index("elevation");
  const cv::Mat elev = map.data[ke];
  if (elev.type() != CV_32FC1) fail("elevation", "must be CV_32FC1");
  const int nx = elev.rows, ny = elev.cols;
  bool has_conf = true;
  try {
    (void)map.layer_index("confidence");
  } catch (const std::out_of_range&) {
    has_conf = false;
  }
  if (!has_conf) {
    map.layers.push_back("confidence");
    cv::Mat c(nx, ny, CV_32F);
    for (int i = 0; i < nx; ++i)
      for (int j = 0; j < ny; ++j) c.at<float>(i, j) = std::isfinite(elev.at<float>(i, j)) ? 1.0f : 0.0f;
    map.data.push_back(c);
  }
  // Create missing layers first (push_back may reallocate), then take references.
  for (const char* name :
       {"traversability_slope", "traversability_roughness", "traversability_step", "traversability"}) {
    bool found = false;
    for (std::size_t k = 0; k < map.layers.size(); ++k)
      if (map.layers[k] == name) {
        map.data[k].create(nx, ny, CV_32F);
        found = true;
      }
    if (!found) {
      map.layers.emplace_back(name);
      map.data.emplace_back(nx, ny, CV_32F);
    }
  }
  cv::Mat& ts = map.data[map.layer_index("traversability_slope")];
  cv::Mat& tr = map.data[map.layer_index("traversability_roughness")];
  cv::Mat& tst = map.data[map.layer_index("traversability_step")];
  cv::Mat& tt = map.data[map.layer_index("traversability")];
  const cv::Mat e = map.data[map.layer_index("elevation")];
  const double res = map.resolution_m;
  // Discs of radius rs (plane fit: slope, roughness) and rst (step) cells. Their sums and extremes
  // come from row prefix sums and running row extremes: the cost per cell grows with the radius,
  // not with its square (a 2 mm patch grid has discs of 50 cells: 9 s per 640x480 patch before).
  const int rs = std::max(1, static_cast<int>(std::ceil(p.slope_radius_m / res - 1e-9)));
  const int rst = std::max(1, static_cast<int>(std::ceil(p.step_radius_m / res - 1e-9)));
  ws.half.resize(static_cast<std::size_t>(rs) + 1);
  for (int di = 0; di <= rs; ++di) ws.half[static_cast<std::size_t>(di)] = disc_half_width(rs, di);
  double zsum = 0.0, zn = 0.0;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      if (const float z = e.at<float>(i, j); std::isfinite(z)) zsum += z, zn += 1.0;
  row_prefix_sums(e, zn > 0 ? zsum / zn : 0.0, ws.prefix);
  disc_extremes(e, rst, ws);
  const double wsum = p.weight_slope + p.weight_step + p.weight_roughness;
  for (int i = 0; i < nx; ++i) {
    row_plane_sums(ws.prefix, i, rs, ws.half, res, ws.plane_sums);
    for (int j = 0; j < ny; ++j) {
      const float z0 = e.at<float>(i, j);
      if (!std::isfinite(z0)) {
        ts.at<float>(i, j) = tr.at<float>(i, j) = tst.at<float>(i, j) = tt.at<float>(i, j) = kNaNf;
        continue;
      }
      // Plane z = a + b dx + c dy over the disc of radius rs (metres).
      const PlaneSums ps = plane_sums_at(ws.plane_sums, ny, j);
      float vs = kNaNf, vr = kNaNf;
      if (ps.s1 >= 3) {
        cv::Vec3d sol;
        if (solve_plane(ps, sol)) {
          const double slope = std::atan(std::sqrt(sol[1] * sol[1] + sol[2] * sol[2]));  // (no overflow here)
          // Residual sum of squares from the normal equations.
          const double ssr = ps.szz - sol[0] * ps.sz - sol[1] * ps.sxz - sol[2] * ps.syz;
          const double rough = std::sqrt(std::max(0.0, ssr) / ps.s1);
          vs = static_cast<float>(slope >= p.critical_slope_rad ? 0.0 : 1.0 - slope / p.critical_slope_rad);
          vr = static_cast<float>(rough >= p.critical_roughness_m ? 0.0 : 1.0 - rough / p.critical_roughness_m);
        }
      }
      const double step = static_cast<double>(ws.zmax.at<float>(i, j) - ws.zmin.at<float>(i, j));
      const float vst = static_cast<float>(step >= p.critical_step_m ? 0.0 : 1.0 - step / p.critical_step_m);
      ts.at<float>(i, j) = vs;
      tr.at<float>(i, j) = vr;
      tst.at<float>(i, j) = vst;
      float t = kNaNf;
      if (std::isfinite(vs) && std::isfinite(vr)) {
        // Weighted combination (ETH traversability_estimation); any critical hazard -> 0.
        if (vs <= 0.0f || vr <= 0.0f || vst <= 0.0f)
          t = 0.0f;
        else
          t = static_cast<float>((p.weight_slope * static_cast<double>(vs) + p.weight_step * static_cast<double>(vst) +
                                  p.weight_roughness * static_cast<double>(vr)) /
                                 wsum);
      }
      tt.at<float>(i, j) = t;
    }
  }
}

}  // namespace regolith::traversability
