#include "regolith/mapping/drive_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <utility>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/common/json_camera.hpp"
#include "regolith/common/plot.hpp"
#include "regolith/core/csv.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/image_file.hpp"
#include "regolith/core/json_file.hpp"
#include "regolith/core/json_text.hpp"
#include "regolith/core/text_file.hpp"

namespace regolith::mapping {
namespace fs = std::filesystem;
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

/// `decimals` after the point, as the columns have always been written, except for a magnitude
/// no drive reaches (a corrupted odometry line echoed back: 1e308 as %f is 309 digits), which is
/// written in exponent form with the same significant digits instead.
std::string csv_fixed(double v, int decimals) {
  char buf[64];
  if (std::abs(v) < 1e9 || !std::isfinite(v))
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  else
    std::snprintf(buf, sizeof buf, "%.*g", decimals + 10, v);
  return buf;
}

// An image file (TIFF, PNG: by the extension); InputError naming it when it cannot be written.
void write_image(const fs::path& p, const cv::Mat& m) {
  if (!cv::imwrite(p.string(), m)) throw InputError("map: cannot write '" + p.string() + "'");
}

}  // namespace

cv::Vec3d RecordedDrive::sun_world() const {
  const double az = sun_azimuth_deg * kDeg, el = sun_elevation_deg * kDeg;
  return {std::cos(el) * std::sin(az), std::cos(el) * std::cos(az), std::sin(el)};
}

RecordedDrive read_drive(const fs::path& dir) {
  RecordedDrive d;
  d.dir = dir;
  if (!fs::is_directory(dir)) throw InputError(dir.string() + ": not a directory (a recorded drive)");
  const fs::path input = dir / "input.json";
  const std::string name = input.string();
  const nlohmann::json j = read_json_file(name, "drive description (input.json: camera, sun, wheels)");
  const auto number = [&](const char* field) { return json_number(j, name, field); };
  const auto optional = [&](const char* field) { return json_optional_number(j, name, field).value_or(0.0); };
  d.camera = common::read_json_camera(j, name);
  d.mount.x_m = optional("camera.mount_x_m");
  d.mount.y_m = optional("camera.mount_y_m");
  d.mount.yaw_rad = optional("camera.mount_yaw_deg") * kDeg;
  d.sun_azimuth_deg = number("sun.azimuth_deg");
  d.sun_elevation_deg = number("sun.elevation_deg");
  if (d.sun_elevation_deg <= 0 || d.sun_elevation_deg > 90)
    throw InputError(name + ": sun.elevation_deg: must be in (0, 90] (got " + number_text(d.sun_elevation_deg) + ")");
  d.wheel_radius_m = optional("wheel.radius_m");

  const fs::path csv = dir / "frames.csv";
  if (!fs::exists(csv))
    throw InputError(csv.string() + ": cannot open (frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad)");
  const CsvTable t = CsvTable::read(csv.string(), {"frame", "file", "t_s", "odom_x_m", "odom_y_m", "odom_yaw_rad"});
  t.require_complete();
  for (std::size_t i = 0; i < t.size(); ++i) {
    DriveFrame fr;
    fr.line = t.line(i);
    fr.index = static_cast<int>(t.whole(i, "frame", 0, std::numeric_limits<int>::max()));
    fr.file = dir / t.text(i, "file");
    fr.t_s = t.number(i, "t_s");
    if (!std::isfinite(fr.t_s)) t.fail(i, "t_s", "must be a finite time (got '" + t.text(i, "t_s") + "')");
    fr.odometry = {t.number(i, "odom_x_m"), t.number(i, "odom_y_m"), t.number(i, "odom_yaw_rad")};
    d.frames.push_back(fr);
  }
  if (d.frames.empty()) throw InputError(csv.string() + ": no frames");
  return d;
}

void write_drive_description(const RecordedDrive& d, const fs::path& file) {
  const direct_depth::CameraModel& c = d.camera;
  const nlohmann::json j = {{"camera",
                             {{"fx", c.fx},
                              {"fy", c.fy},
                              {"cx", c.cx},
                              {"cy", c.cy},
                              {"width", c.width},
                              {"height", c.height},
                              {"mount_height_m", c.mount_height_m},
                              {"pitch_deg", c.pitch_rad / kDeg},
                              {"roll_deg", c.roll_rad / kDeg},
                              {"mount_x_m", d.mount.x_m},
                              {"mount_y_m", d.mount.y_m},
                              {"mount_yaw_deg", d.mount.yaw_rad / kDeg}}},
                            {"sun", {{"azimuth_deg", d.sun_azimuth_deg}, {"elevation_deg", d.sun_elevation_deg}}},
                            {"wheel", {{"radius_m", d.wheel_radius_m}}}};
  write_file(file.string(), regolith::json_text(j, 2) + "\n", "the drive description");
}

namespace {

// The first frame that reads and its image, kept for the frame loop (decoded once); none when no frame reads.
struct FirstFrame {
  const DriveFrame* frame = nullptr;
  cv::Mat image;
};

// The description must be the frames' camera before anything is sized by it: the mapper's per-pixel tables follow the
// declared size (a 16384 x 12288 camera over 320 x 240 frames asked for gigabytes and ended in an OpenCV out-of-memory
// error). The first frame that reads decides (InputError when it is of another size); a later frame of another size
// is skipped by add_frames.
FirstFrame read_first_frame(const RecordedDrive& drive) {
  FirstFrame first;
  for (const DriveFrame& fr : drive.frames) {
    first.image = regolith::read_image_8bit(fr.file.string(), cv::IMREAD_GRAYSCALE);
    if (first.image.empty()) continue;
    first.frame = &fr;
    if (first.image.cols != drive.camera.width || first.image.rows != drive.camera.height)
      throw InputError((drive.dir / "input.json").string() + ": camera is " + std::to_string(drive.camera.width) + "x" +
                       std::to_string(drive.camera.height) + " px, but frame " + std::to_string(fr.index) + " (" +
                       fr.file.string() + ") is " + std::to_string(first.image.cols) + "x" +
                       std::to_string(first.image.rows) + ": the description is not this drive's camera");
    break;
  }
  return first;
}

// The mapper's parameters for the drive and the centre of its map window.
struct MapWindow {
  DriveMapperParams params;
  cv::Point2d center;
};

// The mapper's parameters with a map window covering the wheel path plus the camera's reach (wheel drift is small
// against it), and the window's centre: the path the mapper will dead-reckon, its odometry jumps left out as it leaves
// them out (one corrupted line of 1e6 m asked for a window of 4e7 cells per side).
MapWindow map_window(const RecordedDrive& drive, const DriveMapperParams& params) {
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  bool started = false;
  Pose2 pose, last;
  double last_t = std::numeric_limits<double>::quiet_NaN();
  for (const auto& fr : drive.frames) {
    if (!started) {
      pose = last = fr.odometry.finite() ? fr.odometry : Pose2{};
      started = true;
    } else if (fr.odometry.finite()) {
      const Pose2 step = between(last, fr.odometry);
      if (params.wheel.plausible(step, fr.t_s - last_t)) pose = compose(pose, step);
      last = fr.odometry;
    }
    last_t = fr.t_s;
    xmin = std::min(xmin, pose.x), xmax = std::max(xmax, pose.x);
    ymin = std::min(ymin, pose.y), ymax = std::max(ymax, pose.y);
  }
  if (xmin > xmax) xmin = xmax = ymin = ymax = 0.0;
  MapWindow w{params, {0.5 * (xmin + xmax), 0.5 * (ymin + ymax)}};
  const double reach = w.params.map.max_range_m + 1.5;
  w.params.map.length_x_m = std::max(w.params.map.length_x_m, xmax - xmin + 2 * reach);
  w.params.map.length_y_m = std::max(w.params.map.length_y_m, ymax - ymin + 2 * reach);
  return w;
}

// A frame not used: its note, counted as skipped.
void skip(DriveMapSummary& sum, std::string note) {
  sum.notes.push_back(std::move(note));
  ++sum.skipped;
}

// Per frame: its time is a lone spike, later than the next frame's while the one before it is earlier than that
// (a corrupted timestamp). Skipping it keeps the order; taking it would make every later frame "out of order" (one
// bad time lost the rest of a drive).
std::vector<bool> time_spikes(const std::vector<DriveFrame>& frames) {
  std::vector<bool> spike(frames.size(), false);
  for (std::size_t i = 0; i + 1 < frames.size(); ++i) {
    const double t = frames[i].t_s, next = frames[i + 1].t_s;
    const bool before_ok = i == 0 || frames[i - 1].t_s < next;
    spike[i] =
        std::isfinite(t) && std::isfinite(next) && t > next && before_ok && frames[i + 1].index > frames[i].index;
  }
  return spike;
}

// The corrected and the wheel-odometry path, one pose per used frame.
struct Paths {
  std::vector<Pose2> corrected, wheel;
};

// Every usable frame through the mapper (reports, frame indices, path length and notes in `sum`); returns the
// corrected and the wheel path. Frames out of order, unreadable or of another size are skipped with a note.
Paths add_frames(const RecordedDrive& drive, FirstFrame& first, DriveMapper& mapper,
                 const std::function<void(const DriveFrame&, const FrameReport&)>& progress, DriveMapSummary& sum) {
  Paths paths;
  double last_t = -std::numeric_limits<double>::infinity();
  int last_index = std::numeric_limits<int>::min();
  const std::vector<bool> spike = time_spikes(drive.frames);
  for (std::size_t i = 0; i < drive.frames.size(); ++i) {
    const DriveFrame& fr = drive.frames[i];
    const std::string name = "frame " + std::to_string(fr.index) + " (" + fr.file.filename().string() + ")";
    // a gap in the frame numbers (rows missing from frames.csv): said, the mapper bridges it
    if (i > 0 && fr.index > drive.frames[i - 1].index + 1) {
      const DriveFrame& prev = drive.frames[i - 1];
      const int from = prev.index + 1, to = fr.index - 1;
      sum.notes.push_back(
          name + ": frame" +
          (from == to ? " " + std::to_string(from) : "s " + std::to_string(from) + " to " + std::to_string(to)) +
          " not in the drive (" + number_text(fr.t_s - prev.t_s) + " s since frame " + std::to_string(prev.index) +
          ")");
    }
    if (spike[i]) {
      skip(sum, name + ": its time, " + number_text(fr.t_s) + " s, is later than the next frame's (" +
                    number_text(drive.frames[i + 1].t_s) + " s) while the frames around it are in order: a bad " +
                    "timestamp: skipped");
      continue;
    }
    if (fr.index <= last_index || !(fr.t_s > last_t)) {
      skip(sum, name + ": out of order (frame " + std::to_string(fr.index) + ", t " + std::to_string(fr.t_s) +
                    " s after frame " + std::to_string(last_index) + "): skipped");
      continue;
    }
    std::string why;
    cv::Mat gray = &fr == first.frame ? std::move(first.image)
                                      : regolith::read_image_8bit(fr.file.string(), cv::IMREAD_GRAYSCALE, &why);
    if (gray.empty()) {
      skip(sum, name + ": cannot read '" + fr.file.string() + "': " + why + ": skipped");
      continue;
    }
    if (gray.cols != drive.camera.width || gray.rows != drive.camera.height) {
      skip(sum, name + ": " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) + " px, the camera is " +
                    std::to_string(drive.camera.width) + "x" + std::to_string(drive.camera.height) + ": skipped");
      continue;
    }
    last_index = fr.index;
    last_t = fr.t_s;
    const FrameReport& r = mapper.add_frame(gray, fr.odometry, fr.t_s);
    if (r.odometry_jump)
      sum.notes.push_back(name + (fr.odometry.finite() ? ": wheel odometry jumped" : ": wheel odometry not a number") +
                          ": step ignored, vision only");
    if (!sum.reports.empty() && r.vo != VoStatus::kOk)
      sum.notes.push_back(name + ": visual odometry: " + std::string(to_string(r.vo)) + ": wheel odometry used");
    if (!paths.corrected.empty())
      sum.path_length_m += std::hypot(r.pose.x - paths.corrected.back().x, r.pose.y - paths.corrected.back().y);
    sum.reports.push_back(r);
    sum.frame_index.push_back(fr.index);
    paths.corrected.push_back(r.pose);
    paths.wheel.push_back(fr.odometry);
    if (progress) progress(fr, r);
  }
  return paths;
}

// The cells written: every known cell (an elevation, or a hazard: a rock sighted beyond the known ground) and the
// corrected path, plus a margin; the whole map when there is none.
cv::Rect known_cells(const WorldMap& map, const std::vector<Pose2>& corrected) {
  const cv::Mat& el = map.layer("elevation");
  const cv::Mat& hz = map.layer("hazard");
  int r0 = map.rows(), r1 = -1, c0 = map.cols(), c1 = -1;
  for (int i = 0; i < map.rows(); ++i)
    for (int j = 0; j < map.cols(); ++j)
      if (std::isfinite(el.at<float>(i, j)) || std::isfinite(hz.at<float>(i, j)))
        r0 = std::min(r0, i), r1 = std::max(r1, i), c0 = std::min(c0, j), c1 = std::max(c1, j);
  for (const Pose2& q : corrected) {  // the path is in the map too
    const int j = static_cast<int>(std::lround((q.x - map.origin_x()) / map.resolution()));
    const int i = static_cast<int>(std::lround((q.y - map.origin_y()) / map.resolution()));
    r0 = std::min(r0, i), r1 = std::max(r1, i), c0 = std::min(c0, j), c1 = std::max(c1, j);
  }
  const int margin = 5;
  r0 = std::clamp(r0 - margin, 0, map.rows() - 1), r1 = std::clamp(r1 + margin, 0, map.rows() - 1);
  c0 = std::clamp(c0 - margin, 0, map.cols() - 1), c1 = std::clamp(c1 + margin, 0, map.cols() - 1);
  if (r1 < r0 || c1 < c0) r0 = c0 = 0, r1 = map.rows() - 1, c1 = map.cols() - 1;
  return {c0, r0, c1 - c0 + 1, r1 - r0 + 1};
}

// <layer>.tiff of every layer, cropped to `roi`; returns map.json's `layers` ({layer: file}).
nlohmann::json write_layers(const WorldMap& map, const cv::Rect& roi, const fs::path& out, DriveMapSummary& sum) {
  nlohmann::json layers = nlohmann::json::object();
  for (const std::string& name : WorldMap::layer_names()) {
    const std::string file = name + ".tiff";
    write_image(out / file, map.layer(name)(roi));
    layers[name] = file;
    sum.written.push_back(out / file);
  }
  return layers;
}

// map.json's `cues`: which cues made this map (a stationary rover has no parallax; a sun outside the shadow cue's
// elevation range has no shadows).
nlohmann::json cues_json(const RecordedDrive& drive, const DriveMapperParams& params, const DriveCounters& counters) {
  const double sun_el = drive.sun_elevation_deg * kDeg;
  const bool sun_ok = sun_el >= params.shadow.min_elevation_rad && sun_el <= params.shadow.max_elevation_rad;
  nlohmann::json cues;
  cues["parallax"] = {{"enabled", params.fuse_terrain && params.fuse_parallax},
                      {"mode", params.parallax_mode == ParallaxMode::kSweep       ? "sweep"
                               : params.parallax_mode == ParallaxMode::kRectified ? "rectified"
                                                                                  : "both"},
                      {"frames", counters.parallax_frames}};
  cues["rock_sightings"] = {{"enabled", params.fuse_terrain && params.fuse_sightings},
                            {"sightings", counters.rock_sightings},
                            {"tracked", params.tracks.enabled},
                            {"tracks", counters.rock_tracks}};
  cues["shadows"] = {{"enabled", params.fuse_terrain && params.fuse_parallax && params.fuse_shadows},
                     {"available", sun_ok},
                     {"frames", counters.shadow_frames}};
  if (!sun_ok)
    cues["shadows"]["why"] =
        "sun elevation " + std::to_string(drive.sun_elevation_deg) + " deg outside the cue's range";
  cues["shading"] = {{"enabled", params.fuse_terrain && params.fuse_shading}};
  return cues;
}

// map.json: where the cells of `roi` lie in the world, the layer files, the counters and the cues.
void write_map_json(const RecordedDrive& drive, const DriveMapperParams& params, const WorldMap& map,
                    const cv::Rect& roi, const nlohmann::json& layers, const fs::path& out, DriveMapSummary& sum) {
  const cv::Point2d origin = map.cell_center(roi.y, roi.x);
  nlohmann::json mj;
  mj["origin_x_m"] = origin.x;
  mj["origin_y_m"] = origin.y;
  mj["resolution_m"] = map.resolution();
  mj["width"] = roi.width;
  mj["height"] = roi.height;
  mj["frame"] = "world";
  mj["row0"] = "min_y";
  mj["convention"] =
      "cell (row i, col j) is centred at x = origin_x_m + j*resolution_m, y = origin_y_m + i*resolution_m; "
      "world = odometry frame of frames.csv (x east, y north, z up)";
  mj["layers"] = layers;
  mj["frames"] = sum.counters.frames;
  mj["frames_skipped"] = sum.skipped;
  mj["vo_ok"] = sum.counters.vo_ok;
  mj["vo_failed"] = sum.counters.vo_failed;
  mj["vo_uncertain"] = sum.counters.vo_uncertain;
  mj["odometry_jumps"] = sum.counters.odometry_jumps;
  mj["keyframes"] = sum.counters.keyframes;
  mj["path_length_m"] = sum.path_length_m;
  mj["rocks"] = sum.rocks.size();
  mj["cues"] = cues_json(drive, params, sum.counters);
  write_file((out / "map.json").string(), regolith::json_text(mj, 1) + "\n", "the map description");
  sum.written.push_back(out / "map.json");
}

// rocks.csv: one line per rock of the map.
void write_rocks_csv(const fs::path& out, DriveMapSummary& sum) {
  std::ostringstream o;
  // The five columns first; then the covariance of (x_m, y_m), m^2, and the track number
  // (MapRock; the id of terrain/world_rocks).
  o << "x_m,y_m,height_m,width_m,score,cov_xx,cov_xy,cov_yy,id\n";
  char buf[256];
  for (const MapRock& r : sum.rocks) {
    std::snprintf(buf, sizeof buf, "%.4f,%.4f,%.4f,%.4f,%.4f,%.6g,%.6g,%.6g,%ld\n", r.x_m, r.y_m, r.height_m, r.width_m,
                  r.score, r.cov_xx, r.cov_xy, r.cov_yy, r.id);
    o << buf;
  }
  write_file((out / "rocks.csv").string(), o.str(), "the rocks table");
  sum.written.push_back(out / "rocks.csv");
}

// odometry.csv: one line per used frame, the corrected pose and its covariance beside the wheel pose
// (cov_xy last: added after the other columns, which keep their places).
void write_odometry_csv(const fs::path& out, DriveMapSummary& sum) {
  std::ostringstream o;
  o << "frame,x_m,y_m,yaw_rad,cov_xx,cov_yy,cov_yawyaw,vo,wheel_x_m,wheel_y_m,wheel_yaw_rad,cov_xy\n";
  for (std::size_t k = 0; k < sum.reports.size(); ++k) {
    const FrameReport& r = sum.reports[k];
    const auto g = [](double v) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.3g", v);
      return std::string(buf);
    };
    o << sum.frame_index[k] << ',' << csv_fixed(r.pose.x, 6) << ',' << csv_fixed(r.pose.y, 6) << ','
      << csv_fixed(r.pose.yaw, 8) << ',' << g(r.covariance(0, 0)) << ',' << g(r.covariance(1, 1)) << ','
      << g(r.covariance(2, 2)) << ',' << (r.vo == VoStatus::kOk ? "ok" : (k == 0 ? "first" : "wheel")) << ','
      << csv_fixed(r.wheel_pose.x, 6) << ',' << csv_fixed(r.wheel_pose.y, 6) << ',' << csv_fixed(r.wheel_pose.yaw, 8)
      << ',' << g(r.covariance(0, 1)) << '\n';
  }
  write_file((out / "odometry.csv").string(), o.str(), "the corrected odometry");
  sum.written.push_back(out / "odometry.csv");
}

}  // namespace

DriveMapSummary map_drive(const RecordedDrive& drive, const DriveMapperParams& params, const fs::path& out,
                          const std::function<void(const DriveFrame&, const FrameReport&)>& progress) {
  DriveMapSummary sum;
  FirstFrame first = read_first_frame(drive);
  make_output_dir(out.string(), "the map's output directory");
  const MapWindow window = map_window(drive, params);
  DriveMapper mapper(drive.camera, drive.mount, drive.sun_world(), window.params, window.center);
  const Paths paths = add_frames(drive, first, mapper, progress, sum);
  sum.counters = mapper.counters();

  // Outputs, cropped to the seen cells (+ a margin).
  WorldMap& map = mapper.map();
  map.finish();
  sum.rocks = map.rocks();
  const cv::Rect roi = known_cells(map, paths.corrected);
  const nlohmann::json layers = write_layers(map, roi, out, sum);
  write_map_json(drive, params, map, roi, layers, out, sum);
  write_rocks_csv(out, sum);
  write_odometry_csv(out, sum);
  write_image(out / "overview.png", render_overview(map, paths.corrected, paths.wheel, sum.rocks));
  sum.written.push_back(out / "overview.png");
  return sum;
}

cv::Mat render_overview(const WorldMap& map, const std::vector<Pose2>& corrected, const std::vector<Pose2>& wheel,
                        const std::vector<MapRock>& rocks) {
  const cv::Mat& el = map.layer("elevation");
  const cv::Mat& hz = map.layer("hazard");
  // North up, cropped to the known cells and both paths. Hillshade (heights x4), grey; unknown =
  // dark blue-grey; hazard blended red.
  std::vector<cv::Point2d> paths;
  for (const auto* p : {&corrected, &wheel})
    for (const Pose2& q : *p) paths.emplace_back(q.x, q.y);
  const plot::NorthUpFrame frame(el == el, {map.origin_x(), map.origin_y()}, map.resolution(), paths);
  const cv::Mat shaded = frame.shade(el, 4.0);
  cv::Mat img(frame.size(), CV_8UC3, cv::Scalar(60, 45, 40));
  for (int i = frame.rows().start; i < frame.rows().end; ++i)
    for (int j = frame.cols().start; j < frame.cols().end; ++j) {
      const float shade = shaded.at<float>(i, j);
      if (!std::isfinite(shade)) continue;
      const double g = 60 + 180 * shade;
      const float hv = hz.at<float>(i, j);
      const double a = std::isfinite(hv) ? std::clamp(static_cast<double>(hv), 0.0, 1.0) * 0.8 : 0.0;
      img(frame.cell(i, j)).setTo(cv::Scalar(g * (1 - a), g * (1 - a), g * (1 - a) + 255 * a));
    }
  for (std::size_t k = 1; k < wheel.size(); ++k)
    cv::line(img, frame.px(wheel[k - 1].x, wheel[k - 1].y), frame.px(wheel[k].x, wheel[k].y), cv::Scalar(255, 120, 0),
             2, cv::LINE_AA);
  for (std::size_t k = 1; k < corrected.size(); ++k)
    cv::line(img, frame.px(corrected[k - 1].x, corrected[k - 1].y), frame.px(corrected[k].x, corrected[k].y),
             cv::Scalar(0, 220, 0), 2, cv::LINE_AA);
  for (const MapRock& r : rocks) {
    cv::circle(img, frame.px(r.x_m, r.y_m), std::max(4, static_cast<int>(0.5 * r.width_m * frame.px_per_m())),
               cv::Scalar(0, 230, 255), 2, cv::LINE_AA);
    // The 95 % ellipse of its position (kChi2TwoDof95), thin.
    const double mid = 0.5 * (r.cov_xx + r.cov_yy), rad = std::hypot(0.5 * (r.cov_xx - r.cov_yy), r.cov_xy);
    if (!(mid - rad > 0)) continue;
    const double k = std::sqrt(kChi2TwoDof95) * frame.px_per_m(),
                 theta = 0.5 * std::atan2(2 * r.cov_xy, r.cov_xx - r.cov_yy);
    const cv::Size axes(std::max(1, static_cast<int>(k * std::sqrt(mid + rad))),
                        std::max(1, static_cast<int>(k * std::sqrt(mid - rad))));
    // North up: a direction theta counter-clockwise from east is -theta in the image (rows down).
    cv::ellipse(img, frame.px(r.x_m, r.y_m), axes, -theta / kDeg, 0, 360, cv::Scalar(0, 230, 255), 1, cv::LINE_AA);
  }
  plot::put_scale_bar_and_north(img, frame.px_per_m());
  // Above the map, on a band of its own (a narrow map has no room for it inside): the legend in
  // the colours it explains, wrapped to the width, then the hazard tint's scale (on mid-grey
  // ground: probability of an obstacle 0 .. 1).
  const plot::LegendEntry legend[] = {{"corrected path", {0, 220, 0}},
                                      {"wheel odometry", {255, 120, 0}},
                                      {"hazard", {0, 0, 255}},
                                      {"rocks, 95 % ellipse", {0, 230, 255}}};
  const int width = std::max(img.cols, 240);
  const int lines = plot::legend_lines(legend, 10, width - 10);
  const int band_h = 12 + plot::kLegendLinePx * (lines + 1);
  cv::Mat out(band_h + img.rows, width, CV_8UC3, cv::Scalar(40, 30, 25));
  img.copyTo(out(cv::Rect(0, band_h, img.cols, img.rows)));
  plot::put_legend(out, {10, 18}, legend, width - 10);
  const cv::Rect hb(82, 18 + plot::kLegendLinePx * lines - 8, 120, 8);
  for (int x = 0; x < hb.width; ++x) {
    const double a = 0.8 * x / (hb.width - 1.0), g = 150;
    cv::line(out, hb.tl() + cv::Point(x, 0), hb.tl() + cv::Point(x, hb.height - 1),
             cv::Scalar(g * (1 - a), g * (1 - a), g * (1 - a) + 255 * a));
  }
  cv::putText(out, "hazard 0", hb.tl() + cv::Point(-72, 8), cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar(255, 255, 255),
              1, cv::LINE_AA);
  cv::putText(out, "1", hb.tl() + cv::Point(hb.width + 5, 8), cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar(255, 255, 255),
              1, cv::LINE_AA);
  return out;
}

}  // namespace regolith::mapping
