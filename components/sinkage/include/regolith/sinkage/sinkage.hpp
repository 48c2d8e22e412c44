#pragma once
// Real-time visual sinkage of a wheel-leg from a camera below the hub (thesis section 4.2).
//
// Image conventions: pixel x right, y down. A leg's axis angle phi is measured from straight down
// (image +y) towards image +x, so its unit axis is d = (sin phi, cos phi). For leg k and encoder
// angle theta: phi_k = rotation_direction * theta + angle_offset_rad + k * leg_spacing_rad.
// Sinkage of a leg = vertical depth (image y, converted to mm) of its axis tip below the soil
// interface; the wheel sinkage is the deepest contacting leg.
//
// Framework-free: plain structs + OpenCV. The per-frame entry point `SinkageEstimator::process`
// does no heap allocation once constructed.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/core/image_limits.hpp"

namespace regolith::sinkage {

inline constexpr std::size_t kMaxLegs = 16;
/// Longest leg in pixels: twice the largest camera side. The estimator sizes its tables by the
/// leg (a leg of 1e9 px was a std::bad_alloc at configure, not a located error).
inline constexpr double kMaxLegLengthPx = 2.0 * kMaxImageSidePx;

/// Geometry of the wheel-leg as seen in the image (calibrated once, see calibrate_from_unsunk_frame).
struct WheelGeometry {
  cv::Point2d hub_center_px{320.0, 110.0};      ///< px, centre of rotation in the image
  int leg_count = 5;                            ///< legs on the wheel (Asguard type: 5)
  double leg_spacing_rad = 1.2566370614359172;  ///< rad between neighbouring legs (2 pi / 5)
  double leg_length_px = 300.0;                 ///< px, hub centre to leg tip (thesis "plz")
  double leg_width_px = 28.0;                   ///< px, width of the leg shaft
  double hub_radius_px = 40.0;                  ///< px, legs are visible from this radius outwards
  double foot_width_px = 48.0;                  ///< px, foot width across the leg axis (0 = no foot)
  double foot_thickness_px = 10.0;              ///< px, foot extent along the axis from the tip inwards
  double angle_offset_rad = 0.0;                ///< rad, image angle of leg 0 when the encoder reads 0
  int rotation_direction = 1;                   ///< +1 or -1: sign of encoder angle in image angle

  /// Throws std::invalid_argument naming the first bad field ("WheelGeometry.leg_width_px: ...").
  void validate() const;
  /// Image angle (rad, wrapped to (-pi, pi]) of leg k for an encoder angle.
  double leg_angle(int k, double encoder_angle_rad) const;
  /// Half width (px) of the leg template at axial distance `along_px` from the hub centre.
  double half_width_at(double along_px) const;
};

enum class SegmentationMode : std::uint8_t {
  kHsv,       ///< fixed HSV colour band
  kAdaptive,  ///< Otsu threshold on blue chromaticity b - (r + g) / 2 inside the mask
  kAuto,      ///< HSV, switching to adaptive when the masked area is dark (poor light)
};

enum class TemporalFilter : std::uint8_t { kNone, kEma, kMedian };

struct SinkageParams {
  // --- colour band (HSV, OpenCV-independent units) ---
  double hue_min_deg = 195.0;  ///< deg [0, 360): blue band lower hue
  double hue_max_deg = 255.0;  ///< deg [0, 360): blue band upper hue
  double sat_min = 0.35;       ///< [0, 1] minimum saturation
  double val_min = 0.20;       ///< [0, 1] minimum value (brightness)
  SegmentationMode mode = SegmentationMode::kAuto;
  double dark_mean_value = 0.22;          ///< [0, 1] kAuto: mean V in the mask below this -> adaptive
  double adaptive_min_separation = 12.0;  ///< chroma units (8-bit): Otsu classes closer than this
                                          ///< mean "no leg colour present" (blue chroma b-(r+g)/2)
  // --- morphology ---
  int open_kernel_px = 3;   ///< px, square opening kernel (removes speckle); 1 = off
  int close_kernel_px = 5;  ///< px, square closing kernel (fills sand on legs); 1 = off
  // --- dynamic mask ---
  double contact_half_angle_rad = 0.6981317007977318;  ///< rad: legs within +-40 deg of down
  double angle_tolerance_rad = 0.10471975511965977;    ///< rad: mask sweep for misalignment (6 deg)
  double mask_margin_px = 4.0;                         ///< px: mask dilation around the template
  bool use_dynamic_mask = true;                        ///< false: segment the whole frame (the slow peer, for benches)
  bool refine_leg_angle = true;  ///< re-estimate the leg axis from its pixels (encoder misalignment)
  // --- scale ---
  double mm_per_px = 0.5;      ///< mm/px at the wheel plane
  double leg_length_mm = 0.0;  ///< mm; > 0 overrides mm_per_px with leg_length_mm / leg_length_px
  // --- decision ---
  double min_confidence = 0.3;   ///< [0, 1] below -> leg result invalid
  double min_visible_px = 12.0;  ///< px: a leg needs this much visible length
  double contact_min_mm = 0.5;   ///< mm: a leg deeper than this is "in contact"
  // --- temporal filter on the wheel sinkage ---
  TemporalFilter filter = TemporalFilter::kNone;
  double ema_alpha = 0.5;  ///< (0, 1] weight of the newest frame
  int median_window = 5;   ///< frames, 1..31

  /// Throws std::invalid_argument naming the first bad field ("SinkageParams.ema_alpha: ...").
  void validate() const;
  /// mm per px actually used for a geometry.
  double scale_mm_per_px(const WheelGeometry& g) const;
};

enum class InvalidReason : std::uint8_t {
  kNone = 0,
  kBadAngle,       ///< encoder angle NaN / infinite (stale or missing encoder data)
  kNoContactLeg,   ///< no leg inside the contact window
  kOutsideImage,   ///< the leg's template is (mostly) outside the image
  kNoLegPixels,    ///< leg colour not found / leg not visible
  kLowConfidence,  ///< template poorly explained
  kCount
};
const char* to_string(InvalidReason r);

struct LegSinkage {
  int leg = -1;                  ///< leg index k
  double encoder_angle_rad = 0;  ///< image angle predicted by the encoder
  double angle_rad = 0;          ///< image angle used (refined from pixels when enabled)
  double visible_length_px = 0;  ///< hub centre to interface along the axis
  double sinkage_px = 0;         ///< vertical depth of the tip below the interface
  double sinkage_mm = 0;
  double confidence = 0;  ///< [0, 1]
  int leg_pixels = 0;     ///< segmented pixels used
  bool valid = false;
  bool in_contact = false;
  InvalidReason reason = InvalidReason::kNone;
  cv::Point2d interface_left_px{}, interface_right_px{};  ///< line across the leg at the interface
  cv::Point2d tip_px{};                                   ///< template tip
};

struct SinkageResult {
  bool valid = false;
  double sinkage_mm = 0;       ///< wheel sinkage (temporally filtered when enabled)
  double raw_sinkage_mm = 0;   ///< this frame only
  double confidence = 0;       ///< [0, 1], 0 when invalid
  int deepest = -1;            ///< index into legs[] of the leg giving the wheel sinkage
  bool used_adaptive = false;  ///< adaptive threshold used this frame
  InvalidReason reason = InvalidReason::kNone;
  std::array<LegSinkage, kMaxLegs> legs{};
  std::size_t leg_count = 0;  ///< legs in the contact window this frame
};

struct SinkageDiagnostics {
  std::uint64_t frames = 0;
  std::uint64_t valid_frames = 0;
  std::uint64_t adaptive_frames = 0;
  std::array<std::uint64_t, static_cast<std::size_t>(InvalidReason::kCount)> frame_reasons{};
  std::array<std::uint64_t, static_cast<std::size_t>(InvalidReason::kCount)> leg_reasons{};
};

class SinkageEstimator {
 public:
  /// Validates both structs (std::invalid_argument) and allocates every buffer for `image_size`.
  SinkageEstimator(const WheelGeometry& geometry, const SinkageParams& params, cv::Size image_size);

  /// Per frame. Throws std::invalid_argument for an empty image, a type other than CV_8UC3 or a
  /// size other than the constructed one. A NaN angle or a frame without a usable leg gives an
  /// invalid result (confidence 0) with `reason` set and counted in diagnostics(). No allocation.
  void process(const cv::Mat& bgr, double wheel_angle_rad, SinkageResult& out);

  /// Clears the temporal filter.
  void reset_filter();

  const WheelGeometry& geometry() const { return geometry_; }
  const SinkageParams& params() const { return params_; }
  cv::Size image_size() const { return size_; }
  const SinkageDiagnostics& diagnostics() const { return diag_; }
  /// Dynamic mask of the last frame (CV_8U, bit k set where contact-window leg slot k may be).
  const cv::Mat& mask() const { return mask_; }
  /// Cleaned binary leg segmentation of the last frame (CV_8U, 0/255; only valid inside the mask).
  const cv::Mat& segmentation() const { return clean_; }

 private:
  struct Roi {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // half-open
    bool empty() const { return x1 <= x0 || y1 <= y0; }
  };
  Roi leg_roi(double phi) const;
  void build_mask_and_segment(int slot, double phi, const Roi& roi, const cv::Mat& bgr, bool segment);
  void threshold_adaptive(const Roi& roi);
  void morphology(const Roi& roi, const cv::Mat& src, cv::Mat& dst);
  void analyse_leg(int slot, double phi_enc, const Roi& roi, LegSinkage& leg);
  bool fit_axis(double phi_enc, double along_max, double& phi) const;
  void sample_columns(double phi, const Roi& roi);
  bool fit_interface(double phi, double& soil_y, double& agreement, int& cut_columns, int& known_columns);
  void segment_full_frame(const cv::Mat& bgr, bool adaptive);
  double apply_filter(double z);

  WheelGeometry geometry_;
  SinkageParams params_;
  cv::Size size_;
  double mm_per_px_ = 0.5;

  cv::Mat mask_;    // CV_8U leg-slot bits
  cv::Mat seg_;     // CV_8U raw segmentation 0/255
  cv::Mat chroma_;  // CV_8U chroma code (0 = outside mask)
  cv::Mat tmp_;     // CV_8U morphology scratch
  cv::Mat tmp2_;    // CV_8U morphology scratch
  cv::Mat clean_;   // CV_8U cleaned segmentation
  std::array<Roi, kMaxLegs> prev_rois_{};
  std::size_t prev_roi_count_ = 0;
  bool prev_full_ = true;

  // per-frame statistics of the current leg's mask (filled by build_mask_and_segment)
  std::array<std::uint32_t, 256> hist_{};
  std::uint64_t mask_count_ = 0;
  std::uint64_t hsv_count_ = 0;
  double value_sum_ = 0;
  bool adaptive_frame_ = false;

  // axial moment bins (Sxx, Syy, Sxy, n) for the axis fit, indexed by along px
  std::vector<std::array<double, 4>> bins_;
  // leg samples on a grid of columns parallel to the axis: 0 soil, 1 leg, 2 unknown
  std::vector<std::uint8_t> cols_;
  int n_along_ = 0, n_cols_ = 0;
  double s0_ = 0, col_half_ = 0;
  std::array<double, 64> col_y_{};    // visible end (image y) per known column
  std::array<double, 64> col_end_{};  // template end (image y) per known column

  // temporal filter
  std::array<double, 31> history_{};
  std::array<double, 31> sort_buf_{};
  int history_count_ = 0, history_head_ = 0;
  double ema_ = 0;
  bool ema_init_ = false;

  SinkageDiagnostics diag_;
};

/// Diagnostic overlay: template outline in red, interface line in green, sinkage (tip to
/// interface, vertical) in blue, text with the wheel sinkage. `out` becomes a copy of `bgr` with
/// the drawing (allocates; not for the real-time path).
void draw_overlay(const cv::Mat& bgr, const WheelGeometry& geometry, const SinkageResult& result, cv::Mat& out);
/// Same, with the estimator's geometry.
inline void draw_overlay(const SinkageEstimator& estimator, const cv::Mat& bgr, const SinkageResult& result,
                         cv::Mat& out) {
  draw_overlay(bgr, estimator.geometry(), result, out);
}

/// Hints for calibration from a frame of the un-sunk wheel.
struct CalibrationHints {
  int leg_count = 5;
  double leg_spacing_rad = 1.2566370614359172;
  int rotation_direction = 1;
  SinkageParams colour{};     ///< colour band / mode used to find the legs
  int min_leg_area_px = 200;  ///< px^2: smaller blobs are ignored
};

struct CalibrationReport {
  WheelGeometry geometry;
  int legs_used = 0;          ///< blobs used for the hub fit
  double hub_fit_rms_px = 0;  ///< rms distance of leg axes from the fitted hub
};

/// Derives hub centre, leg length, leg width, hub radius, foot size and the angle offset (modulo
/// the leg spacing) from a frame of the un-sunk wheel. Throws std::invalid_argument for a bad image
/// and std::runtime_error when fewer than two legs are found or the fit is degenerate.
CalibrationReport calibrate_from_unsunk_frame(const cv::Mat& bgr, double encoder_angle_rad,
                                              const CalibrationHints& hints = {});

/// YAML block (key `geometry:` at `indent` spaces) with every WheelGeometry field.
std::string geometry_to_yaml(const WheelGeometry& g, int indent = 0);

// ---------------------------------------------------------------------------------------------
// Evaluation (thesis Table 4.1 analogue). Pure functions over paired samples.

struct EvalSample {
  double truth_mm = 0;
  double estimate_mm = 0;
  bool valid = false;
};

struct EvalSummary {
  std::size_t frames = 0;
  std::size_t valid = 0;
  double mean_abs_error_mm = 0;
  double max_abs_error_mm = 0;
  double rms_error_mm = 0;
  double mean_truth_mm = 0;
  double max_truth_mm = 0;
  double mean_error_pct_of_mean_truth = 0;  ///< 100 * mean |e| / mean truth
  double mean_error_pct_of_max_truth = 0;   ///< 100 * mean |e| / max truth (issue target <= 5)
  double max_error_pct_of_max_truth = 0;    ///< 100 * max |e| / max truth
};

/// Errors over valid samples only (invalid ones are counted in frames - valid).
EvalSummary evaluate(std::span<const EvalSample> samples);

struct SequenceItem {
  cv::Mat bgr;
  double encoder_angle_rad = 0;
  double truth_mm = 0;
};

/// Runs `estimator` over a sequence (filter state reset first) and evaluates it; per-frame samples
/// are written to `samples_out` when not null.
EvalSummary evaluate_sequence(SinkageEstimator& estimator, std::span<const SequenceItem> sequence,
                              std::vector<EvalSample>* samples_out = nullptr);

struct ConditionSummary {
  std::string load;          ///< e.g. "3.5 kg"
  std::string illumination;  ///< e.g. "300-400 lux"
  EvalSummary summary;
};

/// Fixed-width text table: condition, frames, valid, mean / max error in mm and in %.
std::string format_table(std::span<const ConditionSummary> rows);

}  // namespace regolith::sinkage
