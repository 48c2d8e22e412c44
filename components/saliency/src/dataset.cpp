#include "regolith/saliency/dataset.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/core/image_file.hpp"
#include "regolith/saliency/image_ops.hpp"

namespace regolith::saliency {

namespace fs = std::filesystem;

namespace {
std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}
bool is_image_ext(const std::string& ext) {
  static const char* exts[] = {".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff",
                               ".pgm", ".ppm",  ".pbm", ".pnm", ".webp"};
  const std::string e = lower(ext);
  return std::any_of(std::begin(exts), std::end(exts), [&](const char* x) { return e == x; });
}
}  // namespace

std::vector<std::string> list_images(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw DataError(dir + ": not a directory");
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.is_regular_file() && is_image_ext(e.path().extension().string())) out.push_back(e.path().string());
  }
  if (ec) throw DataError(dir + ": " + ec.message());
  std::sort(out.begin(), out.end());
  return out;
}

DatasetListing list_dataset(const std::string& images_dir, const std::string& masks_dir) {
  std::error_code ec;
  if (!fs::is_directory(images_dir, ec)) throw DataError(images_dir + ": not a directory (--images)");
  if (!fs::is_directory(masks_dir, ec)) throw DataError(masks_dir + ": not a directory (--masks)");
  DatasetListing out;
  std::vector<std::string> images;
  try {
    images = list_images(images_dir);
  } catch (const DataError& e) {
    out.errors.push_back(e.what());
  }
  for (const std::string& path : images) {  // sorted by path = by name (one directory)
    const fs::path image(path);
    DatasetItem it;
    it.name = image.filename().string();
    it.image_path = path;
    it.mask_path = (fs::path(masks_dir) / (image.stem().string() + ".png")).string();
    if (!fs::exists(it.mask_path, ec)) {
      out.errors.push_back(it.mask_path + ": no mask for image " + it.image_path);
      continue;
    }
    out.items.push_back(std::move(it));
  }
  return out;
}

namespace {

/// The file's samples as stored (a mask's labels are not rescaled).
cv::Mat read_stored(const std::string& path) {
  std::string why;
  cv::Mat img = regolith::read_image_file(path, cv::IMREAD_UNCHANGED, &why);
  if (img.empty()) throw DataError(path + ": " + why);
  if (img.cols < kMinImageSide || img.rows < kMinImageSide)
    throw DataError(path + ": image is " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
                    " px, too small (at least " + std::to_string(kMinImageSide) + "x" + std::to_string(kMinImageSide) +
                    ")");
  return img;
}

}  // namespace

cv::Mat read_image(const std::string& path) {
  const cv::Mat img = read_stored(path);
  cv::Mat out = regolith::to_8bit(img);
  if (out.empty())
    throw DataError(path + ": samples of a type regolith does not read (depth " + std::to_string(img.depth()) + ")");
  return out;
}

FrameTruth read_truth(const std::string& mask_path, cv::Size image_size, int min_gt_area) {
  cv::Mat m = read_stored(mask_path);
  if (m.size() != image_size) {
    throw DataError(mask_path + ": mask is " + std::to_string(m.cols) + "x" + std::to_string(m.rows) +
                    " but its image is " + std::to_string(image_size.width) + "x" + std::to_string(image_size.height));
  }
  cv::Mat first;
  if (m.channels() > 1)
    cv::extractChannel(m, first, 0);
  else
    first = m;
  cv::Mat bin;
  cv::compare(first, 0, bin, cv::CMP_GT);
  try {
    return truth_from_mask(bin, min_gt_area);
  } catch (const std::invalid_argument& e) {
    throw DataError(mask_path + ": " + e.what());
  }
}

int median_image_width(const std::vector<DatasetItem>& items) {
  std::vector<int> widths;
  for (const auto& item : items) {
    try {
      widths.push_back(read_image(item.image_path).cols);
    } catch (const DataError&) {
      // left out: whoever reads the set names the file
    }
  }
  if (widths.empty()) return 0;
  std::nth_element(widths.begin(), widths.begin() + static_cast<long>(widths.size() / 2), widths.end());
  return widths[widths.size() / 2];
}

std::string sol_group(const std::string& name) {
  size_t begin = 0;
  while (begin <= name.size()) {
    size_t end = name.find('_', begin);
    if (end == std::string::npos) end = name.size();
    const std::string token = name.substr(begin, end - begin);
    const bool digits = !token.empty() && std::all_of(token.begin(), token.end(), [](char c) {
      return std::isdigit(static_cast<unsigned char>(c)) != 0;
    });
    // The last token holds the extension ("..._DXXX.jpg"): never a number.
    if (digits && end < name.size()) {
      const size_t nz = token.find_first_not_of('0');
      return nz == std::string::npos ? std::string("0") : token.substr(nz);
    }
    begin = end + 1;
  }
  return name;
}

std::vector<int> grouped_folds(const std::vector<std::string>& groups, int k) {
  if (k < 2) throw std::invalid_argument("grouped_folds: k must be >= 2");
  std::map<std::string, std::vector<size_t>> members;
  for (size_t i = 0; i < groups.size(); ++i) members[groups[i]].push_back(i);
  if (members.size() < static_cast<size_t>(k)) {
    throw std::invalid_argument("grouped_folds: " + std::to_string(members.size()) + " group(s) (sols) < " +
                                std::to_string(k) + " folds");
  }
  std::vector<std::pair<std::string, std::vector<size_t>>> order(members.begin(), members.end());
  const auto is_number = [](const std::string& s) {
    return !s.empty() &&
           std::all_of(s.begin(), s.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; });
  };
  std::stable_sort(order.begin(), order.end(), [&](const auto& a, const auto& b) {
    if (a.second.size() != b.second.size()) return a.second.size() > b.second.size();
    if (is_number(a.first) && is_number(b.first) && a.first.size() != b.first.size())
      return a.first.size() < b.first.size();  // no leading zeros: shorter = smaller
    return a.first < b.first;
  });
  std::vector<int> fold(groups.size(), 0);
  std::vector<size_t> load(static_cast<size_t>(k), 0);
  for (const auto& [key, idx] : order) {
    const size_t f = static_cast<size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    load[f] += idx.size();
    for (size_t i : idx) fold[i] = static_cast<int>(f);
  }
  return fold;
}

void StudyConfig::validate() const {
  itti.validate();
  itti_weights.validate();
  post.validate();
  if (min_gt_area < 0) throw std::invalid_argument("StudyConfig.min_gt_area: must be >= 0 px");
  if (folds < 2) throw std::invalid_argument("StudyConfig.folds: must be >= 2");
  if (!(weight_step > 0.0 && weight_step <= 1.0)) {
    throw std::invalid_argument("StudyConfig.weight_step: must be in (0,1]");
  }
  if (threshold_scales.empty()) {
    throw std::invalid_argument("StudyConfig.threshold_scales: must not be empty");
  }
  for (double s : threshold_scales) {
    if (!(s > 0.0 && s <= 10.0)) {
      throw std::invalid_argument("StudyConfig.threshold_scales: values must be in (0,10]");
    }
  }
  contrast.validate();
  contrast_post.validate();
  if (contrast_sigmas.empty() || contrast_smooth_sigmas.empty() || contrast_threshold_scales.empty() ||
      contrast_min_areas.empty()) {
    throw std::invalid_argument("StudyConfig.contrast_*: the contrast grid lists must not be empty");
  }
  for (double sg : contrast_sigmas) ContrastParams{sg, 0.0}.validate();
  for (double sm : contrast_smooth_sigmas) ContrastParams{1.0, sm}.validate();
  for (double sc : contrast_threshold_scales) {
    if (!(sc > 0.0 && sc <= 10.0)) {
      throw std::invalid_argument("StudyConfig.contrast_threshold_scales: values must be in (0,10]");
    }
  }
  for (int a : contrast_min_areas) {
    if (a < 1) throw std::invalid_argument("StudyConfig.contrast_min_areas: values must be >= 1 px");
  }
}

std::string Candidate::describe(Method m) const {
  char buf[160];
  if (m == Method::kSams || m == Method::kItti) {
    std::snprintf(buf, sizeof buf, "w_I=%.2f w_O=%.2f w_C=%.2f w_Z=%.2f, Otsu x%.2f", weights.intensity,
                  weights.orientation, weights.colour, weights.structure, threshold_scale);
  } else if (m == Method::kContrast) {
    std::snprintf(buf, sizeof buf, "sigma=%g px smooth=%g px, Otsu x%.2f", contrast.sigma_px, contrast.smooth_sigma_px,
                  threshold_scale);
  } else {
    std::snprintf(buf, sizeof buf, "Otsu x%.2f", threshold_scale);
  }
  std::string out = buf;
  if (min_area) out += ", min area " + std::to_string(*min_area) + " px";
  return out;
}

Candidate CvResult::most_chosen() const {
  if (chosen.empty()) throw std::logic_error("CvResult::most_chosen: no folds");
  size_t best = 0, best_count = 0;
  for (size_t i = 0; i < chosen.size(); ++i) {
    const size_t n = static_cast<size_t>(std::count(chosen.begin(), chosen.end(), chosen[i]));
    if (n > best_count) {
      best_count = n;
      best = i;
    }
  }
  return chosen[best];
}

RockStudy::RockStudy(StudyConfig config, HeightFn height)
    : config_(std::move(config)),
      height_(std::move(height)),
      itti_(config_.itti),
      sr_(Method::kSpectralResidual),
      fg_(Method::kFineGrained) {
  config_.validate();
}

void RockStudy::add(const DatasetItem& item) {
  Frame f;
  f.name = item.name;
  f.group = sol_group(item.name);
  const cv::Mat img = read_image(item.image_path);
  f.size = img.size();
  f.truth = read_truth(item.mask_path, img.size(), config_.min_gt_area);
  try {
    cv::Mat h;
    if (height_) {
      height_(img, height_buf_);
      h = height_buf_;
    }
    const Conspicuity& c = itti_.conspicuity(img, h);
    f.consp.intensity = c.intensity.clone();
    f.consp.orientation = c.orientation.clone();
    if (!c.colour.empty()) f.consp.colour = c.colour.clone();
    if (!c.structure.empty()) f.consp.structure = c.structure.clone();
    sr_.compute(img, f.sr);
    fg_.compute(img, f.fg);
    to_unit_float(img, unit_);
    intensity_of(unit_, f.intensity);
  } catch (const std::exception& e) {
    throw DataError(item.image_path + ": " + e.what());
  }
  frames_.push_back(std::move(f));
}

void RockStudy::saliency(size_t k, Method m, const Candidate& cand, cv::Mat& out) {
  const Frame& f = frames_.at(k);
  const ChannelWeights& w = cand.weights;
  switch (m) {
    case Method::kSams: {
      if (f.consp.structure.empty()) {
        throw std::logic_error("SAMS needs a height map: no HeightFn (regolith::sfs) configured");
      }
      combine_conspicuity(f.consp, w, f.size, out, scratch_);
      break;
    }
    case Method::kItti: {
      Conspicuity c = f.consp;
      c.structure = cv::Mat();
      combine_conspicuity(c, w, f.size, out, scratch_);
      break;
    }
    case Method::kSpectralResidual: f.sr.copyTo(out); break;
    case Method::kFineGrained: f.fg.copyTo(out); break;
    case Method::kContrast: ContrastSaliency(cand.contrast).compute_from_intensity(f.intensity, out); break;
  }
}

FrameRecord RockStudy::evaluate(size_t k, Method m, const Candidate& c, bool pixel) {
  // The map depends on (frame, method, weights / contrast parameters) and the detections
  // before the minimum-area filter also on the threshold scale: candidates that differ only
  // in the later stages reuse them (BoxDetector drops small components, then sorts and
  // truncates; filtering its min_area = 1 output by area and truncating gives the same list).
  const MapKey key{k, m, c.weights, c.contrast};
  if (map_key_ != key) {
    saliency(k, m, c, map_);
    map_key_ = key;
    dets_scale_.reset();
  }
  if (dets_scale_ != c.threshold_scale) {
    PostProcessParams pp = config_.post;
    pp.threshold_scale = c.threshold_scale;
    pp.min_area = 1;
    pp.max_detections = 0;
    BoxDetector det(pp);
    det.detect(map_, all_dets_);
    dets_scale_ = c.threshold_scale;
  }
  const int min_area = c.min_area.value_or(config_.post.min_area);
  dets_.clear();
  for (const Detection& d : all_dets_) {
    if (d.area >= min_area) dets_.push_back(d);
  }
  if (config_.post.max_detections > 0 && dets_.size() > static_cast<size_t>(config_.post.max_detections)) {
    dets_.resize(static_cast<size_t>(config_.post.max_detections));
  }
  cv::Mat map8;
  if (pixel) to_8bit(map_, map8);
  const Frame& f = frames_[k];
  return evaluate_frame(f.name, dets_, f.truth, map8);
}

std::vector<FrameRecord> RockStudy::evaluate_all(Method m, const Candidate& c, bool pixel) {
  std::vector<FrameRecord> out;
  out.reserve(frames_.size());
  for (size_t k = 0; k < frames_.size(); ++k) out.push_back(evaluate(k, m, c, pixel));
  return out;
}

Candidate RockStudy::default_candidate(Method m) const {
  Candidate c;
  c.threshold_scale = config_.post.threshold_scale;
  c.weights = m == Method::kSams ? config_.itti.weights : config_.itti_weights;
  if (m == Method::kContrast) {
    c.contrast = config_.contrast;
    c.threshold_scale = config_.contrast_post.threshold_scale;
    c.min_area = config_.contrast_post.min_area;
  }
  return c;
}

std::vector<Candidate> RockStudy::candidates(Method m, bool sweep_params, bool sweep_scales) const {
  if (m == Method::kContrast) {
    if (!sweep_params) return {default_candidate(m)};
    std::vector<Candidate> out;
    for (double sg : config_.contrast_sigmas) {
      for (double sm : config_.contrast_smooth_sigmas) {
        for (double sc : config_.contrast_threshold_scales) {
          for (int a : config_.contrast_min_areas) {
            Candidate c;
            c.weights = config_.itti_weights;
            c.contrast = {sg, sm};
            c.threshold_scale = sc;
            c.min_area = a;
            out.push_back(c);
          }
        }
      }
    }
    return out;
  }
  std::vector<double> scales = sweep_scales ? config_.threshold_scales : std::vector<double>{1.0};
  std::vector<ChannelWeights> ws;
  if (m == Method::kSams && sweep_params) {
    const int n = static_cast<int>(std::lround(1.0 / config_.weight_step));
    const bool colour = config_.itti.use_colour;
    for (int a = 0; a <= n; ++a) {
      for (int b = 0; a + b <= n; ++b) {
        for (int c = 0; a + b + c <= n; ++c) {
          if (!colour && c > 0) break;
          const int z = n - a - b - c;
          ChannelWeights w{a / static_cast<double>(n), b / static_cast<double>(n), c / static_cast<double>(n),
                           z / static_cast<double>(n)};
          ws.push_back(w);
        }
      }
    }
  } else if (m == Method::kSams) {
    ChannelWeights w = config_.itti_weights;
    w.structure = 1.0;
    ws.push_back(w);
  } else {
    ws.push_back(config_.itti_weights);
  }
  std::vector<Candidate> out;
  for (const auto& w : ws) {
    for (double s : scales) {
      Candidate c;
      c.weights = w;
      c.threshold_scale = s;
      out.push_back(c);
    }
  }
  return out;
}

std::vector<std::vector<FrameRecord>> RockStudy::score_table(Method m, const std::vector<Candidate>& cands) {
  std::vector<std::vector<FrameRecord>> table(cands.size(), std::vector<FrameRecord>(frames_.size()));
  for (size_t k = 0; k < frames_.size(); ++k) {
    for (size_t ci = 0; ci < cands.size(); ++ci) table[ci][k] = evaluate(k, m, cands[ci], false);
  }
  return table;
}

std::vector<SweepRow> RockStudy::sweep(Method m, const std::vector<Candidate>& cands) {
  const auto table = score_table(m, cands);
  std::vector<SweepRow> rows;
  for (size_t ci = 0; ci < cands.size(); ++ci) rows.push_back({cands[ci], summarise(table[ci])});
  std::stable_sort(rows.begin(), rows.end(),
                   [](const SweepRow& a, const SweepRow& b) { return objective(a.summary) > objective(b.summary); });
  return rows;
}

CvResult RockStudy::cross_validate(Method m, const std::vector<Candidate>& cands) {
  if (cands.empty()) throw std::invalid_argument("cross_validate: no candidates");
  const size_t n = frames_.size();
  const int k = config_.folds;
  CvResult r;
  r.fold_of = folds();  // throws when there are fewer sols than folds
  // Detection-only records of every candidate on every frame, computed once.
  const auto table = score_table(m, cands);
  r.pooled.resize(n);
  for (int fold = 0; fold < k; ++fold) {
    std::vector<size_t> train, test;
    for (size_t i = 0; i < n; ++i) (r.fold_of[i] == fold ? test : train).push_back(i);
    size_t best = 0;
    double best_obj = -1e300;
    for (size_t ci = 0; ci < cands.size(); ++ci) {
      const double o = objective(summarise(table[ci], train));
      if (o > best_obj + 1e-12) {
        best_obj = o;
        best = ci;
      }
    }
    std::vector<FrameRecord> test_recs;
    for (size_t i : test) {
      FrameRecord rec = evaluate(i, m, cands[best], true);
      r.pooled[i] = rec;
      test_recs.push_back(rec);
    }
    const Summary s = summarise(test_recs);
    r.fold_summaries.push_back(s);
    r.fold_moda02.push_back(s.n_moda02);
    r.fold_moda05.push_back(s.n_moda05);
    r.chosen.push_back(cands[best]);
  }
  return r;
}

std::vector<int> RockStudy::folds() const {
  std::vector<std::string> groups;
  groups.reserve(frames_.size());
  for (const Frame& f : frames_) groups.push_back(f.group);
  try {
    return grouped_folds(groups, config_.folds);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("cross_validate: ") + e.what());
  }
}

}  // namespace regolith::saliency
