// The trained rock model (trained.hpp, steps 3-4): scores, boxes and the pixel map (its file:
// model_file.cpp).
#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

#include "regolith/saliency/image_ops.hpp"
#include "regolith/saliency/trained.hpp"
#include "trained_forest.hpp"

namespace regolith::saliency {

TrainedModel::TrainedModel() = default;
TrainedModel::~TrainedModel() = default;
TrainedModel::TrainedModel(const TrainedModel&) = default;
TrainedModel& TrainedModel::operator=(const TrainedModel&) = default;

bool TrainedModel::trained() const {
  return forest_ && !forest_->roots.empty();
}

bool TrainedModel::has_pixel_stage() const {
  return pixel_forest_ && !pixel_forest_->roots.empty();
}

std::vector<float> TrainedModel::pixel_values_by_opencv(const cv::Mat& features) const {
  if (!has_pixel_stage() || !pixel_forest_->rtrees)
    throw std::logic_error("TrainedModel::pixel_values_by_opencv: no pixel forest as OpenCV trained it");
  cv::Mat y;
  pixel_forest_->rtrees->predict(features, y);
  return std::vector<float>(y.begin<float>(), y.end<float>());
}

cv::Mat feature_matrix(const std::vector<RockCandidate>& cands) {
  cv::Mat m(static_cast<int>(cands.size()), kFeatureCount, CV_32F);
  for (size_t i = 0; i < cands.size(); ++i)
    std::copy(cands[i].features.begin(), cands[i].features.end(), m.ptr<float>(static_cast<int>(i)));
  return m;
}

std::vector<float> TrainedModel::score(const CandidateSet& set) const {
  std::vector<float> out;
  score(set, out);
  return out;
}

void TrainedModel::score(const CandidateSet& set, std::vector<float>& scores) const {
  if (!trained()) throw std::logic_error("TrainedModel::score: no trained forest");
  scores.resize(set.candidates.size());
  for (std::size_t i = 0; i < set.candidates.size(); ++i)
    scores[i] = std::clamp(forest_->predict(set.candidates[i].features.data()), 0.0f, 1.0f);
}

std::vector<float> TrainedModel::score_by_opencv(const CandidateSet& set) const {
  if (!trained() || !forest_->rtrees)
    throw std::logic_error(
        "TrainedModel::score_by_opencv: no forest as OpenCV trained it (a model read from a file has none)");
  std::vector<float> out(set.candidates.size(), 0.0f);
  if (out.empty()) return out;
  const cv::Mat x = feature_matrix(set.candidates);
  cv::Mat y;
  forest_->rtrees->predict(x, y);
  for (int i = 0; i < x.rows; ++i) out[static_cast<size_t>(i)] = std::clamp(y.at<float>(i), 0.0f, 1.0f);
  return out;
}

std::vector<Detection> TrainedModel::select(const CandidateSet& set, const std::vector<float>& scores,
                                            const BoxParams& p) {
  std::vector<Detection> out;
  std::vector<std::uint32_t> order;
  out.reserve(set.candidates.size());
  order.reserve(set.candidates.size());
  select(set, scores, p, out, order);
  return out;
}

void TrainedModel::select(const CandidateSet& set, const std::vector<float>& scores, const BoxParams& p,
                          std::vector<Detection>& out, std::vector<std::uint32_t>& order) {
  const double threshold = p.score_threshold;
  const CrowdRule& crowd = p.crowd;
  out.clear();
  order.resize(set.candidates.size());
  std::iota(order.begin(), order.end(), std::uint32_t{0});
  // Descending score, ties in candidate order (std::sort does not allocate; stable_sort would).
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return scores[a] != scores[b] ? scores[a] > scores[b] : a < b; });
  // Below the threshold, a crowded image (crowd.count boxes kept above it) goes on to the crowd's.
  const bool crowd_lower = crowd.on() && crowd.threshold < threshold;
  for (std::uint32_t i : order) {
    if (scores[i] < threshold &&
        !(crowd_lower && scores[i] >= crowd.threshold && out.size() >= static_cast<std::size_t>(crowd.count)))
      break;
    const cv::Rect& b = set.candidates[i].box;
    const bool suppressed =
        std::any_of(out.begin(), out.end(), [&](const Detection& d) { return iou(d.box, b) > p.nms_iou; });
    if (suppressed) continue;
    out.push_back(Detection{b, scores[i], set.candidates[i].area});
  }
}

void TrainedModel::score_map(const CandidateSet& set, const std::vector<float>& scores, cv::Mat& map) {
  std::vector<int> spans;
  score_map(set, scores, map, spans);
}

void TrainedModel::score_map(const CandidateSet& set, const std::vector<float>& scores, cv::Mat& map,
                             std::vector<int>& spans) {
  map.create(set.size, CV_32F);
  for (int y = 0; y < map.rows; ++y) std::fill(map.ptr<float>(y), map.ptr<float>(y) + map.cols, 0.0f);
  if (set.sources <= 0) return;
  const float per_source = 1.0f / static_cast<float>(set.sources);
  spans.resize(2 * static_cast<std::size_t>(map.rows + map.cols));  // no-op once sized
  for (size_t i = 0; i < set.candidates.size(); ++i) {
    const RockCandidate& c = set.candidates[i];
    const float w = scores[i] * per_source;
    const int bx = c.box.x, by = c.box.y, bw = c.box.width, bh = c.box.height;
    // Per source of the candidate: its blob filled to the pixels that lie between the blob's
    // first and last pixel both along their row and along their column in the box (holes and
    // notches closed; the outline's outer bends kept, unlike a convex hull).
    int* row_first = spans.data();
    int* row_last = row_first + bh;
    int* col_first = row_last + bh;
    int* col_last = col_first + bw;
    for (unsigned bits = c.source_bits; bits != 0u; bits &= bits - 1u) {
      const unsigned bit = bits & (~bits + 1u);
      std::fill(row_first, row_first + bh, bw);
      std::fill(row_last, row_last + bh, -1);
      std::fill(col_first, col_first + bw, bh);
      std::fill(col_last, col_last + bw, -1);
      for (int y = 0; y < bh; ++y) {
        const uchar* sp = set.source_masks.ptr<uchar>(by + y) + bx;
        for (int x = 0; x < bw; ++x) {
          if ((sp[x] & bit) == 0u) continue;
          row_first[y] = std::min(row_first[y], x);
          row_last[y] = x;
          col_first[x] = std::min(col_first[x], y);
          col_last[x] = y;
        }
      }
      for (int y = 0; y < bh; ++y) {
        float* mp = map.ptr<float>(by + y) + bx;
        for (int x = row_first[y]; x <= row_last[y]; ++x)
          if (y >= col_first[x] && y <= col_last[x]) mp[x] += w;
      }
    }
  }
  for (int y = 0; y < map.rows; ++y)
    for (float* p = map.ptr<float>(y); p != map.ptr<float>(y) + map.cols; ++p) *p = std::min(*p, 1.0f);
}

void TrainedModel::BoxScratch::reserve(cv::Size map, std::size_t candidate_count) {
  order.reserve(candidate_count);
  if (map.empty()) return;
  // no-ops once sized: the words of any box of the map, the parts of the largest box
  above.create(map.height, map.width);
  parts.reserve(map.height, map.width);
  sums.reserve(static_cast<std::size_t>(map.height) * static_cast<std::size_t>((map.width + 1) / 2));
}

int TrainedModel::map_guide_radius_px(int image_width_px) const {
  const int working = candidates.working_width_px;
  if (working <= 0 || image_width_px <= 0) return kMapGuideRadiusPx;
  return std::max(1, static_cast<int>(std::lround(kMapGuideRadiusPx * static_cast<double>(image_width_px) / working)));
}

namespace {

// The scratch's filter at the options' radius (by the image's width unless set) and ridge,
// re-made when either differs; null for radius 0.
GuidedFilter* map_filter(const TrainedModel& m, int image_width_px, TrainedMapScratch& s, const TrainedMapOptions& o) {
  const int radius = o.guide_radius_px.value_or(m.map_guide_radius_px(image_width_px));
  if (radius <= 0) return nullptr;
  if (!s.guide || s.guide->radius() != radius || s.guide->eps() != o.guide_eps) s.guide.emplace(radius, o.guide_eps);
  return &*s.guide;
}

}  // namespace

void TrainedModel::guide_map(const cv::Mat& intensity, cv::Mat& map, TrainedMapScratch& scratch,
                             const TrainedMapOptions& o) const {
  if (GuidedFilter* filter = map_filter(*this, map.cols, scratch, o)) filter->apply(intensity, map, map, 0.0f, 1.0f);
}

void TrainedModel::pixel_stage(const cv::Mat& intensity, cv::Mat& map, TrainedMapScratch& scratch,
                               const TrainedMapOptions& o) const {
  if (!o.pixel_stage || !has_pixel_stage()) return;
  PixelStage& stage = scratch.stage;
  stage.compute(intensity, map, pixel_grid_size(map.size(), candidates.working_width_px));
  // cells: continuous (made by create()), one value per feature row
  pixel_forest_->predict_rows(stage.features(), stage.sums(), stage.cells().ptr<float>(0));
  stage.upsample(intensity, map, map_filter(*this, map.cols, scratch, o));
}

void TrainedModel::finish_map(const cv::Mat& intensity, cv::Mat& map, TrainedMapScratch& scratch,
                              const TrainedMapOptions& o) const {
  guide_map(intensity, map, scratch, o);
  pixel_stage(intensity, map, scratch, o);
}

void TrainedModel::refine(const cv::Mat& map, double fraction, std::vector<Detection>& dets, BoxScratch& scratch) {
  if (!(fraction > 0.0) || dets.empty()) return;
  CV_Assert(map.type() == CV_32FC1);
  const cv::Rect frame(0, 0, map.cols, map.rows);
  for (Detection& d : dets) {
    const cv::Rect roi = d.box & frame;
    if (roi.empty()) continue;
    float peak = 0.f;
    for (int y = roi.y; y < roi.br().y; ++y)
      for (const float* p = map.ptr<float>(y) + roi.x; p != map.ptr<float>(y) + roi.br().x; ++p)
        peak = std::max(peak, *p);
    if (!(peak > 0.f)) continue;
    const auto cut = static_cast<float>(fraction * peak);
    BitMask& above = scratch.above;
    above.create(roi.height, roi.width);
    for (int y = 0; y < roi.height; ++y) {
      const float* p = map.ptr<float>(roi.y + y) + roi.x;
      std::uint64_t* bits = above.row(y);
      std::fill(bits, bits + above.words(), std::uint64_t{0});
      for (int x = 0; x < roi.width; ++x)
        if (p[x] >= cut) bits[x / 64] |= std::uint64_t{1} << (x % 64);
    }
    const int n = scratch.parts.run(above);
    scratch.sums.assign(static_cast<std::size_t>(n), 0.0);
    scratch.parts.for_each_run([&](int part, int row, int begin, int end) {
      const float* p = map.ptr<float>(roi.y + row) + roi.x;
      double& sum = scratch.sums[static_cast<std::size_t>(part)];
      for (int x = begin; x < end; ++x) sum += static_cast<double>(p[x]);
    });
    const auto best = std::max_element(scratch.sums.begin(), scratch.sums.end());  // the first of equal sums
    if (best == scratch.sums.end() || !(*best > 0.0)) continue;
    const std::array<int, 5>& st = scratch.parts.stats(static_cast<int>(best - scratch.sums.begin()));
    d.box = cv::Rect(roi.x + st[0], roi.y + st[1], st[2], st[3]);
  }
}

void TrainedModel::boxes(const CandidateSet& set, const std::vector<float>& scores, const cv::Mat& map,
                         const BoxParams& p, std::vector<Detection>& out, BoxScratch& scratch) {
  select(set, scores, p, out, scratch.order);
  refine(map, p.refine_fraction, out, scratch);
}

std::vector<Detection> TrainedModel::detect(const CandidateSet& set) const {
  const std::vector<float> s = score(set);
  cv::Mat map;
  if (box.refine_fraction > 0.0) score_map(set, s, map);
  std::vector<Detection> out;
  BoxScratch scratch;
  boxes(set, s, map, box, out, scratch);
  return out;
}

}  // namespace regolith::saliency
