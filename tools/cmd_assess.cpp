// `regolith assess IMAGE --out DIR`: one image -> SfS height map (TIFF, heat map, hillshade),
// traversability layers (PNG) and a JSON summary; with a camera model also the ground range per
// pixel (range.tiff) and the rocks it sees, ranged and sized in metres (rocks.csv). Algorithms:
// components/sfs, direct_depth, traversability, mapping (RockSightings). Bad input -> InputError /
// ConfigError (exit code 2) naming the file or option. assess() runs four stages, each a function
// below: read_input (the image, or a recording's frame), configure (YAML file, command line,
// rover description -> SfS, grid, sun, camera), solve_image + map_terrain (SfS, traversability
// grid), and the outputs (write_pictures, find_hazards, image_rocks, summary.json).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cli.hpp"
#ifdef REGOLITH_HAVE_HAL_RECORD
#include "regolith/record/recording.hpp"
#endif
#include "regolith/common/camera.hpp"
#include "regolith/common/grid_params.hpp"
#include "regolith/common/plot.hpp"
#include "regolith/common/scene.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/image_file.hpp"
#include "regolith/core/json_text.hpp"
#include "regolith/core/params.hpp"
#include "regolith/core/rover.hpp"
#include "regolith/core/text_file.hpp"
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/mapping/rock_sightings.hpp"
#include "regolith/sfs/component.hpp"
#include "regolith/sfs/flat_field.hpp"
#include "regolith/sfs/sfs.hpp"
#include "regolith/traversability/traversability.hpp"

namespace regolith::cli {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

struct AssessOptions {
  std::string image, config, out, method, flat_field, camera;
  std::string rover, device;         ///< camera + sun from a deployment's rover description
  std::string scene;                 ///< camera (or pixel size), sun and flat field from a scene's input.json
  std::string sfs_frame = "ground";  ///< camera mode: "ground" (rectified) or "image" SfS for the grid
  double sun_slant_deg = std::nan(""), sun_tilt_deg = std::nan("");
  double height_m = std::nan(""), pitch_deg = std::nan("");
  double pixel_size_m = 0.02;
  int frame = 0;                 ///< IMAGE is a recording (.mcap): this frame of the camera --device
  double min_rock_score = 0.35;  ///< rocks whose contrast score is lower are texture (counted, not listed)
};

double now_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string fmt(double v, int prec = 3) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(prec);
  s << v;
  return s.str();
}

void write_png(const fs::path& p, const cv::Mat& img) {
  try {
    plot::write_png(p, img);
  } catch (const std::runtime_error& e) {
    throw InputError(std::string("assess: ") + e.what());
  }
}

// Metric axes of a grid picture (grid_map convention: row 0 = the far edge, column 0 = the left
// edge), x forward and y left in metres, as summary.json gives positions.
plot::MapAxes grid_axes(const common::GridGeometry& g) {
  plot::MapAxes a;
  a.top = g.center_x_m + 0.5 * g.length_x_m;
  a.bottom = g.center_x_m - 0.5 * g.length_x_m;
  a.left = g.center_y_m + 0.5 * g.length_y_m;
  a.right = g.center_y_m - 0.5 * g.length_y_m;
  a.x_label = "y, left (m)";
  a.y_label = "x, forward (m)";
  return a;
}

// Text labels on a picture that never overlap: a label whose box would cover one already
// placed is left out (crowded hazards far away would otherwise print over each other).
class LabelPlacer {
 public:
  bool put(cv::Mat& img, const std::string& text, cv::Point at, double scale, cv::Scalar colour) {
    int base = 0;
    const cv::Size ts = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &base);
    const cv::Rect box(at.x - 2, at.y - ts.height - 2, ts.width + 4, ts.height + base + 4);
    for (const cv::Rect& r : placed_)
      if ((r & box).area() > 0) {
        ++skipped_;
        return false;
      }
    placed_.push_back(box);
    cv::putText(img, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
    cv::putText(img, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
    return true;
  }
  int skipped() const { return skipped_; }

 private:
  std::vector<cv::Rect> placed_;
  int skipped_ = 0;
};

// One rock seen in a perspective image: its image box and its size on the ground.
struct ImageRock {
  cv::Rect box;            ///< px
  double range_m = 0.0;    ///< forward ground distance of its centre (camera foot frame)
  double lateral_m = 0.0;  ///< left of the optical axis's ground track
  double width_m = 0.0;    ///< across the line of sight, at the ground contact
  double height_m = 0.0;   ///< top above the ground
  bool top_cut = false;    ///< the image's top edge cuts it: height is a lower bound
  double score = 0.0;      ///< 0..1, contrast against the ground
  double height_sfs_m = std::numeric_limits<double>::quiet_NaN();  ///< from the grid's SfS elevation; NaN: not seen
};

// Each rock's height as the grid's shading solve sees it: the highest known elevation within the
// rock's footprint (half its width, at least 1.5 cells, around its ground position) over the median of
// the ring 1.5-2.5 footprint radii out (the local ground). NaN when fewer than 3 footprint or 5
// ring cells are known.
void sfs_rock_heights(const traversability::GridMap& grid, std::vector<ImageRock>& rocks) {
  const cv::Mat& e = grid.layer("elevation");
  const double res = grid.resolution_m;
  std::vector<float> ring;
  for (ImageRock& r : rocks) {
    const double rf = std::max(0.5 * r.width_m, 1.5 * res), ring_out = 2.5 * rf;
    int ci = 0, cj = 0;
    if (!grid.cell_of(r.range_m, r.lateral_m, ci, cj)) continue;
    const int span = static_cast<int>(std::ceil(ring_out / res));
    float top = -std::numeric_limits<float>::infinity();
    int inside = 0;
    ring.clear();
    for (int i = std::max(0, ci - span); i <= std::min(e.rows - 1, ci + span); ++i)
      for (int j = std::max(0, cj - span); j <= std::min(e.cols - 1, cj + span); ++j) {
        const float z = e.at<float>(i, j);
        if (!std::isfinite(z)) continue;
        const cv::Point2d c = grid.cell_center(i, j);
        const double d = std::hypot(c.x - r.range_m, c.y - r.lateral_m);
        if (d <= rf)
          top = std::max(top, z), ++inside;
        else if (d >= 1.5 * rf && d <= ring_out)
          ring.push_back(z);
      }
    if (inside < 3 || ring.size() < 5) continue;
    std::nth_element(ring.begin(), ring.begin() + static_cast<std::ptrdiff_t>(ring.size() / 2), ring.end());
    r.height_sfs_m = std::max(0.0, static_cast<double>(top - ring[ring.size() / 2]));
  }
}

// Rocks in one perspective image: mapping::RockSightings (contrast blobs against the local
// ground, ranged by direct depth: contact = the blob's lowest row, width = its side columns at
// that range, height = its top ray over the centre), with its pixel scales grown with the image
// (RockSightingParams::scaled_to_width; blobs of at least 24 px at the 320 px reference, twice the
// map's: one frame has no second look to confirm a small one), its range window opened to what a single
// image shows (0.2 m to 10 m, rocks of 5 mm and more), and a side-lit rock's bright and dark
// halves merged into one (merge_halves), measured at the image's full size (max_width_px 0). `g8`: the 8-bit grey image
// (assess converts on reading).
std::vector<ImageRock> image_rocks(const cv::Mat& g8, const direct_depth::DirectDepth& depth, const cv::Vec3d& sun_body,
                                   double min_score, int& below_min_score) {
  mapping::RockSightingParams p;
  p.min_pixels = 24;      // at the reference width: twice the map's (one frame, no second look)
  p.merge_halves = true;  // a side-lit rock's bright and dark halves are one rock
  // Full size: on the development scenes (persp_dev 0 / 1, 640 px) the map's 320 px working frame
  // gave median height errors of 9 / 24 % (full size 14 / 17 %), widths 10 / 9 % (15 / 9 %) and one
  // box on no rock (none): no clear gain for a single image, which has time for its full rows.
  p.max_width_px = 0;
  p = p.scaled_to_width(g8.cols);
  p.max_pixels = std::max(p.min_pixels, g8.cols * g8.rows / 4);
  p.min_range_m = 0.2;
  p.max_range_m = 10.0;
  p.min_height_m = 0.005;
  p.max_height_m = 1.0;
  p.max_sightings = 256;
  mapping::RockSightings sightings(depth, p);
  const int n = sightings.compute(g8, {}, sun_body);
  std::vector<ImageRock> out;
  const cv::Mat& t = sightings.table();
  below_min_score = 0;
  for (int k = 0; k < n; ++k) {
    if (t.at<float>(mapping::kSightScore, k) < min_score) {
      ++below_min_score;
      continue;
    }
    ImageRock r;
    const int c0 = static_cast<int>(t.at<float>(mapping::kSightCol0, k)),
              r0 = static_cast<int>(t.at<float>(mapping::kSightRow0, k));
    const int c1 = static_cast<int>(t.at<float>(mapping::kSightCol1, k)),
              r1 = static_cast<int>(t.at<float>(mapping::kSightRow1, k));
    r.box = cv::Rect(c0, r0, c1 - c0 + 1, r1 - r0 + 1);
    r.range_m = t.at<float>(mapping::kSightX, k);
    r.lateral_m = t.at<float>(mapping::kSightY, k);
    r.width_m = t.at<float>(mapping::kSightWidth, k);
    r.height_m = t.at<float>(mapping::kSightHeight, k);
    r.score = t.at<float>(mapping::kSightScore, k);
    r.top_cut = r0 == 0;
    out.push_back(r);
  }
  std::sort(out.begin(), out.end(), [](const ImageRock& a, const ImageRock& b) { return a.range_m < b.range_m; });
  return out;
}

// Rock boxes drawn on the overlay (above its legend strip): R<n>, width x height in cm.
void draw_rocks(cv::Mat& img, const std::vector<ImageRock>& rocks, LabelPlacer& labels) {
  for (std::size_t k = 0; k < rocks.size(); ++k) {
    const ImageRock& r = rocks[k];
    cv::rectangle(img, r.box, cv::Scalar(0, 220, 255), 1, cv::LINE_AA);
    std::ostringstream text;
    text.setf(std::ios::fixed);
    text.precision(1);
    text << "R" << k + 1 << " " << 100.0 * r.width_m << "x" << (r.top_cut ? ">" : "") << 100.0 * r.height_m << " cm";
    const cv::Point at(r.box.x, r.box.y > 16 ? r.box.y - 4 : r.box.y + r.box.height + 14);
    labels.put(img, text.str(), at, 0.4, cv::Scalar(0, 220, 255));
  }
}

// Without a configured grid (camera mode), the grid covers the ground the camera sees: from the
// bottom row's range to the top row's (at most 5 m), the lateral extent of the view there (at
// most +-2 m), in cells of 1/60 of its length (0.01-0.05 m), so a camera close to the ground
// (0.3-1.4 m of view) is mapped as fully as a rover's navigation camera (the default 1-5 m grid).
// A camera that sees no ground keeps the configured default.
void fit_grid_to_view(const direct_depth::DirectDepth& depth, cv::Size image,
                      traversability::TraversabilityParams& tp) {
  const double cxm = 0.5 * (image.width - 1);
  const direct_depth::GroundPoint bottom = depth.ground(cxm, image.height - 0.5), top = depth.ground(cxm, -0.5);
  if (!bottom.valid) return;
  const double near = bottom.range_m, far = std::min(5.0, top.valid ? top.range_m : 5.0);
  if (!(far > near + 0.1)) return;
  // Lateral extent of the view where the grid ends: the left image edge at range `far`.
  double half = 2.0;
  for (int r = image.height - 1; r >= 0; --r) {
    const direct_depth::GroundPoint e = depth.ground(-0.5, r + 0.5);
    if (!e.valid) break;
    half = std::abs(e.lateral_m);
    if (e.range_m >= far) break;
  }
  common::GridGeometry g = tp.grid();
  g.resolution_m = std::clamp((far - near) / 60.0, 0.01, 0.05);
  g.center_x_m = 0.5 * (near + far);
  g.length_x_m = far - near;
  g.center_y_m = 0.0;
  g.length_y_m = 2.0 * std::clamp(half, 0.1, 2.0);
  tp.set_grid(g);
  // The ground solve's rectified cells at most half a grid cell: with coarser ones (a close
  // camera's 1-2 cm grid against the default 2 cm rectification) rows and columns of grid cells
  // receive no rectified sample, and the holes read as hazards.
  tp.rectify_resolution_m = std::min(tp.rectify_resolution_m, 0.5 * g.resolution_m);
}

// rocks.csv: one line per rock (id from 1, nearest first), the columns of summary.json's rocks.
void write_rocks(const fs::path& out, const std::vector<ImageRock>& rocks) {
  std::ostringstream csv;
  csv << "id,range_m,lateral_m,width_m,height_m,height_is_lower_bound,score,xmin,ymin,xmax,ymax,height_sfs_m\n";
  for (std::size_t k = 0; k < rocks.size(); ++k) {
    const ImageRock& r = rocks[k];
    csv << k + 1 << "," << fmt(r.range_m, 4) << "," << fmt(r.lateral_m, 4) << "," << fmt(r.width_m, 4) << ","
        << fmt(r.height_m, 4) << "," << (r.top_cut ? 1 : 0) << "," << fmt(r.score, 3) << "," << r.box.x << ","
        << r.box.y << "," << r.box.x + r.box.width - 1 << "," << r.box.y + r.box.height - 1 << ","
        << (std::isfinite(r.height_sfs_m) ? fmt(r.height_sfs_m, 4) : std::string()) << "\n";
  }
  write_file((out / "rocks.csv").string(), csv.str(), "the rocks table");
}

nlohmann::json rocks_json(const std::vector<ImageRock>& rocks) {
  nlohmann::json a = nlohmann::json::array();
  for (std::size_t k = 0; k < rocks.size(); ++k) {
    const ImageRock& r = rocks[k];
    a.push_back({{"id", k + 1},
                 {"range_m", r.range_m},
                 {"lateral_m", r.lateral_m},
                 {"width_m", r.width_m},
                 {"height_m", r.height_m},
                 {"height_is_lower_bound", r.top_cut},
                 {"score", r.score},
                 {"box_px", {r.box.x, r.box.y, r.box.x + r.box.width - 1, r.box.y + r.box.height - 1}},
                 {"height_sfs_m", std::isfinite(r.height_sfs_m) ? nlohmann::json(r.height_sfs_m) : nlohmann::json()}});
  }
  return a;
}

// The camera image with the traversability grid drawn where it lies on the ground (camera mode):
// every known cell's footprint projected through the camera model, hazards (traversability 0)
// red, poor ground (< 0.5) orange, the rest left clear; each hazard labelled with its number and
// its highest elevation. What a person compares with: the rocks they can see.
cv::Mat camera_overlay(const cv::Mat& gray, const traversability::GridMap& grid, const direct_depth::DirectDepth& depth,
                       const cv::Mat& hazard_labels, const std::vector<std::pair<int, std::string>>& hazard_text,
                       const std::vector<ImageRock>& rocks) {
  cv::Mat img;
  cv::cvtColor(gray, img, cv::COLOR_GRAY2BGR);
  cv::Mat paint = img.clone();
  const cv::Mat& trav = grid.layer("traversability");
  const double h = 0.5 * grid.resolution_m;
  std::vector<std::vector<cv::Point>> outlines(hazard_text.size() + 1);
  for (int i = 0; i < trav.rows; ++i)
    for (int j = 0; j < trav.cols; ++j) {
      const float t = trav.at<float>(i, j);
      if (!std::isfinite(t) || t >= 0.5f) continue;
      const cv::Point2d c = grid.cell_center(i, j);
      std::vector<cv::Point> quad;
      for (const auto& [dx, dy] : {std::pair{-h, -h}, std::pair{-h, h}, std::pair{h, h}, std::pair{h, -h}}) {
        const auto p = depth.project(c.x + dx, c.y + dy);
        if (!p) break;
        quad.emplace_back(static_cast<int>(std::lround(p->x)), static_cast<int>(std::lround(p->y)));
      }
      if (quad.size() != 4) continue;
      const bool hazard = t == 0.0f;
      cv::fillConvexPoly(paint, quad, hazard ? cv::Scalar(40, 40, 230) : cv::Scalar(0, 150, 255), cv::LINE_AA);
      const int k = hazard_labels.at<int>(i, j);
      if (k > 0 && k < static_cast<int>(outlines.size()))
        outlines[k].insert(outlines[k].end(), quad.begin(), quad.end());
    }
  cv::addWeighted(paint, 0.45, img, 0.55, 0.0, img);
  LabelPlacer labels;
  for (const auto& [k, text] : hazard_text) {
    if (k <= 0 || k >= static_cast<int>(outlines.size()) || outlines[k].empty()) continue;
    std::vector<cv::Point> hull;
    cv::convexHull(outlines[k], hull);
    cv::polylines(img, hull, true, cv::Scalar(0, 0, 255), 2, cv::LINE_AA);
    const cv::Rect b = cv::boundingRect(hull);
    labels.put(img, text, cv::Point(b.x, std::max(14, b.y - 4)), 0.5, cv::Scalar(255, 255, 255));
  }
  draw_rocks(img, rocks, labels);
  cv::Mat out(img.rows + 26, img.cols, CV_8UC3, cv::Scalar(255, 255, 255));
  img.copyTo(out(cv::Rect(0, 0, img.cols, img.rows)));
  std::string legend =
      "hazards (red, H<n>: highest elevation), poor ground (orange), rocks (yellow, R<n>: width x height)";
  if (labels.skipped() > 0)
    legend += "; " + std::to_string(labels.skipped()) + " crowded labels left out (summary.json)";
  plot::put_fitted_text(out, legend, {6, img.rows + 18}, img.cols - 12, 0.42);
  return out;
}

std::vector<double> parse_camera(const std::string& s) {
  std::vector<double> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw ConfigError("--camera: '" + s + "' is not fx,fy,cx,cy (numbers in px)");
    }
  }
  if (v.size() != 4) throw ConfigError("--camera: expected fx,fy,cx,cy (4 numbers in px), got '" + s + "'");
  return v;
}

// ---- 1. the image ----

// The image assess works on, in 8-bit grey, and the camera and deployment it came with.
struct AssessInput {
  cv::Mat gray;
  std::string device;      ///< --device, or the recording's camera
  std::string rover_file;  ///< --rover, or the recording's deployment (name)
  std::string rover_text;  ///< the recording's deployment (YAML), empty when read from rover_file
};

AssessInput read_input(const AssessOptions& o) {
  if (!fs::exists(o.image)) throw InputError("assess: image '" + o.image + "' does not exist");
  AssessInput in{.gray = {}, .device = o.device, .rover_file = o.rover, .rover_text = {}};
  cv::Mat raw;
  // A recording (`regolith run --record`): one frame of one camera, and the deployment it ran
  // gives that camera's calibration, mount and the sun unless the command line says otherwise.
  if (fs::path(o.image).extension() == ".mcap") {
#ifdef REGOLITH_HAVE_HAL_RECORD
    if (o.frame < 0) throw ConfigError("--frame: must be >= 0");
    const record::RecordedFrame f = record::recorded_camera_frame(o.image, o.device, static_cast<std::size_t>(o.frame));
    raw = f.image;
    in.device = f.device;
    std::printf("%s: camera %s, frame %d of %zu (sequence %u)\n", o.image.c_str(), f.device.c_str(), o.frame, f.count,
                f.sequence);
    if (in.rover_file.empty() && o.camera.empty() && !std::isfinite(o.height_m)) {
      in.rover_file = f.deployment.name;
      in.rover_text = f.deployment.text;
    }
#else
    throw ConfigError("assess: this build reads no recordings (built without the HAL recording)");
#endif
  } else {
    std::string why;
    raw = regolith::read_image_file(o.image, cv::IMREAD_UNCHANGED, &why);
    if (raw.empty()) throw InputError("assess: cannot read image '" + o.image + "': " + why);
  }
  if (raw.depth() != CV_8U) {
    // 16-bit (a 12-bit camera's PNG or TIFF) and float images are scaled to 8 bits by the range
    // they use (regolith::to_8bit); signed samples are refused.
    const cv::Mat g8 = regolith::to_8bit(raw);
    if (g8.empty())
      throw InputError("assess: image '" + o.image + "' has signed samples (depth " + std::to_string(raw.depth()) +
                       "); give 8- or 16-bit grey or colour");
    raw = g8;
  }
  if (raw.channels() == 1)
    in.gray = raw;
  else if (raw.channels() == 3)
    cv::cvtColor(raw, in.gray, cv::COLOR_BGR2GRAY);
  else if (raw.channels() == 4)
    cv::cvtColor(raw, in.gray, cv::COLOR_BGRA2GRAY);
  else
    throw InputError("assess: image '" + o.image + "' has " + std::to_string(raw.channels()) + " channels");
  if (in.gray.rows < 16 || in.gray.cols < 16)
    throw InputError("assess: image '" + o.image + "' is " + std::to_string(in.gray.cols) + "x" +
                     std::to_string(in.gray.rows) + " px; at least 16x16 is needed");
  return in;
}

// ---- 2. the settings: an optional YAML file, then the command line ----

struct AssessSetup {
  sfs::SfsParams sp;
  traversability::TraversabilityParams tp;
  std::optional<sfs::LightDirection> light;        ///< the sun in the image frame; none: estimated
  std::optional<direct_depth::CameraModel> model;  ///< none: an orthographic top-down patch
  double pixel_size_m = 0.02;                      ///< orthographic mode
  bool grid_given = false;  ///< grid geometry from the config; else (camera mode) fitted to the view
  std::string sun_error;    ///< non-empty: the sun is ahead of the camera (no image-frame SfS)
  std::unique_ptr<direct_depth::DirectDepth> depth;  ///< of `model`
  bool sun_ahead() const { return !sun_error.empty(); }
};

// `--config FILE`: method, iterations, tolerance, vignetting, sun, pixel size, camera_model, grid.
void read_config_file(const std::string& file, cv::Size image, AssessSetup& s) {
  Params p = Params::load_file(file);
  sfs::SfsParams& sp = s.sp;
  traversability::TraversabilityParams& tp = s.tp;
  sp.method = sfs::method_from_string(
      p.get<std::string>("method", sfs::to_string(sp.method),
                         {.choices = {"tsai_shah", "pentland", "bichsel_pentland"}, .doc = "SfS method"}));
  sp.iterations = p.get<int>("iterations", sp.iterations, {.min = 1, .max = 100000});
  sp.tolerance = p.get<double>("tolerance", sp.tolerance, {.unit = "px", .min = 0.0});
  sp.vignetting.a2 = p.get<double>("vignetting_a2", 0.0);
  sp.vignetting.a4 = p.get<double>("vignetting_a4", 0.0);
  sp.vignetting.a6 = p.get<double>("vignetting_a6", 0.0);
  sp.vignetting.enabled = sp.vignetting.a2 != 0 || sp.vignetting.a4 != 0 || sp.vignetting.a6 != 0;
  if (p.has("sun_slant_rad") || p.has("sun_tilt_rad"))
    s.light = sfs::LightDirection{p.require<double>("sun_slant_rad", {.unit = "rad"}),
                                  p.require<double>("sun_tilt_rad", {.unit = "rad"})};
  s.pixel_size_m = p.get<double>(
      "pixel_size_m", s.pixel_size_m,
      {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "orthographic mode: ground size of a pixel"});
  // The same camera_model reader as the rover description's tools (sfs component header).
  if (p.has("camera_model")) s.model = sfs::read_camera_model(p.child("camera_model"), image.width, image.height);
  Params g = p.child("grid");
  s.grid_given = common::has_grid_geometry(g);
  tp.set_grid(common::read_grid_geometry(g, tp.grid(), "grid map"));
  tp.critical_slope_rad = g.get<double>("critical_slope_rad", tp.critical_slope_rad,
                                        {.unit = "rad", .min = 0.0, .max = 1.57, .min_exclusive = true});
  tp.critical_step_m =
      g.get<double>("critical_step_m", tp.critical_step_m, {.unit = "m", .min = 0.0, .min_exclusive = true});
  tp.critical_roughness_m =
      g.get<double>("critical_roughness_m", tp.critical_roughness_m, {.unit = "m", .min = 0.0, .min_exclusive = true});
  tp.height_gain = g.get<double>("height_gain", tp.height_gain, {.min = 0.0, .min_exclusive = true});
  g.finish();
  p.finish();
}

// --sun-slant / --sun-tilt over the file's sun. A sun behind the image plane (slant >= 90 deg:
// ahead of a forward camera) leaves no image-frame shading to solve, but the ground-frame path
// (camera mode) still maps the ground and the rocks need no sun: accepted there (checked once the
// camera is known, `sun_error`), refused else. No sun at all: SfS estimates it.
void apply_sun_options(const AssessOptions& o, AssessSetup& s) {
  if (std::isfinite(o.sun_slant_deg) != std::isfinite(o.sun_tilt_deg))
    throw ConfigError("--sun-slant and --sun-tilt must be given together");
  if (std::isfinite(o.sun_slant_deg)) s.light = sfs::LightDirection{o.sun_slant_deg * kDeg, o.sun_tilt_deg * kDeg};
  if (!s.light) {
    s.sp.estimate_light = true;
    return;
  }
  try {
    s.light->validate("sun");
  } catch (const std::invalid_argument& e) {
    char msg[320];
    if (o.sun_slant_deg >= 0 && o.sun_slant_deg < 90)  // the slant is fine: the tilt is not
      std::snprintf(msg, sizeof msg, "--sun-tilt %g deg: must be a finite angle", o.sun_tilt_deg);
    else
      std::snprintf(msg, sizeof msg,
                    "--sun-slant %g deg: must be 0 to below 90 deg (the angle of the sun from the optical axis; "
                    "at 90 deg and beyond it is at or behind the image plane and shades nothing the camera sees)",
                    o.sun_slant_deg);
    s.sun_error = msg;
    const bool behind_image_plane =
        s.light->slant_rad >= kPi / 2 && s.light->slant_rad < kPi && std::isfinite(s.light->tilt_rad);
    if (!behind_image_plane) throw ConfigError(s.sun_error);
  }
}

// --rover FILE --device NAME (or a recording's own): the camera as the rover describes it
// (calibration + mount) and, unless given, the one sun converted into its image frame (level rover).
void camera_from_rover(const AssessOptions& o, const AssessInput& in, AssessSetup& s) {
  const std::string& rover_file = in.rover_file;
  const std::string& device = in.device;
  if (rover_file.empty() || device.empty()) throw ConfigError("--rover FILE and --device NAME go together");
  if (!o.camera.empty() || std::isfinite(o.height_m) || std::isfinite(o.pitch_deg))
    throw ConfigError("--rover gives the camera (rover.cameras." + device + "): drop --camera/--height/--pitch");
  if (in.rover_text.empty() && !fs::is_regular_file(rover_file))
    throw ConfigError("--rover: '" + rover_file + "' does not exist");
  Params root = in.rover_text.empty() ? Params::load_file(rover_file) : Params::load_string(in.rover_text, rover_file);
  const fs::path rp(rover_file);
  const RoverDescription rd = read_rover_description(root, rp.has_parent_path() ? rp.parent_path().string() : ".");
  const RoverCamera* rc = rd.camera(device);
  if (rc == nullptr) {
    std::string names;
    for (const auto& [n, c] : rd.cameras) names += (names.empty() ? "" : ", ") + n;
    throw ConfigError(rover_file + ": no rover.cameras." + device + " (described: " + (names.empty() ? "none" : names) +
                      ")");
  }
  if (rc->info.width != in.gray.cols || rc->info.height != in.gray.rows)
    throw InputError("assess: image '" + o.image + "' is " + std::to_string(in.gray.cols) + "x" +
                     std::to_string(in.gray.rows) + " px but rover.cameras." + device + " is " +
                     std::to_string(rc->info.width) + "x" + std::to_string(rc->info.height) + " px (" + rc->where +
                     ")");
  s.model = common::camera_model_of(*rc);
  if (!s.light && rd.sun) {
    const common::CameraLight cl = common::camera_light(*rd.sun, *rc);
    if (!cl.in_view)
      s.sun_error = rover_file + ": the sun is ahead of camera '" + device + "' (image slant " +
                    std::to_string(cl.light.slant_rad / kDeg) + " deg): no image-frame shading to solve";
    s.light = cl.light;
    s.sp.estimate_light = false;
  }
}

// --camera fx,fy,cx,cy --height M [--pitch DEG], or --height / --pitch over the file's camera_model.
void camera_from_options(const AssessOptions& o, cv::Size image, AssessSetup& s) {
  if (!o.camera.empty()) {
    const auto v = parse_camera(o.camera);
    if (!std::isfinite(o.height_m)) throw ConfigError("--camera needs --height M (camera height above the ground)");
    direct_depth::CameraModel m;
    m.fx = v[0];
    m.fy = v[1];
    m.cx = v[2];
    m.cy = v[3];
    m.width = image.width;
    m.height = image.height;
    m.mount_height_m = o.height_m;
    m.pitch_rad = std::isfinite(o.pitch_deg) ? o.pitch_deg * kDeg : 0.0;
    s.model = m;
  } else if (std::isfinite(o.height_m) || std::isfinite(o.pitch_deg)) {
    if (!s.model) throw ConfigError("--height/--pitch need --camera fx,fy,cx,cy");
    if (std::isfinite(o.height_m)) s.model->mount_height_m = o.height_m;
    if (std::isfinite(o.pitch_deg)) s.model->pitch_rad = o.pitch_deg * kDeg;
  }
}

// --scene input.json (common::read_scene_description: the development sets' orthographic or
// perspective scene description): fills the setup as --pixel-size / --camera --height --pitch /
// --sun-* would; returns the flat field it names (empty: none; --flat-field wins).
std::string scene_setup(const std::string& file, cv::Size image, AssessSetup& s) {
  const common::SceneDescription d = common::read_scene_description(file, image.width, image.height);
  s.sp.estimate_light = false;
  s.light = d.light;
  if (d.camera)
    s.model = *d.camera;
  else
    s.pixel_size_m = d.pixel_size_m;
  if (!d.sun_in_view)
    s.sun_error = file + ": the sun is ahead of the camera (image slant " + fmt(d.light.slant_rad / kDeg, 1) +
                  " deg): no image-frame shading to solve";
  return d.flat_field;
}

AssessSetup configure(const AssessOptions& o, const AssessInput& in) {
  AssessSetup s;
  s.pixel_size_m = o.pixel_size_m;
  if (!o.config.empty()) read_config_file(o.config, in.gray.size(), s);
  if (!o.method.empty()) s.sp.method = sfs::method_from_string(o.method);
  const std::string scene_flat = o.scene.empty() ? std::string() : scene_setup(o.scene, in.gray.size(), s);
  if (const std::string& flat = o.flat_field.empty() ? scene_flat : o.flat_field; !flat.empty()) {
    cv::Mat ff;
    if (const std::string why = sfs::read_flat_field(flat, ff); !why.empty())
      throw InputError("assess: " + (o.flat_field.empty() ? o.scene + ": flat_field" : std::string("--flat-field")) +
                       " '" + flat + "': " + why);
    s.sp.vignetting.flat_field = ff;
    s.sp.vignetting.enabled = true;
  }
  if (o.scene.empty()) {  // else the scene gave the sun and the camera (or the pixel size)
    apply_sun_options(o, s);
    if (!in.rover_file.empty() || !in.device.empty())
      camera_from_rover(o, in, s);
    else
      camera_from_options(o, in.gray.size(), s);
  }
  if (s.sun_ahead() && !(s.model && o.sfs_frame == "ground"))
    throw ConfigError(s.sun_error + (s.model ? " (--sfs-frame image needs it in front)" : ""));
  try {
    s.sp.validate();
    s.tp.validate();
    if (s.model) s.depth = std::make_unique<direct_depth::DirectDepth>(*s.model);
  } catch (const std::invalid_argument& e) {
    throw ConfigError(std::string("assess: ") + e.what());
  }
  if (s.depth && !s.grid_given) fit_grid_to_view(*s.depth, in.gray.size(), s.tp);
  return s;
}

// ---- 3. the solves ----

// Image-frame SfS (skipped with the sun ahead of the camera: height.tiff is then all NaN and the
// ground path maps the grid).
sfs::SfsResult solve_image(const AssessOptions& o, const cv::Mat& gray, const AssessSetup& s) {
  sfs::SfsResult res;
  if (s.sun_ahead()) {
    res.light = *s.light;
    res.height = cv::Mat(gray.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    res.valid = cv::Mat::zeros(gray.size(), CV_8U);
  } else {
    try {
      sfs::ShapeFromShading solver(s.sp);
      solver.compute(gray, s.light, res);
    } catch (const std::invalid_argument& e) {
      throw InputError("assess: " + o.image + ": " + e.what());
    }
  }
  if (res.status == sfs::SfsStatus::kUnreliableLight)
    throw InputError("assess: " + o.image + ": " + sfs::unreliable_light_message(res, s.sp) +
                     ": give --sun-slant DEG --sun-tilt DEG (the sun in the image frame), or --rover DEPLOYMENT.yaml "
                     "--device CAMERA (the camera and the sun of a rover description)");
  return res;
}

struct AssessTerrain {
  traversability::GridMap grid;
  cv::Mat height_m;   ///< metric height per pixel (m), NaN where unknown (not in ground mode)
  cv::Mat rectified;  ///< ground-rectified grey image (camera mode, --sfs-frame ground)
};

// The traversability grid: in camera mode from the ground-rectified image (the component's
// default) or from the image-frame heights; an orthographic patch is its own grid.
AssessTerrain map_terrain(const AssessOptions& o, const cv::Mat& gray, const AssessSetup& s,
                          const sfs::SfsResult& res) {
  AssessTerrain t;
  if (s.depth && o.sfs_frame == "ground") {
    // The traversability component's default: the (vignetting-corrected) grey image resampled
    // onto the ground grid and solved there with the sun in the ground frame.
    traversability::TraversabilityMapper mapper(*s.depth, s.tp);
    cv::Mat corrected = gray;
    if (s.sp.vignetting.enabled) {
      cv::Mat g32, f;
      gray.convertTo(g32, CV_32F, 1.0 / 255.0);
      sfs::correct_vignetting(g32, s.sp.vignetting, f);
      f.convertTo(corrected, CV_8U, 255.0);
    }
    try {
      mapper.compute_from_image(corrected, {res.light.slant_rad, res.light.tilt_rad}, t.grid);
    } catch (const std::invalid_argument& e) {
      throw InputError("assess: " + o.image + ": " + e.what());
    }
    t.rectified = mapper.rectified_image().clone();
  } else if (s.depth) {
    traversability::TraversabilityMapper mapper(*s.depth, s.tp);
    mapper.compute_from_sfs(res.height, res.valid, {res.light.slant_rad, res.light.tilt_rad}, t.grid);
    t.height_m = mapper.metric_heights().clone();
  } else {
    // Orthographic top-down patch: image row 0 = +x (forward), column 0 = +y (left); a pixel is
    // pixel_size metres; SfS heights are in pixel units, so metres = units * pixel_size.
    t.height_m = res.height * s.pixel_size_m * s.tp.height_gain;
    traversability::GridMap& grid = t.grid;
    grid.resolution_m = s.pixel_size_m;
    grid.length_x_m = gray.rows * s.pixel_size_m;
    grid.length_y_m = gray.cols * s.pixel_size_m;
    grid.center_x_m = 0;
    grid.center_y_m = 0;
    grid.layers = {"elevation"};
    cv::Mat e = t.height_m.clone();
    e.setTo(std::numeric_limits<float>::quiet_NaN(), res.valid == 0);
    grid.data = {e};
    traversability::compute_layers(grid, s.tp);
  }
  return t;
}

// ---- 4. the outputs ----

// height.tiff, height_heatmap.png, hillshade.png, rectified.png and one PNG per grid layer.
// Returns summary.json's outputs.layers.
nlohmann::json write_pictures(const fs::path& out, const cv::Mat& gray, const AssessSetup& s, const sfs::SfsResult& res,
                              const AssessTerrain& t) {
  const traversability::GridMap& grid = t.grid;
  const cv::Mat& h_up = res.height;  // pixel units, up positive
  if (!cv::imwrite((out / "height.tiff").string(), h_up))
    throw InputError("assess: cannot write '" + (out / "height.tiff").string() + "'");
  // The height picture: in camera mode the grid's elevation painted on the camera image (each
  // pixel coloured by the cell its ground point falls in: what a person compares with the rocks
  // they see); in orthographic mode the SfS heights of the patch in metres on metric axes.
  const int elev_layer =
      static_cast<int>(std::find(grid.layers.begin(), grid.layers.end(), "elevation") - grid.layers.begin());
  plot::MapStyle elev_style;
  elev_style.unit_label = "cm";
  elev_style.scale = 100.0;
  elev_style.palette = plot::Palette::turbo;
  if (s.depth && elev_layer < static_cast<int>(grid.data.size())) {
    const cv::Mat& elev = grid.data[static_cast<std::size_t>(elev_layer)];
    cv::Mat on_image(gray.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    for (int r = 0; r < gray.rows; ++r)
      for (int c = 0; c < gray.cols; ++c) {
        const direct_depth::GroundPoint g = s.depth->ground(c, r);
        int i = 0, j = 0;
        if (g.valid && grid.cell_of(g.range_m, g.lateral_m, i, j)) on_image.at<float>(r, c) = elev.at<float>(i, j);
      }
    elev_style.title = "elevation above the fitted ground (cm) on the camera image";
    elev_style.unknown_note = "uncoloured: no ground cell (sky, beyond the grid, unknown)";
    write_png(out / "height_heatmap.png", plot::render_map(on_image, elev_style, gray));
  } else {
    cv::Mat metric = t.height_m.clone();
    metric.setTo(std::numeric_limits<float>::quiet_NaN(), res.valid == 0);
    elev_style.title = "SfS height of the patch (cm; the solve's pixel units x pixel size)";
    elev_style.unknown_note = "grey: masked (shadow, no shading)";
    elev_style.axes = grid_axes(grid);
    write_png(out / "height_heatmap.png", plot::render_map(metric, elev_style));
  }
  // Hillshade (light from the upper left, 45 deg): independent of the input shading, so it shows
  // the recovered surface. Of the image-frame SfS heights when that solve ran; when it did not
  // (e.g. the sun ahead of the camera) of the grid's elevation, on its metric axes.
  plot::MapStyle pic;  // a picture with a title, no values: no colour bar
  pic.colour_bar = false;
  pic.unknown_note.clear();
  cv::Mat u8;
  const bool image_solved = cv::countNonZero(res.valid) > 0;
  if (image_solved || elev_layer >= static_cast<int>(grid.data.size())) {
    cv::Mat shade = sfs::render_lambertian(h_up, sfs::LightDirection{45 * kDeg, -135 * kDeg});
    shade.convertTo(u8, CV_8U, 255.0);
    u8.setTo(0, res.valid == 0);
    pic.title = "hillshade of the image-frame SfS heights (lit from the upper left; black: not solved)";
  } else {
    const cv::Mat shade = plot::hillshade(grid.data[static_cast<std::size_t>(elev_layer)], grid.resolution_m);
    u8.create(shade.size(), CV_8UC3);
    for (int r = 0; r < shade.rows; ++r)
      for (int c = 0; c < shade.cols; ++c) {
        const float v = shade.at<float>(r, c);
        const auto g = cv::saturate_cast<uchar>(255.0f * v);
        u8.at<cv::Vec3b>(r, c) = std::isfinite(v) ? cv::Vec3b(g, g, g) : cv::Vec3b(110, 60, 40);  // NaN: unknown
      }
    pic.title = "hillshade of the grid elevation (lit from the upper left; blue: unknown)";
    pic.axes = grid_axes(grid);
  }
  const cv::Mat none(u8.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  write_png(out / "hillshade.png", plot::render_map(none, pic, u8));
  pic.axes.reset();
  nlohmann::json layers = nlohmann::json::object();
  if (!t.rectified.empty()) {  // what the ground solve saw: far = top, rover = bottom, left = left
    pic.title = "the camera image rectified onto the ground (what the ground SfS solves)";
    pic.axes = grid_axes(grid);
    const cv::Mat none_r(t.rectified.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    write_png(out / "rectified.png", plot::render_map(none_r, pic, t.rectified));
    layers["rectified_input"] = "rectified.png";
  }
  for (std::size_t k = 0; k < grid.layers.size(); ++k) {
    const std::string& name = grid.layers[k];
    plot::MapStyle style;
    style.axes = grid_axes(grid);
    if (name == "elevation") {
      style.title = "elevation above the fitted ground (cm), " + fmt(100.0 * grid.resolution_m, 1) + " cm cells";
      style.unit_label = "cm";
      style.scale = 100.0;
    } else {
      style.title = name + ": 0 hazard .. 1 good";
      style.unit_label = "score";
      style.palette = plot::Palette::score;
      style.range = cv::Vec2d(0.0, 1.0);
    }
    write_png(out / (name + ".png"), plot::render_map(grid.data[k], style));
    layers[name] = name + ".png";
  }
  return layers;
}

// Hazards: 8-connected groups of cells with traversability 0. A group lying wholly in the band
// along the edge of the view (within kEdgeBandCells of the grid border or of a cell whose centre
// the camera does not see) is where the solve ran out of image, not an obstacle: reported apart
// as `edge_hazards`, not counted. A group reaching further in is counted even where it also
// touches the edge (a rock in front of the rover whose red ground runs on out of view). Unknown
// cells inside the view (ground hidden behind a rock) do not make an edge.
struct Hazards {
  nlohmann::json counted = nlohmann::json::array();  ///< summary.json's hazards
  nlohmann::json edge = nlohmann::json::array();     ///< summary.json's edge_hazards
  cv::Mat labels;                                    ///< CV_32S per grid cell: its group (0 = none)
  std::vector<std::pair<int, std::string>> text;     ///< counted group label -> "H<n> <elevation> cm"
};

Hazards find_hazards(const traversability::GridMap& grid, const direct_depth::DirectDepth* depth, cv::Size image) {
  constexpr int kEdgeBandCells = 2;
  const cv::Mat& trav = grid.layer("traversability");
  cv::Mat in_view(trav.rows + 2, trav.cols + 2, CV_8U, cv::Scalar(0));  // one out-of-view cell all round
  for (int i = 0; i < trav.rows; ++i)
    for (int j = 0; j < trav.cols; ++j) {
      bool seen = true;
      if (depth) {
        const cv::Point2d c = grid.cell_center(i, j);
        const auto p = depth->project(c.x, c.y);
        seen = p && p->x >= 0 && p->y >= 0 && p->x <= image.width - 1 && p->y <= image.height - 1;
      }
      in_view.at<uchar>(i + 1, j + 1) = seen ? 1 : 0;
    }
  cv::Mat edge_distance;  // cells (chessboard) to the nearest unseen cell
  cv::distanceTransform(in_view, edge_distance, cv::DIST_C, 3, CV_32F);
  cv::Mat haz = (trav == 0.0f);
  Hazards h;
  cv::Mat stats, cents;
  const int n = cv::connectedComponentsWithStats(haz, h.labels, stats, cents, 8, CV_32S);
  const cv::Mat& elev = grid.layer("elevation");
  for (int k = 1; k < n; ++k) {
    const int area = stats.at<int>(k, cv::CC_STAT_AREA);
    double zmax = -1e9;
    bool edge = true;
    for (int i = 0; i < h.labels.rows; ++i)
      for (int j = 0; j < h.labels.cols; ++j) {
        if (h.labels.at<int>(i, j) != k) continue;
        if (std::isfinite(elev.at<float>(i, j))) zmax = std::max(zmax, static_cast<double>(elev.at<float>(i, j)));
        edge = edge && edge_distance.at<float>(i + 1, j + 1) <= kEdgeBandCells;
      }
    const cv::Point2d c = grid.cell_center(static_cast<int>(std::lround(cents.at<double>(k, 1))),
                                           static_cast<int>(std::lround(cents.at<double>(k, 0))));
    const nlohmann::json hz = {{"x_m", c.x},
                               {"y_m", c.y},
                               {"cells", area},
                               {"area_m2", area * grid.resolution_m * grid.resolution_m},
                               {"max_elevation_m", zmax}};
    if (edge) {
      h.edge.push_back(hz);
    } else {
      h.counted.push_back(hz);
      h.text.emplace_back(k, "H" + std::to_string(h.counted.size()) + " " + fmt(100.0 * zmax, 1) + " cm");
    }
  }
  return h;
}

// What summary.json's `warning` says (also printed): a sun below the ground plane, no ground
// cell, the sun ahead of the camera. Adds light.ground_elevation_deg and image_sfs to `j`.
std::vector<std::string> assess_warnings(const AssessSetup& s, const sfs::SfsResult& res, int known,
                                         nlohmann::json& j) {
  std::vector<std::string> warnings;
  if (s.depth) {
    // A sun below the ground plane (often a tilt given in another convention) shades no ground:
    // every grid cell stays unknown. Said here, with the elevation, rather than left as 0 cells.
    const double el = traversability::sun_elevation(s.depth->model(), {res.light.slant_rad, res.light.tilt_rad});
    j["light"]["ground_elevation_deg"] = el / kDeg;
    if (!(el > traversability::kMinSunElevationRad))
      warnings.push_back("the sun is not above the ground plane (elevation " + fmt(el / kDeg, 1) + " deg from slant " +
                         fmt(res.light.slant_rad / kDeg, 1) + " deg, tilt " + fmt(res.light.tilt_rad / kDeg, 1) +
                         " deg and the camera's pitch and roll): no ground shading, every grid cell unknown; check "
                         "--sun-slant / --sun-tilt (tilt: from image +x towards +y, clockwise)");
  }
  // An image without shading (all black, all saturated): said as such, not blamed on the geometry.
  const int usable = res.valid.empty() ? -1 : cv::countNonZero(res.valid);
  if (known == 0 && warnings.empty() && usable >= 0 && usable * 100 < static_cast<int>(res.valid.total()))
    warnings.push_back("no shading to read: " + std::to_string(usable) + " of " + std::to_string(res.valid.total()) +
                       " pixels are neither black, saturated nor in shadow; every grid cell unknown");
  if (known == 0 && warnings.empty())
    warnings.push_back("no ground cell in the grid (camera looks above the horizon or grid outside the view)");
  if (s.sun_ahead()) {
    j["image_sfs"] = "skipped: sun ahead of the camera (image slant " + fmt(s.light->slant_rad / kDeg, 1) +
                     " deg): height.tiff is NaN; the grid comes from the ground-frame path";
    warnings.push_back(warnings.empty() ? "sun ahead of the camera: no image-frame SfS" : "sun ahead of the camera");
  }
  return warnings;
}

void assess(const AssessOptions& o) {
  const double t0 = now_ms();
  const AssessInput in = read_input(o);
  const cv::Mat& gray = in.gray;
  const AssessSetup s = configure(o, in);
  make_output_dir(o.out, "assess's output directory (--out)");
  const double t1 = now_ms();
  const sfs::SfsResult res = solve_image(o, gray, s);
  const double t2 = now_ms();
  const AssessTerrain terrain = map_terrain(o, gray, s, res);
  const traversability::GridMap& grid = terrain.grid;
  const double t3 = now_ms();

  const fs::path out(o.out);
  nlohmann::json layers = write_pictures(out, gray, s, res, terrain);
  const Hazards hazards = find_hazards(grid, s.depth.get(), gray.size());
  // Rocks seen in the image, ranged and sized on the ground; the ground range of every pixel.
  std::vector<ImageRock> rocks;
  int rocks_below_min_score = 0;
  if (s.depth) {
    rocks = image_rocks(gray, *s.depth, traversability::sun_in_body(s.depth->model(), *s.light), o.min_rock_score,
                        rocks_below_min_score);
    sfs_rock_heights(grid, rocks);
    write_rocks(out, rocks);
    if (!cv::imwrite((out / "range.tiff").string(), s.depth->range_map()))
      throw InputError("assess: cannot write '" + (out / "range.tiff").string() + "'");
    write_png(out / "overlay.png", camera_overlay(gray, grid, *s.depth, hazards.labels, hazards.text, rocks));
    layers["camera_overlay"] = "overlay.png";
  }
  const cv::Mat& trav = grid.layer("traversability");
  int known = 0;
  for (int i = 0; i < trav.rows; ++i)
    for (int j = 0; j < trav.cols; ++j) known += std::isfinite(trav.at<float>(i, j)) ? 1 : 0;
  const bool camera = s.depth != nullptr;
  nlohmann::json j = {
      {"image", o.image},
      {"width_px", gray.cols},
      {"height_px", gray.rows},
      {"method", sfs::to_string(s.sp.method)},
      {"light",
       {{"slant_deg", res.light.slant_rad / kDeg},
        {"tilt_deg", res.light.tilt_rad / kDeg},
        {"source", res.light_estimated ? "estimated" : "given"},
        {"confidence", res.light_confidence}}},
      {"iterations", res.iterations},
      {"final_mean_update_px", res.final_mean_update},
      {"mode", camera ? "camera" : "orthographic"},
      {"grid_sfs_frame", camera ? o.sfs_frame : "orthographic"},
      {"timings_ms", {{"load", t1 - t0}, {"sfs", t2 - t1}, {"traversability", t3 - t2}}},
      {"grid",
       {{"source", s.grid_given || !camera ? "configured" : "fitted to the view"},
        {"resolution_m", grid.resolution_m},
        {"length_x_m", grid.length_x_m},
        {"length_y_m", grid.length_y_m},
        {"center_x_m", grid.center_x_m},
        {"center_y_m", grid.center_y_m},
        {"known_cells", known},
        {"cells", static_cast<int>(trav.total())}}},
      {"outputs",
       {{"height", "height.tiff"},
        {"heatmap", "height_heatmap.png"},
        {"hillshade", "hillshade.png"},
        {"layers", layers}}},
      {"hazards", hazards.counted},
      {"edge_hazards", hazards.edge},
  };
  if (!o.scene.empty()) j["scene"] = o.scene;
  if (camera) {
    j["outputs"]["range"] = "range.tiff";
    j["outputs"]["rocks"] = "rocks.csv";
    j["rocks"] = rocks_json(rocks);
    j["min_rock_score"] = o.min_rock_score;
    j["rocks_below_min_score"] = rocks_below_min_score;
  }
  const std::vector<std::string> warnings = assess_warnings(s, res, known, j);
  if (!warnings.empty()) {
    std::string w = warnings[0];
    for (std::size_t i = 1; i < warnings.size(); ++i) w += "; " + warnings[i];
    j["warning"] = w;
    std::cerr << "assess: " << o.image << ": warning: " << w << "\n";
  }
  write_file((out / "summary.json").string(), regolith::json_text(j, 2) + "\n", "the summary");
  std::cout << "assess: " << o.image << " -> " << o.out << " (" << sfs::to_string(s.sp.method) << ", light "
            << (res.light_estimated ? "estimated" : "given") << " slant " << fmt(res.light.slant_rad / kDeg, 1)
            << " deg tilt " << fmt(res.light.tilt_rad / kDeg, 1) << " deg, " << hazards.counted.size() << " hazards ("
            << hazards.edge.size() << " more at the edge of the view, not counted), " << known << " known cells"
            << (camera ? ", " + std::to_string(rocks.size()) + " rocks" : std::string()) << ")\n";
}

void add_assess(CLI::App& app) {
  auto o = std::make_shared<AssessOptions>();
  CLI::App* cmd = app.add_subcommand("assess", "one image -> SfS height map, traversability layers, JSON summary");
  cmd->add_option("image", o->image, "input image (8- or 16-bit grey or colour), or a recording (.mcap, with --frame)")
      ->required();
  cmd->add_option("--out,-o", o->out, "output directory")->required();
  cmd->add_option("--config,-c", o->config,
                  "YAML: method, sun_slant_rad, sun_tilt_rad, vignetting_a2.., camera_model {..}, grid {..}");
  cmd->add_option("--sun-slant", o->sun_slant_deg, "deg, sun angle from the optical axis (towards the camera)")
      ->check(finite());
  cmd->add_option("--sun-tilt", o->sun_tilt_deg, "deg, sun direction in the image from +x towards +y (clockwise)")
      ->check(finite());
  cmd->add_option("--method", o->method, "tsai_shah|pentland|bichsel_pentland")
      ->check(CLI::IsMember({"tsai_shah", "pentland", "bichsel_pentland"}));
  cmd->add_option("--flat-field", o->flat_field, "flat-field image for vignetting correction");
  cmd->add_option("--camera", o->camera, "fx,fy,cx,cy in px (perspective rover camera; default: orthographic patch)");
  cmd->add_option("--sfs-frame", o->sfs_frame,
                  "camera mode: SfS for the grid on the ground-rectified image (default) or in the image frame")
      ->check(CLI::IsMember({"ground", "image"}));
  cmd->add_option("--rover", o->rover, "deployment (or any YAML with rover: and sun:) giving the camera and the sun");
  cmd->add_option("--device", o->device,
                  "with --rover: the camera device (rover.cameras.NAME) that took the image; "
                  "with a recording: the camera whose frame is read");
  cmd->add_option("--frame", o->frame,
                  "IMAGE is a recording (.mcap of `regolith run --record`): its frame N (0 = first) of "
                  "the camera --device (or the only one); the recorded deployment gives the camera and the sun");
  cmd->add_option("--height", o->height_m, "m, camera height above the ground")->check(positive());
  cmd->add_option("--pitch", o->pitch_deg, "deg, camera pitch below the horizontal")->check(finite());
  CLI::Option* pixel =
      cmd->add_option("--pixel-size", o->pixel_size_m, "m, ground size of a pixel in orthographic mode")
          ->check(regolith::cli::positive());
  cmd->add_option("--scene", o->scene,
                  "a rendered scene's input.json (the development sets' format): the orthographic patch's pixel size, "
                  "sun and flat field, or the perspective camera (intrinsics, height, pitch) and the world sun")
      ->excludes(pixel)
      ->excludes("--camera")
      ->excludes("--height")
      ->excludes("--pitch")
      ->excludes("--sun-slant")
      ->excludes("--sun-tilt")
      ->excludes("--rover")
      ->excludes("--device")
      ->excludes("--frame");
  cmd->add_option("--min-rock-score", o->min_rock_score,
                  "camera mode: rocks whose contrast score (0..1) is lower are not listed, only counted "
                  "(summary.json rocks_below_min_score); 0 lists every blob")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->callback([o] { assess(*o); });
}

}  // namespace

[[maybe_unused]] const bool registered_assess = add_command(add_assess);

}  // namespace regolith::cli
