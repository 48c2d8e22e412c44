// The trained rock detector's pixel stage (pixel_stage.hpp): its features and grid.
#include "regolith/saliency/pixel_stage.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace regolith::saliency {

const std::vector<std::string>& pixel_feature_names() {
  static const std::vector<std::string> names{
      "map",              // the guided map at the cell
      "map_blur1",        // ... smoothed by a Gaussian of 1 / 4 / 8 cells
      "map_blur4",        //
      "map_blur8",        //
      "map_minus_blur4",  // the map's local peak
      "intensity",        // the cell's intensity, normalised by the image's mean and std
      "contrast1",        // intensity minus its Gaussian surround of 1 / 4 / 16 cells
      "contrast4",        //
      "contrast16",       //
      "gradient",         // Sobel magnitude of the normalised intensity
      "gradient_blur2",   // ... smoothed by 2 cells: the texture around
      "local_std1",       // the intensity's standard deviation in a Gaussian window of 1 cell
      "row_fraction",     // the cell's row / the grid's height (0 at the top)
  };
  return names;
}

cv::Size pixel_grid_size(cv::Size map_size, int working_width_px) {
  if (map_size.width < 1 || map_size.height < 1) throw std::invalid_argument("pixel_grid_size: empty map");
  const double across = (working_width_px > 0 ? working_width_px : map_size.width) / double{kPixelGridDivisor};
  const int w = std::clamp(static_cast<int>(std::lround(across)), 1, map_size.width);
  const int h =
      std::clamp(static_cast<int>(std::lround(across * map_size.height / map_size.width)), 1, map_size.height);
  return {w, h};
}

void PixelStage::compute(const cv::Mat& intensity, const cv::Mat& map, cv::Size grid) {
  if (map.empty() || map.type() != CV_32FC1) throw std::invalid_argument("PixelStage: the map must be CV_32FC1");
  if (intensity.size() != map.size() || (intensity.type() != CV_32FC1 && intensity.type() != CV_8UC1))
    throw std::invalid_argument("PixelStage: the intensity must be CV_32FC1 or CV_8UC1 of the map's size");
  if (grid.width < 1 || grid.height < 1 || grid.width > map.cols || grid.height > map.rows)
    throw std::invalid_argument("PixelStage: the grid must be 1 x 1 to the map's size");
  if (map.size() != map_size_ || grid != grid_) {
    down_.build(map.size(), grid, ResizeTable::Mode::kArea);
    up_.build(grid, map.size(), ResizeTable::Mode::kLinear);
    map_size_ = map.size();
    grid_ = grid;
  }
  const cv::Mat* in = &intensity;
  if (intensity.type() == CV_8UC1) {
    intensity.convertTo(unit_, CV_32F, 1.0 / 255.0);  // into unit_'s buffer once it has the size
    in = &unit_;
  }
  down_.apply(*in, i_);
  down_.apply(map, g_);
  // the intensity normalised by the image's own mean and standard deviation
  double sum = 0.0, sum2 = 0.0;
  for (int y = 0; y < grid.height; ++y) {
    const float* p = i_.ptr<float>(y);
    for (int x = 0; x < grid.width; ++x) sum += p[x], sum2 += double{p[x]} * p[x];
  }
  const double n = grid.area();
  const double mean = sum / n, sd = std::sqrt(std::max(0.0, sum2 / n - mean * mean));
  const float scale = static_cast<float>(1.0 / std::max(sd, 1e-3)), shift = static_cast<float>(mean);
  ii_.create(grid, CV_32F);
  for (int y = 0; y < grid.height; ++y) {
    float* p = i_.ptr<float>(y);
    float* q = ii_.ptr<float>(y);
    for (int x = 0; x < grid.width; ++x) {
      p[x] = (p[x] - shift) * scale;
      q[x] = p[x] * p[x];
    }
  }
  blur1_.apply(g_, g1_, 1.0);
  blur4_.apply(g_, g4_, 4.0);
  blur8_.apply(g_, g8_, 8.0);
  blur1_.apply(i_, i1_, 1.0);
  blur4_.apply(i_, i4_, 4.0);
  blur16_.apply(i_, i16_, 16.0);
  blur1_.apply(ii_, ii1_, 1.0);
  sobel3_32f(i_, gx_, gy_, 1.0f);
  grad_.create(grid, CV_32F);
  for (int y = 0; y < grid.height; ++y) {
    const float* a = gx_.ptr<float>(y);
    const float* b = gy_.ptr<float>(y);
    float* o = grad_.ptr<float>(y);
    for (int x = 0; x < grid.width; ++x) o[x] = std::sqrt(a[x] * a[x] + b[x] * b[x]);
  }
  blur2_.apply(grad_, grad2_, 2.0);
  features_.create(grid.area(), kPixelFeatureCount, CV_32F);
  const float inv_h = 1.0f / static_cast<float>(grid.height);
  for (int y = 0; y < grid.height; ++y) {
    const float *g = g_.ptr<float>(y), *g1 = g1_.ptr<float>(y), *g4 = g4_.ptr<float>(y), *g8 = g8_.ptr<float>(y);
    const float *i = i_.ptr<float>(y), *i1 = i1_.ptr<float>(y), *i4 = i4_.ptr<float>(y), *i16 = i16_.ptr<float>(y);
    const float *ii1 = ii1_.ptr<float>(y), *gr = grad_.ptr<float>(y), *gr2 = grad2_.ptr<float>(y);
    for (int x = 0; x < grid.width; ++x) {
      float* f = features_.ptr<float>(y * grid.width + x);
      f[0] = g[x];
      f[1] = g1[x];
      f[2] = g4[x];
      f[3] = g8[x];
      f[4] = g[x] - g4[x];
      f[5] = i[x];
      f[6] = i[x] - i1[x];
      f[7] = i[x] - i4[x];
      f[8] = i[x] - i16[x];
      f[9] = gr[x];
      f[10] = gr2[x];
      f[11] = std::sqrt(std::max(0.0f, ii1[x] - i1[x] * i1[x]));
      f[12] = static_cast<float>(y) * inv_h;
    }
  }
  cells_.create(grid, CV_32F);
  sums_.resize(static_cast<std::size_t>(grid.area()));  // no-op once sized
}

void PixelStage::upsample(const cv::Mat& intensity, cv::Mat& map, GuidedFilter* guide) {
  if (cells_.size() != grid_ || up_.dst_size() != map_size_)
    throw std::logic_error("PixelStage::upsample before compute()");
  up_.apply(cells_, map, true);
  if (guide) guide->apply(intensity, map, map, 0.0f, 1.0f);
}

}  // namespace regolith::saliency
