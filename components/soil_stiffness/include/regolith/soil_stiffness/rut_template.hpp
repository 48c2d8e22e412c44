#pragma once
// Rut depth by fitting a rendered cross-section to the image (analysis by synthesis).
//
// A rigid wheel leaves a rut of known shape: a flat floor one wheel width b wide at depth z, walls
// at the soil's repose angle rising to the undisturbed ground, and berms of height berm_ratio * z
// just outside (raised-cosine bumps whose position and width scale with the wheel width). With the sun known, the
// brightness of every part of that cross-section is predictable: Lambertian shading of the walls
// and berms, cast shadows of the sunward crest over the floor (and, with a low sun, the far wall),
// self-shadowed walls, ambient light in shadow, the camera's perspective (a floor point at depth z
// is seen at ground lateral y H / (H + z)), its pixel footprint and 8-bit saturation. The fit
// compares that prediction with the image along each stretch of the rut and keeps the depth (and
// lateral centre) with the smallest robust residual.
//
// Every cue is used at once: the width of a lit wall, the width of a cast shadow, the shading of a
// wall lit at a grazing angle, a floor fully in shadow, or no shadow at all. Photoclinometry of a
// cross-section fails exactly where shadows are (ambient brightness carries no slope), and a
// shadow-width measurement fails where the shadow fills the floor; the template does not care.
//
// Framework-free (plain C++ over cv::Mat); the workspace is sized at construction and fit() does
// not allocate.
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/common/sun.hpp"
#include "regolith/direct_depth/direct_depth.hpp"

namespace regolith::soil {

/// The cross-section of a rut (in units of its depth z and the wheel width b).
struct RutShape {
  double wall_slope_rad = 0.70;  ///< wall slope (~ angle of repose, 40 deg) [rad]
  double berm_ratio = 0.16;      ///< berm crest height above the ground / z (effective, see README) [-]
  double berm_offset = 0.15;     ///< berm crest beyond the wall's top edge / b [-]
  double berm_half_width = 0.3;  ///< half-width of the (raised-cosine) berm / b [-]
  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

struct RutTemplateParams {
  double max_sinkage_m = 0.06;      ///< deepest rut hypothesis [m]
  double sinkage_step_m = 0.001;    ///< hypothesis spacing (refined by a parabola) [m]
  double centre_search_m = 0.03;    ///< +- lateral search around the nominal rut centre [m]
  double centre_step_m = 0.002;     ///< [m]
  double sample_step_m = 0.002;     ///< lateral sampling of the image along a cross-section [m]
  double huber_dn = 20.0;           ///< residual beyond which the loss grows linearly [DN]
  double min_valid_fraction = 0.6;  ///< of a window's samples inside the image, else no depth [-]
  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

/// Photometry of one frame: the undisturbed ground's brightness and the ambient share of light.
struct RutLight {
  common::GroundSun sun;  ///< in the camera's ground frame
  double flat_dn = 0.0;   ///< brightness of flat, sunlit ground [DN]
  double ambient = 0.0;   ///< ambient / direct irradiance: shadow = flat * ambient / (sin(el) + ambient) [-]
  double saturation_dn = 255.0;
};

class RutTemplateFit {
 public:
  /// wheel_width_m: b. max_rows: most cross-sections one call fits (the estimator's grid rows).
  RutTemplateFit(const direct_depth::CameraModel& camera, double wheel_width_m, const RutShape& shape,
                 const RutTemplateParams& params, int max_rows);

  /// Ambient share from the brightness of shadowed ground (`shadow_dn`) and of flat sunlit ground.
  static double ambient_from_shadow(double shadow_dn, double flat_dn, double sun_elevation_rad);

  /// Fits the rut nominally centred at body lateral `lateral_m` (left +) on the cross-sections at
  /// the given ground ranges, `window` consecutive ranges sharing one depth. grey: CV_8UC1 of the
  /// camera's size. depth_m[i]: sinkage of range i (NaN where the window is mostly outside the
  /// image). Returns the fitted centre (mean over windows; the nominal one if none was fitted).
  double fit(const cv::Mat& grey, const RutLight& light, double lateral_m, const double* ranges_m, int count,
             int window, double* depth_m);

  /// Predicted brightness [DN] at ground lateral offset `offset_m` from the rut centre for depth z
  /// (no pixel blur): for tests and plots.
  double predict(const RutLight& light, double lateral_m, double z_m, double offset_m);

  int hypotheses() const { return nz_; }
  /// Windows of the last fit() whose depth was not measurable (the residual does not rise clearly
  /// on both sides of the best depth: a rut in full shadow, or deeper than max_sinkage_m).
  int unmeasurable_windows() const { return unmeasurable_; }

 private:
  void build_templates(const RutLight& light, double lateral_m);
  double profile_height(double z, double d) const;  ///< height at offset d from the centre
  /// Mean brightness over a footprint f centred at ground offset u, from the prefix sums P of one
  /// template, clamped at saturation [DN].
  double footprint_mean(const double* P, double u, double f, double saturation_dn) const;
  /// lattice_ for the current window's footprint f.
  void fill_lattice(double f, double saturation_dn);
  /// The window's Huber cost against depth hypothesis k at centre offset c.
  double window_cost(int k, int c, double f, double saturation_dn) const;

  direct_depth::DirectDepth geometry_;
  double H_ = 0.0, b_ = 0.0;
  RutShape shape_;
  RutTemplateParams p_;
  int nz_ = 0, nc_ = 0, nfine_ = 0, nsamp_ = 0, max_rows_ = 0;
  double fine_step_ = 0.0005, half_fine_ = 0.0, half_samp_ = 0.0;
  std::vector<double> fine_h_, fine_b_;  // per fine surface sample: height, brightness [DN]
  std::vector<double> prefix_;           // [nz][nfine + 1]: integral of DN over ground lateral
  std::vector<double> obs_, obs_n_;      // window mean observation per sample
  std::vector<double> px_x_, px_y_;      // per row and sample: pixel position (NaN outside)
  std::vector<double> foot_;             // per row: pixel footprint [m]
  std::vector<double> sse_;              // [nz][nc]
  // When the centre step is a whole number r of sample steps, every (sample j, offset c) reads a
  // template at a lattice point j - r c: per window, each hypothesis' footprint means are made
  // once on that lattice ([nz][nsamp + r (nc - 1)]) instead of once per offset (r = 0: no lattice).
  int lattice_r_ = 0, lattice_n_ = 0;
  std::vector<double> lattice_;
  int unmeasurable_ = 0;
  bool built_ = false;  // templates of built_light_ / built_lateral_ in prefix_
  RutLight built_light_;
  double built_lateral_ = 0.0;
};

}  // namespace regolith::soil
