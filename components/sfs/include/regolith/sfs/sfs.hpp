#pragma once
// Shape from shading (thesis ch. 3, spec algorithms.md sections 2.4-2.7).
//
// Frames and conventions (read before using the light direction):
//  * Image frame: x = columns (to the right), y = rows (downwards), third axis pointing from the
//    scene TOWARDS the camera/viewer. For a camera this is the optical frame with z flipped.
//  * LightDirection is the direction FROM the scene TOWARDS the light source (the sun):
//      S = (cos(tilt) sin(slant), sin(tilt) sin(slant), cos(slant))  in that image frame.
//    slant = angle between S and the line of sight back to the camera (0 = sun right behind the
//            camera, pi/2 = sun on the image plane / horizon of the image). Valid range [0, pi/2).
//    tilt  = angle of S's image-plane projection, measured from image +x (columns) towards image
//            +y (rows), i.e. clockwise on screen; it points towards the sun. Any value (wrapped).
//  * Output height is UP positive (towards the viewer), in pixel units: a surface rising by one
//    height unit per pixel step has a 45 degree slope. Tsai-Shah's internal Z is depth (away from
//    the viewer); SfsResult::height is its negative.
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/sfs/real_fft.hpp"

namespace regolith::sfs {

/// Direction towards the light in the image frame (see file comment). Radians.
struct LightDirection {
  double slant_rad = 0.0;  ///< rad, [0, pi/2): angle from the viewing direction back to the camera
  double tilt_rad = 0.0;   ///< rad, from image +x (columns) towards +y (rows), towards the sun

  /// Unit vector (sx, sy, sz) towards the light in the image frame.
  cv::Vec3d vector() const;
  /// Throws std::invalid_argument naming `what` if not finite or slant outside [0, pi/2).
  void validate(const std::string& what = "light") const;
};

enum class Method {
  kTsaiShah,        ///< linear SfS, per-pixel Jacobi iteration (spec 2.4)
  kPentland,        ///< Pentland linear, one FFT pair (spec 2.6)
  kBichselPentland  ///< minimum-downhill propagation from singular points (spec 2.6)
};

/// "tsai_shah" | "pentland" | "bichsel_pentland".
const char* to_string(Method m);
/// Parses the names above; throws std::invalid_argument listing the accepted names.
Method method_from_string(const std::string& name);

/// Radial vignetting model V(r) = 1 + a2 r^2 + a4 r^4 + a6 r^6 (r normalised to the image
/// half-diagonal measured from (cx, cy)), or a flat-field image. Correction: I_c = I / V.
struct Vignetting {
  bool enabled = false;
  double a2 = 0.0, a4 = 0.0, a6 = 0.0;  ///< dimensionless polynomial coefficients
  double cx_frac = 0.5;                 ///< centre column as a fraction of the width
  double cy_frac = 0.5;                 ///< centre row as a fraction of the height
  /// Optional flat-field image (any size: resized to the frame). When non-empty it is used
  /// instead of the polynomial: V = F / mean(F).
  cv::Mat flat_field;
  void validate() const;
  /// Gain map V (CV_32F, size) for the model (polynomial or flat field).
  cv::Mat gain_map(cv::Size size) const;
};

struct VignettingFit {
  Vignetting model;     ///< enabled = true, fitted a2, a4, a6, centre as given
  double rms_residual;  ///< RMS of (F/F0 - V(r)) over the fitted pixels, dimensionless
  double f0;            ///< fitted centre brightness (same unit as the flat field)
};

/// Least-squares fit of F(r) = f0 (1 + a2 r^2 + a4 r^4 + a6 r^6) to a flat-field image
/// (CV_8U, CV_16U or CV_32F single channel; colour is converted to grey). Saturated (>= 98 % of
/// the type maximum for 8/16 bit) and zero pixels are ignored. Throws std::invalid_argument.
VignettingFit fit_vignetting_polynomial(const cv::Mat& flatfield, double cx_frac = 0.5, double cy_frac = 0.5);

/// dst = src / V (src CV_32F single channel; dst reallocated only if size/type differ).
void correct_vignetting(const cv::Mat& src, const Vignetting& v, cv::Mat& dst);

/// Tsai-Shah update schemes (see README "Tsai-Shah: why the reference does not converge").
enum class TsaiShahScheme {
  kMarching,  ///< default: raster sweep in the light-oriented frame, per-pixel Newton to convergence
  kJacobi     ///< reference: all Z^n from Z^{n-1}, one (damped / Kalman) step per pixel per iteration
};

struct SfsParams {
  /// Default Pentland: most accurate per millisecond (README "Choice of default"); the sfs
  /// component defaults to Tsai-Shah (marching), the only allocation-free method per frame.
  Method method = Method::kPentland;
  /// Max sweeps over the image: Tsai-Shah Jacobi and Bichsel-Pentland (marching: see below).
  int iterations = 200;
  /// Tsai-Shah marching: max Newton iterations per pixel (measured: 2-3 reach the accuracy of
  /// full convergence; the mean last update is ~2e-4 px after 3).
  int tsai_shah_newton_iterations = 3;
  double tolerance = 1e-4;  ///< px: stop when |dZ| (marching: per pixel) or mean |dZ| < tolerance
  double wn = 1e-8;         ///< Tsai-Shah measurement noise Wn (reference 1e-8)
  double s0 = 0.01;         ///< Tsai-Shah initial variance S0 (reference 0.01)
  TsaiShahScheme tsai_shah_scheme = TsaiShahScheme::kMarching;  ///< update scheme
  /// Marching: memory length (px) of the integration along the light: upstream heights are
  /// multiplied by 1 - 1/leak before use, which damps the low-frequency drift that integrating
  /// noise and albedo errors produces (like Pentland's Tikhonov term). 0 = no leak.
  double tsai_shah_leak_px = 80.0;
  /// Marching: bound on the backward differences |p|, |q| (height units per px; 2 = 63 deg).
  double tsai_shah_max_gradient = 2.0;
  /// Marching: pixels darker than shadow_level / 2 (no data, sky, cast shadow) continue flat
  /// instead of being solved. Off by default: on rendered terrain the attached shadows of rocks
  /// are black and solving them (to the gradient bound) scores better (r 0.70 vs 0.59).
  bool tsai_shah_skip_black = false;
  /// Marching: solve four rows per 128-bit vector (SSE2 / NEON). Off = the scalar sweep, kept as
  /// the reference: both give the same heights bit for bit where the compiler does not fuse
  /// multiply-adds (x86-64; tests/sfs checks it).
  bool tsai_shah_simd = true;
  bool kalman_gain = false;            ///< Jacobi: reference Kalman-style gain (freezes; for comparison)
  bool gauss_seidel = false;           ///< Tsai-Shah: in-place raster update instead of Jacobi
  double step_damping = 0.5;           ///< Tsai-Shah damped Newton step fraction (0, 1]
  double max_step = 0.5;               ///< px, clamp on |dZ| per pixel per iteration (Tsai-Shah)
  double saturation_level = 0.98;      ///< normalised E at/above which a pixel is masked invalid
  double shadow_level = 0.02;          ///< normalised E at/below which a pixel is masked invalid
  bool normalise_albedo = true;        ///< scale E so the median valid pixel = cos(slant) (flat ground)
  bool estimate_light = false;         ///< estimate the light when none is supplied to compute()
  bool zheng_chellappa_refine = true;  ///< refine the estimated slant with the Z-C polynomial
  double min_light_confidence = 0.2;   ///< estimated light below this confidence -> throws
  /// Pentland: Tikhonov term of the inverse filter (frequencies whose |denominator| is below it
  /// are damped). 0.02: on the development ortho patches r / detail r 0.56 / 0.75 (0.05: 0.39 /
  /// 0.72, 0.01: 0.66 / 0.72); detail is the harder goal, full-band r stays well above it.
  double pentland_min_denominator = 0.02;
  /// Pentland: masked pixels (shadow, saturation) enter the solve with their measured
  /// brightness (false) or with the mean brightness (true, the earlier rule). A cast shadow
  /// replaced by the mean reads as a bright patch between its dark edges; left dark it reads as a
  /// slope facing away, which its edges already imply: detail r 0.64 -> 0.72 on the dev patches.
  bool pentland_fill_masked = false;
  double bichsel_singular_tolerance = 0.01;  ///< B-P singular points: |E - 1| < tolerance
  Vignetting vignetting;
  /// Throws std::invalid_argument naming the offending field.
  void validate() const;
};

/// Result of the moment-based light estimator.
struct LightEstimate {
  LightDirection light;
  double albedo = 0.0;      ///< estimated albedo rho (same scale as E)
  double confidence = 0.0;  ///< 0..1: coherence of the gradient direction x slant conditioning
};

/// Moment-based estimator (Lee-Rosenfeld / Zheng-Chellappa): tilt from mean normalised image
/// gradient, slant and albedo from the first two intensity moments, optionally refined with the
/// Zheng-Chellappa polynomial. `gray` CV_8U or CV_32F (0..1). `mask` optional CV_8U.
LightEstimate estimate_light(const cv::Mat& gray, bool zheng_chellappa_refine = true, const cv::Mat& mask = cv::Mat());

/// Outcome of one solve. Not an exception: an unusable frame is normal input on a rover.
enum class SfsStatus {
  kSolved,           ///< height / valid hold the solution
  kUnreliableLight,  ///< estimated light below min_light_confidence: height NaN, valid all 0
};

struct SfsResult {
  SfsStatus status = SfsStatus::kSolved;
  cv::Mat height;        ///< CV_32F, same size as the input, relative height UP positive, pixel units
  cv::Mat valid;         ///< CV_8U, 255 = valid pixel (not saturated / shadowed / outside)
  LightDirection light;  ///< light direction actually used
  bool light_estimated = false;
  double light_confidence = 1.0;   ///< 1 when supplied, estimator confidence otherwise
  int iterations = 0;              ///< iterations run (Pentland: 1)
  double final_mean_update = 0.0;  ///< mean |dZ| of the last iteration (px units)
};

/// Reusable solver. Buffers are kept between calls; for a sequence of frames of the same size
/// and type, Tsai-Shah and Pentland do no heap allocation after the first frame (out must be
/// the same SfsResult object each time).
class ShapeFromShading {
 public:
  explicit ShapeFromShading(SfsParams params);

  /// gray: CV_8U (0..255) or CV_32F (0..1), one channel, non-empty. light: the known light
  /// direction; if absent, params.estimate_light must be true (else std::invalid_argument).
  /// Throws std::invalid_argument (FieldError) on bad input. An estimated light whose confidence
  /// is below params.min_light_confidence is not an error: out.status = kUnreliableLight, with
  /// out.light / light_confidence set to the estimate and no height (allocation-free after the
  /// first frame, like a solve).
  void compute(const cv::Mat& gray, const std::optional<LightDirection>& light, SfsResult& out);

  const SfsParams& params() const { return params_; }

 private:
  void prepare(const cv::Mat& gray);
  void tsai_shah(const LightDirection& l, SfsResult& out);
  void tsai_shah_marching(const LightDirection& l, SfsResult& out);
  void pentland(const LightDirection& l, SfsResult& out);
  void bichsel_pentland(const LightDirection& l, SfsResult& out);

  SfsParams params_;
  cv::Mat e_;              // CV_32F normalised brightness
  cv::Mat gain_;           // vignetting gain map (cached per size)
  cv::Mat work_e_;         // oriented copy for Tsai-Shah
  cv::Mat z_, z_new_, s_;  // Tsai-Shah state (oriented frame)
  cv::Mat mask_;           // CV_8U valid mask (image frame)
  cv::Mat work_mask_;      // oriented copy of the mask for Tsai-Shah
  RealFft2d fft_;          // Pentland: FFTW plans and buffers (allocation-free after the first frame)
  cv::Mat filt_re_;        // Pentland: imaginary part of the inverse filter over the half spectrum
  cv::Size last_size_;
  double last_tilt_ = 1e9, last_slant_ = 1e9;
};

/// "estimated light direction is unreliable (confidence .. < min_light_confidence .., slant ..)".
std::string unreliable_light_message(const SfsResult& r, const SfsParams& params);

/// Convenience: one-off computation with a fresh solver. Throws std::runtime_error with
/// unreliable_light_message() when the result's status is kUnreliableLight.
SfsResult shape_from_shading(const cv::Mat& gray, const std::optional<LightDirection>& light,
                             const SfsParams& params = {});

/// Lambertian image of a height field (UP positive, pixel units) under `light`, orthographic,
/// albedo 1, forward differences; E = max(0, n.S). For tests and the scene generator.
cv::Mat render_lambertian(const cv::Mat& height, const LightDirection& light);

}  // namespace regolith::sfs
