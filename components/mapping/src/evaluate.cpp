#include "regolith/mapping/evaluate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/common/plot.hpp"
#include "regolith/core/csv.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/image_file.hpp"
#include "regolith/core/json_file.hpp"
#include "regolith/mapping/drive_io.hpp"

namespace regolith::mapping {
namespace fs = std::filesystem;
namespace {

// A CSV table -> rows of named doubles, every column of the header in every row (a missing or
// non-numeric cell is NaN). The columns the caller reads (`required`) must be in the header, and
// a required `frame` must be a whole number 0..2^31-1 on every row (CsvTable's errors name the
// file, the line and the column).
std::vector<std::map<std::string, double>> read_csv(const fs::path& p,
                                                    std::initializer_list<std::string_view> required) {
  const CsvTable t = CsvTable::read(p.string(), required);
  const bool frames = std::find(required.begin(), required.end(), "frame") != required.end();
  std::vector<std::map<std::string, double>> rows(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (frames) t.whole(i, "frame", 0, std::numeric_limits<int>::max());
    for (const std::string& c : t.header()) rows[i][c] = t.number_or_nan(i, c);
  }
  return rows;
}

cv::Mat read_float(const fs::path& p) {
  std::string why;
  cv::Mat m = regolith::read_image_file(p.string(), cv::IMREAD_UNCHANGED, &why);
  if (m.empty()) throw InputError(p.string() + ": cannot read as a float32 TIFF: " + why);
  if (m.type() != CV_32FC1) throw InputError(p.string() + ": not a float32 single-channel TIFF");
  return m;
}

double pearson(const std::vector<double>& a, const std::vector<double>& b) {
  const std::size_t n = a.size();
  if (n < 3) return std::nan("");
  double ma = 0, mb = 0;
  for (std::size_t k = 0; k < n; ++k) ma += a[k], mb += b[k];
  ma /= static_cast<double>(n), mb /= static_cast<double>(n);
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t k = 0; k < n; ++k) {
    sab += (a[k] - ma) * (b[k] - mb);
    saa += (a[k] - ma) * (a[k] - ma);
    sbb += (b[k] - mb) * (b[k] - mb);
  }
  return (saa > 0 && sbb > 0) ? sab / std::sqrt(saa * sbb) : std::nan("");
}

// Least-squares plane z = a x + b y + c over (x, y, z) samples, removed in place.
void remove_plane(const std::vector<double>& x, const std::vector<double>& y, std::vector<double>& z) {
  if (z.size() < 3) return;
  cv::Mat A(static_cast<int>(z.size()), 3, CV_64F), Z(static_cast<int>(z.size()), 1, CV_64F);
  for (std::size_t k = 0; k < z.size(); ++k) {
    A.at<double>(static_cast<int>(k), 0) = x[k];
    A.at<double>(static_cast<int>(k), 1) = y[k];
    A.at<double>(static_cast<int>(k), 2) = 1.0;
    Z.at<double>(static_cast<int>(k), 0) = z[k];
  }
  cv::Mat coef;
  if (!cv::solve(A, Z, coef, cv::DECOMP_SVD)) return;
  for (std::size_t k = 0; k < z.size(); ++k)
    z[k] -= coef.at<double>(0) * x[k] + coef.at<double>(1) * y[k] + coef.at<double>(2);
}

double auc(std::vector<std::pair<double, int>> s) {
  std::sort(s.begin(), s.end());
  double pos = 0, neg = 0, rank_sum = 0;
  for (std::size_t k = 0; k < s.size();) {
    std::size_t e = k;
    while (e < s.size() && s[e].first == s[k].first) ++e;
    const double avg = 0.5 * static_cast<double>(k + 1 + e);  // average 1-based rank of ties
    for (std::size_t q = k; q < e; ++q)
      if (s[q].second)
        rank_sum += avg, ++pos;
      else
        ++neg;
    k = e;
  }
  if (pos == 0 || neg == 0) return std::nan("");
  return (rank_sum - pos * (pos + 1) / 2) / (pos * neg);
}

// Gaussian blur with NaN-aware normalisation (sigma in cells).
cv::Mat blur_known(const cv::Mat& z, const cv::Mat& known, double sigma) {
  cv::Mat zz = z.clone(), w;
  known.convertTo(w, CV_32F, 1.0 / 255.0);
  zz.setTo(0, ~known);
  cv::Mat bz, bw;
  cv::GaussianBlur(zz, bz, cv::Size(), sigma);
  cv::GaussianBlur(w, bw, cv::Size(), sigma);
  return bz / cv::max(bw, 1e-6);
}

struct TRock {
  double x, y, h, ext, w, l, yaw;
  bool observed;
};

// What evaluate_map scored, for the overlay (references to its locals, alive while it draws).
struct Scored {
  const cv::Mat& truth;  // true heights on the map's cells (NaN where the truth has none)
  const cv::Mat& seen;   // cells some true camera pose saw within 5 m
  const cv::Mat& elev;   // the map's elevation on the same cells (NaN = not mapped)
  cv::Point2d origin;    // the map's cell (0, 0) centre
  double res;            // cell size
  const std::vector<TRock>& rocks;
  const std::vector<std::map<std::string, double>>& detections;
  const std::vector<int>& rock_of_detection;  // truth index or -1
  const std::vector<int>& detection_of_rock;  // detection index or -1
  std::vector<cv::Point2d> true_path, corrected_path, wheel_path;
  std::string title, scores;  // two lines above the legend
};

cv::Mat render_scored(const Scored& s) {
  // North up, cropped to the seen cells and the paths.
  std::vector<cv::Point2d> paths = s.true_path;
  paths.insert(paths.end(), s.corrected_path.begin(), s.corrected_path.end());
  paths.insert(paths.end(), s.wheel_path.begin(), s.wheel_path.end());
  const plot::NorthUpFrame frame(s.seen, s.origin, s.res, paths);
  constexpr int kTitle = 62;  // px of the title band above the map
  const cv::Mat shaded = frame.shade(s.truth, 4.0);
  cv::Mat out(frame.size().height + kTitle, std::max(frame.size().width, 720), CV_8UC3, cv::Scalar(60, 45, 40));
  cv::Mat img = out(cv::Rect(0, kTitle, out.cols, frame.size().height));  // the map; drawing is clipped to it
  for (int i = frame.rows().start; i < frame.rows().end; ++i)
    for (int j = frame.cols().start; j < frame.cols().end; ++j) {
      const float shade = shaded.at<float>(i, j);
      if (!std::isfinite(shade)) continue;
      const bool seen = s.seen.at<uchar>(i, j);
      const double g = (60 + 180 * shade) * (seen ? 1.0 : 0.45);
      // Seen but left unmapped (what the coverage counts against the map): tinted blue.
      if (seen && !std::isfinite(s.elev.at<float>(i, j)))
        img(frame.cell(i, j)).setTo(cv::Scalar(std::min(255.0, g + 70), 0.8 * g, 0.55 * g));
      else
        img(frame.cell(i, j)).setTo(cv::Scalar::all(g));
    }
  const double px_per_m = frame.px_per_m();
  const auto polyline = [&](const std::vector<cv::Point2d>& path, const cv::Scalar& colour, int thickness) {
    for (std::size_t k = 1; k < path.size(); ++k)
      cv::line(img, frame.px(path[k - 1].x, path[k - 1].y), frame.px(path[k].x, path[k].y), colour, thickness,
               cv::LINE_AA);
  };
  polyline(s.wheel_path, {255, 120, 0}, 2);
  polyline(s.true_path, {255, 255, 255}, 1);
  polyline(s.corrected_path, {0, 220, 0}, 2);
  const cv::Scalar kMatched(0, 230, 255), kMissed(0, 0, 255), kFalse(255, 0, 255), kOther(170, 170, 170);
  // True footprints (north up: the image's y runs south, so the angle turns the other way).
  for (std::size_t a = 0; a < s.rocks.size(); ++a) {
    const TRock& t = s.rocks[a];
    if (t.h < 0.10) continue;
    const bool scored = t.observed, hit = s.detection_of_rock[a] >= 0;
    const cv::Scalar colour = !scored ? kOther : (hit ? kMatched : kMissed);
    const cv::Size axes(std::max(2, static_cast<int>(std::lround(0.5 * t.w * px_per_m))),
                        std::max(2, static_cast<int>(std::lround(0.5 * t.l * px_per_m))));
    cv::ellipse(img, frame.px(t.x, t.y), axes, -t.yaw * 180.0 / 3.14159265358979323846, 0, 360, colour, scored ? 2 : 1,
                cv::LINE_8);
  }
  for (std::size_t b = 0; b < s.detections.size(); ++b) {
    const auto& d = s.detections[b];
    const cv::Point p = frame.px(d.at("x_m"), d.at("y_m"));
    const int a = s.rock_of_detection[b];
    cv::Scalar colour = kFalse;
    if (a >= 0) {
      const TRock& t = s.rocks[static_cast<std::size_t>(a)];
      const bool scored_hit = t.observed && t.h >= 0.10;
      colour = scored_hit ? kMatched : kOther;
      if (scored_hit) cv::line(img, p, frame.px(t.x, t.y), colour, 1, cv::LINE_8);
    }
    const int r = 6;
    cv::line(img, p + cv::Point(-r, -r), p + cv::Point(r, r), colour, 2, cv::LINE_8);
    cv::line(img, p + cv::Point(-r, r), p + cv::Point(r, -r), colour, 2, cv::LINE_8);
  }
  // Scale bar (1 m), north arrow, title and legend.
  plot::put_scale_bar_and_north(img, px_per_m);
  cv::Mat band = out(cv::Rect(0, 0, out.cols, kTitle));
  band.setTo(cv::Scalar(40, 30, 25));
  cv::putText(band, s.title, cv::Point(10, 17), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 255), 1,
              cv::LINE_AA);
  cv::putText(band, s.scores, cv::Point(10, 35), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 255), 1,
              cv::LINE_AA);
  const plot::LegendEntry legend[] = {
      {"rock hit", kMatched},
      {"rock missed", kMissed},
      {"false alarm", kFalse},
      {"true path", {255, 255, 255}},
      {"corrected", {0, 220, 0}},
      {"wheels", {255, 120, 0}},
      {"seen, not mapped", {230, 110, 75}},
  };
  plot::put_legend(band, {10, 55}, legend);
  return out;
}

using Row = std::map<std::string, double>;

// The scored map on its cells: the map's elevation and hazard, the truth heightfield averaged
// onto the same cells, and which cells a true camera pose saw within 5 m.
struct ScoredGrid {
  cv::Mat elev, hazard, truth;
  cv::Mat in_view;                 // cells some true camera pose had in its image within 5 m
  cv::Mat seen;                    // ... of which the line of sight reached the ground (not hidden by rocks or rises)
  double ox = 0, oy = 0, res = 0;  // cell (0, 0) centre and cell size (m)
  cv::Mat height;                  // the truth heightfield at its own resolution (grid.json)
  double hox = 0, hoy = 0, hres = 0;
  /// The true height at world (x, y), NaN outside the heightfield.
  float height_at(double x, double y) const {
    const int i = static_cast<int>(std::lround((y - hoy) / hres)), j = static_cast<int>(std::lround((x - hox) / hres));
    return (i >= 0 && j >= 0 && i < height.rows && j < height.cols) ? height.at<float>(i, j) : std::nanf("");
  }
  cv::Point2d centre(int i, int j) const { return {ox + j * res, oy + i * res}; }
};

// --- poses: the corrected and the wheel path against the truth, frame by frame (`path_m`: the
// true path length over the frames both tables have).
nlohmann::json score_poses(const std::map<int, Row>& tp, const std::vector<Row>& est, const fs::path& map_dir) {
  double path = 0, mean_err = 0, mean_err_w = 0;
  // Is the reported covariance honest? Per frame with one, the error normalised by it: the squared
  // Mahalanobis distance of (x, y) (with cov_xy when the file has it) and the heading's z.
  double d2_sum = 0, zyaw2_sum = 0;
  int n_cov = 0, within95 = 0;
  int n = 0;
  const Row* last_t = nullptr;
  const Row* last_e = nullptr;
  for (const auto& e : est) {
    const auto it = tp.find(static_cast<int>(e.at("frame")));
    if (it == tp.end()) continue;
    const Row& t = it->second;
    if (last_t)
      path += std::hypot(t.at("rover_x_m") - last_t->at("rover_x_m"), t.at("rover_y_m") - last_t->at("rover_y_m"));
    const double ex = e.at("x_m") - t.at("rover_x_m"), ey = e.at("y_m") - t.at("rover_y_m");
    mean_err += std::hypot(ex, ey);
    mean_err_w += std::hypot(e.at("wheel_x_m") - t.at("rover_x_m"), e.at("wheel_y_m") - t.at("rover_y_m"));
    const auto col = [&](const char* k) {
      const auto c = e.find(k);
      return c != e.end() ? c->second : std::nan("");
    };
    const double cxx = col("cov_xx"), cyy = col("cov_yy"), cww = col("cov_yawyaw"), cxy_read = col("cov_xy");
    const double cxy = std::isfinite(cxy_read) ? cxy_read : 0.0;
    const double d2 = mahalanobis2(ex, ey, cxx, cxy, cyy);
    if (std::isfinite(d2) && cww > 0) {
      const double ew = std::remainder(e.at("yaw_rad") - t.at("rover_yaw_rad"), 2 * 3.14159265358979323846);
      d2_sum += d2;
      zyaw2_sum += ew * ew / cww;
      within95 += d2 <= kChi2TwoDof95 ? 1 : 0;
      ++n_cov;
    }
    ++n;
    last_t = &t, last_e = &e;
  }
  if (n < 2) throw InputError(map_dir.string() + "/odometry.csv: fewer than two frames match truth_poses.csv");
  auto yaw_err = [](double a, double b) {
    return std::abs(std::remainder(a - b, 2 * 3.14159265358979323846)) * 180.0 / 3.14159265358979323846;
  };
  const Row &lt = *last_t, &le = *last_e;
  const double fe = std::hypot(le.at("x_m") - lt.at("rover_x_m"), le.at("y_m") - lt.at("rover_y_m"));
  const double fw = std::hypot(le.at("wheel_x_m") - lt.at("rover_x_m"), le.at("wheel_y_m") - lt.at("rover_y_m"));
  return {{"frames", n},
          {"path_m", path},
          {"final_position_error_m", fe},
          {"final_position_error_pct", 100 * fe / path},
          {"final_heading_error_deg", yaw_err(le.at("yaw_rad"), lt.at("rover_yaw_rad"))},
          {"mean_position_error_m", mean_err / n},
          {"wheel_final_position_error_m", fw},
          {"wheel_final_position_error_pct", 100 * fw / path},
          {"wheel_final_heading_error_deg", yaw_err(le.at("wheel_yaw_rad"), lt.at("rover_yaw_rad"))},
          {"wheel_mean_position_error_m", mean_err_w / n},
          // Covariance consistency (NaN without covariance columns): an honest covariance gives
          // a mean squared Mahalanobis distance of 2 (position) and 1 (heading) and 95 % of the
          // frames inside the 95 % ellipse; more is over-confident.
          {"covariance_frames", n_cov},
          {"position_mahalanobis2_mean", n_cov > 0 ? d2_sum / n_cov : std::nan("")},
          {"position_within_95pct_ellipse", n_cov > 0 ? static_cast<double>(within95) / n_cov : std::nan("")},
          {"heading_z_rms", n_cov > 0 ? std::sqrt(zyaw2_sum / n_cov) : std::nan("")}};
}

// The map's grids and the truth heightfield averaged onto its cells.
ScoredGrid read_scored_grid(const fs::path& drive_dir, const fs::path& map_dir) {
  const nlohmann::json mj = read_json_file((map_dir / "map.json").string(), "map description (map.json)");
  const nlohmann::json gj = read_json_file((drive_dir / "grid.json").string(), "truth grid (grid.json)");
  ScoredGrid g;
  g.elev = read_float(map_dir / "elevation.tiff");
  g.hazard = read_float(map_dir / "hazard.tiff");
  g.height = read_float(drive_dir / "height.tiff");
  const cv::Mat& th = g.height;
  if (g.hazard.size() != g.elev.size())
    throw InputError((map_dir / "hazard.tiff").string() + ": " + std::to_string(g.hazard.cols) + "x" +
                     std::to_string(g.hazard.rows) + " cells, elevation.tiff has " + std::to_string(g.elev.cols) + "x" +
                     std::to_string(g.elev.rows));
  const std::string mname = (map_dir / "map.json").string(), gname = (drive_dir / "grid.json").string();
  g.ox = json_number(mj, mname, "origin_x_m"), g.oy = json_number(mj, mname, "origin_y_m"),
  g.res = json_number(mj, mname, "resolution_m");
  const double gox = json_number(gj, gname, "origin_x_m"), goy = json_number(gj, gname, "origin_y_m"),
               gres = json_number(gj, gname, "resolution_m");
  if (!(gres > 0)) throw InputError(gname + ": resolution_m: must be > 0");
  g.hox = gox, g.hoy = goy, g.hres = gres;
  const int R = g.elev.rows, C = g.elev.cols;
  g.truth = cv::Mat(R, C, CV_32F, cv::Scalar(std::nanf("")));
  g.seen = cv::Mat(R, C, CV_8U, cv::Scalar(0));
  g.in_view = cv::Mat(R, C, CV_8U, cv::Scalar(0));
  const int k = std::max(1, static_cast<int>(std::lround(g.res / gres)));
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j) {
      const cv::Point2d c = g.centre(i, j);
      const int gi = static_cast<int>(std::lround((c.y - goy) / gres)),
                gj2 = static_cast<int>(std::lround((c.x - gox) / gres));
      double acc = 0;
      int m = 0;
      for (int a = gi - k / 2; a <= gi + (k - 1) / 2; ++a)
        for (int b = gj2 - k / 2; b <= gj2 + (k - 1) / 2; ++b)
          if (a >= 0 && b >= 0 && a < th.rows && b < th.cols && std::isfinite(th.at<float>(a, b)))
            acc += th.at<float>(a, b), ++m;
      if (m) g.truth.at<float>(i, j) = static_cast<float>(acc / m);
    }
  return g;
}

// Whether the line of sight from the camera at `from` reaches the ground point `to`: no true
// height above it on the way (marched every 2 cm; the last 6 cm are the cell itself, whose mean
// height may lie under its own rock's surface; 5 mm of tolerance).
bool line_of_sight(const ScoredGrid& g, const cv::Vec3d& from, const cv::Vec3d& to) {
  const double d = std::hypot(to[0] - from[0], to[1] - from[1]);
  const int n = static_cast<int>(std::ceil(d / 0.02));
  for (int k = 1; k < n; ++k) {
    const double s = static_cast<double>(k) / n;
    if ((1.0 - s) * d < 0.06) break;
    const cv::Vec3d p = from + (to - from) * s;
    if (g.height_at(p[0], p[1]) > p[2] + 0.005) return false;
  }
  return true;
}

// Ground seen within 5 m: each true cell projected into the true camera poses' images (in_view),
// and seen where the line of sight reaches it (the development set's `observed`: projection and
// depth test).
void mark_seen(ScoredGrid& g, const std::map<int, Row>& tp, const direct_depth::CameraModel& cam) {
  for (const auto& [f, t] : tp) {
    (void)f;
    const double cx = t.at("x_m"), cy = t.at("y_m"), cz = t.at("z_m"), yaw = t.at("yaw_rad"), pitch = t.at("pitch_rad"),
                 roll = t.at("roll_rad");
    // Camera axes in the world: forward f (heading yaw, pitched down), right r, down d (roll about f).
    const cv::Vec3d fwd(std::cos(yaw) * std::cos(pitch), std::sin(yaw) * std::cos(pitch), -std::sin(pitch));
    cv::Vec3d right(std::sin(yaw), -std::cos(yaw), 0.0);
    cv::Vec3d down = fwd.cross(right);
    const cv::Vec3d r2 = right * std::cos(roll) + down * std::sin(roll),
                    d2 = down * std::cos(roll) - right * std::sin(roll);
    for (int i = 0; i < g.truth.rows; ++i)
      for (int j = 0; j < g.truth.cols; ++j) {
        const float zt = g.truth.at<float>(i, j);
        if (!std::isfinite(zt)) continue;
        const cv::Point2d c = g.centre(i, j);
        const cv::Vec3d v(c.x - cx, c.y - cy, zt - cz);
        const double z = v.dot(fwd);
        if (z <= 0 || cv::norm(v) > 5.0) continue;
        const double u = cam.fx * v.dot(r2) / z + cam.cx, w = cam.fy * v.dot(d2) / z + cam.cy;
        if (!(u >= 0 && w >= 0 && u <= cam.width - 1 && w <= cam.height - 1)) continue;
        g.in_view.at<uchar>(i, j) = 255;
        if (!g.seen.at<uchar>(i, j) && line_of_sight(g, {cx, cy, cz}, {c.x, c.y, zt})) g.seen.at<uchar>(i, j) = 255;
      }
  }
}

// --- map: coverage of the seen cells, elevation r (plane removed) and detail r (0.2 m high-pass).
nlohmann::json score_elevation(const ScoredGrid& g) {
  const int R = g.elev.rows, C = g.elev.cols;
  std::vector<double> xs, ys, ze, zt;
  int n_seen = 0, n_known = 0, n_view = 0, n_view_known = 0;
  cv::Mat both(R, C, CV_8U, cv::Scalar(0));
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j) {
      if (g.in_view.at<uchar>(i, j)) ++n_view, n_view_known += std::isfinite(g.elev.at<float>(i, j)) ? 1 : 0;
      if (!g.seen.at<uchar>(i, j)) continue;
      ++n_seen;
      if (!std::isfinite(g.elev.at<float>(i, j))) continue;
      ++n_known;
      both.at<uchar>(i, j) = 255;
      const cv::Point2d c = g.centre(i, j);
      xs.push_back(c.x), ys.push_back(c.y);
      ze.push_back(g.elev.at<float>(i, j)), zt.push_back(g.truth.at<float>(i, j));
    }
  remove_plane(xs, ys, ze);
  remove_plane(xs, ys, zt);
  const double r_plane = pearson(ze, zt);
  // Detail: subtract a 0.2 m Gaussian from both (over the known cells).
  cv::Mat ez = g.elev.clone(), tz = g.truth.clone();
  const cv::Mat be = blur_known(ez, both, 0.2 / g.res), bt = blur_known(tz, both, 0.2 / g.res);
  std::vector<double> de, dt;
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j)
      if (both.at<uchar>(i, j))
        de.push_back(ez.at<float>(i, j) - be.at<float>(i, j)), dt.push_back(tz.at<float>(i, j) - bt.at<float>(i, j));
  return {{"seen_cells", n_seen},    {"coverage", n_seen ? static_cast<double>(n_known) / n_seen : 0.0},
          {"in_view_cells", n_view}, {"coverage_in_view", n_view ? static_cast<double>(n_view_known) / n_view : 0.0},
          {"elevation_r", r_plane},  {"elevation_detail_r", pearson(de, dt)}};
}

std::vector<TRock> read_truth_rocks(const fs::path& drive_dir) {
  const std::string tname = (drive_dir / "truth.json").string();
  const nlohmann::json tj = read_json_file(tname, "truth (truth.json)");
  if (!tj.is_object() || !tj.contains("rocks") || !tj["rocks"].is_array())
    throw InputError(tname + ": rocks: must be an array");
  std::vector<TRock> truth_rocks;
  for (std::size_t q = 0; q < tj["rocks"].size(); ++q) {
    const nlohmann::json& r = tj["rocks"][q];
    const std::string at = tname + ": rocks[" + std::to_string(q) + "]";
    const auto num = [&](const char* key) { return json_number(r, at, key); };
    if (!r.is_object() || !r.contains("observed") || !r["observed"].is_boolean())
      throw InputError(at + ": observed: must be true or false");
    truth_rocks.push_back({num("x_m"), num("y_m"), num("height_above_ground_m"),
                           std::max(num("width_m"), num("length_m")), num("major_axis_m"), num("minor_axis_m"),
                           num("yaw_deg") * 3.14159265358979323846 / 180, r["observed"].get<bool>()});
  }
  return truth_rocks;
}

// Detections matched one-to-one to true rocks, nearest pairs first, within max(0.6 x the rock's
// extent, 0.10 m).
struct RockMatch {
  std::vector<int> rock_of_detection;  // truth index or -1
  std::vector<int> detection_of_rock;  // detection index or -1
};

RockMatch match_rocks(const std::vector<TRock>& truth_rocks, const std::vector<Row>& det) {
  std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;
  for (std::size_t a = 0; a < truth_rocks.size(); ++a)
    for (std::size_t b = 0; b < det.size(); ++b) {
      const TRock& t = truth_rocks[a];
      const double d = std::hypot(det[b].at("x_m") - t.x, det[b].at("y_m") - t.y);
      if (d <= std::max(0.6 * t.ext, 0.10)) pairs.emplace_back(d, a, b);
    }
  std::sort(pairs.begin(), pairs.end());
  RockMatch m{std::vector<int>(det.size(), -1), std::vector<int>(truth_rocks.size(), -1)};
  for (const auto& [d, a, b] : pairs)
    if (m.rock_of_detection[b] < 0 && m.detection_of_rock[a] < 0)
      m.rock_of_detection[b] = static_cast<int>(a), m.detection_of_rock[a] = static_cast<int>(b);
  return m;
}

// --- rocks: recall, precision and F1 over the observed rocks >= 10 cm, median height error.
nlohmann::json score_rocks(const std::vector<TRock>& truth_rocks, const std::vector<Row>& det, const RockMatch& m) {
  int positives = 0, hits = 0, false_alarms = 0;
  std::vector<double> herr;
  for (std::size_t a = 0; a < truth_rocks.size(); ++a)
    if (truth_rocks[a].observed && truth_rocks[a].h >= 0.10) {
      ++positives;
      if (const int d = m.detection_of_rock[a]; d >= 0) {
        ++hits;
        herr.push_back(100 * std::abs(det[static_cast<std::size_t>(d)].at("height_m") - truth_rocks[a].h) /
                       truth_rocks[a].h);
      }
    }
  for (std::size_t b = 0; b < det.size(); ++b)
    if (m.rock_of_detection[b] < 0) ++false_alarms;
  // Is each rock's claimed position covariance honest (rocks.csv's cov_xx, cov_xy, cov_yy)? Per
  // observed true rock >= 10 cm with a detection within 1 m (matched or not: a rock placed 0.5 m
  // short is what its covariance has to cover), the squared Mahalanobis distance of the nearest
  // such detection's error. (A detection near no rock is a false alarm, scored by the precision.)
  double d2_sum = 0;
  int n_cov = 0, within95 = 0;
  for (const TRock& t : truth_rocks) {
    if (!t.observed || t.h < 0.10) continue;
    const Row* near = nullptr;
    double best = 1.0;
    for (const Row& r : det) {
      const double d = std::hypot(r.at("x_m") - t.x, r.at("y_m") - t.y);
      if (d <= best) best = d, near = &r;
    }
    if (near == nullptr || !near->count("cov_xx") || !near->count("cov_xy") || !near->count("cov_yy")) continue;
    const double d2 = mahalanobis2(near->at("x_m") - t.x, near->at("y_m") - t.y, near->at("cov_xx"), near->at("cov_xy"),
                                   near->at("cov_yy"));
    if (!std::isfinite(d2)) continue;
    d2_sum += d2;
    within95 += d2 <= kChi2TwoDof95 ? 1 : 0;
    ++n_cov;
  }
  const double recall = positives ? static_cast<double>(hits) / positives : std::nan("");
  const double precision = (hits + false_alarms) ? static_cast<double>(hits) / (hits + false_alarms) : std::nan("");
  std::sort(herr.begin(), herr.end());
  return {{"truth_rocks_ge10cm_observed", positives},
          {"detections", det.size()},
          {"hits", hits},
          {"false_alarms", false_alarms},
          {"recall", recall},
          {"precision", precision},
          {"f1", (recall + precision) > 0 ? 2 * recall * precision / (recall + precision) : 0.0},
          {"median_height_error_pct", herr.empty() ? std::nan("") : herr[herr.size() / 2]},
          {"covariance_rocks", n_cov},
          {"position_mahalanobis2_mean", n_cov ? d2_sum / n_cov : std::nan("")},
          {"position_within_95pct_ellipse", n_cov ? static_cast<double>(within95) / n_cov : std::nan("")}};
}

// --- hazard: ROC AUC over the seen cells with a hazard value; positive = on a rock >= 10 cm,
// negative = on no rock >= 5 cm (cells on 5-10 cm rocks are left out). Also the other reading of
// "over the seen cells": every seen cell scored, an unknown (NaN) hazard as 0 (auc_unknown_as_zero),
// with how many seen cells are unknown and how many of them lie on a rock >= 10 cm.
nlohmann::json score_hazard(const ScoredGrid& g, const std::vector<TRock>& truth_rocks) {
  std::vector<std::pair<double, int>> scores, with_unknown, in_view;
  int unknown_pos = 0;
  for (int i = 0; i < g.hazard.rows; ++i)
    for (int j = 0; j < g.hazard.cols; ++j) {
      if (!g.in_view.at<uchar>(i, j)) continue;
      const bool known = std::isfinite(g.hazard.at<float>(i, j));
      const cv::Point2d c = g.centre(i, j);
      bool pos = false, near5 = false;
      for (const TRock& t : truth_rocks) {
        if (t.h < 0.05) continue;
        const double dx = c.x - t.x, dy = c.y - t.y, cs = std::cos(t.yaw), sn = std::sin(t.yaw);
        const double u = (cs * dx + sn * dy) / (0.5 * t.w), v = (-sn * dx + cs * dy) / (0.5 * t.l);
        if (u * u + v * v <= 1.0) {
          near5 = true;
          if (t.h >= 0.10) pos = true;
        }
      }
      if (!pos && near5) continue;
      if (known) in_view.emplace_back(g.hazard.at<float>(i, j), pos ? 1 : 0);
      if (!g.seen.at<uchar>(i, j)) continue;
      const double h = known ? g.hazard.at<float>(i, j) : 0.0;
      with_unknown.emplace_back(h, pos ? 1 : 0);
      if (known)
        scores.emplace_back(h, pos ? 1 : 0);
      else if (pos)
        ++unknown_pos;
    }
  const auto positives = std::count_if(scores.begin(), scores.end(), [](const auto& s) { return s.second == 1; });
  return {{"cells", scores.size()},
          {"positive_cells", positives},
          {"auc", auc(scores)},
          {"unknown_cells", with_unknown.size() - scores.size()},
          {"unknown_positive_cells", unknown_pos},
          {"auc_unknown_as_zero", auc(with_unknown)},
          {"auc_in_view", auc(in_view)}};
}

}  // namespace

nlohmann::json evaluate_map(const fs::path& drive_dir, const fs::path& map_dir, const fs::path& overlay) {
  nlohmann::json out;
  const RecordedDrive drive = read_drive(drive_dir);
  std::map<int, Row> tp;
  for (auto& r : read_csv(drive_dir / "truth_poses.csv", {"frame", "rover_x_m", "rover_y_m", "rover_yaw_rad", "x_m",
                                                          "y_m", "z_m", "yaw_rad", "pitch_rad", "roll_rad"}))
    tp[static_cast<int>(r.at("frame"))] = std::move(r);
  const auto est =
      read_csv(map_dir / "odometry.csv", {"frame", "x_m", "y_m", "yaw_rad", "wheel_x_m", "wheel_y_m", "wheel_yaw_rad"});
  out["poses"] = score_poses(tp, est, map_dir);
  ScoredGrid grid = read_scored_grid(drive_dir, map_dir);
  mark_seen(grid, tp, drive.camera);
  out["map"] = score_elevation(grid);
  const std::vector<TRock> truth_rocks = read_truth_rocks(drive_dir);
  const auto det = read_csv(map_dir / "rocks.csv", {"x_m", "y_m", "height_m"});
  const RockMatch match = match_rocks(truth_rocks, det);
  out["rocks"] = score_rocks(truth_rocks, det, match);
  out["hazard"] = score_hazard(grid, truth_rocks);
  if (overlay.empty()) return out;

  std::vector<cv::Point2d> true_path, corrected_path, wheel_path;
  for (const auto& [f, t] : tp) true_path.emplace_back(t.at("rover_x_m"), t.at("rover_y_m"));
  for (const auto& e : est) {
    corrected_path.emplace_back(e.at("x_m"), e.at("y_m"));
    wheel_path.emplace_back(e.at("wheel_x_m"), e.at("wheel_y_m"));
  }
  // The drive's name, also when its path was given with a trailing slash.
  std::error_code ec;
  const fs::path whole = fs::absolute(drive_dir / "", ec);
  const std::string drive_name = (ec ? drive_dir / "" : whole).lexically_normal().parent_path().filename().string();
  const nlohmann::json& rocks = out["rocks"];
  const int positives = rocks["truth_rocks_ge10cm_observed"], hits = rocks["hits"];
  const int false_alarms = rocks["false_alarms"];
  char title[256], scores[256];
  std::snprintf(title, sizeof title, "%s: rocks >= 10 cm seen %d: %d hit, %d missed; %d false alarms; F1 %.2f",
                drive_name.c_str(), positives, hits, positives - hits, false_alarms, rocks["f1"].get<double>());
  std::snprintf(
      scores, sizeof scores, "hazard AUC %.3f, coverage %.2f, elevation r %.3f, final position error %.2f %% of %.2f m",
      out["hazard"]["auc"].get<double>(), out["map"]["coverage"].get<double>(), out["map"]["elevation_r"].get<double>(),
      out["poses"]["final_position_error_pct"].get<double>(), out["poses"]["path_m"].get<double>());
  const Scored sc{.truth = grid.truth,
                  .seen = grid.seen,
                  .elev = grid.elev,
                  .origin = {grid.ox, grid.oy},
                  .res = grid.res,
                  .rocks = truth_rocks,
                  .detections = det,
                  .rock_of_detection = match.rock_of_detection,
                  .detection_of_rock = match.detection_of_rock,
                  .true_path = std::move(true_path),
                  .corrected_path = std::move(corrected_path),
                  .wheel_path = std::move(wheel_path),
                  .title = title,
                  .scores = scores};
  plot::write_png(overlay, render_scored(sc));
  return out;
}

}  // namespace regolith::mapping
