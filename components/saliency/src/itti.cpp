#include "regolith/saliency/itti.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/core/error.hpp"
#include "regolith/saliency/image_ops.hpp"

namespace regolith::saliency {

namespace {

void require(bool ok, const std::string& field, const std::string& why) {
  if (!ok) throw FieldError("IttiParams", field, why);
}

bool finite_nonneg(double v) {
  return std::isfinite(v) && v >= 0.0;
}

// Mat::setTo(scalar) allocates in OpenCV 4.6; this does not.
void fill_value(cv::Mat& m, float v) {
  for (int y = 0; y < m.rows; ++y) {
    float* p = m.ptr<float>(y);
    std::fill(p, p + m.cols, v);
  }
}

// Gaussian kernel normalised to sum 1 over [-hw, hw].
cv::Mat gaussian_kernel(double sigma, int hw) {
  cv::Mat k(2 * hw + 1, 1, CV_32F);
  double sum = 0.0;
  for (int i = -hw; i <= hw; ++i) {
    const double v = sigma > 0.0 ? std::exp(-0.5 * (i * i) / (sigma * sigma)) : (i == 0 ? 1.0 : 0.0);
    k.at<float>(i + hw) = static_cast<float>(v);
    sum += v;
  }
  k /= sum;
  return k;
}

struct IterativeKernels {
  cv::Mat kex, kin;  // 1-D kernels, sum 1
  cv::Mat norm_ex,
      norm_in;  // response of the kernels to a map of ones (zero border)

  void build(cv::Size size, const IttiParams& p) {
    const double side = std::max(size.width, size.height);
    const int maxhw = std::max(0, std::min(size.width, size.height) / 2 - 1);
    const double sex = p.excit_sigma * side;
    const double sinh_ = p.inhib_sigma * side;
    const int hex = std::min(maxhw, static_cast<int>(std::ceil(3.0 * sex)));
    const int hin = std::min(maxhw, static_cast<int>(std::ceil(3.0 * sinh_)));
    kex = gaussian_kernel(sex, hex);
    kin = gaussian_kernel(sinh_, hin);
    const cv::Mat ones(size, CV_32F, cv::Scalar(1.0));
    cv::sepFilter2D(ones, norm_ex, CV_32F, kex, kex, cv::Point(-1, -1), 0.0, cv::BORDER_CONSTANT);
    cv::sepFilter2D(ones, norm_in, CV_32F, kin, kin, cv::Point(-1, -1), 0.0, cv::BORDER_CONSTANT);
  }
};

// Negative values (and NaN) := 0, then scale linearly so that [min, max] -> [0, top]. Returns
// false (the map all 0) if flat. Plain loops: the maps are small (the map level), where OpenCV's
// per-call dispatch cost more than the arithmetic.
bool clamp_and_rescale(cv::Mat& map, double top) {
  float mn = std::numeric_limits<float>::infinity(), mx = 0.f;
  for (int y = 0; y < map.rows; ++y) {
    float* m = map.ptr<float>(y);
    for (int x = 0; x < map.cols; ++x) {
      const float v = m[x] > 0.f ? m[x] : 0.f;
      m[x] = v;
      mn = std::min(mn, v);
      mx = std::max(mx, v);
    }
  }
  const double range = static_cast<double>(mx) - static_cast<double>(mn);
  if (!(range > 1e-12)) {
    fill_value(map, 0.f);
    return false;
  }
  const float a = static_cast<float>(top / range), b = static_cast<float>(-static_cast<double>(mn) * top / range);
  for (int y = 0; y < map.rows; ++y) {
    float* m = map.ptr<float>(y);
    for (int x = 0; x < map.cols; ++x) m[x] = m[x] * a + b;
  }
  return true;
}

void iterate_dog(cv::Mat& map, const IttiParams& p, const IterativeKernels& k, cv::Mat& excit, cv::Mat& inhib) {
  if (!clamp_and_rescale(map, 10.0)) return;
  const double cex2 = p.excit_coeff * p.excit_coeff;
  const double cin2 = p.inhib_coeff * p.inhib_coeff;
  for (int it = 0; it < p.iterations; ++it) {
    double mx = 0.0;
    cv::minMaxLoc(map, nullptr, &mx);
    cv::sepFilter2D(map, excit, CV_32F, k.kex, k.kex, cv::Point(-1, -1), 0.0, cv::BORDER_CONSTANT);
    cv::sepFilter2D(map, inhib, CV_32F, k.kin, k.kin, cv::Point(-1, -1), 0.0, cv::BORDER_CONSTANT);
    cv::divide(excit, k.norm_ex, excit);
    cv::divide(inhib, k.norm_in, inhib);
    cv::scaleAdd(excit, cex2, map, map);
    cv::scaleAdd(inhib, -cin2, map, map);
    cv::subtract(map, cv::Scalar(p.global_inhibition * mx), map);
    cv::threshold(map, map, 0.0, 0.0, cv::THRESH_TOZERO);
  }
}

}  // namespace

void ChannelWeights::validate() const {
  const std::pair<const char*, double> fields[] = {
      {"intensity", intensity}, {"orientation", orientation}, {"colour", colour}, {"structure", structure}};
  for (const auto& [name, v] : fields) {
    if (!finite_nonneg(v)) {
      throw FieldError("ChannelWeights", name, "must be finite and >= 0 (got " + number_text(v) + ")");
    }
  }
}

cv::Size IttiParams::input_size(cv::Size image, double max_pixels) const {
  const int need = min_input_side(), side = std::min(image.width, image.height);
  if (side <= 0) throw std::invalid_argument("image: empty");
  if (side >= need) return image;
  const double s = static_cast<double>(need) / side;
  const double w = std::max<double>(need, std::ceil(image.width * s));
  const double h = std::max<double>(need, std::ceil(image.height * s));
  if (w > kMaxImageSidePx || h > kMaxImageSidePx || w * h > std::min(max_pixels, static_cast<double>(kMaxImagePixels)))
    throw std::invalid_argument(
        std::to_string(image.width) + "x" + std::to_string(image.height) + " px is too small for the " +
        std::to_string(need) + " px a side of the pyramid: enlarged to that it would be " +
        std::to_string(static_cast<long>(w)) + "x" + std::to_string(static_cast<long>(h)) + " px");
  return {static_cast<int>(w), static_cast<int>(h)};
}

void IttiParams::validate() const {
  require(centre_min >= 0, "centre_min", "must be >= 0");
  require(centre_max >= centre_min, "centre_max", "must be >= centre_min");
  require(delta_min >= 1, "delta_min", "must be >= 1");
  require(delta_max >= delta_min, "delta_max", "must be >= delta_min");
  require(max_level() <= 12, "delta_max", "centre_max + delta_max must be <= 12");
  require(map_level >= 0 && map_level <= max_level(), "map_level", "must be in [0, centre_max + delta_max]");
  require(num_orientations >= 1 && num_orientations <= 16, "num_orientations", "must be in [1,16]");
  require(std::isfinite(gabor_period) && gabor_period > 1.0, "gabor_period", "must be > 1 px");
  require(gabor_size >= 3 && gabor_size % 2 == 1 && gabor_size <= 63, "gabor_size", "must be odd in [3,63]");
  require(std::isfinite(gabor_sigma) && gabor_sigma > 0.0, "gabor_sigma", "must be > 0");
  require(std::isfinite(gabor_elongation) && gabor_elongation > 0.0, "gabor_elongation", "must be > 0");
  require(std::isfinite(border_fraction) && border_fraction >= 0.0 && border_fraction < 0.5, "border_fraction",
          "must be in [0, 0.5)");
  require(iterations >= 1 && iterations <= 100, "iterations", "must be in [1,100]");
  require(finite_nonneg(excit_coeff), "excit_coeff", "must be finite and >= 0");
  require(finite_nonneg(inhib_coeff), "inhib_coeff", "must be finite and >= 0");
  require(std::isfinite(excit_sigma) && excit_sigma > 0.0, "excit_sigma", "must be > 0");
  require(std::isfinite(inhib_sigma) && inhib_sigma > 0.0, "inhib_sigma", "must be > 0");
  require(finite_nonneg(global_inhibition), "global_inhibition", "must be finite and >= 0");
  require(std::isfinite(colour_lum_threshold) && colour_lum_threshold >= 0.0 && colour_lum_threshold < 1.0,
          "colour_lum_threshold", "must be in [0,1)");
  weights.validate();
}

void downsample_stb(const cv::Mat& src, cv::Mat& dst, cv::Mat& tmp) {
  CV_Assert(src.type() == CV_32FC1 && !src.empty());
  static constexpr float w[6] = {1.f / 32, 5.f / 32, 10.f / 32, 10.f / 32, 5.f / 32, 1.f / 32};
  const int sw = src.cols, sh = src.rows;
  const int dw = (sw + 1) / 2, dh = (sh + 1) / 2;
  // Rows 0..sh-1: the horizontal pass; rows sh, sh+1: one source row split into its even and odd
  // pixels (edge-clamped, one pixel of margin each side), so that the six taps of output i read
  // e[i-1] o[i-1] e[i] o[i] e[i+1] o[i+1] contiguously (the loop vectorises) and add in the
  // same order as a tap loop over s[2i-2 .. 2i+3].
  tmp.create(sh + 2, std::max(dw + 2, 1), CV_32F);
  dst.create(dh, dw, CV_32F);
  float *e = tmp.ptr<float>(sh) + 1, *o = tmp.ptr<float>(sh + 1) + 1;
  // Pixel pairs (2j, 2j + 1) wholly inside the row: j in [0, inner); the others are clamped.
  const int inner = sw / 2;
  for (int y = 0; y < sh; ++y) {
    const float* s = src.ptr<float>(y);
    int j = 0;
    for (; j + cv::v_float32x4::nlanes <= inner; j += cv::v_float32x4::nlanes) {
      cv::v_float32x4 even, odd;
      cv::v_load_deinterleave(s + 2 * j, even, odd);
      cv::v_store(e + j, even);
      cv::v_store(o + j, odd);
    }
    for (; j < inner; ++j) e[j] = s[2 * j], o[j] = s[2 * j + 1];
    for (int k : {-1, inner, inner + 1})
      if (k <= dw) {
        e[k] = s[std::clamp(2 * k, 0, sw - 1)];
        o[k] = s[std::clamp(2 * k + 1, 0, sw - 1)];
      }
    float* t = tmp.ptr<float>(y);
    for (int i = 0; i < dw; ++i) {
      float acc = 0.f;
      acc += w[0] * e[i - 1];
      acc += w[1] * o[i - 1];
      acc += w[2] * e[i];
      acc += w[3] * o[i];
      acc += w[4] * e[i + 1];
      acc += w[5] * o[i + 1];
      t[i] = acc;
    }
  }
  for (int j = 0; j < dh; ++j) {
    const float* rows[6];
    for (int k = 0; k < 6; ++k) rows[k] = tmp.ptr<float>(std::clamp(2 * j - 2 + k, 0, sh - 1));
    float* d = dst.ptr<float>(j);
    for (int x = 0; x < dw; ++x) {
      float acc = 0.f;
      for (int k = 0; k < 6; ++k) acc += w[k] * rows[k][x];
      d[x] = acc;
    }
  }
}

void normalise_local_max(cv::Mat& map) {
  CV_Assert(map.type() == CV_32FC1);
  if (!clamp_and_rescale(map, 10.0)) return;
  // Local maxima: inner pixels >= their 4 neighbours and >= 1 (10 % of the
  // range). Itti 1998 averages the maxima other than the global one; with none,
  // the factor is 10^2.
  double sum = 0.0;
  int n = 0;
  float gmax = 0.f;
  for (int y = 1; y + 1 < map.rows; ++y) {
    const float* up = map.ptr<float>(y - 1);
    const float* row = map.ptr<float>(y);
    const float* dn = map.ptr<float>(y + 1);
    for (int x = 1; x + 1 < map.cols; ++x) {
      const float v = row[x];
      if (v >= 1.f && v >= row[x - 1] && v >= row[x + 1] && v >= up[x] && v >= dn[x]) {
        sum += v;
        ++n;
        gmax = std::max(gmax, v);
      }
    }
  }
  double mean_other = 0.0;
  if (n > 1) mean_other = (sum - gmax) / (n - 1);
  const float f = static_cast<float>((10.0 - mean_other) * (10.0 - mean_other));
  for (int y = 0; y < map.rows; ++y) {
    float* m = map.ptr<float>(y);
    for (int x = 0; x < map.cols; ++x) m[x] *= f;
  }
}

void normalise_iterative(cv::Mat& map, const IttiParams& p) {
  CV_Assert(map.type() == CV_32FC1);
  IterativeKernels k;
  k.build(map.size(), p);
  cv::Mat excit, inhib;
  iterate_dog(map, p, k, excit, inhib);
}

namespace {
IterativeKernels& kernels_for(const IttiParams& p, cv::Size size) {
  thread_local IterativeKernels k;
  thread_local cv::Size ksize;
  thread_local double kex = -1, kin = -1;
  if (size != ksize || kex != p.excit_sigma || kin != p.inhib_sigma) {
    k.build(size, p);
    ksize = size;
    kex = p.excit_sigma;
    kin = p.inhib_sigma;
  }
  return k;
}
}  // namespace

IttiSaliency::IttiSaliency(IttiParams params) : params_(std::move(params)) {
  params_.validate();
  sobel_x_ = (cv::Mat_<float>(3, 3) << -1, 0, 1, -2, 0, 2, -1, 0, 1) / 8.0;
  sobel_y_ = (cv::Mat_<float>(3, 3) << -1, -2, -1, 0, 0, 0, 1, 2, 1) / 8.0;
  const int n = params_.num_orientations;
  gabor_even_.resize(static_cast<size_t>(n));
  gabor_odd_.resize(static_cast<size_t>(n));
  // An isotropic envelope (elongation 1, the default) makes each pair separable: filtered as such.
  const bool separable = params_.gabor_elongation == 1.0;
  for (int t = 0; t < n; ++t) {
    const double theta = std::numbers::pi * t / n;
    gabor_kernels(params_.gabor_size, params_.gabor_sigma, params_.gabor_period, params_.gabor_elongation, theta,
                  gabor_even_[static_cast<size_t>(t)], gabor_odd_[static_cast<size_t>(t)]);
    if (separable)
      gabor_separable_.push_back(
          SeparableGabor::make(params_.gabor_size, params_.gabor_sigma, params_.gabor_period, theta));
  }
}

void IttiSaliency::prepare(cv::Size size) {
  if (size == input_size_) return;
  input_size_ = size;
  const int levels = params_.max_level() + 1;
  level_sizes_.assign(static_cast<size_t>(levels), cv::Size());
  level_sizes_[0] = size;
  for (int l = 1; l < levels; ++l)
    level_sizes_[static_cast<size_t>(l)] = level_size(level_sizes_[static_cast<size_t>(l - 1)], 1);
  map_size_ = level_sizes_[static_cast<size_t>(params_.map_level)];
  auto alloc = [&](std::vector<cv::Mat>& pyr) {
    pyr.assign(static_cast<size_t>(levels), cv::Mat());
    for (int l = 0; l < levels; ++l) pyr[static_cast<size_t>(l)].create(level_sizes_[static_cast<size_t>(l)], CV_32F);
  };
  alloc(intensity_pyr_);
  alloc(struct_pyr_);
  // Per-job scratch: pyramid temporaries, the Gabor filtering's padded level and two
  // accumulator rows per level (orientation jobs), the map-level buffers; and the resampling
  // tables level -> map level (INTER_AREA below it, INTER_LINEAR above it, read-only while
  // the jobs run), so that no buffer changes size from one call to the next.
  const int r = params_.gabor_size / 2;
  scratch_.assign(static_cast<size_t>(params_.num_orientations + 2), Scratch());
  for (size_t j = 0; j < scratch_.size(); ++j) {
    Scratch& sc = scratch_[j];
    alloc(sc.down_tmp);
    const bool orientation = j >= 1 && j <= static_cast<size_t>(params_.num_orientations);
    sc.gabor_pad.assign(static_cast<size_t>(levels), cv::Mat());
    sc.gabor_rows.assign(static_cast<size_t>(levels), cv::Mat());
    for (int l = params_.centre_min; orientation && l < levels; ++l) {
      const cv::Size ls = level_sizes_[static_cast<size_t>(l)];
      // the direct pass's padded level (the separable pass reads the shared gabor_levels_)
      if (gabor_separable_.empty())
        sc.gabor_pad[static_cast<size_t>(l)].create(ls.height + 2 * r, ls.width + 2 * r, CV_32F);
      // the separable pass's two row planes, or the direct pass's two accumulator rows
      sc.gabor_rows[static_cast<size_t>(l)].create(gabor_separable_.empty() ? 2 : 2 * (ls.height + 2 * r), ls.width,
                                                   CV_32F);
    }
    for (cv::Mat* m : {&sc.diff, &sc.acc, &sc.excit, &sc.inhib}) m->create(map_size_, CV_32F);
  }
  for (Scratch& sc : scratch_) {  // built per job: a copy would share the tables' row buffers
    sc.to_map.assign(static_cast<size_t>(levels), ResizeTable());
    sc.at_map.assign(static_cast<size_t>(levels), cv::Mat());
    for (int l = 0; l < levels; ++l) {
      const cv::Size ls = level_sizes_[static_cast<size_t>(l)];
      if (l != params_.map_level) {
        sc.to_map[static_cast<size_t>(l)].build(
            ls, map_size_, l < params_.map_level ? ResizeTable::Mode::kArea : ResizeTable::Mode::kLinear);
        sc.at_map[static_cast<size_t>(l)].create(map_size_, CV_32F);
      }
    }
  }
  // Per level, the padded image and window sums every orientation's separable pass reads.
  gabor_levels_.assign(static_cast<size_t>(levels), GaborLevel());
  for (int l = params_.centre_min; !gabor_separable_.empty() && l < levels; ++l) {
    const cv::Size ls = level_sizes_[static_cast<size_t>(l)];
    GaborLevel& g = gabor_levels_[static_cast<size_t>(l)];
    g.pad.create(ls.height + 2 * r, ls.width + 2 * r, CV_32F);
    g.rows.create(ls.height + 2 * r, ls.width, CV_32F);
    g.box.create(ls, CV_32F);
  }
  to_input_.build(map_size_, size, ResizeTable::Mode::kLinear);
  combined_.create(map_size_, CV_32F);
  if (params_.structure_feature == StructureFeature::kSlope) {
    sobel_pad_.create(size.height + 2, size.width + 2, CV_32F);
    tmp_.create(size, CV_32F);
    tmp2_.create(size, CV_32F);
  }
  if (params_.use_colour) {
    alloc(rg_pyr_);
    alloc(by_pyr_);
  }
  orient_pyr_.assign(static_cast<size_t>(params_.num_orientations), {});
  for (auto& p : orient_pyr_) alloc(p);
  consp_.intensity.create(map_size_, CV_32F);
  consp_.orientation.create(map_size_, CV_32F);
  // Border attenuation ramp.
  border_.create(map_size_, CV_32F);
  const int b = static_cast<int>(std::lround(std::max(map_size_.width, map_size_.height) * params_.border_fraction));
  for (int y = 0; y < map_size_.height; ++y) {
    for (int x = 0; x < map_size_.width; ++x) {
      const int d = std::min({x, y, map_size_.width - 1 - x, map_size_.height - 1 - y});
      border_.at<float>(y, x) = d >= b ? 1.f : static_cast<float>(d + 1) / static_cast<float>(b + 1);
    }
  }
}

void IttiSaliency::build_pyramid(std::vector<cv::Mat>& pyr, Scratch& s, int from) {
  for (size_t l = static_cast<size_t>(from) + 1; l < pyr.size(); ++l) {
    downsample_stb(pyr[l - 1], pyr[l], s.down_tmp[l]);
  }
}

void IttiSaliency::normalise(cv::Mat& map, Scratch& s) {
  if (params_.normalisation == Normalisation::kLocalMax) {
    normalise_local_max(map);
  } else {
    // kernels_for: one cache per thread (a worker builds its own on its first frame)
    iterate_dog(map, params_, kernels_for(params_, map.size()), s.excit, s.inhib);
  }
}

void IttiSaliency::centre_surround_channel(const std::vector<cv::Mat>& pyr, cv::Mat& out, Scratch& sc) {
  fill_value(out, 0.f);
  const int ml = params_.map_level;
  // Every level a centre or a surround reads, at the map level once (= cv::resize INTER_AREA
  // below the map level, INTER_LINEAR above it, through precomputed tables); a level serves
  // several centre-surround pairs.
  auto at_map = [&](int l) -> const cv::Mat& {
    return l == ml ? pyr[static_cast<size_t>(ml)] : sc.at_map[static_cast<size_t>(l)];
  };
  for (int l = params_.centre_min; l <= params_.max_level(); ++l) {
    const bool used = l <= params_.centre_max || l >= params_.centre_min + params_.delta_min;
    if (l != ml && used)
      sc.to_map[static_cast<size_t>(l)].apply(pyr[static_cast<size_t>(l)], sc.at_map[static_cast<size_t>(l)]);
  }
  for (int c = params_.centre_min; c <= params_.centre_max; ++c) {
    for (int d = params_.delta_min; d <= params_.delta_max; ++d) {
      const cv::Mat &centre = at_map(c), &surround = at_map(c + d);
      for (int y = 0; y < map_size_.height; ++y) {  // |centre - surround| x border ramp
        const float *pc = centre.ptr<float>(y), *ps = surround.ptr<float>(y), *pb = border_.ptr<float>(y);
        float* o = sc.diff.ptr<float>(y);
        for (int x = 0; x < map_size_.width; ++x) o[x] = std::abs(pc[x] - ps[x]) * pb[x];
      }
      normalise(sc.diff, sc);
      for (int y = 0; y < map_size_.height; ++y) {
        const float* pd = sc.diff.ptr<float>(y);
        float* o = out.ptr<float>(y);
        for (int x = 0; x < map_size_.width; ++x) o[x] += pd[x];
      }
    }
  }
}

void IttiSaliency::intensity_job(bool colour) {
  Scratch& sc = scratch_[0];
  centre_surround_channel(intensity_pyr_, consp_.intensity, sc);
  normalise(consp_.intensity, sc);
  if (colour) {
    build_pyramid(rg_pyr_, sc);
    build_pyramid(by_pyr_, sc);
    centre_surround_channel(rg_pyr_, consp_.colour, sc);
    centre_surround_channel(by_pyr_, sc.acc, sc);
    consp_.colour += sc.acc;
    normalise(consp_.colour, sc);
  }
}

// Orientation t: Gabor energy of every needed intensity level, then its centre-surround map
// (normalised) in its scratch's acc.
void IttiSaliency::orientation_job(int t) {
  Scratch& sc = scratch_[static_cast<size_t>(1 + t)];
  auto& op = orient_pyr_[static_cast<size_t>(t)];
  for (int l = params_.centre_min; l <= params_.max_level(); ++l) {
    const size_t li = static_cast<size_t>(l);
    // |even| + |odd| with the filter2D correlation and BORDER_REPLICATE (own direct
    // convolution: cv::filter2D builds a filter engine on the heap at every call).
    if (!gabor_separable_.empty())
      gabor_energy(gabor_levels_[li], gabor_separable_[static_cast<size_t>(t)], op[li], sc.gabor_rows[li]);
    else
      gabor_energy(intensity_pyr_[li], gabor_even_[static_cast<size_t>(t)], gabor_odd_[static_cast<size_t>(t)], op[li],
                   sc.gabor_pad[li], sc.gabor_rows[li]);
  }
  centre_surround_channel(op, sc.acc, sc);
  normalise(sc.acc, sc);
}

void IttiSaliency::structure_job(const cv::Mat& height, int level) {
  Scratch& sc = scratch_[static_cast<size_t>(1 + params_.num_orientations)];
  cv::Mat& z0 = struct_pyr_[static_cast<size_t>(level)];
  height.convertTo(z0, CV_32F);
  // NaN / inf -> the mean of the finite values, then min-max to [0,1].
  double sum = 0.0, mn = std::numeric_limits<double>::max(), mx = -mn;
  long n = 0;
  for (int y = 0; y < z0.rows; ++y) {
    const float* p = z0.ptr<float>(y);
    for (int x = 0; x < z0.cols; ++x) {
      if (std::isfinite(p[x])) {
        sum += p[x];
        mn = std::min(mn, static_cast<double>(p[x]));
        mx = std::max(mx, static_cast<double>(p[x]));
        ++n;
      }
    }
  }
  const float fill = n > 0 ? static_cast<float>(sum / static_cast<double>(n)) : 0.f;
  for (int y = 0; y < z0.rows; ++y) {
    float* p = z0.ptr<float>(y);
    for (int x = 0; x < z0.cols; ++x) {
      if (!std::isfinite(p[x])) p[x] = fill;
    }
  }
  if (params_.structure_feature == StructureFeature::kSlope) {
    // = cv::Sobel(z0, ., CV_32F, 1, 0 / 0, 1, 3, 1/8, 0, BORDER_REPLICATE).
    correlate_replicate(z0, sobel_x_, tmp2_, sobel_pad_);
    correlate_replicate(z0, sobel_y_, tmp_, sobel_pad_);
    cv::magnitude(tmp2_, tmp_, z0);
    cv::minMaxLoc(z0, &mn, &mx);
  }
  if (mx - mn > 1e-12)
    z0.convertTo(z0, CV_32F, 1.0 / (mx - mn), -mn / (mx - mn));
  else
    fill_value(z0, 0.f);
  build_pyramid(struct_pyr_, sc, level);
  centre_surround_channel(struct_pyr_, consp_.structure, sc);
  normalise(consp_.structure, sc);
}

const Conspicuity& IttiSaliency::conspicuity(const cv::Mat& image, const cv::Mat& height) {
  if (image.empty()) throw std::invalid_argument("image: empty");
  const int ch = image.channels();
  if (ch != 1 && ch != 3 && ch != 4) {
    throw std::invalid_argument("image: must have 1, 3 or 4 channels (got " + std::to_string(ch) + ")");
  }
  const int min_side = params_.min_input_side();
  if (image.cols < min_side || image.rows < min_side) {
    throw std::invalid_argument("image: " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                                " is smaller than the pyramid needs (each side >= " + std::to_string(min_side) +
                                " px for " + std::to_string(params_.max_level() + 1) + " levels)");
  }
  prepare(image.size());
  // The heights enter the structure pyramid at the level of their size: the image's (0) or a
  // reduced one up to the first centre level (levels below it only build the ones above).
  int height_level = -1;
  if (!height.empty()) {
    for (int l = 0; l <= params_.centre_min && height_level < 0; ++l)
      if (height.size() == level_sizes_[static_cast<size_t>(l)]) height_level = l;
    if (height_level < 0) {
      const cv::Size q = level_sizes_[static_cast<size_t>(params_.centre_min)];
      throw std::invalid_argument("height: size " + std::to_string(height.cols) + "x" + std::to_string(height.rows) +
                                  " is neither the image's " + std::to_string(image.cols) + "x" +
                                  std::to_string(image.rows) + " nor a pyramid level's down to level " +
                                  std::to_string(params_.centre_min) + " (" + std::to_string(q.width) + "x" +
                                  std::to_string(q.height) + ")");
    }
    if (height.channels() != 1) throw std::invalid_argument("height: must have one channel");
  }
  // Intensity (and colour opponency) at level 0; a grey image is its own intensity.
  cv::Mat& i0 = intensity_pyr_[0];
  if (ch == 1) {
    to_unit_float(image, i0);
  } else {
    to_unit_float(image, bgr_);
    intensity_of(bgr_, i0);
  }
  const bool colour = params_.use_colour && ch >= 3;
  if (colour) {
    double gmax = 0.0;
    cv::minMaxLoc(i0, nullptr, &gmax);
    const float thr = static_cast<float>(params_.colour_lum_threshold * gmax);
    for (int y = 0; y < bgr_.rows; ++y) {
      const float* p = bgr_.ptr<float>(y);
      float* rg = rg_pyr_[0].ptr<float>(y);
      float* by = by_pyr_[0].ptr<float>(y);
      for (int x = 0; x < bgr_.cols; ++x) {
        const float b = p[x * ch], g = p[x * ch + 1], r = p[x * ch + 2];
        const float mx = std::max({r, g, b});
        if (mx > thr && mx > 0.f) {
          rg[x] = (r - g) / mx;
          by[x] = (b - std::min(r, g)) / mx;
        } else {
          rg[x] = 0.f;
          by[x] = 0.f;
        }
      }
    }
  }

  // The intensity pyramid feeds the orientation jobs: built first. Then every channel is an
  // independent job with its own scratch (run on par_ when given); the orientation maps are
  // summed in angle order afterwards, so the result does not depend on the thread count.
  build_pyramid(intensity_pyr_, scratch_[0]);
  const int n_orient = params_.num_orientations;
  if (n_orient > 0 && !gabor_separable_.empty())  // shared by the orientation jobs: made first
    for (int l = params_.centre_min; l <= params_.max_level(); ++l)
      gabor_levels_[static_cast<size_t>(l)].prepare(intensity_pyr_[static_cast<size_t>(l)], gabor_separable_[0]);
  const bool with_height = !height.empty();
  if (colour)
    consp_.colour.create(map_size_, CV_32F);
  else
    consp_.colour.release();
  if (with_height)
    consp_.structure.create(map_size_, CV_32F);
  else
    consp_.structure.release();
  const int jobs = 1 + n_orient + (with_height ? 1 : 0);
  parallel_for(par_, jobs, [&](int job) {
    if (job == 0)
      intensity_job(colour);
    else if (job <= n_orient)
      orientation_job(job - 1);
    else
      structure_job(height, height_level);
  });
  fill_value(consp_.orientation, 0.f);
  for (int t = 0; t < n_orient; ++t) consp_.orientation += scratch_[static_cast<size_t>(1 + t)].acc;
  normalise(consp_.orientation, scratch_[0]);
  return consp_;
}

void combine_conspicuity(const Conspicuity& c, const ChannelWeights& w, cv::Size out_size, cv::Mat& saliency,
                         cv::Mat& scratch) {
  w.validate();
  const std::pair<const cv::Mat*, double> parts[] = {
      {&c.intensity, w.intensity}, {&c.orientation, w.orientation}, {&c.colour, w.colour}, {&c.structure, w.structure}};
  bool first = true;
  for (const auto& [m, wt] : parts) {
    if (m->empty()) continue;
    if (first) {
      scratch.create(m->size(), CV_32F);
      scratch.setTo(0.0);
      first = false;
    }
    if (wt > 0.0) cv::scaleAdd(*m, wt, scratch, scratch);
  }
  if (first) throw std::invalid_argument("combine_conspicuity: no conspicuity maps");
  double mx = 0.0;
  cv::minMaxLoc(scratch, nullptr, &mx);
  if (mx > 0.0) scratch *= 1.0 / mx;
  cv::resize(scratch, saliency, out_size, 0, 0, cv::INTER_LINEAR);
  cv::threshold(saliency, saliency, 1.0, 1.0, cv::THRESH_TRUNC);
  cv::threshold(saliency, saliency, 0.0, 0.0, cv::THRESH_TOZERO);
}

void IttiSaliency::compute(const cv::Mat& image, const cv::Mat& height, cv::Mat& saliency) {
  const Conspicuity& c = conspicuity(image, height);
  // combine_conspicuity() into the pre-sized buffer, resized through the table built for
  // this input size (cv::resize allocates its coefficient tables at every call).
  const ChannelWeights& w = params_.weights;
  const std::pair<const cv::Mat*, double> parts[] = {
      {&c.intensity, w.intensity}, {&c.orientation, w.orientation}, {&c.colour, w.colour}, {&c.structure, w.structure}};
  fill_value(combined_, 0.f);
  for (const auto& [m, wt] : parts) {
    if (!m->empty() && wt > 0.0) cv::scaleAdd(*m, wt, combined_, combined_);
  }
  double mx = 0.0;
  cv::minMaxLoc(combined_, nullptr, &mx);
  if (mx > 0.0) combined_ *= 1.0 / mx;
  to_input_.apply(combined_, saliency, /*clamp_unit=*/true);  // into [0, 1] (NaN -> 0)
}

}  // namespace regolith::saliency
