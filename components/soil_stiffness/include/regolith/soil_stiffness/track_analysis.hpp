#pragma once
// Retrospective soil stiffness (spec algorithms.md section 5): from one rear-camera frame of the
// rover's own wheel tracks to a sinkage profile per track and Bernstein-Goriatchkin k (and n).
//
// Pipeline per frame (all buffers sized at construction):
//  1. ground-plane rectification of the configured region (range x lateral, metric grid) with the
//     flat-ground camera geometry of regolith::direct_depth (intrinsics, distortion, height, pitch,
//     roll);
//  2. albedo normalisation (median of the region = flat ground = sin(sun elevation));
//  3. SfS DTM of the region with regolith::sfs (metric heights = pixel heights x grid cell);
//  4. tracks: configured lateral positions, or troughs of the along-track mean cross-section of
//     the DTM (matched filter: shoulders minus floor, one wheel width wide);
//  5. per grid row and track: the sinkage, by default from a rendered rut cross-section fitted to
//     the image (rut_template.hpp: shading, cast shadows, perspective), else from a cross-track
//     height profile (1-D photoclinometry or the SfS DTM) against the line through both shoulders;
//  6. fits: k for fixed n (+ bootstrap std, spread over the profile), joint (k, n) when the
//     tracks carry at least two distinct loads, the reported (k, n) with a prior on n; soil class.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/common/sun.hpp"
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/soil_stiffness/rigid_wheel.hpp"
#include "regolith/soil_stiffness/rut_template.hpp"

namespace regolith::soil {

/// The rear camera: regolith::direct_depth::CameraModel (intrinsics, OpenCV distortion, mount
/// height, pitch, roll). Body frame per REP-103 with its origin on the ground below the optical
/// centre: x = range along the camera's horizontal viewing direction, y = lateral (left +), z up.
/// The one camera model of the project; the estimator projects its ground grid with
/// direct_depth::DirectDepth::project once, at construction.
using CameraModel = direct_depth::CameraModel;

/// The sun in the camera's ground frame (azimuth from the viewing direction towards the left,
/// elevation): the shared type, computed from the deployment sun by common::ground_sun().
using SunDirection = common::GroundSun;

enum class ProfileSource {
  kTemplate,         ///< rendered rut cross-sections fitted to the image (default, rut_template.hpp)
  kPhotoclinometry,  ///< 1-D Lambertian inversion of each cross-section, shadow widths where cast
  kSfsDtm,           ///< cross-sections read from the SfS DTM (regolith::sfs)
};

enum class SfsMethod { kPentland, kTsaiShah };

/// Most ruts one image is analysed for (configured or detected): a rover's wheels. Readers of a
/// track list refuse more, naming the field (100 000 configured ruts ran for minutes).
inline constexpr std::size_t kMaxTracks = 8;

/// A track to measure at a known lateral position (and optionally its own wheel load).
struct TrackSpec {
  double lateral_m = 0.0;  ///< body y of the rut centre [m]
  double load_n = 0.0;     ///< vertical load of the wheel that made it [N]; 0 = rover M g / N_w
};

struct TrackAnalysisParams {
  // region of interest on the ground
  double range_min_m = 0.8;     ///< [m]
  double range_max_m = 3.0;     ///< [m]
  double lateral_min_m = -0.8;  ///< [m] (right)
  double lateral_max_m = 0.8;   ///< [m] (left)
  double grid_res_m = 0.008;    ///< rectified cell [m]
  // tracks
  std::vector<TrackSpec> tracks;  ///< empty = automatic detection
  double track_search_m = 0.08;   ///< +- search around a configured lateral position [m]
  int max_tracks = 4;             ///< automatic detection keeps at most this many
  double min_sinkage_m = 0.004;   ///< a track must be at least this deep on average [m]
  double detection_snr = 4.0;     ///< measured mean sinkage must exceed this many standard errors [-]
  // cross-section geometry, in wheel widths b
  double floor_fraction = 0.5;      ///< central part of the rut used as floor [-]
  double shoulder_gap = 0.6;        ///< gap between the rut edge and the shoulder window [b]
  double shoulder_width = 0.6;      ///< width of each shoulder window [b]
  double profile_window_m = 0.08;   ///< along-track smoothing (box) of the profile [m]
  double presmooth_m = 0.04;        ///< along-track box filter of the brightness before inversion [m]
  double min_valid_fraction = 0.3;  ///< of the profile rows, else the track is rejected [-]
  ProfileSource profile_source = ProfileSource::kTemplate;
  RutTemplateParams rut_template;  ///< the template fit's search (profile_source kTemplate)
  double berm_offset = 0.15;       ///< berm crest beyond the rut wall's top edge / b (template) [-]
  double berm_half_width = 0.3;    ///< berm half-width / b (template) [-]
  SfsMethod sfs_method = SfsMethod::kPentland;
  int sfs_iterations = 200;       ///< Tsai-Shah only
  double min_lateral_sun = 0.2;   ///< |lateral component of the sun vector| needed (cos el sin az) [-]
  bool use_shadows = true;        ///< rows whose rut holds a measurable cast shadow take its depth [-]
  double shadow_fraction = 0.35;  ///< shadow = darker than this x the flat-ground brightness [-]
  /// Berm crest height above the surface / sinkage (the crest casts the shadow) [-]. 0.16: the
  /// value the template fit needs to read unbiased depths on the development scenes (leave-one-
  /// scene-out choice; their berms are 0.25 z high, which reads 1.5 mm shallow: README "Rut template").
  double berm_ratio = 0.16;
  double wall_slope_rad =
      0.70;  ///< rut wall slope (~ angle of repose, 40 deg): shadows are used only for a lower sun [rad]
  // fit
  double n_fixed = 1.0;  ///< sinkage exponent for the fixed-n fit [-]
  SinkageModel model = SinkageModel::kBekker;
  int bootstrap_samples = 200;  ///< 0 disables the bootstrap
  std::uint32_t seed = 12345;
  double min_load_ratio = 1.2;  ///< loads must differ by this ratio for the joint fit [-]
  // reported (k, n): the joint fit's n combined with a prior on n (k refitted for that n)
  double n_prior = 1.0;  ///< prior mean of n (Lunar Sourcebook regolith) [-]
  /// Prior standard deviation of n [-]; 0 = always n_prior. 0.12: the spread of n about 1 across
  /// the development track scenes (0.117, empirical Bayes), also what leave-one-scene-out
  /// cross-validation of this value picks (README "Measured accuracy on independent scenes").
  double n_prior_sigma = 0.12;
  double profile_sigma_m = 0.0015;  ///< systematic error of one rut's mean depth [m] (measured, README)
  // frame quality
  double max_saturated_fraction = 0.3;  ///< region cells at >= 250 DN [-]
  double max_dark_fraction = 0.3;       ///< region cells at <= 5 DN [-]
  // soil class: bearing pressure p(z_ref) = k z_ref^n
  double class_z_ref_m = 0.01;     ///< [m]
  double loose_below_pa = 4100.0;  ///< half the Lunar Sourcebook value at 1 cm [Pa]
  double firm_above_pa = 16400.0;  ///< twice the Lunar Sourcebook value at 1 cm [Pa]
  /// Throws std::invalid_argument naming the offending field.
  void validate() const;
};

enum class SoilClass { kUnknown, kLoose, kNominal, kFirm };
const char* to_string(SoilClass c);

struct TrackProfile {
  double lateral_m = 0.0;         ///< measured rut centre [m]
  double load_n = 0.0;            ///< wheel load used in the fit [N]
  std::vector<double> range_m;    ///< along-track positions [m] (grid rows, far to near)
  std::vector<double> sinkage_m;  ///< smoothed sinkage [m], NaN where not measurable
  double mean_sinkage_m = 0.0;
  double std_sinkage_m = 0.0;
  int samples = 0;       ///< valid profile samples
  double k_fixed = 0.0;  ///< k of this track alone with n fixed [N/m^(n+2)]
};

struct SoilEstimate {
  bool ok = false;
  std::string reason;    ///< why there is no estimate (empty when ok)
  std::string rejected;  ///< ruts not used (configured but too weak, shallow troughs), each with its reason
  std::vector<TrackProfile> tracks;
  double mean_sinkage_m = 0.0;  ///< over all valid samples of all tracks [m]
  int samples_used = 0;
  // fixed n
  double n_fixed = 1.0;
  double k_fixed = 0.0;       ///< [N/m^(n+2)]
  double k_fixed_std = 0.0;   ///< bootstrap std [N/m^(n+2)]
  double k_spread_p25 = 0.0;  ///< 25th / 75th percentile of per-sample k (along-track spread)
  double k_spread_p75 = 0.0;
  // joint
  bool joint_ok = false;
  std::string joint_reason;
  double k_joint = 0.0, n_joint = 0.0;
  double k_joint_std = 0.0, n_joint_std = 0.0;
  // reported: n from the joint fit (its error from profile_sigma_m and the bootstrap) combined
  // with the prior on n, k fitted for that n; n_prior and the fixed-n k without a joint fit
  double k = 0.0, n = 0.0;  ///< [N/m^(n+2)], [-]
  double k_std = 0.0, n_std = 0.0;
  double n_data_std = 0.0;  ///< standard deviation of the joint fit's n alone (0 = none) [-]
  // class and diagnostics
  SoilClass soil_class = SoilClass::kUnknown;
  double class_pressure_pa = 0.0;  ///< p(z_ref) used for the class [Pa]
  int sfs_iterations = 0;
};

/// Per-frame estimator with a workspace sized at construction. Real time: once warm (the same
/// `out` object passed again, at most as many tracks as seen before) estimate() does no heap
/// allocation, including the no-estimate paths (reasons are formatted into reserved strings);
/// OpenCV is called only in its dst-argument forms on pre-sized buffers.
class SoilStiffnessEstimator {
 public:
  /// Validates all three (std::invalid_argument naming the field) and sizes the workspace.
  SoilStiffnessEstimator(const CameraModel& camera, const RoverConfig& rover, const TrackAnalysisParams& params);
  ~SoilStiffnessEstimator();
  SoilStiffnessEstimator(const SoilStiffnessEstimator&) = delete;
  SoilStiffnessEstimator& operator=(const SoilStiffnessEstimator&) = delete;

  /// image: CV_8UC1 or CV_8UC3 (BGR) of the camera's size. Throws std::invalid_argument for a
  /// wrong image type/size or a bad sun; all data-dependent failures (no tracks, saturated,
  /// black) are reported in out.ok / out.reason.
  void estimate(const cv::Mat& image, const SunDirection& sun, SoilEstimate& out);

  /// Pre-allocates every buffer `out` can need (reason strings, one profile per possible track
  /// with a full-length profile), so that even the first estimate() into `out` does not allocate.
  void reserve(SoilEstimate& out);

  /// Last rectified, albedo-normalised brightness (CV_32F, rows = range far->near, cols =
  /// lateral left->right) and SfS DTM in metres (same grid).
  const cv::Mat& rectified() const;
  const cv::Mat& dtm_m() const;
  /// Grid geometry: range / lateral of cell (row, col) centres.
  double row_range_m(int row) const;
  double col_lateral_m(int col) const;

  const TrackAnalysisParams& params() const { return params_; }
  const RoverConfig& rover() const { return rover_; }
  const CameraModel& camera() const { return camera_; }

 private:
  struct Impl;
  CameraModel camera_;
  RoverConfig rover_;
  TrackAnalysisParams params_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace regolith::soil
