#pragma once
// Itti-Koch-Niebur saliency (spec algorithms.md 6.2) with the Saliency Toolbox
// (Walther & Koch) defaults, and SAMS (spec 6.3): the same model plus a
// structure channel computed from a height map (the shape-from-shading DTM of
// the same frame) through the same pyramid, centre-surround and normalisation.
//
// Pipeline (all per frame, into buffers owned by the object):
//   input (grey or BGR, 8U/16U/32F) -> float [0,1] -> intensity I (and colour
//   opponency RG, BY)
//   -> dyadic pyramids, levels 0..max(c)+max(delta), 6-tap STB kernel [1 5 10
//   10 5 1]/32
//   -> orientation: Gabor energy |even|+|odd| of each intensity level, 4 angles
//   -> centre-surround |X(c) - X(s)| for c in {2,3,4}, s = c + delta, delta in
//   {3,4}, computed at
//      the map level (4) as in the Saliency Toolbox, with border attenuation
//   -> N(.) on every feature map, across-scale sum, N(.) of each conspicuity
//   map
//   -> SM = sum_f w_f N(conspicuity_f), scaled so that max = 1, bilinearly
//   resized to the input.
#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/core/image_limits.hpp"
#include "regolith/core/parallel.hpp"
#include "regolith/saliency/image_ops.hpp"

namespace regolith::saliency {

/// The normalisation operator N(.).
enum class Normalisation {
  kIterative,  ///< Itti & Koch 2001 iterative DoG (STB default): 3 iterations
  kLocalMax    ///< Itti 1998: scale to [0,10], multiply by (10 - mean local max)^2
};

/// What the structure channel feeds into the pyramid.
enum class StructureFeature {
  kHeight,  ///< the height map normalised to [0,1] (spec 6.3 step 2)
  kSlope    ///< gradient magnitude sqrt(p^2+q^2) of the height map, normalised to
            ///< [0,1]
};

/// Channel weights of the final sum of maps (spec 6.3 step 3). Dimensionless,
/// >= 0.
struct ChannelWeights {
  double intensity = 1.0;
  double orientation = 1.0;
  double colour = 1.0;     ///< used only when IttiParams::use_colour and the input
                           ///< has 3 channels
  double structure = 0.0;  ///< used only when a height map is supplied
  void validate() const;
  bool operator==(const ChannelWeights&) const = default;
};

struct IttiParams {
  int centre_min = 2;  ///< finest centre level c (0 = input resolution)
  int centre_max = 4;  ///< coarsest centre level
  int delta_min = 3;   ///< surround offset: s = c + delta
  int delta_max = 4;
  int map_level = 4;               ///< level of the feature / conspicuity / saliency maps (1:16)
  bool use_colour = false;         ///< RG/BY opponency (the thesis drops colour for planetary scenes)
  int num_orientations = 4;        ///< Gabor angles k*180/num (STB: 4 -> 0,45,90,135 deg)
  double gabor_period = 7.0;       ///< px (at the level filtered)
  int gabor_size = 9;              ///< px, odd kernel side
  double gabor_sigma = 7.0 / 3.0;  ///< px
  double gabor_elongation = 1.0;   ///< aspect ratio of the Gaussian envelope
  double border_fraction = 0.05;   ///< centre-surround border attenuation: round(max side * f) px
  Normalisation normalisation = Normalisation::kIterative;
  int iterations = 3;                 ///< iterative N(.): number of iterations
  double excit_coeff = 0.5;           ///< iterative N(.): c_ex
  double inhib_coeff = 1.5;           ///< iterative N(.): c_inh
  double excit_sigma = 0.02;          ///< iterative N(.): sigma_ex as a fraction of the map's larger side
  double inhib_sigma = 0.25;          ///< iterative N(.): sigma_inh as a fraction of the larger side
  double global_inhibition = 0.02;    ///< iterative N(.): fraction of the max subtracted
  double colour_lum_threshold = 0.1;  ///< colour: ignore pixels with max(r,g,b) < f * global max
  StructureFeature structure_feature = StructureFeature::kHeight;
  ChannelWeights weights;

  int max_level() const { return centre_max + delta_max; }
  /// Smallest input side (px) that gives at least 1 px at the coarsest level.
  int min_input_side() const { return 1 << max_level(); }
  /// The size an image of `image` size is processed at: itself when both sides reach
  /// min_input_side(), else enlarged by one factor (aspect kept, rounded up) until the shorter side
  /// does (a 320x240 navigation frame -> 342x256 with the default 256 px). Throws
  /// std::invalid_argument when the enlarged image would exceed kMaxImageSidePx a side or
  /// `max_pixels` (a sliver: 2x4000 px would need 256x512000).
  cv::Size input_size(cv::Size image, double max_pixels = static_cast<double>(kMaxImagePixels)) const;
  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

/// Conspicuity maps N(channel) at the map level (CV_32F, >= 0). An empty Mat =
/// channel unused.
struct Conspicuity {
  cv::Mat intensity;
  cv::Mat orientation;
  cv::Mat colour;
  cv::Mat structure;
};

/// Reusable Itti / SAMS saliency model. For a stream of frames of one size and
/// type the buffers are allocated on the first frame only.
class IttiSaliency {
 public:
  explicit IttiSaliency(IttiParams params = {});

  /// Conspicuity maps of one frame. `image`: 1 or 3 (BGR) or 4 (BGRA) channels,
  /// CV_8U, CV_16U or CV_32F (floats are taken as [0,1]). `height`: optional
  /// height map (any single-channel depth, NaN = unknown) for the SAMS
  /// structure channel, the image's size or a pyramid level's down to
  /// params().centre_min (each level halves the previous, rounding up:
  /// level_size()), where it then enters the pyramid; empty = none. Throws
  /// std::invalid_argument on empty / wrong-type / too-small input or a size
  /// mismatch. The returned maps alias internal buffers and stay valid until
  /// the next call.
  const Conspicuity& conspicuity(const cv::Mat& image, const cv::Mat& height = cv::Mat());

  /// Full saliency map at the input size (CV_32F in [0,1]) with
  /// params().weights.
  void compute(const cv::Mat& image, const cv::Mat& height, cv::Mat& saliency);
  void compute(const cv::Mat& image, cv::Mat& saliency) { compute(image, cv::Mat(), saliency); }

  const IttiParams& params() const { return params_; }

  /// Size of pyramid level `level` for an image of `image` size (each level halves the one
  /// below, rounding up).
  static cv::Size level_size(cv::Size image, int level) {
    for (int l = 0; l < level; ++l) image = cv::Size((image.width + 1) / 2, (image.height + 1) / 2);
    return image;
  }

  /// Runs the channels (intensity + colour, each orientation, structure) as independent jobs on
  /// `par` (nullptr = one after the other on the calling thread, the default). The maps are the
  /// same bit for bit with or without it. `par` must outlive this object or be reset.
  void set_parallel(ParallelFor* par) { par_ = par; }

 private:
  /// Scratch of one channel job: every buffer a job writes is its own, so jobs can run at once.
  struct Scratch {
    cv::Mat diff, excit, inhib, acc;
    std::vector<cv::Mat> down_tmp, gabor_pad, gabor_rows;  // per level (gabor_pad: the direct pass's)
    // level -> map level resampling (INTER_AREA below it, INTER_LINEAR above it); a table
    // keeps its own row buffer, so every job has its own copy
    std::vector<ResizeTable> to_map;
    std::vector<cv::Mat> at_map;  // per level: the level resampled to the map level
  };
  void prepare(cv::Size size);
  void build_pyramid(std::vector<cv::Mat>& pyr, Scratch& s, int from = 0);
  void centre_surround_channel(const std::vector<cv::Mat>& pyr, cv::Mat& out, Scratch& s);
  void normalise(cv::Mat& map, Scratch& s);
  void intensity_job(bool colour);
  void orientation_job(int t);
  void structure_job(const cv::Mat& height, int level);

  IttiParams params_;
  cv::Size input_size_;
  cv::Size map_size_;
  std::vector<cv::Size> level_sizes_;
  cv::Mat bgr_;  // CV_32FC3 or CV_32FC1 in [0,1]
  std::vector<cv::Mat> intensity_pyr_, rg_pyr_, by_pyr_, struct_pyr_;
  std::vector<std::vector<cv::Mat>> orient_pyr_;  // [theta][level]
  std::vector<cv::Mat> gabor_even_, gabor_odd_;
  std::vector<SeparableGabor> gabor_separable_;  // per orientation when the envelope is isotropic
  std::vector<GaborLevel> gabor_levels_;         // per level: what every orientation's separable pass reads
  cv::Mat tmp_, tmp2_, border_;
  Conspicuity consp_;
  cv::Mat combined_;
  // Allocation-free per-frame path: per-job scratch ([0] intensity and colour, [1 + t]
  // orientation t, [1 + num_orientations] structure) and resampling tables (prepare()).
  std::vector<Scratch> scratch_;
  ParallelFor* par_ = nullptr;
  ResizeTable to_input_;  // map level -> input size
  cv::Mat sobel_x_, sobel_y_, sobel_pad_;
};

/// SM = sum_f w_f * c_f over the non-empty maps of `c` (weights of absent
/// channels ignored), divided by its maximum (all-zero stays zero), resized
/// bilinearly to `out_size` (CV_32F, [0,1]).
void combine_conspicuity(const Conspicuity& c, const ChannelWeights& w, cv::Size out_size, cv::Mat& saliency,
                         cv::Mat& scratch);

/// Itti normalisation operators, exposed for tests. `map` CV_32F, modified in
/// place.
void normalise_local_max(cv::Mat& map);
/// Iterative DoG normalisation (Itti & Koch 2001) with the parameters of `p`.
void normalise_iterative(cv::Mat& map, const IttiParams& p);

/// One level of the STB dyadic pyramid: separable [1 5 10 10 5 1]/32 filter and
/// decimation by 2 (output side ceil(n/2), replicated border). `src` CV_32F one
/// channel; `dst` pre-sized or empty.
void downsample_stb(const cv::Mat& src, cv::Mat& dst, cv::Mat& tmp);

}  // namespace regolith::saliency
