#pragma once
// Allocation-free image operations used on the per-frame path of IttiSaliency and
// BoxDetector, in place of OpenCV calls that build filter engines / buffers on the heap at
// every call (cv::filter2D, cv::morphologyEx, cv::connectedComponentsWithStats, cv::resize).
// Each one reproduces the OpenCV operation it replaces (same border handling, same label
// numbering) up to float rounding; tests/saliency/test_image_ops.cpp checks that on random
// inputs. Scratch buffers are passed in (or owned by the object) and are only (re)allocated when
// the image size changes.
#include <array>
#include <vector>

#include <opencv2/core.hpp>

namespace regolith::saliency {

/// Input conversion shared by every method that reads intensity (IttiSaliency, ContrastSaliency):
/// `image` (any channel count; 8U, 16U, 16S, 32F or 64F) -> CV_32F with the same channels in
/// [0,1]: integers divided by their type's maximum, floats by their maximum when it exceeds 1,
/// negative values clipped to 0. Throws std::invalid_argument on an unsupported depth or a
/// non-finite float. `out` is reused when it has the right size and type.
void to_unit_float(const cv::Mat& image, cv::Mat& out);

/// Intensity I = (r + g + b) / 3 of a to_unit_float() result with 1, 3 (BGR) or 4 (BGRA, alpha
/// ignored) channels; one channel is copied. `intensity` becomes CV_32FC1 of the same size.
/// Throws std::invalid_argument for another channel count.
void intensity_of(const cv::Mat& unit, cv::Mat& intensity);

/// Gabor energy |src (*) even| + |src (*) odd| where (*) is the correlation of cv::filter2D
/// (kernel not flipped, anchor at the kernel centre) with cv::BORDER_REPLICATE.
/// `src` CV_32FC1; `even`, `odd` CV_32FC1 of one odd size. `dst` becomes CV_32FC1 of src's size
/// (must not alias src); `pad` and `rows` are scratch (sized on first use for a given size).
void gabor_energy(const cv::Mat& src, const cv::Mat& even, const cv::Mat& odd, cv::Mat& dst, cv::Mat& pad,
                  cv::Mat& rows);

/// The Gabor pair of orientation `theta_rad` (IttiSaliency's kernels): a size x size window,
/// envelope exp(-(xr^2 + elongation^2 yr^2) / (2 sigma^2)) with xr = x cos theta + y sin theta
/// (x the column offset, y the row offset), carrier cos(2 pi xr / period + phi) with phi 0 (even)
/// and pi/2 (odd); each kernel made zero-mean, then of unit L2 norm. CV_32F.
void gabor_kernels(int size, double sigma, double period, double elongation, double theta_rad, cv::Mat& even,
                   cv::Mat& odd);

/// The same pair when the envelope is isotropic (elongation 1), in separable form: with g the 1-D
/// Gaussian, even + i (-odd) before the mean and norm is g(y) e^{i b y} g(x) e^{i a x}
/// (a = 2 pi cos theta / period, b = 2 pi sin theta / period), so the pair's correlation is one
/// complex pass along the rows, one down the columns and a box sum for the means: 72 instead of
/// 162 multiply-adds per pixel at 9x9.
struct SeparableGabor {
  std::vector<float> row_re, row_im;  ///< taps over x (columns)
  std::vector<float> col_re, col_im;  ///< taps over y (rows)
  float mean_even = 0.0f, inv_norm_even = 1.0f, mean_odd = 0.0f, inv_norm_odd = 1.0f;
  /// Throws std::invalid_argument on a size that is not odd and >= 1 or a sigma / period <= 0.
  static SeparableGabor make(int size, double sigma, double period, double theta_rad);
  int size() const { return static_cast<int>(row_re.size()); }
};

/// What the separable Gabor energy of one image needs whatever the orientation: the image padded
/// by replication and the sums of its kernel-sized windows (which the kernels' means apply to),
/// made once and read by every orientation's gabor_energy(). Buffers kept between calls.
struct GaborLevel {
  cv::Mat pad, box;  ///< (h + n - 1) x (w + n - 1) padded image; h x w window sums
  cv::Mat rows;      ///< scratch: the window sums along the rows
  cv::Size size;     ///< of the image
  int taps = 0;      ///< n
  bool folded = false;
  /// For `src` (CV_32FC1) and kernels of `k`'s size and symmetry (those of every make()).
  /// Throws std::invalid_argument on an empty or non-float image or a malformed kernel.
  void prepare(const cv::Mat& src, const SeparableGabor& k);
};

/// gabor_energy() of the pair `k` describes (the same map up to float rounding), of the image
/// `level` was prepared from; `rows` is scratch (sized on first use for a given size). Throws
/// std::invalid_argument when `level` was prepared for a kernel of another size or symmetry.
void gabor_energy(const GaborLevel& level, const SeparableGabor& k, cv::Mat& dst, cv::Mat& rows);
/// The same of `src`, preparing `level` first.
void gabor_energy(const cv::Mat& src, const SeparableGabor& k, cv::Mat& dst, GaborLevel& level, cv::Mat& rows);

/// Single-kernel version of the same correlation (= cv::filter2D(src, dst, CV_32F, kernel,
/// centre anchor, 0, BORDER_REPLICATE)); used by tests and the slope feature.
void correlate_replicate(const cv::Mat& src, const cv::Mat& kernel, cv::Mat& dst, cv::Mat& pad);

/// Precomputed resampling of a CV_32FC1 image from one size to another, equal to
/// cv::resize with INTER_LINEAR (any scale) or INTER_AREA (downscaling, both factors >= 1).
class ResizeTable {
 public:
  enum class Mode { kLinear, kArea };
  /// Allocates the tables. Throws std::invalid_argument on empty sizes or an area upscale.
  void build(cv::Size src, cv::Size dst, Mode mode);
  /// `src` CV_32FC1 of the source size; `dst` pre-sized (or created) CV_32FC1 of the target
  /// size. No allocation once `dst` has the target size. `clamp_unit`: each output clamped into
  /// [0, 1] (NaN -> 0) as it is written.
  void apply(const cv::Mat& src, cv::Mat& dst, bool clamp_unit = false);
  cv::Size src_size() const { return src_; }
  cv::Size dst_size() const { return dst_; }

 private:
  struct Axis {
    std::vector<int> begin;  // per output index: taps [begin[i], begin[i+1])
    std::vector<int> index;  // source index of each tap
    std::vector<float> weight;
  };
  static void build_linear(int src, int dst, Axis& a);
  static void build_area(int src, int dst, Axis& a);
  cv::Size src_, dst_;
  Axis x_, y_;
  int x_taps_ = 0;  // taps per output along x when every output has the same number, else 0
  cv::Mat rows_;    // src rows resampled horizontally: src.rows x dst.cols
};

/// cv::GaussianBlur(src, dst, cv::Size(0, 0), sigma, sigma, cv::BORDER_REFLECT_101) of a CV_32FC1
/// image: the kernel of OpenCV's size for float images (round(8 sigma + 1) | 1 taps) made once
/// per sigma, separable passes through a row buffer kept between calls. `dst` may alias `src`.
class GaussianBlur32f {
 public:
  /// Throws std::invalid_argument when sigma is not finite and > 0.
  void apply(const cv::Mat& src, cv::Mat& dst, double sigma);

 private:
  double sigma_ = 0.0;
  std::vector<float> kernel_;   // 2 r + 1 taps
  std::vector<float> line_;     // one padded row
  cv::Mat rows_;                // horizontal pass
  std::vector<int> row_index_;  // reflected row of each vertical tap, per output row
};

/// Guided filter (He, Sun & Tang, ECCV 2010) of a CV_32FC1 image: in every (2 r + 1)^2 window
/// the source is fitted as a * guide + b by least squares with the ridge `eps` on a; each output
/// pixel is mean(a) * guide + mean(b) over the windows that hold it. Windows are clipped at the
/// image's border (means over the pixels inside). Where the guide is flat the output is the
/// source's local mean; across an edge of the guide it keeps the edge: an edge-preserving
/// smoothing that makes the source follow the guide's outlines. Buffers kept between calls:
/// allocation-free from the second image of a size on. `dst` may alias `src`.
class GuidedFilter {
 public:
  /// Throws std::invalid_argument when radius < 1 or eps is not finite and > 0.
  GuidedFilter(int radius_px, double eps);
  /// `guide`: CV_8UC1 (read as value / 255) or CV_32FC1, of src's size; `src` CV_32FC1. `dst`
  /// becomes CV_32FC1, clamped to [lo, hi] (the source's range when it has one).
  void apply(const cv::Mat& guide, const cv::Mat& src, cv::Mat& dst, float lo = -FLT_MAX, float hi = FLT_MAX);
  int radius() const { return r_; }
  double eps() const { return eps_; }

 private:
  void box_mean(const cv::Mat& in, cv::Mat& out);  // mean over each pixel's clipped window
  int r_;
  double eps_;
  cv::Mat guide_, ip_, ii_, mean_i_, mean_p_, mean_ip_, mean_ii_, rows_;
  std::vector<float> inv_count_x_, column_;  // 1 / each column's window width; the running column sums
};

/// cv::Sobel(src, gx, CV_32F, 1, 0, 3, scale) and (0, 1) with the default border
/// (BORDER_REFLECT_101), in one pass, of a CV_32FC1 image. `gx`, `gy` must not alias `src`.
void sobel3_32f(const cv::Mat& src, cv::Mat& gx, cv::Mat& gy, float scale);

}  // namespace regolith::saliency
