#pragma once
// Synthetic wheel-leg scene with exact sinkage ground truth (mock for components/sinkage).
//
// A camera just below the hub looks sideways at the lower half of a wheel-leg (Asguard type:
// blue legs with feet, a grey hub) standing in textured sand. Image x right, y down. Leg k's axis
// angle from straight down (towards +x) is
//   phi_k = rotation_direction * encoder + angle_offset_rad + misalignment_rad + k * spacing,
// i.e. the encoder reading used by an estimator is off by `misalignment_rad` from the true legs.
// The soil surface is the horizontal line y = soil_y_px; leg pixels below it are hidden by sand.
// Ground-truth sinkage = vertical depth (mm) of the deepest leg's axis tip below the soil line,
// clamped at 0 (positive down).

#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace regolith::wheel_scene {

struct WheelModel {
  cv::Point2d hub_center_px{320.0, 110.0};      ///< px
  int leg_count = 5;                            ///< legs
  double leg_spacing_rad = 1.2566370614359172;  ///< rad (2 pi / 5)
  double leg_length_px = 300.0;                 ///< px, hub centre to tip
  double leg_width_px = 28.0;                   ///< px
  double hub_radius_px = 40.0;                  ///< px, radius of the grey hub disc
  double foot_width_px = 48.0;                  ///< px across the axis (0 = no foot)
  double foot_thickness_px = 10.0;              ///< px along the axis from the tip
  double angle_offset_rad = 0.0;                ///< rad, leg 0 image angle at encoder 0
  int rotation_direction = 1;                   ///< +1 / -1
  double mm_per_px = 0.5;                       ///< mm/px at the wheel plane
  void validate() const;                        ///< std::invalid_argument naming the field
};

struct Illumination {
  double gain = 1.0;            ///< multiplies scene radiance (1 = 300-400 lux, ~0.12 = 10-15 lux)
  double noise_sigma = 2.0;     ///< 8-bit units, additive Gaussian sensor noise after gain
  double blur_sigma_px = 0.6;   ///< px, Gaussian optical blur (0 = off)
  double motion_blur_px = 0.0;  ///< px, horizontal box motion blur length (0 = off)
  static Illumination normal() { return {}; }
  static Illumination poor() { return {0.12, 5.0, 1.2, 3.0}; }
  void validate() const;
};

struct SceneParams {
  cv::Size size{640, 480};
  WheelModel wheel{};
  cv::Scalar leg_bgr{175, 95, 35};  ///< painted blue legs
  cv::Scalar hub_bgr{120, 120, 125};
  cv::Scalar soil_bgr{110, 150, 185};     ///< sand
  cv::Scalar background_bgr{60, 66, 72};  ///< test-bed wall behind the wheel
  double soil_texture_contrast = 0.25;    ///< relative amplitude of the sand texture
  double sand_on_leg_fraction = 0.01;     ///< fraction of leg pixels covered by sand grains
  Illumination light{};
  double misalignment_rad = 0.0;  ///< rad, true legs minus encoder prediction
  std::uint32_t seed = 1;
  void validate() const;
};

struct FrameTruth {
  double encoder_angle_rad = 0;  ///< what the encoder reports
  double leg0_angle_rad = 0;     ///< true image angle of leg 0 (wrapped)
  double soil_y_px = 0;          ///< soil line
  double sinkage_px = 0;         ///< deepest tip below soil, >= 0
  double sinkage_mm = 0;
  int deepest_leg = -1;
};

class WheelSceneGenerator {
 public:
  explicit WheelSceneGenerator(const SceneParams& params);

  /// True image angle (rad, wrapped to (-pi, pi]) of leg k for an encoder reading.
  double leg_angle(int k, double encoder_angle_rad) const;
  /// Image y (px) of the lowest leg tip and which leg it is.
  double lowest_tip_y(double encoder_angle_rad, int* leg = nullptr) const;

  /// Renders with the soil line at `soil_y_px`; returns the exact truth.
  FrameTruth render_at_soil_level(double encoder_angle_rad, double soil_y_px, cv::Mat& bgr);
  /// Renders with the soil placed so that the deepest tip is `sinkage_mm` below it (>= 0).
  FrameTruth render_with_sinkage(double encoder_angle_rad, double sinkage_mm, cv::Mat& bgr);

  const SceneParams& params() const { return params_; }
  void set_illumination(const Illumination& l);
  void set_misalignment(double rad) { params_.misalignment_rad = rad; }

 private:
  SceneParams params_;
  cv::Mat soil_tex_;   // CV_32FC3 radiance of the sand (before gain)
  cv::Mat back_tex_;   // CV_32FC3 radiance of the wall
  cv::Mat radiance_;   // CV_32FC3 work
  cv::Mat cover_;      // CV_8U leg coverage work
  cv::Mat hub_cover_;  // CV_8U hub coverage work
  std::mt19937 rng_;
};

/// Sinkage profile of a generated sequence.
struct SequenceSpec {
  int frames = 100;
  double start_angle_rad = 0.0;
  double angle_step_rad = 0.035;  ///< encoder advance per frame
  double max_sinkage_mm = 40.0;   ///< peak sinkage of the deepest tip
  /// Profile: 0 for the first 10 % of frames, a ramp to max by 50 %, then max with a +-15 %
  /// slow oscillation (settling under load).
  double profile_mm(int i) const;
  void validate() const;
};

struct SequenceFrame {
  cv::Mat bgr;
  FrameTruth truth;
};

std::vector<SequenceFrame> make_sequence(WheelSceneGenerator& gen, const SequenceSpec& spec);

// ---- sequence CSV: header `frame,encoder_angle_rad,truth_mm`, frame = image path relative to
// the CSV's folder (or absolute) ----
struct SequenceRow {
  std::string frame;
  double encoder_angle_rad = 0;
  double truth_mm = 0;
  int line = 0;  ///< line in the CSV (set by read_sequence_csv, for messages)
};

/// Throws std::runtime_error naming the file (and line) on I/O failure. `comments` are written
/// first as `# <comment>` lines (e.g. "load: 3.5 kg", "illumination: 10-15 lux").
void write_sequence_csv(const std::filesystem::path& csv, const std::vector<SequenceRow>& rows,
                        const std::vector<std::string>& comments = {});
/// Throws std::runtime_error "FILE:LINE: ..." for a malformed header, row, or non-finite number.
std::vector<SequenceRow> read_sequence_csv(const std::filesystem::path& csv);
/// `# key: value` comment lines of a sequence CSV (value for `key`, or "" when absent).
std::string read_sequence_comment(const std::filesystem::path& csv, const std::string& key);
/// Writes frame_%04d.png files and sequence.csv into `dir` (created); returns the CSV path.
std::filesystem::path write_sequence(const std::filesystem::path& dir, const std::vector<SequenceFrame>& frames,
                                     const std::vector<std::string>& comments = {});

}  // namespace regolith::wheel_scene
