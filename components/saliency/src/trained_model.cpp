// The trained rock model (trained.hpp, steps 3-4): scores, boxes, the pixel map and the model file.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <numeric>
#include <string>
#include <vector>

#include <zlib.h>

#include "regolith/core/csv.hpp"
#include "regolith/saliency/image_ops.hpp"
#include "regolith/saliency/trained.hpp"
#include "trained_forest.hpp"

#ifndef REGOLITH_ROCKS_MODEL_SOURCE
#define REGOLITH_ROCKS_MODEL_SOURCE ""
#endif
#ifndef REGOLITH_ROCKS_MODEL_INSTALLED
#define REGOLITH_ROCKS_MODEL_INSTALLED ""
#endif

namespace regolith::saliency {

TrainedModel::TrainedModel() = default;
TrainedModel::~TrainedModel() = default;
TrainedModel::TrainedModel(const TrainedModel&) = default;
TrainedModel& TrainedModel::operator=(const TrainedModel&) = default;

bool TrainedModel::trained() const {
  return forest_ && forest_->rtrees && forest_->rtrees->isTrained();
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
  if (!trained()) throw std::logic_error("TrainedModel::score_by_opencv: no trained forest");
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

void TrainedModel::guide_map(const cv::Mat& intensity, cv::Mat& map, GuidedFilter& filter) {
  filter.apply(intensity, map, map, 0.0f, 1.0f);
}

int TrainedModel::map_guide_radius_px(int image_width_px) const {
  const int working = candidates.working_width_px;
  if (working <= 0 || image_width_px <= 0) return kMapGuideRadiusPx;
  return std::max(1, static_cast<int>(std::lround(kMapGuideRadiusPx * static_cast<double>(image_width_px) / working)));
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

void TrainedModel::save(const std::string& path) const {
  if (!trained()) throw ModelError(path + ": cannot save an untrained model");
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
    if (!fs.isOpened()) throw ModelError(path + ": cannot open for writing");
    fs << "format" << kTrainedModelFormat;
    fs << "version" << kTrainedModelVersion;
    fs << "feature_count" << kFeatureCount;
    fs << "features"
       << "[";
    for (const auto& n : feature_names()) fs << n;
    fs << "]";
    fs << "candidates"
       << "{";
    fs << "coarse_sigma_px" << candidates.coarse.sigma_px << "coarse_smooth_px" << candidates.coarse.smooth_sigma_px;
    fs << "fine_sigma_px" << candidates.fine.sigma_px << "fine_smooth_px" << candidates.fine.smooth_sigma_px;
    fs << "coarse_scales" << candidates.coarse_scales << "fine_scales" << candidates.fine_scales;
    fs << "chroma_sigma_px" << candidates.chroma.sigma_px << "chroma_smooth_px" << candidates.chroma.smooth_sigma_px;
    fs << "chroma_scales" << candidates.chroma_scales;
    fs << "min_area_px" << candidates.min_area << "open_radius_px" << candidates.open_radius << "close_radius_px"
       << candidates.close_radius;
    fs << "working_width_px" << candidates.working_width_px;
    fs << "}";
    fs << "score_threshold" << box.score_threshold << "nms_iou" << box.nms_iou << "box_refine_fraction"
       << box.refine_fraction;
    fs << "crowd_count" << box.crowd.count << "crowd_threshold" << box.crowd.threshold;
    fs << "training_images" << training_images << "training_samples" << training_samples << "training_positives"
       << training_positives;
    fs << "forest"
       << "{";
    forest_->rtrees->write(fs);
    fs << "}";
    fs.release();
  } catch (const cv::Exception& e) {
    throw ModelError(path + ": cannot write model (" + trim_blanks(e.msg) + ")");
  }
  if (!std::filesystem::is_regular_file(path)) throw ModelError(path + ": model file not written");
}

namespace {

// The model in an open FileStorage; `path` names it in every error. What OpenCV throws while
// reading is turned into a ModelError by parse().
TrainedModel read_model(const cv::FileStorage& fs, const std::string& path) {
  TrainedModel m;
  const std::string format = fs["format"].isString() ? static_cast<std::string>(fs["format"]) : "";
  if (format != kTrainedModelFormat)
    throw ModelError(path + ": not a regolith rock model (format '" + format + "', expected '" + kTrainedModelFormat +
                     "')");
  const int version = fs["version"].isInt() ? static_cast<int>(fs["version"]) : -1;
  if (version != kTrainedModelVersion)
    throw ModelError(path + ": rock model version " + std::to_string(version) + ", this build reads version " +
                     std::to_string(kTrainedModelVersion) + " (re-train with `regolith train rocks`)");
  if (static_cast<int>(fs["feature_count"]) != kFeatureCount)
    throw ModelError(path + ": rock model has " + std::to_string(static_cast<int>(fs["feature_count"])) +
                     " features, this build computes " + std::to_string(kFeatureCount));
  const cv::FileNode c = fs["candidates"];
  if (!c.isMap()) throw ModelError(path + ": rock model: missing 'candidates'");
  m.candidates.coarse.sigma_px = static_cast<double>(c["coarse_sigma_px"]);
  m.candidates.coarse.smooth_sigma_px = static_cast<double>(c["coarse_smooth_px"]);
  m.candidates.fine.sigma_px = static_cast<double>(c["fine_sigma_px"]);
  m.candidates.fine.smooth_sigma_px = static_cast<double>(c["fine_smooth_px"]);
  c["coarse_scales"] >> m.candidates.coarse_scales;
  c["fine_scales"] >> m.candidates.fine_scales;
  m.candidates.chroma.sigma_px = static_cast<double>(c["chroma_sigma_px"]);
  m.candidates.chroma.smooth_sigma_px = static_cast<double>(c["chroma_smooth_px"]);
  c["chroma_scales"] >> m.candidates.chroma_scales;
  m.candidates.min_area = static_cast<int>(c["min_area_px"]);
  m.candidates.open_radius = static_cast<int>(c["open_radius_px"]);
  m.candidates.close_radius = static_cast<int>(c["close_radius_px"]);
  // absent in models written before 2026-11-28: each image at its own size, as they were trained
  m.candidates.working_width_px = c["working_width_px"].isInt() ? static_cast<int>(c["working_width_px"]) : 0;
  try {
    m.candidates.validate();
  } catch (const std::invalid_argument& e) {
    throw ModelError(path + ": rock model: " + e.what());
  }
  BoxParams& b = m.box;
  b.score_threshold = static_cast<double>(fs["score_threshold"]);
  b.nms_iou = static_cast<double>(fs["nms_iou"]);
  if (!(b.score_threshold >= 0.0 && b.score_threshold <= 1.0) || !(b.nms_iou > 0.0 && b.nms_iou <= 1.0))
    throw ModelError(path + ": rock model: score_threshold / nms_iou out of range");
  // absent in models written before 2026-12-06: the boxes as selected
  b.refine_fraction = fs["box_refine_fraction"].empty() ? 0.0 : static_cast<double>(fs["box_refine_fraction"]);
  if (!(b.refine_fraction >= 0.0 && b.refine_fraction < 1.0))
    throw ModelError(path + ": rock model: box_refine_fraction must be in [0, 1)");
  if (!fs["crowd_count"].empty()) {  // models written before 2026-12-07: no crowd rule
    b.crowd.count = static_cast<int>(fs["crowd_count"]);
    if (fs["crowd_threshold"].empty())
      throw ModelError(path + ": rock model: crowd_count without crowd_threshold (both or neither)");
    b.crowd.threshold = static_cast<double>(fs["crowd_threshold"]);
    if (b.crowd.count < 0) throw ModelError(path + ": rock model: crowd_count must be >= 0");
    if (!(b.crowd.threshold >= 0.0 && b.crowd.threshold <= 1.0))
      throw ModelError(path + ": rock model: crowd_threshold must be in [0, 1]");
  }
  m.training_images = static_cast<int>(fs["training_images"]);
  m.training_samples = static_cast<int>(fs["training_samples"]);
  m.training_positives = static_cast<int>(fs["training_positives"]);
  const cv::FileNode f = fs["forest"];
  if (!f.isMap()) throw ModelError(path + ": rock model: missing 'forest'");
  m.forest_ = std::make_shared<TrainedModel::Forest>();
  m.forest_->rtrees = cv::ml::RTrees::create();
  m.forest_->rtrees->read(f);
  if (!m.forest_->rtrees->isTrained() || m.forest_->rtrees->getVarCount() != kFeatureCount)
    throw ModelError(path + ": rock model: the forest is empty or has the wrong input size");
  m.forest_->flatten();
  return m;
}

// The model file's bytes, gzip-decompressed when they are gzip (zlib's reader passes other files
// through), at most kMaxModelBytes.
constexpr std::size_t kMaxModelBytes = std::size_t{256} << 20;
std::string read_model_text(const std::string& path) {
  gzFile f = gzopen(path.c_str(), "rb");
  if (f == nullptr) throw ModelError(path + ": cannot read rock model file");
  std::string text;
  std::vector<char> buf(1 << 16);
  int n = 0;
  while ((n = gzread(f, buf.data(), static_cast<unsigned>(buf.size()))) > 0) {
    text.append(buf.data(), static_cast<std::size_t>(n));
    if (text.size() > kMaxModelBytes) {
      gzclose(f);
      throw ModelError(path + ": rock model file larger than " + std::to_string(kMaxModelBytes >> 20) + " MB");
    }
  }
  int err = Z_OK;
  const std::string why = n < 0 ? gzerror(f, &err) : "";
  gzclose(f);
  if (n < 0) throw ModelError(path + ": corrupt rock model file (" + why + ")");
  return text;
}

// What OpenCV's YAML reader is given: a model file begins with its %YAML header, its top level is
// a map (the first line after the header, and "---", starts with a key at column 0), it has no
// NUL byte, and its flow collections ({ } and [ ], outside quoted strings and comments) close in
// order. OpenCV 4.6's reader loops for ever on a top-level sequence indented by a space or more
// and followed by a line less indented ("%YAML:1.\n   -h\n}\n " and "...\n.\n ": found by
// the rock_model fuzz target), so such text is refused before it runs.
void check_model_text(const std::string& text, const std::string& path) {
  const auto corrupt = [&](const std::string& why, std::size_t at) {
    const long line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n');
    throw ModelError(path + ": corrupt rock model file (" + why + " on line " + std::to_string(line) + ")");
  };
  if (text.rfind("%YAML", 0) != 0) corrupt("no %YAML header", 0);
  std::size_t first = text.find('\n');  // the line after the header
  if (first != std::string::npos && text.compare(first + 1, 3, "---") == 0) first = text.find('\n', first + 1);
  if (first == std::string::npos || first + 1 >= text.size()) corrupt("no content after the header", text.size());
  std::size_t key = first + 1;
  const auto key_char = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; };
  while (key < text.size() && key_char(text[key])) ++key;
  if (key == first + 1 || key >= text.size() || text[key] != ':') corrupt("the top level is not a map", first + 1);
  std::vector<char> open;
  bool quoted = false, comment = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char ch = text[i];
    if (ch == '\0') corrupt("a NUL byte", i);
    if (comment) {
      comment = ch != '\n';
      continue;
    }
    if (quoted) {
      if (ch == '\\')
        ++i;  // the escaped character
      else if (ch == '"')
        quoted = false;
      continue;
    }
    if (ch == '"') {
      quoted = true;
    } else if (ch == '#' && (i == 0 || text[i - 1] == ' ' || text[i - 1] == '\t' || text[i - 1] == '\n')) {
      comment = true;
    } else if (ch == '{' || ch == '[') {
      open.push_back(ch);
    } else if (ch == '}' || ch == ']') {
      if (open.empty() || open.back() != (ch == '}' ? '{' : '[')) corrupt(std::string("an unmatched '") + ch + "'", i);
      open.pop_back();
    }
  }
  if (quoted) corrupt("an unclosed string", text.size());
  if (!open.empty()) corrupt(std::string("an unclosed '") + open.back() + "'", text.size());
}

}  // namespace

TrainedModel TrainedModel::load(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw ModelError(path + ": rock model file not found");
  return parse(read_model_text(path), path);
}

TrainedModel TrainedModel::parse(const std::string& text, const std::string& name) {
  check_model_text(text, name);
  try {
    cv::FileStorage fs;
    fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
    if (!fs.isOpened()) throw ModelError(name + ": cannot read rock model file");
    return read_model(fs, name);
  } catch (const ModelError&) {
    throw;
  } catch (const std::runtime_error& e) {  // Forest::flatten
    throw ModelError(name + ": " + e.what());
  } catch (const cv::Exception& e) {
    throw ModelError(name + ": corrupt rock model file (" + trim_blanks(e.msg) + ")");
  } catch (const std::exception& e) {  // OpenCV's reader also lets std::length_error out (rock_model fuzz target)
    throw ModelError(name + ": corrupt rock model file (" + e.what() + ")");
  }
}

std::string default_trained_model_path() {
  const std::string src = REGOLITH_ROCKS_MODEL_SOURCE;
  if (!src.empty() && std::filesystem::is_regular_file(src)) return src;
  const std::string inst = REGOLITH_ROCKS_MODEL_INSTALLED;
  if (!inst.empty()) return inst;
  return src;
}

}  // namespace regolith::saliency
