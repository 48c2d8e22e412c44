#include "regolith/saliency/evaluate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "regolith/saliency/hungarian.hpp"

namespace regolith::saliency {

int FrameTruth::valid_count() const {
  return static_cast<int>(std::count_if(objects.begin(), objects.end(), [](const GtObject& o) { return !o.ignored; }));
}

FrameTruth truth_from_mask(const cv::Mat& mask, int min_area) {
  if (mask.empty()) throw std::invalid_argument("mask: empty");
  if (mask.type() != CV_8UC1) throw std::invalid_argument("mask: must be 8-bit single channel");
  if (min_area < 0) throw std::invalid_argument("min_gt_area: must be >= 0");
  FrameTruth t;
  cv::compare(mask, 0, t.mask, cv::CMP_GT);
  cv::Mat stats, centroids;
  const int n = cv::connectedComponentsWithStats(t.mask, t.labels, stats, centroids, 8, CV_32S);
  t.objects.reserve(static_cast<size_t>(std::max(0, n - 1)));
  for (int i = 1; i < n; ++i) {
    GtObject o;
    o.box = cv::Rect(stats.at<int>(i, cv::CC_STAT_LEFT), stats.at<int>(i, cv::CC_STAT_TOP),
                     stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT));
    o.area = stats.at<int>(i, cv::CC_STAT_AREA);
    o.ignored = o.area < min_area;
    t.objects.push_back(o);
  }
  return t;
}

namespace {

// Hungarian matching of `dets` (indices in det_idx) to `gts` maximising summed
// IoU among pairs with IoU >= thr. Returns matched (det index, IoU) pairs;
// marks used detections.
void match_group(const std::vector<cv::Rect>& dets, const std::vector<const GtObject*>& gts, double thr,
                 std::vector<char>& det_used, int& matched, double& iou_sum) {
  std::vector<int> free_dets;
  for (size_t j = 0; j < dets.size(); ++j) {
    if (!det_used[j]) free_dets.push_back(static_cast<int>(j));
  }
  const int rows = static_cast<int>(gts.size());
  const int cols = static_cast<int>(free_dets.size());
  if (rows == 0 || cols == 0) return;
  std::vector<double> cost(static_cast<size_t>(rows) * static_cast<size_t>(cols), 0.0);
  std::vector<double> ov(cost.size(), 0.0);
  bool any = false;
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < cols; ++j) {
      const double o =
          iou(gts[static_cast<size_t>(i)]->box, dets[static_cast<size_t>(free_dets[static_cast<size_t>(j)])]);
      const size_t k = static_cast<size_t>(i) * static_cast<size_t>(cols) + static_cast<size_t>(j);
      ov[k] = o;
      if (o >= thr) {
        cost[k] = -o;
        any = true;
      }
    }
  }
  if (!any) return;
  const std::vector<int> a = solve_assignment(cost, rows, cols);
  for (int i = 0; i < rows; ++i) {
    const int j = a[static_cast<size_t>(i)];
    if (j < 0) continue;
    const double o = ov[static_cast<size_t>(i) * static_cast<size_t>(cols) + static_cast<size_t>(j)];
    if (o >= thr) {
      det_used[static_cast<size_t>(free_dets[static_cast<size_t>(j)])] = 1;
      ++matched;
      iou_sum += o;
    }
  }
}

}  // namespace

FrameMatch match_frame(const std::vector<cv::Rect>& dets, const FrameTruth& truth, double iou_threshold) {
  if (!(iou_threshold > 0.0 && iou_threshold <= 1.0)) {
    throw std::invalid_argument("iou_threshold: must be in (0,1]");
  }
  std::vector<const GtObject*> valid, ignored;
  for (const auto& o : truth.objects) (o.ignored ? ignored : valid).push_back(&o);
  std::vector<char> used(dets.size(), 0);
  FrameMatch m;
  m.n_gt = static_cast<int>(valid.size());
  match_group(dets, valid, iou_threshold, used, m.matched, m.iou_sum);
  int ign_matched = 0;
  double ign_sum = 0.0;
  match_group(dets, ignored, iou_threshold, used, ign_matched, ign_sum);
  m.n_det = static_cast<int>(dets.size()) - ign_matched;
  return m;
}

int centroid_hits(const std::vector<cv::Rect>& dets, const FrameTruth& truth) {
  std::vector<char> hit(truth.objects.size(), 0);
  for (const auto& d : dets) {
    const int x = d.x + d.width / 2;
    const int y = d.y + d.height / 2;
    if (x < 0 || y < 0 || x >= truth.labels.cols || y >= truth.labels.rows) continue;
    const int l = truth.labels.at<int>(y, x);
    if (l > 0) hit[static_cast<size_t>(l - 1)] = 1;
  }
  int n = 0;
  for (size_t k = 0; k < hit.size(); ++k) {
    if (hit[k] && !truth.objects[k].ignored) ++n;
  }
  return n;
}

PixelStats pixel_stats(const cv::Mat& map8, const cv::Mat& mask, double beta2) {
  if (map8.type() != CV_8UC1 || mask.type() != CV_8UC1 || map8.size() != mask.size()) {
    throw std::invalid_argument("pixel_stats: map and mask must be CV_8UC1 of the same size");
  }
  std::array<double, 256> fg{}, bg{};
  double abs_err = 0.0;
  for (int y = 0; y < map8.rows; ++y) {
    const uchar* s = map8.ptr<uchar>(y);
    const uchar* m = mask.ptr<uchar>(y);
    for (int x = 0; x < map8.cols; ++x) {
      if (m[x]) {
        fg[s[x]] += 1.0;
        abs_err += (255 - s[x]) / 255.0;
      } else {
        bg[s[x]] += 1.0;
        abs_err += s[x] / 255.0;
      }
    }
  }
  PixelStats p;
  p.mae = abs_err / static_cast<double>(map8.total());
  double total_fg = 0.0;
  for (double v : fg) total_fg += v;
  double tp = 0.0, fp = 0.0;
  for (int t = 255; t >= 0; --t) {  // positives: value >= t
    tp += fg[static_cast<size_t>(t)];
    fp += bg[static_cast<size_t>(t)];
    const double prec = tp + fp > 0.0 ? tp / (tp + fp) : 0.0;
    const double rec = total_fg > 0.0 ? tp / total_fg : 0.0;
    const double den = beta2 * prec + rec;
    p.f_curve[static_cast<size_t>(t)] = den > 0.0 ? (1.0 + beta2) * prec * rec / den : 0.0;
  }
  return p;
}

FrameRecord evaluate_frame(const std::string& name, const std::vector<Detection>& dets, const FrameTruth& truth,
                           const cv::Mat& map8) {
  std::vector<cv::Rect> boxes;
  boxes.reserve(dets.size());
  for (const auto& d : dets) boxes.push_back(d.box);
  FrameRecord r;
  r.name = name;
  r.at02 = match_frame(boxes, truth, 0.2);
  r.at05 = match_frame(boxes, truth, 0.5);
  r.hits = centroid_hits(boxes, truth);
  r.n_boxes = static_cast<int>(boxes.size());
  if (!map8.empty()) {
    r.pixel = pixel_stats(map8, truth.mask);
    r.has_pixel = true;
  }
  return r;
}

double n_moda(const std::vector<FrameMatch>& frames) {
  double err = 0.0, gt = 0.0;
  for (const auto& f : frames) {
    err += f.misses() + f.false_positives();
    gt += f.n_gt;
  }
  if (gt <= 0.0) return err > 0.0 ? -err : 1.0;  // no ground truth: 1 only if nothing reported
  return 1.0 - err / gt;
}

double n_modp(const std::vector<FrameMatch>& frames) {
  double sum = 0.0;
  int n = 0;
  for (const auto& f : frames) {
    if (f.matched > 0) {
      sum += f.iou_sum / f.matched;
      ++n;
    }
  }
  return n > 0 ? sum / n : 0.0;
}

Summary summarise(const std::vector<FrameRecord>& records, const std::vector<size_t>& subset) {
  std::vector<size_t> idx = subset;
  if (idx.empty()) {
    for (size_t k = 0; k < records.size(); ++k) idx.push_back(k);
  }
  Summary s;
  std::vector<FrameMatch> m02, m05;
  std::array<double, 256> fsum{};
  double mae = 0.0;
  int npix = 0, hits = 0, matched02 = 0, matched05 = 0, det02 = 0, det05 = 0;
  for (size_t k : idx) {
    const FrameRecord& r = records.at(k);
    ++s.images;
    s.gt += r.at02.n_gt;
    s.boxes += r.n_boxes;
    m02.push_back(r.at02);
    m05.push_back(r.at05);
    hits += r.hits;
    matched02 += r.at02.matched;
    matched05 += r.at05.matched;
    det02 += r.at02.n_det;
    det05 += r.at05.n_det;
    if (r.has_pixel) {
      for (size_t t = 0; t < 256; ++t) fsum[t] += r.pixel.f_curve[t];
      mae += r.pixel.mae;
      ++npix;
    }
  }
  s.n_moda02 = n_moda(m02);
  s.n_moda05 = n_moda(m05);
  s.n_modp02 = n_modp(m02);
  s.n_modp05 = n_modp(m05);
  s.precision02 = det02 > 0 ? static_cast<double>(matched02) / det02 : 0.0;
  s.precision05 = det05 > 0 ? static_cast<double>(matched05) / det05 : 0.0;
  s.recall02 = s.gt > 0 ? static_cast<double>(matched02) / s.gt : 0.0;
  s.recall05 = s.gt > 0 ? static_cast<double>(matched05) / s.gt : 0.0;
  s.centroid_rate = s.gt > 0 ? static_cast<double>(hits) / s.gt : 0.0;
  if (npix > 0) {
    s.max_f = 0.0;
    for (double v : fsum) s.max_f = std::max(s.max_f, v / npix);
    s.mae = mae / npix;
  }
  return s;
}

std::string markdown_table(const std::vector<std::pair<std::string, Summary>>& rows) {
  std::ostringstream o;
  o << "| method | images | GT | boxes | N-MODA@0.2 | N-MODP@0.2 | P@0.2 | "
       "R@0.2 | N-MODA@0.5 | "
       "N-MODP@0.5 | P@0.5 | R@0.5 | centroid hit | max F | MAE |\n";
  o << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|-"
       "--:|\n";
  char buf[512];
  for (const auto& [label, s] : rows) {
    auto pix = [](double v) {
      char b[32];
      if (v < 0)
        std::snprintf(b, sizeof b, "n/a");
      else
        std::snprintf(b, sizeof b, "%.3f", v);
      return std::string(b);
    };
    std::snprintf(buf, sizeof buf,
                  "| %s | %d | %d | %d | %.3f | %.3f | %.3f | %.3f | %.3f | "
                  "%.3f | %.3f | %.3f | "
                  "%.3f | %s | %s |\n",
                  label.c_str(), s.images, s.gt, s.boxes, s.n_moda02, s.n_modp02, s.precision02, s.recall02, s.n_moda05,
                  s.n_modp05, s.precision05, s.recall05, s.centroid_rate, pix(s.max_f).c_str(), pix(s.mae).c_str());
    o << buf;
  }
  return o.str();
}

}  // namespace regolith::saliency
