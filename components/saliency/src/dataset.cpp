#include "regolith/saliency/dataset.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

namespace regolith::saliency {

namespace fs = std::filesystem;

namespace {
std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  return s;
}
bool is_image_ext(const std::string &ext) {
  static const char *exts[] = {".jpg", ".jpeg", ".png", ".bmp",
                               ".tif", ".tiff", ".pgm", ".ppm"};
  const std::string e = lower(ext);
  return std::any_of(std::begin(exts), std::end(exts),
                     [&](const char *x) { return e == x; });
}
} // namespace

DatasetListing list_dataset(const std::string &images_dir,
                            const std::string &masks_dir) {
  std::error_code ec;
  if (!fs::is_directory(images_dir, ec))
    throw DataError(images_dir + ": not a directory (--images)");
  if (!fs::is_directory(masks_dir, ec))
    throw DataError(masks_dir + ": not a directory (--masks)");
  DatasetListing out;
  for (const auto &e : fs::directory_iterator(images_dir, ec)) {
    if (!e.is_regular_file() || !is_image_ext(e.path().extension().string()))
      continue;
    DatasetItem it;
    it.name = e.path().filename().string();
    it.image_path = e.path().string();
    it.mask_path =
        (fs::path(masks_dir) / (e.path().stem().string() + ".png")).string();
    if (!fs::exists(it.mask_path, ec)) {
      out.errors.push_back(it.mask_path + ": no mask for image " +
                           it.image_path);
      continue;
    }
    out.items.push_back(std::move(it));
  }
  if (ec)
    out.errors.push_back(images_dir + ": " + ec.message());
  std::sort(out.items.begin(), out.items.end(),
            [](const DatasetItem &a, const DatasetItem &b) {
              return a.name < b.name;
            });
  return out;
}

cv::Mat read_image(const std::string &path) {
  cv::Mat img;
  try {
    img = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception &e) {
    throw DataError(path + ": cannot read image (" + e.what() + ")");
  }
  if (img.empty())
    throw DataError(
        path + ": cannot read image (missing, unreadable or not an image)");
  return img;
}

FrameTruth read_truth(const std::string &mask_path, cv::Size image_size,
                      int min_gt_area) {
  cv::Mat m = read_image(mask_path);
  if (m.size() != image_size) {
    throw DataError(mask_path + ": mask is " + std::to_string(m.cols) + "x" +
                    std::to_string(m.rows) + " but its image is " +
                    std::to_string(image_size.width) + "x" +
                    std::to_string(image_size.height));
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
  } catch (const std::invalid_argument &e) {
    throw DataError(mask_path + ": " + e.what());
  }
}

void StudyConfig::validate() const {
  itti.validate();
  itti_weights.validate();
  post.validate();
  if (min_gt_area < 0)
    throw std::invalid_argument("StudyConfig.min_gt_area: must be >= 0 px");
  if (folds < 2)
    throw std::invalid_argument("StudyConfig.folds: must be >= 2");
  if (!(weight_step > 0.0 && weight_step <= 1.0)) {
    throw std::invalid_argument("StudyConfig.weight_step: must be in (0,1]");
  }
  if (threshold_scales.empty()) {
    throw std::invalid_argument(
        "StudyConfig.threshold_scales: must not be empty");
  }
  for (double s : threshold_scales) {
    if (!(s > 0.0 && s <= 10.0)) {
      throw std::invalid_argument(
          "StudyConfig.threshold_scales: values must be in (0,10]");
    }
  }
}

std::string Candidate::describe(bool with_structure) const {
  char buf[160];
  if (with_structure) {
    std::snprintf(buf, sizeof buf,
                  "w_I=%.2f w_O=%.2f w_C=%.2f w_Z=%.2f, Otsu x%.2f",
                  weights.intensity, weights.orientation, weights.colour,
                  weights.structure, threshold_scale);
  } else {
    std::snprintf(buf, sizeof buf, "Otsu x%.2f", threshold_scale);
  }
  return buf;
}

RockStudy::RockStudy(StudyConfig config, HeightFn height)
    : config_(std::move(config)), height_(std::move(height)),
      itti_(config_.itti), sr_(Method::kSpectralResidual),
      fg_(Method::kFineGrained) {
  config_.validate();
}

void RockStudy::add(const DatasetItem &item) {
  Frame f;
  f.name = item.name;
  const cv::Mat img = read_image(item.image_path);
  f.size = img.size();
  f.truth = read_truth(item.mask_path, img.size(), config_.min_gt_area);
  try {
    cv::Mat h;
    if (height_) {
      height_(img, height_buf_);
      h = height_buf_;
    }
    const Conspicuity &c = itti_.conspicuity(img, h);
    f.consp.intensity = c.intensity.clone();
    f.consp.orientation = c.orientation.clone();
    if (!c.colour.empty())
      f.consp.colour = c.colour.clone();
    if (!c.structure.empty())
      f.consp.structure = c.structure.clone();
    sr_.compute(img, f.sr);
    fg_.compute(img, f.fg);
  } catch (const std::exception &e) {
    throw DataError(item.image_path + ": " + e.what());
  }
  frames_.push_back(std::move(f));
}

void RockStudy::saliency(size_t k, Method m, const ChannelWeights &w,
                         cv::Mat &out) {
  const Frame &f = frames_.at(k);
  switch (m) {
  case Method::kSams: {
    if (f.consp.structure.empty()) {
      throw std::logic_error(
          "SAMS needs a height map: no HeightFn (regolith::sfs) configured");
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
  case Method::kSpectralResidual:
    f.sr.copyTo(out);
    break;
  case Method::kFineGrained:
    f.fg.copyTo(out);
    break;
  }
}

FrameRecord RockStudy::evaluate(size_t k, Method m, const Candidate &c,
                                bool pixel) {
  saliency(k, m, c.weights, map_);
  PostProcessParams pp = config_.post;
  pp.threshold_scale = c.threshold_scale;
  BoxDetector det(pp);
  det.detect(map_, dets_);
  cv::Mat map8;
  if (pixel)
    to_8bit(map_, map8);
  const Frame &f = frames_[k];
  return evaluate_frame(f.name, dets_, f.truth, map8);
}

std::vector<FrameRecord> RockStudy::evaluate_all(Method m, const Candidate &c,
                                                 bool pixel) {
  std::vector<FrameRecord> out;
  out.reserve(frames_.size());
  for (size_t k = 0; k < frames_.size(); ++k)
    out.push_back(evaluate(k, m, c, pixel));
  return out;
}

std::vector<Candidate> RockStudy::candidates(Method m, bool sweep_weights,
                                             bool sweep_scales) const {
  std::vector<double> scales =
      sweep_scales ? config_.threshold_scales : std::vector<double>{1.0};
  std::vector<ChannelWeights> ws;
  if (m == Method::kSams && sweep_weights) {
    const int n = static_cast<int>(std::lround(1.0 / config_.weight_step));
    const bool colour = config_.itti.use_colour;
    for (int a = 0; a <= n; ++a) {
      for (int b = 0; a + b <= n; ++b) {
        for (int c = 0; a + b + c <= n; ++c) {
          if (!colour && c > 0)
            break;
          const int z = n - a - b - c;
          ChannelWeights w{
              a / static_cast<double>(n), b / static_cast<double>(n),
              c / static_cast<double>(n), z / static_cast<double>(n)};
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
  for (const auto &w : ws) {
    for (double s : scales)
      out.push_back(Candidate{w, s});
  }
  return out;
}

std::vector<SweepRow> RockStudy::sweep(Method m,
                                       const std::vector<Candidate> &cands) {
  std::vector<SweepRow> rows;
  for (const auto &c : cands)
    rows.push_back({c, summarise(evaluate_all(m, c, false))});
  std::stable_sort(rows.begin(), rows.end(),
                   [](const SweepRow &a, const SweepRow &b) {
                     return objective(a.summary) > objective(b.summary);
                   });
  return rows;
}

CvResult RockStudy::cross_validate(Method m,
                                   const std::vector<Candidate> &cands) {
  if (cands.empty())
    throw std::invalid_argument("cross_validate: no candidates");
  const size_t n = frames_.size();
  const int k = config_.folds;
  if (n < static_cast<size_t>(k)) {
    throw std::invalid_argument("cross_validate: " + std::to_string(n) +
                                " frames < " + std::to_string(k) + " folds");
  }
  // Detection-only records of every candidate on every frame, computed once.
  std::vector<std::vector<FrameRecord>> table;
  table.reserve(cands.size());
  for (const auto &c : cands)
    table.push_back(evaluate_all(m, c, false));
  CvResult r;
  r.pooled.resize(n);
  for (int fold = 0; fold < k; ++fold) {
    std::vector<size_t> train, test;
    for (size_t i = 0; i < n; ++i)
      (static_cast<int>(i % static_cast<size_t>(k)) == fold ? test : train)
          .push_back(i);
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
    r.fold_moda02.push_back(s.n_moda02);
    r.fold_moda05.push_back(s.n_moda05);
    r.chosen.push_back(
        cands[best].describe(m == Method::kSams || m == Method::kItti));
  }
  return r;
}

} // namespace regolith::saliency
