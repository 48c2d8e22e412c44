#include "regolith/soil_stiffness/track_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>

#include "regolith/core/error.hpp"
#include "regolith/sfs/sfs.hpp"

namespace regolith::soil {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::size_t kMessageCapacity = 512;  ///< reserved length of reason strings [chars]

[[noreturn]] void bad(const std::string& field, const std::string& what, double got) {
  std::ostringstream os;
  os << what << " (got " << got << ")";
  throw FieldError("", field, os.str());
}
void need(bool ok, const char* field, const char* what, double got) {
  if (!ok) bad(field, what, got);
}
bool finite_pos(double v) {
  return std::isfinite(v) && v > 0.0;
}

/// printf-style message into `dst` without allocating once dst has the capacity (reserved by the
/// estimator): formats into a stack buffer, then assigns.
[[gnu::format(printf, 2, 3)]] void say(std::string& dst, const char* fmt, ...) {
  char buf[kMessageCapacity];
  va_list ap;
  va_start(ap, fmt);
  std::vsnprintf(buf, sizeof buf, fmt, ap);
  va_end(ap);
  dst.assign(buf);
}
[[gnu::format(printf, 2, 3)]] void say_append(std::string& dst, const char* fmt, ...) {
  char buf[kMessageCapacity];
  va_list ap;
  va_start(ap, fmt);
  std::vsnprintf(buf, sizeof buf, fmt, ap);
  va_end(ap);
  if (dst.size() + std::strlen(buf) < dst.capacity()) dst.append(buf);  // never grow in estimate()
}

double percentile(std::vector<double>& v, double q) {
  if (v.empty()) return kNaN;
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const auto hi = std::min(v.size() - 1, lo + 1);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(lo), v.end());
  const double a = v[lo];
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(hi), v.end());
  const double b = v[hi];
  return a + (pos - static_cast<double>(lo)) * (b - a);
}

}  // namespace

const char* to_string(SoilClass c) {
  switch (c) {
    case SoilClass::kLoose: return "loose";
    case SoilClass::kNominal: return "nominal";
    case SoilClass::kFirm: return "firm";
    default: return "unknown";
  }
}

void TrackAnalysisParams::validate() const {
  need(std::isfinite(range_min_m) && range_min_m > 0, "range_min_m", "must be > 0", range_min_m);
  need(std::isfinite(range_max_m) && range_max_m > range_min_m, "range_max_m", "must be > range_min_m", range_max_m);
  need(std::isfinite(lateral_min_m), "lateral_min_m", "must be finite", lateral_min_m);
  need(std::isfinite(lateral_max_m) && lateral_max_m > lateral_min_m, "lateral_max_m", "must be > lateral_min_m",
       lateral_max_m);
  need(finite_pos(grid_res_m) && grid_res_m < 0.2, "grid_res_m", "must be in (0, 0.2) m", grid_res_m);
  const double cells = (range_max_m - range_min_m) / grid_res_m * (lateral_max_m - lateral_min_m) / grid_res_m;
  need(cells <= 4.0e6, "grid_res_m", "region too large for the grid (> 4e6 cells)", cells);
  need(cells >= 100.0, "grid_res_m", "region too small for the grid (< 100 cells)", cells);
  static_assert(kMaxTracks == 8, "the messages below say 8");
  need(tracks.size() <= kMaxTracks, "tracks", "at most 8 ruts", static_cast<double>(tracks.size()));
  for (const auto& t : tracks) {
    need(std::isfinite(t.lateral_m), "tracks[].lateral_m", "must be finite", t.lateral_m);
    need(std::isfinite(t.load_n) && t.load_n >= 0, "tracks[].load_n", "must be >= 0", t.load_n);
  }
  need(std::isfinite(track_search_m) && track_search_m >= 0, "track_search_m", "must be >= 0", track_search_m);
  need(max_tracks >= 1 && static_cast<std::size_t>(max_tracks) <= kMaxTracks, "max_tracks", "must be in [1, 8]",
       max_tracks);
  need(std::isfinite(min_sinkage_m) && min_sinkage_m >= 0, "min_sinkage_m", "must be >= 0", min_sinkage_m);
  need(std::isfinite(detection_snr) && detection_snr >= 0, "detection_snr", "must be >= 0", detection_snr);
  need(floor_fraction > 0 && floor_fraction <= 1, "floor_fraction", "must be in (0, 1]", floor_fraction);
  need(std::isfinite(shoulder_gap) && shoulder_gap >= 0, "shoulder_gap", "must be >= 0", shoulder_gap);
  need(shoulder_width > 0 && shoulder_width <= 5, "shoulder_width", "must be in (0, 5]", shoulder_width);
  need(std::isfinite(presmooth_m) && presmooth_m >= 0, "presmooth_m", "must be >= 0", presmooth_m);
  need(std::isfinite(profile_window_m) && profile_window_m >= 0, "profile_window_m", "must be >= 0", profile_window_m);
  need(min_valid_fraction >= 0 && min_valid_fraction <= 1, "min_valid_fraction", "must be in [0, 1]",
       min_valid_fraction);
  need(sfs_iterations >= 1 && sfs_iterations <= 100000, "sfs_iterations", "must be in [1, 1e5]", sfs_iterations);
  need(min_lateral_sun >= 0 && min_lateral_sun < 1, "min_lateral_sun", "must be in [0, 1)", min_lateral_sun);
  need(shadow_fraction > 0 && shadow_fraction < 1, "shadow_fraction", "must be in (0, 1)", shadow_fraction);
  need(std::isfinite(berm_ratio) && berm_ratio >= 0 && berm_ratio < 2, "berm_ratio", "must be in [0, 2)", berm_ratio);
  need(wall_slope_rad > 0 && wall_slope_rad < kPi / 2, "wall_slope_rad", "must be in (0, pi/2)", wall_slope_rad);
  rut_template.validate();
  need(std::isfinite(n_fixed) && n_fixed >= 0 && (model == SinkageModel::kBeta || n_fixed < 3.0), "n_fixed",
       "must be in [0, 3) (Bekker form) or >= 0 (Beta form)", n_fixed);
  need(bootstrap_samples >= 0 && bootstrap_samples <= 100000, "bootstrap_samples", "must be in [0, 1e5]",
       bootstrap_samples);
  need(std::isfinite(min_load_ratio) && min_load_ratio > 1.0, "min_load_ratio", "must be > 1", min_load_ratio);
  need(std::isfinite(n_prior) && n_prior > 0 && n_prior < 3, "n_prior", "must be in (0, 3)", n_prior);
  need(std::isfinite(n_prior_sigma) && n_prior_sigma >= 0, "n_prior_sigma", "must be >= 0", n_prior_sigma);
  need(std::isfinite(profile_sigma_m) && profile_sigma_m >= 0, "profile_sigma_m", "must be >= 0 m", profile_sigma_m);
  need(max_saturated_fraction >= 0 && max_saturated_fraction <= 1, "max_saturated_fraction", "must be in [0, 1]",
       max_saturated_fraction);
  need(max_dark_fraction >= 0 && max_dark_fraction <= 1, "max_dark_fraction", "must be in [0, 1]", max_dark_fraction);
  need(finite_pos(class_z_ref_m), "class_z_ref_m", "must be > 0", class_z_ref_m);
  need(finite_pos(loose_below_pa), "loose_below_pa", "must be > 0", loose_below_pa);
  need(std::isfinite(firm_above_pa) && firm_above_pa > loose_below_pa, "firm_above_pa", "must be > loose_below_pa",
       firm_above_pa);
}

// ------------------------------------------------------------------------------------------------
struct SoilStiffnessEstimator::Impl {
  const SoilStiffnessEstimator& est;  // camera, rover, parameters and grid geometry (never moves)
  struct Candidate {
    int col;
    double load;
    double score;
    bool configured;
    double configured_lateral;
  };
  int rows = 0, cols = 0;
  int track_cap = 0;  // most candidate tracks one frame can produce
  // bilinear sampling of the image at each grid cell (precomputed ground projection)
  std::vector<std::int32_t> src_x, src_y;  // top-left neighbour of the cell's pixel, -1 outside
  std::vector<float> wx, wy;               // bilinear weights of the right / lower neighbour
  cv::Mat inside;                          // CV_8U, 255 = cell projects into the image
  cv::Mat grey;                            // CV_8U image size (BGR input converted here)
  cv::Mat rect8;                           // CV_8U grid (rounded, for the frame-quality histogram)
  cv::Mat rectf;                           // CV_32F grid: bilinear brightness without re-quantisation [DN]
  cv::Mat e;                               // CV_32F normalised brightness (flat ground = sin(elevation))
  cv::Mat e_smooth;                        // e box-filtered along the track (photoclinometry input)
  cv::Mat dtm;                             // CV_32F metres
  sfs::ShapeFromShading solver;
  sfs::SfsResult sfs_out;
  std::vector<double> col_mean, score, line_h, slope, raw, shade_raw, ratios, valid_scores, column_acc;
  std::vector<double> mean_xs, cnt_xs, row_xs;
  std::vector<Candidate> cands, kept;
  std::vector<std::vector<double>> kept_raw;   // [track_cap][rows]: raw per-row sinkage (NaN invalid)
  std::vector<std::vector<double>> valid_raw;  // [track_cap]: finite raw samples (bootstrap)
  std::vector<double> ks, means, bmeans, bk, bjk, bjn;
  std::vector<SinkageSample> samples;
  std::vector<std::size_t> order;
  std::vector<TrackProfile> spare;  // profiles not in use by `out`, keeping their buffers
  std::string rejected;
  int inside_count = 0;
  std::unique_ptr<RutTemplateFit> rut;  // profile_source kTemplate
  RutLight light;
  std::vector<double> ranges;  // grid row centres [m]

  Impl(const SoilStiffnessEstimator& owner, const sfs::SfsParams& sp) : est(owner), solver(sp) {}

  /// What one estimate() carries from stage to stage.
  struct Frame {
    SunDirection sun;
    double sx = 0.0, sy = 0.0, sz = 0.0;  // unit vector to the sun (x forward, y left, z up)
    const cv::Mat* src = nullptr;         // the image in grey
    int hist[256] = {};                   // brightness histogram of the region's inside cells [DN]
    int median = 0;                       // its median: flat ground [DN]
    // a rut's cross-section in cells from its centre: floor half-width, the floor used for the
    // depth, the gap to the shoulders and the shoulders' outer edge
    int half = 1, fhalf = 0, gap = 0, reach = 0;
    int win = 1;             // profile smoothing window [rows]
    bool photoclin = false;  // profiles by cross-track photoclinometry (else from the DTM / template)
    bool shadows = false;    // cast shadows in the ruts are measured (sun lower than the walls)
    int sun_dir = 1;         // +1: columns away from the sun run towards +column
  };
  // The stages of estimate(), in order; a bool stage returns false with out.reason set when the
  // frame gives no estimate.
  Frame begin_frame(const SunDirection& sun) const;                 // sun vector, rut geometry in cells
  bool rectify(const cv::Mat& image, Frame& f, SoilEstimate& out);  // image -> ground grid (rectf, rect8)
  bool normalise(Frame& f, SoilEstimate& out);                      // frame quality; albedo-normalised e
  void solve_dtm(const Frame& f, SoilEstimate& out);                // SfS DTM of the region (dtm)
  bool find_tracks(const Frame& f, SoilEstimate& out);              // candidate rut centres (cands)
  bool measure_tracks(const Frame& f, SoilEstimate& out);           // a profile per measured rut (out.tracks)
  void fit(const Frame& f, SoilEstimate& out);                      // k, n, their spreads, the soil class
  // find_tracks / measure_tracks
  double window_mean(const std::vector<double>& v, int a, int b) const;  // finite values of v[a..b]
  void presmooth();                                                      // e -> e_smooth, box along the track
  bool cross_section(const Frame& f, int i, int j0, int j1);             // row i's heights -> line_h
  static double depth_at(const Frame& f, const std::vector<double>& v, int base, int c);  // matched filter
  double shadow_depth(const Frame& f, int i, int c) const;  // rut depth from a cast shadow (NaN: none)
  void set_rut_light(const Frame& f);                       // the template's light (flat, ambient)
  void measure_rut_template(const Frame& f, const Candidate& cd, SoilEstimate& out);
  void measure_rut_profile(const Frame& f, const Candidate& cd, SoilEstimate& out);
  void add_track(const Frame& f, const Candidate& cd, int c, int valid_rows, SoilEstimate& out);  // raw -> profile
  void keep_deepest(SoilEstimate& out);  // the max_tracks deepest, in lateral order
  // fit
  double fixed_k(const SoilEstimate& out, const std::vector<double>& depths, double n) const;
  JointFit joint(const SoilEstimate& out, const std::vector<double>& depths);
  void bootstrap(const Frame& f, SoilEstimate& out);      // spreads of k_fixed, k_joint, n_joint
  void apply_n_prior(const Frame& f, SoilEstimate& out);  // the reported k, n with the prior on n

  /// Moves every profile of `out` to the spare list (buffers kept) and resets the scalars.
  void release_tracks(SoilEstimate& out) {
    for (auto& t : out.tracks)
      if (spare.size() < spare.capacity()) spare.push_back(std::move(t));
    out.tracks.clear();
  }
  void reset(SoilEstimate& out, const TrackAnalysisParams& P) {
    release_tracks(out);
    if (out.tracks.capacity() < static_cast<std::size_t>(track_cap))
      out.tracks.reserve(static_cast<std::size_t>(track_cap));
    if (out.reason.capacity() < kMessageCapacity) out.reason.reserve(kMessageCapacity);
    if (out.joint_reason.capacity() < kMessageCapacity) out.joint_reason.reserve(kMessageCapacity);
    if (out.rejected.capacity() < kMessageCapacity) out.rejected.reserve(kMessageCapacity);
    out.ok = false;
    out.reason.clear();
    out.rejected.clear();
    out.mean_sinkage_m = 0.0;
    out.samples_used = 0;
    out.n_fixed = P.n_fixed;
    out.k_fixed = out.k_fixed_std = out.k_spread_p25 = out.k_spread_p75 = 0.0;
    out.joint_ok = false;
    out.joint_reason.clear();
    out.k_joint = out.n_joint = out.k_joint_std = out.n_joint_std = 0.0;
    out.soil_class = SoilClass::kUnknown;
    out.class_pressure_pa = 0.0;
    out.sfs_iterations = 0;
  }
  /// A profile appended to out.tracks, reusing a spare one's buffers when available.
  TrackProfile& add_profile(SoilEstimate& out) {
    if (!spare.empty()) {
      out.tracks.push_back(std::move(spare.back()));
      spare.pop_back();
    } else {
      out.tracks.emplace_back();
    }
    return out.tracks.back();
  }
};

namespace {
sfs::SfsParams make_sfs_params(const TrackAnalysisParams& p) {
  sfs::SfsParams sp;
  sp.method = p.sfs_method == SfsMethod::kPentland ? sfs::Method::kPentland : sfs::Method::kTsaiShah;
  sp.iterations = p.sfs_iterations;
  sp.normalise_albedo = false;  // done here from the flat-ground median
  sp.estimate_light = false;    // the sun is known
  return sp;
}
}  // namespace

SoilStiffnessEstimator::SoilStiffnessEstimator(const CameraModel& camera, const RoverConfig& rover,
                                               const TrackAnalysisParams& params)
    : camera_(camera), rover_(rover), params_(params) {
  rover_.validate();
  params_.validate();
  const direct_depth::DirectDepth geometry(camera_);  // validates the camera (names the field)
  impl_ = std::make_unique<Impl>(*this, make_sfs_params(params_));
  Impl& m = *impl_;
  m.rows = static_cast<int>(std::lround((params_.range_max_m - params_.range_min_m) / params_.grid_res_m));
  m.cols = static_cast<int>(std::lround((params_.lateral_max_m - params_.lateral_min_m) / params_.grid_res_m));
  const auto cells = static_cast<std::size_t>(m.rows) * static_cast<std::size_t>(m.cols);
  m.src_x.assign(cells, -1);
  m.src_y.assign(cells, -1);
  m.wx.assign(cells, 0.f);
  m.wy.assign(cells, 0.f);
  m.inside.create(m.rows, m.cols, CV_8U);
  m.inside_count = 0;
  const int W = camera_.width, H = camera_.height;
  for (int i = 0; i < m.rows; ++i) {
    for (int j = 0; j < m.cols; ++j) {
      const auto px = geometry.project(row_range_m(i), col_lateral_m(j), 0.0);
      const bool ok = px.has_value() && px->x >= 0.0 && px->y >= 0.0 && px->x <= W - 1 && px->y <= H - 1;
      m.inside.at<unsigned char>(i, j) = ok ? 255 : 0;
      if (!ok) continue;
      const auto q = static_cast<std::size_t>(i) * static_cast<std::size_t>(m.cols) + static_cast<std::size_t>(j);
      const int x0 = std::min(static_cast<int>(px->x), W - 1), y0 = std::min(static_cast<int>(px->y), H - 1);
      m.src_x[q] = x0;
      m.src_y[q] = y0;
      m.wx[q] = static_cast<float>(px->x - x0);
      m.wy[q] = static_cast<float>(px->y - y0);
      ++m.inside_count;
    }
  }
  m.ranges.resize(static_cast<std::size_t>(m.rows));
  for (int i = 0; i < m.rows; ++i) m.ranges[static_cast<std::size_t>(i)] = row_range_m(i);
  if (params_.profile_source == ProfileSource::kTemplate) {
    RutShape shape;
    shape.wall_slope_rad = params_.wall_slope_rad;
    shape.berm_ratio = params_.berm_ratio;
    shape.berm_offset = params_.berm_offset;
    shape.berm_half_width = params_.berm_half_width;
    m.rut = std::make_unique<RutTemplateFit>(camera_, rover_.wheel_width_m, shape, params_.rut_template, m.rows);
  }
  m.grey.create(H, W, CV_8U);
  m.rect8.create(m.rows, m.cols, CV_8U);
  m.rectf.create(m.rows, m.cols, CV_32F);
  m.e.create(m.rows, m.cols, CV_32F);
  m.e_smooth.create(m.rows, m.cols, CV_32F);
  m.dtm.create(m.rows, m.cols, CV_32F);
  const auto rows = static_cast<std::size_t>(m.rows), cols = static_cast<std::size_t>(m.cols);
  m.track_cap = std::max(2 * params_.max_tracks, static_cast<int>(params_.tracks.size()));
  const auto cap = static_cast<std::size_t>(m.track_cap);
  m.col_mean.resize(cols);
  m.score.resize(cols);
  m.line_h.resize(cols + 2);
  m.slope.resize(cols + 2);
  m.raw.resize(rows);
  m.shade_raw.resize(rows);
  m.ratios.reserve(rows);
  m.column_acc.resize(cols);
  m.valid_scores.reserve(cols);
  m.mean_xs.reserve(cols + 1);
  m.cnt_xs.reserve(cols + 1);
  m.row_xs.reserve(cols + 1);
  m.cands.reserve(cols + params_.tracks.size());
  m.kept.reserve(cols + params_.tracks.size());
  m.kept_raw.assign(cap, std::vector<double>(rows, kNaN));
  m.valid_raw.assign(cap, {});
  for (auto& v : m.valid_raw) v.reserve(rows);
  m.ks.reserve(rows * cap);
  m.means.reserve(cap);
  m.bmeans.reserve(cap);
  m.samples.reserve(cap);
  m.order.reserve(cap);
  const auto boot = static_cast<std::size_t>(params_.bootstrap_samples);
  m.bk.reserve(boot);
  m.bjk.reserve(boot);
  m.bjn.reserve(boot);
  m.spare.reserve(cap);
  m.rejected.reserve(kMessageCapacity);
}

SoilStiffnessEstimator::~SoilStiffnessEstimator() = default;

void SoilStiffnessEstimator::reserve(SoilEstimate& out) {
  Impl& m = *impl_;
  m.reset(out, params_);
  const auto rows = static_cast<std::size_t>(m.rows);
  while (m.spare.size() < m.spare.capacity()) {
    TrackProfile t;
    t.range_m.reserve(rows);
    t.sinkage_m.reserve(rows);
    m.spare.push_back(std::move(t));
  }
  for (auto& t : m.spare) {
    t.range_m.reserve(rows);
    t.sinkage_m.reserve(rows);
  }
}

const cv::Mat& SoilStiffnessEstimator::rectified() const {
  return impl_->e;
}
const cv::Mat& SoilStiffnessEstimator::dtm_m() const {
  return impl_->dtm;
}
double SoilStiffnessEstimator::row_range_m(int row) const {
  return params_.range_max_m - (row + 0.5) * params_.grid_res_m;
}
double SoilStiffnessEstimator::col_lateral_m(int col) const {
  return params_.lateral_max_m - (col + 0.5) * params_.grid_res_m;
}

void SoilStiffnessEstimator::estimate(const cv::Mat& image, const SunDirection& sun, SoilEstimate& out) {
  // input checks (programming/config errors -> exceptions)
  if (image.empty()) throw std::invalid_argument("image: empty frame");
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    throw std::invalid_argument("image: expected CV_8UC1 or CV_8UC3 (got type " + std::to_string(image.type()) + ")");
  if (image.cols != camera_.width || image.rows != camera_.height)
    throw std::invalid_argument("image: size " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                                " does not match camera " + std::to_string(camera_.width) + "x" +
                                std::to_string(camera_.height));
  need(std::isfinite(sun.azimuth_rad), "sun.azimuth_rad", "must be finite", sun.azimuth_rad);
  need(std::isfinite(sun.elevation_rad) && sun.elevation_rad > 0.02 && sun.elevation_rad <= kPi / 2,
       "sun.elevation_rad", "must be in (0.02, pi/2] rad", sun.elevation_rad);
  Impl& m = *impl_;
  m.reset(out, params_);
  Impl::Frame f = m.begin_frame(sun);
  // Each stage returns false with out.reason set when the frame gives no estimate.
  if (!m.rectify(image, f, out) || !m.normalise(f, out)) return;
  m.solve_dtm(f, out);
  if (!m.find_tracks(f, out) || !m.measure_tracks(f, out)) return;
  m.fit(f, out);
  out.ok = true;
}

// ---- the stages of estimate() -------------------------------------------------------------------
SoilStiffnessEstimator::Impl::Frame SoilStiffnessEstimator::Impl::begin_frame(const SunDirection& sun) const {
  const TrackAnalysisParams& P = est.params();
  Frame f;
  f.sun = sun;
  f.sz = std::sin(sun.elevation_rad);
  f.sx = std::cos(sun.elevation_rad) * std::cos(sun.azimuth_rad);
  f.sy = std::cos(sun.elevation_rad) * std::sin(sun.azimuth_rad);
  const double b = est.rover().wheel_width_m, res = P.grid_res_m;
  f.half = std::max(1, static_cast<int>(std::lround(0.5 * b / res)));
  f.fhalf = std::max(0, static_cast<int>(std::lround(0.5 * b * P.floor_fraction / res)));
  f.gap = static_cast<int>(std::lround(P.shoulder_gap * b / res));
  const int sw = std::max(2, static_cast<int>(std::lround(P.shoulder_width * b / res)));
  f.reach = f.half + f.gap + sw;
  f.win = std::max(1, static_cast<int>(std::lround(P.profile_window_m / res)));
  f.photoclin = P.profile_source == ProfileSource::kPhotoclinometry;
  // Shadows are measured only when the sun, seen in the cross-track plane, is lower than the rut
  // walls: then the wall away from the sun is in its own shadow and casts one onto the floor. With
  // a higher sun every wall is lit, and a dark run is a grazing-lit wall, not a shadow.
  f.shadows = P.use_shadows && std::abs(f.sy) > 1e-6 && std::atan2(f.sz, std::abs(f.sy)) < P.wall_slope_rad;
  f.sun_dir = f.sy > 0 ? 1 : -1;
  return f;
}

bool SoilStiffnessEstimator::Impl::rectify(const cv::Mat& image, Frame& f, SoilEstimate& out) {
  const TrackAnalysisParams& P = est.params();
  const CameraModel& camera = est.camera();
  if (static_cast<double>(inside_count) < 0.5 * rows * cols) {
    say(out.reason,
        "region of interest (range %.3g m to %.3g m, lateral %.3g m to %.3g m) is mostly outside "
        "the image",
        P.range_min_m, P.range_max_m, P.lateral_min_m, P.lateral_max_m);
    return false;
  }
  f.src = &image;
  if (image.channels() == 3) {
    for (int r = 0; r < image.rows; ++r) {
      const auto* b = image.ptr<unsigned char>(r);
      auto* g = grey.ptr<unsigned char>(r);
      for (int c = 0; c < image.cols; ++c, b += 3)  // ITU-R BT.601 luma, as cv::COLOR_BGR2GRAY
        g[c] = static_cast<unsigned char>((1868 * b[0] + 9617 * b[1] + 4899 * b[2] + 8192) >> 14);
    }
    f.src = &grey;
  }
  for (int i = 0; i < rows; ++i) {
    auto* r8 = rect8.ptr<unsigned char>(i);
    float* rf = rectf.ptr<float>(i);
    for (int j = 0; j < cols; ++j) {
      const auto q = static_cast<std::size_t>(i) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(j);
      const int x0 = src_x[q], y0 = src_y[q];
      if (x0 < 0) {
        r8[j] = 0;
        rf[j] = 0.f;
        continue;
      }
      const unsigned char* p0 = f.src->ptr<unsigned char>(y0) + x0;
      const unsigned char* p1 = f.src->ptr<unsigned char>(std::min(y0 + 1, camera.height - 1)) + x0;
      const float a = wx[q], b = wy[q];
      const int dx = x0 + 1 < camera.width ? 1 : 0;
      const float top = (1.f - a) * p0[0] + a * p0[dx];
      const float bot = (1.f - a) * p1[0] + a * p1[dx];
      rf[j] = (1.f - b) * top + b * bot;
      r8[j] = static_cast<unsigned char>(std::lround(rf[j]));
    }
  }
  return true;
}

bool SoilStiffnessEstimator::Impl::normalise(Frame& f, SoilEstimate& out) {
  const TrackAnalysisParams& P = est.params();
  std::fill(std::begin(f.hist), std::end(f.hist), 0);
  for (int i = 0; i < rows; ++i) {
    const auto* r = rect8.ptr<unsigned char>(i);
    const auto* in = inside.ptr<unsigned char>(i);
    for (int j = 0; j < cols; ++j)
      if (in[j]) ++f.hist[r[j]];
  }
  int sat = 0, dark = 0;
  for (int v = 250; v < 256; ++v) sat += f.hist[v];
  for (int v = 0; v <= 5; ++v) dark += f.hist[v];
  const double nin = inside_count;
  if (sat / nin > P.max_saturated_fraction) {
    say(out.reason, "frame saturated: %d %% of the track region at >= 250 DN", static_cast<int>(100.0 * sat / nin));
    return false;
  }
  if (dark / nin > P.max_dark_fraction) {
    say(out.reason, "frame too dark: %d %% of the track region at <= 5 DN", static_cast<int>(100.0 * dark / nin));
    return false;
  }
  int median = 0;
  for (int acc = 0; median < 256; ++median) {
    acc += f.hist[median];
    if (acc * 2 >= inside_count) break;
  }
  if (median < 10) {
    say(out.reason, "frame too dark: median brightness of the track region %d DN", median);
    return false;
  }
  f.median = median;
  const float gain = static_cast<float>(f.sz / median);
  for (int i = 0; i < rows; ++i) {
    const float* r = rectf.ptr<float>(i);
    const auto* in = inside.ptr<unsigned char>(i);
    float* ep = e.ptr<float>(i);
    for (int j = 0; j < cols; ++j) ep[j] = in[j] ? std::min(1.0f, gain * r[j]) : static_cast<float>(f.sz);
  }
  return true;
}

void SoilStiffnessEstimator::Impl::solve_dtm(const Frame& f, SoilEstimate& out) {
  // Grid frame: columns = -y (right), rows = -x (towards the camera), third axis up; the sun
  // vector in that frame is (-sy, -sx, sz).
  sfs::LightDirection sun_light;
  sun_light.slant_rad = kPi / 2 - f.sun.elevation_rad;
  sun_light.tilt_rad = std::atan2(-f.sx, -f.sy);
  solver.compute(e, sun_light, sfs_out);
  out.sfs_iterations = sfs_out.iterations;
  sfs_out.height.convertTo(dtm, CV_32F, est.params().grid_res_m);
}

double SoilStiffnessEstimator::Impl::window_mean(const std::vector<double>& v, int a, int b) const {
  double acc = 0.0;
  int n = 0;
  for (int j = std::max(0, a); j <= std::min(cols - 1, b); ++j) {
    const double x = v[static_cast<std::size_t>(j)];
    if (std::isfinite(x)) {
      acc += x;
      ++n;
    }
  }
  return n > 0 ? acc / n : kNaN;
}

bool SoilStiffnessEstimator::Impl::find_tracks(const Frame& f, SoilEstimate& out) {
  const TrackAnalysisParams& P = est.params();
  const double res = P.grid_res_m;
  const int half = f.half, fhalf = f.fhalf, gap = f.gap, reach = f.reach;
  if (2 * reach + 1 > cols) {
    say(out.reason, "region of interest narrower than one track cross-section (%.3g m)", (2 * reach + 1) * res);
    return false;
  }
  // along-track mean cross-section of the DTM (inside cells only)
  for (int j = 0; j < cols; ++j) {
    double acc = 0.0;
    int n = 0;
    for (int i = 0; i < rows; ++i) {
      if (!inside.at<unsigned char>(i, j)) continue;
      acc += dtm.at<float>(i, j);
      ++n;
    }
    col_mean[static_cast<std::size_t>(j)] = n > 0 ? acc / n : kNaN;
  }
  // matched filter: mean of both shoulders minus the floor
  valid_scores.clear();
  for (int c = 0; c < cols; ++c) {
    double s = kNaN;
    if (c - reach >= 0 && c + reach < cols) {
      const double l = window_mean(col_mean, c - reach, c - half - gap - 1);
      const double r = window_mean(col_mean, c + half + gap + 1, c + reach);
      const double fl = window_mean(col_mean, c - fhalf, c + fhalf);
      s = 0.5 * (l + r) - fl;
      if (std::isfinite(s)) valid_scores.push_back(s);
    }
    score[static_cast<std::size_t>(c)] = s;
  }
  if (valid_scores.size() < 3) {
    say(out.reason, "region of interest too small to search for tracks");
    return false;
  }
  cands.clear();
  const double default_load = est.rover().wheel_load_n();
  if (!P.tracks.empty()) {
    for (const auto& t : P.tracks) {
      const double cf = (P.lateral_max_m - t.lateral_m) / res - 0.5;
      const int c0 = static_cast<int>(std::floor(cf - P.track_search_m / res));
      const int c1 = static_cast<int>(std::ceil(cf + P.track_search_m / res));
      if (c1 < reach || c0 > cols - 1 - reach) {
        say(out.reason,
            "configured track at lateral %.3g m lies outside the region of interest (lateral "
            "%.3g m to %.3g m incl. shoulders)",
            t.lateral_m, P.lateral_min_m, P.lateral_max_m);
        return false;
      }
      int best = -1;
      double best_s = -std::numeric_limits<double>::infinity();
      for (int c = std::max(reach, c0); c <= std::min(cols - 1 - reach, c1); ++c) {
        const double s = score[static_cast<std::size_t>(c)];
        if (std::isfinite(s) && s > best_s) {
          best_s = s;
          best = c;
        }
      }
      // no trough response (e.g. the rut near the region's edge): measure at the configured place
      if (best < 0) best = std::clamp(static_cast<int>(std::lround(cf)), 0, cols - 1);
      cands.push_back({best, t.load_n > 0 ? t.load_n : default_load, best_s, true, t.lateral_m});
    }
    return true;
  }
  const double score_median = percentile(valid_scores, 0.5);
  for (auto& v : valid_scores) v = std::abs(v - score_median);
  const double score_sigma = 1.4826 * percentile(valid_scores, 0.5);
  // weak gate only: the decision is taken on the measured sinkage (depth and significance)
  const double score_threshold = std::max(0.0, score_median + 1.0 * score_sigma);
  for (int c = 1; c + 1 < cols; ++c) {
    const double s = score[static_cast<std::size_t>(c)];
    if (!std::isfinite(s) || s <= score_threshold) continue;
    const double sl = score[static_cast<std::size_t>(c - 1)];
    const double sr = score[static_cast<std::size_t>(c + 1)];
    if ((std::isfinite(sl) && sl > s) || (std::isfinite(sr) && sr >= s)) continue;
    cands.push_back({c, default_load, s, false, 0.0});
  }
  std::sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& c) { return a.score > c.score; });
  kept.clear();
  const int min_sep = 2 * half + gap;
  for (const auto& cd : cands) {
    bool clash = false;
    for (const auto& k : kept) clash = clash || std::abs(k.col - cd.col) < min_sep;
    if (!clash) kept.push_back(cd);
    if (static_cast<int>(kept.size()) >= 2 * P.max_tracks) break;
  }
  cands.assign(kept.begin(), kept.end());
  std::sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& c) { return a.col < c.col; });
  if (cands.empty()) {
    say(out.reason,
        "no wheel tracks detected: no trough in the DTM cross-section (matched-filter response "
        "never exceeds its median + 1 robust sigma)");
    return false;
  }
  return true;
}

bool SoilStiffnessEstimator::Impl::measure_tracks(const Frame& f, SoilEstimate& out) {
  const TrackAnalysisParams& P = est.params();
  if (f.photoclin && std::abs(f.sy) < P.min_lateral_sun) {
    say(out.reason,
        "sun too close to the track direction for cross-track photoclinometry (lateral component "
        "%.3f < min_lateral_sun %.3f)",
        std::abs(f.sy), P.min_lateral_sun);
    return false;
  }
  presmooth();
  rejected.clear();
  if (rut) set_rut_light(f);
  for (const auto& cd : cands) {
    if (cd.col < 0) continue;
    if (rut)
      measure_rut_template(f, cd, out);
    else
      measure_rut_profile(f, cd, out);
  }
  if (static_cast<int>(out.tracks.size()) > P.max_tracks) keep_deepest(out);
  if (out.tracks.empty()) {
    say(out.reason, "no wheel tracks detected: candidate troughs rejected:%s (min_sinkage_m %.3g mm)", rejected.c_str(),
        P.min_sinkage_m * 1e3);
    return false;
  }
  if (!rejected.empty() && rejected.size() < out.rejected.capacity()) out.rejected.assign(rejected);
  return true;
}

void SoilStiffnessEstimator::Impl::presmooth() {
  // along-track pre-smoothing before the non-linear inversion (ruts are uniform along x): a
  // vertical box filter with replicated borders, as running sums per column
  const TrackAnalysisParams& P = est.params();
  const int kh = static_cast<int>(std::lround(0.5 * P.presmooth_m / P.grid_res_m));
  if (kh < 1) {
    e.copyTo(e_smooth);
    return;
  }
  const float inv = 1.0f / static_cast<float>(2 * kh + 1);
  double* acc = column_acc.data();
  for (int j = 0; j < cols; ++j) acc[j] = 0.0;
  auto row_at = [&](int i) { return e.ptr<float>(std::clamp(i, 0, rows - 1)); };
  for (int i = -kh; i <= kh; ++i) {
    const float* r = row_at(i);
    for (int j = 0; j < cols; ++j) acc[j] += r[j];
  }
  for (int i = 0; i < rows; ++i) {
    float* o = e_smooth.ptr<float>(i);
    for (int j = 0; j < cols; ++j) o[j] = static_cast<float>(acc[j]) * inv;
    const float* add = row_at(i + kh + 1);
    const float* sub = row_at(i - kh);
    for (int j = 0; j < cols; ++j) acc[j] += add[j] - sub[j];
  }
}

bool SoilStiffnessEstimator::Impl::cross_section(const Frame& f, int i, int j0, int j1) {
  const double res = est.params().grid_res_m;
  const auto* in = inside.ptr<unsigned char>(i);
  const auto* sv = sfs_out.valid.empty() ? nullptr : sfs_out.valid.ptr<unsigned char>(i);
  for (int j = j0; j <= j1; ++j)
    if (!in[j] || (!f.photoclin && sv != nullptr && !sv[j])) return false;
  double* h = line_h.data();
  if (f.photoclin) {
    const double sy = f.sy, sz = f.sz;
    const float* ep = e_smooth.ptr<float>(i);
    // Lambert with zero along-track slope: (sz - g sy) / sqrt(1 + g^2) = e, g = dh/dy
    const double gmax = sz / std::abs(sy);  // self-shadow boundary
    for (int j = j0; j <= j1; ++j) {
      const double ev = std::clamp(static_cast<double>(ep[j]), 0.0, 1.0);
      const double a = sy * sy - ev * ev, bq = -2.0 * sy * sz, cq = sz * sz - ev * ev;
      const double g_lin = (sz - ev) / sy;
      double g = g_lin;
      if (std::abs(a) > 1e-9) {
        const double disc = std::max(0.0, bq * bq - 4.0 * a * cq);
        const double r1 = (-bq + std::sqrt(disc)) / (2.0 * a);
        const double r2 = (-bq - std::sqrt(disc)) / (2.0 * a);
        g = std::abs(r1 - g_lin) < std::abs(r2 - g_lin) ? r1 : r2;
      } else if (std::abs(bq) > 1e-12) {
        g = -cq / bq;
      }
      slope[static_cast<std::size_t>(j - j0)] = std::clamp(g, -4.0 * gmax, 4.0 * gmax);
    }
    // columns run towards -y: h(j+1) = h(j) - g * res (trapezoid)
    h[0] = 0.0;
    for (int j = j0 + 1; j <= j1; ++j) {
      const auto k = static_cast<std::size_t>(j - j0);
      h[k] = h[k - 1] - 0.5 * (slope[k - 1] + slope[k]) * res;
    }
  } else {
    const float* d = dtm.ptr<float>(i);
    for (int j = j0; j <= j1; ++j) h[j - j0] = d[j];
  }
  return true;
}

double SoilStiffnessEstimator::Impl::depth_at(const Frame& f, const std::vector<double>& v, int base, int c) {
  double s0 = 0, s1 = 0, s2 = 0, t0 = 0, t1 = 0;
  auto add = [&](int j) {
    const double x = j - c, y = v[static_cast<std::size_t>(j - base)];
    s0 += 1;
    s1 += x;
    s2 += x * x;
    t0 += y;
    t1 += x * y;
  };
  for (int j = c - f.reach; j <= c - f.half - f.gap - 1; ++j) add(j);
  for (int j = c + f.half + f.gap + 1; j <= c + f.reach; ++j) add(j);
  const double det = s0 * s2 - s1 * s1;
  if (std::abs(det) < 1e-12) return kNaN;
  const double la = (s2 * t0 - s1 * t1) / det, lb = (s0 * t1 - s1 * t0) / det;
  double acc = 0.0;
  int n = 0;
  for (int j = c - f.fhalf; j <= c + f.fhalf; ++j) {
    acc += (la + lb * (j - c)) - v[static_cast<std::size_t>(j - base)];
    ++n;
  }
  return acc / n;
}

double SoilStiffnessEstimator::Impl::shadow_depth(const Frame& f, int i, int c) const {
  const TrackAnalysisParams& P = est.params();
  const int half = f.half, gap = f.gap, sun_dir = f.sun_dir;
  const float* ep = e.ptr<float>(i);
  const auto* in = inside.ptr<unsigned char>(i);
  const float shadow_below = static_cast<float>(P.shadow_fraction * f.sz);
  auto seen = [&](int j) { return j >= 0 && j < cols && in[j] != 0; };
  const int from = c - sun_dir * (half + gap), far_floor = c + sun_dir * half;
  int jd = -1;
  for (int j = from; j != c + sun_dir; j += sun_dir) {
    if (!seen(j)) return kNaN;
    if (ep[j] < shadow_below) {
      jd = j;
      break;
    }
  }
  if (jd < 0 || !seen(jd - sun_dir) || ep[jd - sun_dir] < shadow_below) return kNaN;
  int je = jd;
  while (seen(je + sun_dir) && ep[je + sun_dir] < shadow_below) {
    je += sun_dir;
    if ((je - far_floor) * sun_dir >= 0) return kNaN;
  }
  if (!seen(je + sun_dir)) return kNaN;
  const double w = (std::abs(je - jd) + 1) * P.grid_res_m;
  return w * f.sz / std::abs(f.sy) / (1.0 + P.berm_ratio);
}

void SoilStiffnessEstimator::Impl::add_track(const Frame& f, const Candidate& cd, int c, int valid_rows,
                                             SoilEstimate& out) {
  const TrackAnalysisParams& P = est.params();
  const int win = f.win;
  const double lateral = est.col_lateral_m(c);
  if (valid_rows < std::max(3.0, P.min_valid_fraction * rows)) {
    say_append(rejected, " track at %.3g m: too few measurable rows (%d);", lateral, valid_rows);
    return;
  }
  double acc = 0.0, acc2 = 0.0;
  for (int i = 0; i < rows; ++i) {
    const double z = raw[static_cast<std::size_t>(i)];
    if (!std::isfinite(z)) continue;
    acc += z;
    acc2 += z * z;
  }
  const double mean = acc / valid_rows;
  const double sd = std::sqrt(std::max(0.0, acc2 / valid_rows - mean * mean));
  const double std_err = sd / std::sqrt(std::max(1.0, static_cast<double>(valid_rows) / win));
  if (!(mean >= P.min_sinkage_m) || mean <= 0.0 || mean < P.detection_snr * std_err) {
    if (cd.configured) {  // reported, and the other ruts still give an estimate
      say_append(rejected,
                 " no track found at configured lateral %.3g m: mean sinkage %.3g mm below "
                 "min_sinkage_m %.3g mm or not significant (%.3g standard errors, detection_snr %.3g);",
                 cd.configured_lateral, mean * 1e3, P.min_sinkage_m * 1e3, std_err > 0 ? mean / std_err : 0.0,
                 P.detection_snr);
      return;
    }
    say_append(rejected, " trough at %.3g m only %.3g mm deep;", lateral, mean * 1e3);
    return;
  }
  const std::size_t slot = out.tracks.size();  // < track_cap: one slot per candidate at most
  TrackProfile& tp = add_profile(out);
  tp.lateral_m = lateral;
  tp.load_n = cd.load;
  tp.samples = valid_rows;
  tp.mean_sinkage_m = mean;
  tp.std_sinkage_m = sd;
  // smoothed output profile
  tp.range_m.resize(static_cast<std::size_t>(rows));
  tp.sinkage_m.resize(static_cast<std::size_t>(rows));
  for (int i = 0; i < rows; ++i) {
    double a2 = 0.0;
    int n = 0;
    for (int q = std::max(0, i - win / 2); q <= std::min(rows - 1, i + win / 2); ++q) {
      const double z = raw[static_cast<std::size_t>(q)];
      if (std::isfinite(z)) {
        a2 += z;
        ++n;
      }
    }
    tp.range_m[static_cast<std::size_t>(i)] = est.row_range_m(i);
    tp.sinkage_m[static_cast<std::size_t>(i)] =
        (n * 2 >= std::min(rows, win / 2 * 2 + 1) && std::isfinite(raw[static_cast<std::size_t>(i)])) ? a2 / n : kNaN;
  }
  tp.k_fixed = stiffness_from_sinkage(tp.mean_sinkage_m, P.n_fixed, tp.load_n, est.rover().wheel_width_m,
                                      est.rover().wheel_diameter_m, P.model);
  std::copy(raw.begin(), raw.end(), kept_raw[slot].begin());
}

void SoilStiffnessEstimator::Impl::set_rut_light(const Frame& f) {
  // the light for the rendered cross-sections: flat ground = the region's median; ambient from
  // the median brightness of shadowed cells (below shadow_fraction of the flat ground)
  const int median = f.median;
  const int dark_below = static_cast<int>(est.params().shadow_fraction * median);
  int dark_n = 0;
  for (int v = 0; v < dark_below; ++v) dark_n += f.hist[v];
  light.sun = f.sun;
  light.flat_dn = median;
  light.ambient = 0.0;
  if (dark_n >= std::max(20, inside_count / 500)) {
    int v = 0;
    for (int acc = 0; v < dark_below; ++v) {
      acc += f.hist[v];
      if (2 * acc >= dark_n) break;
    }
    light.ambient = RutTemplateFit::ambient_from_shadow(v + 0.5, median, f.sun.elevation_rad);
  }
}

void SoilStiffnessEstimator::Impl::measure_rut_template(const Frame& f, const Candidate& cd, SoilEstimate& out) {
  const TrackAnalysisParams& P = est.params();
  const double nominal = cd.configured ? cd.configured_lateral : est.col_lateral_m(cd.col);
  const double centre = rut->fit(*f.src, light, nominal, ranges.data(), rows, f.win, raw.data());
  const int c = std::clamp(static_cast<int>(std::lround((P.lateral_max_m - centre) / P.grid_res_m - 0.5)), 0, cols - 1);
  int valid_rows = 0;
  for (int i = 0; i < rows; ++i) valid_rows += std::isfinite(raw[static_cast<std::size_t>(i)]) ? 1 : 0;
  if (valid_rows < std::max(3.0, P.min_valid_fraction * rows) && rut->unmeasurable_windows() > 0) {
    say_append(rejected,
               " track at %.3g m: not measurable (%d stretches fit no single depth: the rut in full "
               "shadow or deeper than max_sinkage_m %.3g m);",
               centre, rut->unmeasurable_windows(), P.rut_template.max_sinkage_m);
    return;
  }
  add_track(f, cd, c, valid_rows, out);
}

void SoilStiffnessEstimator::Impl::measure_rut_profile(const Frame& f, const Candidate& cd, SoilEstimate& out) {
  const int reach = f.reach;
  // refine the centre on the along-track mean cross-section of the measured heights
  const int search = std::max(1, f.half);
  const int ja = std::max(0, cd.col - reach - search), jb = std::min(cols - 1, cd.col + reach + search);
  mean_xs.assign(static_cast<std::size_t>(jb - ja + 1), 0.0);
  cnt_xs.assign(mean_xs.size(), 0.0);
  for (int i = 0; i < rows; ++i) {
    if (!cross_section(f, i, ja, jb)) continue;
    for (int j = ja; j <= jb; ++j) {
      mean_xs[static_cast<std::size_t>(j - ja)] += line_h[static_cast<std::size_t>(j - ja)];
      cnt_xs[static_cast<std::size_t>(j - ja)] += 1.0;
    }
  }
  int c = cd.col;
  if (cnt_xs[0] > 0) {
    for (std::size_t q = 0; q < mean_xs.size(); ++q) mean_xs[q] /= cnt_xs[q];
    double best = -std::numeric_limits<double>::infinity();
    for (int cc = std::max(ja + reach, cd.col - search); cc <= std::min(jb - reach, cd.col + search); ++cc) {
      const double d = depth_at(f, mean_xs, ja, cc);
      if (std::isfinite(d) && d > best) {
        best = d;
        c = cc;
      }
    }
  }
  const int j0 = c - reach, j1 = c + reach;
  int valid_rows = 0;
  row_xs.resize(static_cast<std::size_t>(j1 - j0 + 1));
  for (int i = 0; i < rows; ++i) {
    double& zi = raw[static_cast<std::size_t>(i)];
    zi = kNaN;
    if (!cross_section(f, i, j0, j1)) continue;
    std::copy(line_h.begin(), line_h.begin() + (j1 - j0 + 1), row_xs.begin());
    zi = depth_at(f, row_xs, j0, c);
    shade_raw[static_cast<std::size_t>(i)] = zi;
    if (f.shadows) {
      const double zs = shadow_depth(f, i, c);
      if (std::isfinite(zs)) zi = zs;  // a shadow is a measurement; shading in shadow is not
    }
    if (std::isfinite(zi)) ++valid_rows;
  }
  // Rows without a measurable shadow: their photoclinometric depth, scaled by the median ratio
  // shadow / photoclinometry of the rows of this rut that have both (the same rut, the same
  // light: shading in a partly shadowed rut under-reads by one factor).
  if (f.shadows) {
    ratios.clear();
    for (int i = 0; i < rows; ++i) {
      const double zs = raw[static_cast<std::size_t>(i)], zp = shade_raw[static_cast<std::size_t>(i)];
      if (std::isfinite(zs) && std::isfinite(zp) && zp > 0.001 && zs != zp) ratios.push_back(zs / zp);
    }
    if (static_cast<int>(ratios.size()) >= std::max(5, rows / 10)) {
      std::nth_element(ratios.begin(), ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() / 2), ratios.end());
      const double ratio = std::clamp(ratios[ratios.size() / 2], 0.5, 3.0);
      for (int i = 0; i < rows; ++i) {
        double& z = raw[static_cast<std::size_t>(i)];
        const double zp = shade_raw[static_cast<std::size_t>(i)];
        if (std::isfinite(z) && z == zp) z = zp * ratio;
      }
    }
  }
  add_track(f, cd, c, valid_rows, out);
}

void SoilStiffnessEstimator::Impl::keep_deepest(SoilEstimate& out) {
  // keep the max_tracks deepest, in their lateral order (swaps move buffers, no allocation)
  const int max_tracks = est.params().max_tracks;
  order.resize(out.tracks.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t c) { return out.tracks[a].mean_sinkage_m > out.tracks[c].mean_sinkage_m; });
  order.resize(static_cast<std::size_t>(max_tracks));
  std::sort(order.begin(), order.end());
  for (std::size_t w = 0; w < order.size(); ++w) {
    const std::size_t q = order[w];  // q >= w: ascending selection
    if (q == w) continue;
    std::swap(out.tracks[w], out.tracks[q]);
    std::swap(kept_raw[w], kept_raw[q]);
  }
  while (static_cast<int>(out.tracks.size()) > max_tracks) {
    if (spare.size() < spare.capacity()) spare.push_back(std::move(out.tracks.back()));
    out.tracks.pop_back();
  }
}

double SoilStiffnessEstimator::Impl::fixed_k(const SoilEstimate& out, const std::vector<double>& depths,
                                             double n) const {
  const TrackAnalysisParams& P = est.params();
  const double b = est.rover().wheel_width_m, D = est.rover().wheel_diameter_m;
  double num = 0.0, den = 0.0;
  for (std::size_t t = 0; t < out.tracks.size(); ++t) {
    if (!(depths[t] > 0.0)) return kNaN;
    const double w = out.tracks[t].samples;
    num += w * std::log(stiffness_from_sinkage(depths[t], n, out.tracks[t].load_n, b, D, P.model));
    den += w;
  }
  return std::exp(num / den);
}

JointFit SoilStiffnessEstimator::Impl::joint(const SoilEstimate& out, const std::vector<double>& depths) {
  const double b = est.rover().wheel_width_m, D = est.rover().wheel_diameter_m;
  samples.clear();
  for (std::size_t t = 0; t < out.tracks.size(); ++t) samples.push_back({depths[t], out.tracks[t].load_n, b, D});
  return fit_joint(samples, est.params().model, est.params().min_load_ratio);
}

void SoilStiffnessEstimator::Impl::fit(const Frame& f, SoilEstimate& out) {
  const TrackAnalysisParams& P = est.params();
  const double b = est.rover().wheel_width_m, D = est.rover().wheel_diameter_m;
  const std::size_t nt = out.tracks.size();
  means.clear();
  ks.clear();
  double all = 0.0;
  int all_n = 0;
  for (std::size_t t = 0; t < nt; ++t) {
    means.push_back(out.tracks[t].mean_sinkage_m);
    all += out.tracks[t].mean_sinkage_m * out.tracks[t].samples;
    all_n += out.tracks[t].samples;
    for (double z : kept_raw[t])
      if (std::isfinite(z) && z > 0.0)
        ks.push_back(stiffness_from_sinkage(z, P.n_fixed, out.tracks[t].load_n, b, D, P.model));
  }
  out.mean_sinkage_m = all / all_n;
  out.samples_used = all_n;
  out.k_fixed = fixed_k(out, means, P.n_fixed);
  out.k_spread_p25 = percentile(ks, 0.25);
  out.k_spread_p75 = percentile(ks, 0.75);
  const JointFit jf = joint(out, means);
  out.joint_ok = jf.ok;
  if (!jf.ok) say(out.joint_reason, "%s", jf.reason);
  out.k_joint = jf.k;
  out.n_joint = jf.n;
  if (P.bootstrap_samples > 0) bootstrap(f, out);
  apply_n_prior(f, out);
  out.class_pressure_pa = bg_pressure(out.k, out.n, P.class_z_ref_m);
  out.soil_class = out.class_pressure_pa < P.loose_below_pa  ? SoilClass::kLoose
                   : out.class_pressure_pa > P.firm_above_pa ? SoilClass::kFirm
                                                             : SoilClass::kNominal;
}

void SoilStiffnessEstimator::Impl::bootstrap(const Frame& f, SoilEstimate& out) {
  // moving-block bootstrap over each track's rows (block = smoothing window: rows are correlated)
  const TrackAnalysisParams& P = est.params();
  const std::size_t nt = out.tracks.size();
  std::mt19937 rng(P.seed);
  bk.clear();
  bjk.clear();
  bjn.clear();
  bmeans.assign(nt, 0.0);
  for (std::size_t t = 0; t < nt; ++t) {
    valid_raw[t].clear();
    for (double z : kept_raw[t])
      if (std::isfinite(z)) valid_raw[t].push_back(z);
  }
  for (int s = 0; s < P.bootstrap_samples; ++s) {
    for (std::size_t t = 0; t < nt; ++t) {
      const auto& v = valid_raw[t];
      const int nv = static_cast<int>(v.size());
      const int blk = std::min(nv, f.win);
      std::uniform_int_distribution<int> pick(0, nv - blk);
      double acc = 0.0;
      int n = 0;
      while (n < nv) {
        const int st = pick(rng);
        for (int q = 0; q < blk && n < nv; ++q, ++n) acc += v[static_cast<std::size_t>(st + q)];
      }
      bmeans[t] = acc / nv;
    }
    const double k = fixed_k(out, bmeans, P.n_fixed);
    if (std::isfinite(k)) bk.push_back(k);
    if (out.joint_ok) {
      const JointFit b2 = joint(out, bmeans);
      if (b2.ok) {
        bjk.push_back(b2.k);
        bjn.push_back(b2.n);
      }
    }
  }
  auto sd = [](const std::vector<double>& v) {
    if (v.size() < 2) return 0.0;
    const double mu = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
    double a = 0.0;
    for (double x : v) a += (x - mu) * (x - mu);
    return std::sqrt(a / static_cast<double>(v.size() - 1));
  };
  out.k_fixed_std = sd(bk);
  out.k_joint_std = sd(bjk);
  out.n_joint_std = sd(bjn);
}

void SoilStiffnessEstimator::Impl::apply_n_prior(const Frame& f, SoilEstimate& out) {
  // reported (k, n): the joint fit's n weighed against the prior on n. The data's n error comes
  // from a systematic profile_sigma_m on each rut's mean depth (and its along-track standard
  // error) through the log-depth vs log-load regression, with the bootstrap spread beside it.
  const TrackAnalysisParams& P = est.params();
  const double b = est.rover().wheel_width_m, D = est.rover().wheel_diameter_m;
  const std::size_t nt = out.tracks.size();
  out.n = P.n_fixed;
  out.k = out.k_fixed;
  out.k_std = out.k_fixed_std;
  out.n_std = 0.0;
  out.n_data_std = 0.0;
  if (!out.joint_ok || !(P.n_prior_sigma > 0.0)) return;
  // per rut: x = ln(W / (b sqrt(D))) and the variance of ln(mean depth)
  auto log_load = [&](std::size_t t) { return std::log(out.tracks[t].load_n / (b * std::sqrt(D))); };
  auto log_depth_var = [&](std::size_t t) {
    const TrackProfile& tr = out.tracks[t];
    const double se = tr.std_sinkage_m / std::sqrt(std::max(1.0, static_cast<double>(tr.samples) / f.win));
    return (P.profile_sigma_m * P.profile_sigma_m + se * se) / (tr.mean_sinkage_m * tr.mean_sinkage_m);
  };
  double wsum = 0.0, swx = 0.0;
  for (std::size_t t = 0; t < nt; ++t) {
    wsum += 1.0 / log_depth_var(t);
    swx += log_load(t) / log_depth_var(t);
  }
  double sxx = 0.0;
  for (std::size_t t = 0; t < nt; ++t) {
    const double dx = log_load(t) - swx / wsum;
    sxx += dx * dx / log_depth_var(t);
  }
  const double slope_n = 2.0 / (2.0 * out.n_joint + 1.0);
  const double n_data = sxx > 0.0 ? std::sqrt(1.0 / sxx) / (slope_n * slope_n) : kNaN;
  if (!(std::isfinite(n_data) && n_data > 0.0)) return;
  const double var_d = n_data * n_data + out.n_joint_std * out.n_joint_std;
  const double var_p = P.n_prior_sigma * P.n_prior_sigma;
  const double n_post = std::clamp((out.n_joint / var_d + P.n_prior / var_p) / (1.0 / var_d + 1.0 / var_p), 0.05,
                                   P.model == SinkageModel::kBekker ? 2.9 : 10.0);
  out.n_data_std = std::sqrt(var_d);
  out.n = n_post;
  out.n_std = std::sqrt(1.0 / (1.0 / var_d + 1.0 / var_p));
  out.k = fixed_k(out, means, n_post);  // means: the ruts' mean depths
  // k's spread: the fixed-n bootstrap's relative spread and the n uncertainty at the mean depth
  const double dlnk_dn = -std::log(std::max(1e-4, out.mean_sinkage_m));
  const double rel_k = std::hypot(out.k_fixed > 0 ? out.k_fixed_std / out.k_fixed : 0.0, dlnk_dn * out.n_std);
  out.k_std = out.k * rel_k;
}

}  // namespace regolith::soil
