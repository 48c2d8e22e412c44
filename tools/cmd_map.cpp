// regolith map DRIVE_DIR --out DIR: the drive-long terrain map of a recorded drive
// (components/mapping): ground visual odometry fused with the wheel odometry of frames.csv, each
// frame's terrain fused into one world-frame map. Writes map.json, elevation.tiff, hazard.tiff
// (+ the other layers), rocks.csv, odometry.csv and overview.png.
// regolith map REC.mcap --out DIR: the same from a HAL recording (`regolith run --record`): the
// frames of one camera, the wheel odometry integrated from the recorded encoder samples, and the
// camera, wheels and sun of the recorded deployment.
// regolith eval map DRIVE_DIR --map DIR: scores such an output against the drive's truth files.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "cli.hpp"
#include "regolith/common/camera.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/frame_order.hpp"
#include "regolith/core/json_text.hpp"
#include "regolith/core/params.hpp"
#include "regolith/core/rover.hpp"
#include "regolith/core/text_file.hpp"
#include "regolith/hal/imu.hpp"
#include "regolith/mapping/config.hpp"
#include "regolith/mapping/drive_io.hpp"
#include "regolith/mapping/evaluate.hpp"
#include "regolith/mapping/wheel_odometry.hpp"
#ifdef REGOLITH_HAVE_HAL_RECORD
#include "regolith/record/hal_messages.hpp"
#include "regolith/record/hal_recorder.hpp"
#include "regolith/record/mcap_reader.hpp"
#include "regolith/record/recording.hpp"
#endif

namespace regolith::cli {
namespace {
namespace fs = std::filesystem;

struct MapArgs {
  std::string drive;
  std::string out;
  std::string device;    ///< recordings: the camera (default: the terrain_map component's, else the only one)
  std::string encoders;  ///< recordings: the encoder set (default: the terrain_map component's, else the wheels')
  bool wheel_only = false;
  double resolution_m = 0.04;
  bool quiet = false;
  std::string config;             ///< YAML mapping of the terrain_map component's parameter keys
  std::vector<std::string> sets;  ///< key=value overrides, after --config
};

/// The mapper's parameters: library defaults, then --config FILE, then --set key=value (each a
/// located error on a bad or unknown key), then --resolution / --wheel-only when given.
mapping::DriveMapperParams mapper_params(const MapArgs& a, bool resolution_given) {
  mapping::DriveMapperParams p;
  if (!a.config.empty()) {
    Params file = Params::load_file(a.config);
    p = mapping::read_drive_mapper_params(file, p);
    file.finish();
  }
  if (!a.sets.empty()) {
    std::string text;
    for (const std::string& kv : a.sets) {
      const auto eq = kv.find('=');
      if (eq == std::string::npos || eq == 0) throw InputError("map: --set: expected key=value, got '" + kv + "'");
      text += kv.substr(0, eq) + ": " + kv.substr(eq + 1) + "\n";
    }
    Params set = Params::load_string(text, "--set");
    p = mapping::read_drive_mapper_params(set, p);
    set.finish();
  }
  if (resolution_given) p.map.resolution_m = a.resolution_m;
  if (a.wheel_only) p.use_vision = false;
  return p;
}

#ifdef REGOLITH_HAVE_HAL_RECORD
/// The block of the first terrain_map component of the recorded deployment (an empty block named
/// after the file when there is none: every key then takes the component's default).
Params terrain_map_params(Params& root, const std::string& file) {
  if (root.has("components")) {
    Params comps = root.child("components");
    for (const std::string& name : comps.keys()) {
      Params c = comps.child(name);
      if (c.has("type") && c.get<std::string>("type", "") == "terrain_map") return c;
    }
  }
  return Params::load_string("{}", file);
}

/// Time-ordered samples of one recorded signal, read as the HAL devices read theirs: linear
/// interpolation between the samples around t (for a heading, the shorter way round), at most
/// `max_extrapolation` past the newest; false before the oldest.
struct SampleTrack {
  std::vector<std::pair<TimeNs, double>> samples;
  bool angle = false;  ///< a heading: interpolated modulo 2 pi
  void sort() {
    std::stable_sort(samples.begin(), samples.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  }
  bool at(TimeNs t, TimeNs max_extrapolation, double& v) const {
    const auto it =
        std::lower_bound(samples.begin(), samples.end(), t, [](const auto& s, TimeNs u) { return s.first < u; });
    if (it == samples.end()) {
      if (samples.empty() || t - samples.back().first > max_extrapolation) return false;
      v = samples.back().second;
      return true;
    }
    if (it->first == t) return v = it->second, true;
    if (it == samples.begin()) return false;
    const auto& [t0, v0] = *(it - 1);
    const double f = static_cast<double>(t - t0) / static_cast<double>(it->first - t0);
    const double d = it->second - v0;
    v = v0 + f * (angle ? std::remainder(d, 2.0 * 3.14159265358979323846) : d);
    return true;
  }
};

// What the recording is mapped from: the camera and the encoder set (the command line's, else
// the recorded terrain_map component's, else the rover description's only one).
struct MapSources {
  std::string device, encoders;
};

MapSources choose_sources(const MapArgs& a, Params& tm, const RoverDescription& rover, const std::string& dep_name) {
  MapSources src{!a.device.empty() ? a.device : tm.get<std::string>("camera", ""),
                 !a.encoders.empty() ? a.encoders : tm.get<std::string>("encoders", "")};
  if (src.encoders.empty()) {
    for (const Wheel& w : rover.wheels) {
      if (src.encoders.empty())
        src.encoders = w.encoders;
      else if (w.encoders != src.encoders)
        throw InputError(dep_name + ": rover.wheels report to several encoder sets: choose one with --encoders");
    }
  }
  if (src.device.empty()) {
    if (rover.cameras.size() != 1)
      throw InputError(dep_name + ": " + std::to_string(rover.cameras.size()) +
                       " cameras described and no terrain_map component names one: choose one with --device");
    src.device = rover.cameras.begin()->first;
  }
  return src;
}

// The recording's inputs to the map: the camera's frames (written as grey PNG into out/frames as
// they come, with their capture stamps), each wheel's angle samples and the IMU heading samples
// (when `imu_topic` is set). Samples are sorted by time; frames stay in the order they were recorded
// (the order the live component took them: FrameOrder judges them there). Damaged messages
// are skipped with a warning.
struct RecordedInputs {
  std::vector<std::pair<TimeNs, fs::path>> frames;
  std::vector<SampleTrack> angles;  // per wheel (wheel_of's index)
  SampleTrack yaws{.samples = {}, .angle = true};
  std::size_t samples = 0;  // encoder samples of the wheels mapped
};

RecordedInputs read_recorded_inputs(record::McapReader& reader, const std::string& name, const std::string& cam_topic,
                                    const std::string& enc_topic, const std::string& imu_topic,
                                    const std::map<std::string, std::size_t>& wheel_of, const fs::path& out) {
  RecordedInputs in;
  in.angles.resize(wheel_of.size());
  make_output_dir((out / "frames").string(), "the drive's frames directory");
  const auto problems = reader.for_each_message([&](const record::MessageView& m) {
    if (m.channel.topic == cam_topic) {
      record::DecodedImage d;
      try {
        d = record::decode_image(m.data);
      } catch (const std::exception& e) {
        spdlog::warn("{}: {} frame {}: {}; skipped", name, cam_topic, in.frames.size(), e.what());
        return;
      }
      cv::Mat gray = d.image;
      if (gray.channels() == 3) cv::cvtColor(d.image, gray, cv::COLOR_BGR2GRAY);
      char fn[32];
      std::snprintf(fn, sizeof fn, "%05zu.png", in.frames.size());
      const fs::path p = out / "frames" / fn;
      if (!cv::imwrite(p.string(), gray)) throw InputError(p.string() + ": cannot write");
      in.frames.emplace_back(d.stamp, p);
    } else if (!imu_topic.empty() && m.channel.topic == imu_topic) {
      try {
        const hal::ImuSample i = record::decode_imu(m.data);
        // the live system's check (hal::PlausibleImu): a recording made without it may hold damaged samples
        if (hal::plausible(i)) in.yaws.samples.emplace_back(i.stamp, i.attitude.yaw_rad);
      } catch (const std::exception& e) {
        spdlog::warn("{}: {}: {}; sample skipped", name, imu_topic, e.what());
      }
    } else if (m.channel.topic == enc_topic) {
      try {
        const record::DecodedWheelAngle w = record::decode_wheel_angle(m.data);
        const auto it = wheel_of.find(w.wheel);
        if (it != wheel_of.end() && std::isfinite(w.angle))
          in.angles[it->second].samples.emplace_back(w.stamp, w.angle), ++in.samples;
      } catch (const std::exception& e) {
        spdlog::warn("{}: {}: {}; sample skipped", name, enc_topic, e.what());
      }
    }
  });
  for (const auto& pr : problems) spdlog::warn("{}", reader.describe(pr));
  for (SampleTrack& w : in.angles) w.sort();
  in.yaws.sort();
  return in;
}

/// A HAL recording as a drive: the frames of one camera written as PNG into `out`/frames (and
/// `out`/frames.csv) with the skid-steer wheel odometry (rover.wheels of the recorded deployment)
/// at each frame's capture time, in the odometry frame of the recording's start (x forward, y
/// left, z up: the frame the terrain_map component publishes in).
mapping::RecordedDrive drive_from_recording(const fs::path& file, const MapArgs& a) {
  const std::string name = file.string();
  record::McapReader reader(file);
  const record::RecordedDeployment dep = record::recorded_deployment(reader, file);
  if (dep.text.empty())
    throw InputError(name + ": no deployment recorded (a `regolith run --record` file carries its deployment YAML)");
  Params root = Params::load_string(dep.text, dep.name);
  const RoverDescription rover = read_rover_description(root, fs::path(dep.name).parent_path().string());
  if (!rover.sun) throw InputError(dep.name + ": the recorded deployment has no `sun:` (the map needs it for shadows)");

  // The terrain_map component's settings, read with the component's own readers.
  Params tm = terrain_map_params(root, dep.name);
  const auto [device, encoders] = choose_sources(a, tm, rover, dep.name);
  const mapping::OdometrySettings settings = mapping::read_odometry_settings(tm, rover);
  const double max_speed = mapping::read_drive_mapper_params(tm).wheel.max_speed_mps;
  const RoverCamera* rc = rover.camera(device);
  if (rc == nullptr) throw InputError(dep.name + ": no rover.cameras." + device + " in the recorded deployment");
  std::vector<mapping::OdometryWheel> wheels;
  std::map<std::string, std::size_t> wheel_of;  // joint name -> index in `wheels`
  double radius = 0;
  for (const Wheel& w : rover.wheels) {
    if (w.encoders != encoders) continue;
    wheel_of[w.name] = wheels.size();
    wheels.push_back({w.y_m, w.radius_m});
    radius += w.radius_m;
  }
  if (wheels.empty())
    throw InputError(dep.name + ": no rover.wheels entry reports to encoder set '" + encoders + "' (--encoders)");
  // The terrain_map component's integration (FieldError naming the wheels when one side is missing).
  mapping::SteppedOdometry odometry(wheels, settings.step, max_speed);

  // The recording: frames to PNG files as they come, samples kept (a few bytes each).
  const fs::path out(a.out);
  const std::string cam_topic = record::hal_camera_topic(device);
  const std::string enc_topic = record::hal_samples_topic("encoders", encoders);
  const std::string imu_topic = settings.imu_heading ? record::hal_samples_topic("imus", rover.imu) : std::string();
  const RecordedInputs in = read_recorded_inputs(reader, name, cam_topic, enc_topic, imu_topic, wheel_of, out);
  const auto& frames = in.frames;
  if (frames.empty()) throw InputError(name + ": no frames of camera '" + device + "' (" + cam_topic + ")");
  if (in.samples == 0) throw InputError(name + ": no samples of encoder set '" + encoders + "' (" + enc_topic + ")");
  if (settings.imu_heading && in.yaws.samples.empty())
    throw InputError(
        name + ": no samples of IMU '" + rover.imu + "' (" + imu_topic +
        "), which gives the terrain_map's heading (heading_source: wheels in the deployment to map without it)");
  // The recorded inputs read at t as the component reads its devices (one odometry sub-step of
  // extrapolation past the newest sample).
  const auto read = [&](TimeNs t, std::span<double> wheel_angles, double& yaw) {
    for (std::size_t i = 0; i < in.angles.size(); ++i)
      if (!in.angles[i].at(t, settings.step, wheel_angles[i])) return false;
    yaw = std::numeric_limits<double>::quiet_NaN();
    return !settings.imu_heading || in.yaws.at(t, settings.step, yaw);
  };

  // Odometry at each frame: every sample up to the frame's capture time, once each wheel has one.
  mapping::RecordedDrive drive;
  drive.dir = out;
  drive.camera = common::camera_model_of(*rc);
  drive.mount = {rc->mount.x_m, rc->mount.y_m, rc->mount.yaw_rad};
  const Vec3 sun = rover.sun->local_level();
  drive.sun_azimuth_deg = std::atan2(sun.x, sun.y) * 180.0 / 3.14159265358979323846;  // from +y towards +x
  drive.sun_elevation_deg = std::asin(std::clamp(sun.z, -1.0, 1.0)) * 180.0 / 3.14159265358979323846;
  drive.wheel_radius_m = radius / static_cast<double>(wheels.size());
  std::string csv = "frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad\n";
  long unavailable = 0;
  // The live component's frame order: frames stamped at or before the last one taken are skipped, a
  // step back past the input timeout maps on (the odometry re-read there). The drive's t_s stays
  // increasing across such a step: one mean frame interval after the frame before it.
  std::vector<TimeNs> gaps;  // the camera's rate: the median interval between successive frames
  for (std::size_t i = 1; i < frames.size(); ++i)
    if (frames[i].first > frames[i - 1].first) gaps.push_back(frames[i].first - frames[i - 1].first);
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2), gaps.end());
  const double rate_hz = gaps.empty() ? 1.0 : 1.0 / to_seconds(gaps[gaps.size() / 2]);
  FrameOrder order(mapping::read_input_timeout(tm, rate_hz));
  TimeNs shift = 0, last_taken = 0;
  for (const auto& [stamp, path] : frames) {
    const FrameOrder::Verdict verdict = order.admit(stamp);
    if (verdict == FrameOrder::Verdict::kOutOfOrder) {
      std::error_code ec;  // not part of the drive: its PNG goes too (a leftover file is harmless)
      fs::remove(path, ec);
      continue;
    }
    if (verdict == FrameOrder::Verdict::kClockStep) {
      odometry.clock_stepped_back();
      shift += last_taken - stamp + from_seconds(1.0 / rate_hz);
    }
    if (!odometry.advance_to(stamp, read)) {
      if (!odometry.started()) {
        spdlog::warn("{}: frame at {:.3f} s precedes the wheel odometry (the first sample of every wheel{}); skipped",
                     name, static_cast<double>(stamp - frames.front().first) / 1e9,
                     settings.imu_heading ? " and the IMU" : "");
        continue;
      }
      ++unavailable;  // no odometry at its capture time (after the last samples): the last pose
    }
    mapping::DriveFrame f;
    f.index = static_cast<int>(drive.frames.size());
    f.file = path;
    f.t_s = static_cast<double>(stamp + shift - frames.front().first) / 1e9;
    f.odometry = odometry.pose();
    f.line = f.index + 2;
    char row[256];
    std::snprintf(row, sizeof row, "%d,frames/%s,%.6f,%.6f,%.6f,%.6f\n", f.index, path.filename().c_str(), f.t_s,
                  f.odometry.x, f.odometry.y, f.odometry.yaw);
    csv += row;
    drive.frames.push_back(f);
    last_taken = stamp;
  }
  if (drive.frames.empty()) throw InputError(name + ": no frame after the first encoder samples");
  write_file((out / "frames.csv").string(), csv, "the drive's frame table");
  mapping::write_drive_description(drive, out / "input.json");  // `out` is now a drive directory too
  if (unavailable > 0)
    spdlog::warn("{}: {} frames have no wheel{} samples around their capture time and keep the last odometry pose",
                 name, unavailable, settings.imu_heading ? " or IMU" : "");
  if (order.out_of_order() > 0)
    spdlog::warn(
        "{}: {} frames stamped at or before the frame mapped before them (the camera clock stepped back) "
        "were skipped (not in frames.csv or frames/)",
        name, order.out_of_order());
  if (order.clock_steps() > 0)
    spdlog::warn(
        "{}: the camera clock stepped back {} times by more than the input timeout: mapped on from the new "
        "time base, the wheel odometry re-read there",
        name, order.clock_steps());
  if (odometry.reanchored() > 0)
    spdlog::warn("{}: {} implausible wheel steps (faster than wheel_max_speed_mps) re-anchored the odometry", name,
                 odometry.reanchored());
  std::printf("%s: camera %s, %zu frames, encoder set %s (%zu wheels, %zu samples), heading %s, wheel path %.3f m\n",
              name.c_str(), device.c_str(), drive.frames.size(), encoders.c_str(), wheels.size(), in.samples,
              settings.imu_heading
                  ? ("imu " + rover.imu + " (" + std::to_string(in.yaws.samples.size()) + " samples)").c_str()
                  : "wheels",
              odometry.distance());
  return drive;
}
#endif

struct EvalMapArgs {
  std::string drive;
  std::string map;
  std::string overlay;  // PNG of what was scored ("" = none)
};

const bool registered = add_command([](CLI::App& app) {
  auto a = std::make_shared<MapArgs>();
  CLI::App* cmd = app.add_subcommand(
      "map", "drive-long terrain map of a recorded drive: corrected odometry + world-frame map (TIFF, CSV, PNG)");
  cmd->add_option(
         "drive", a->drive,
         "drive directory (input.json, frames.csv, frames/) or a HAL recording FILE.mcap (`regolith run --record`)")
      ->required();
  cmd->add_option("--device", a->device, "recordings: the camera (default: the terrain_map component's)");
  cmd->add_option("--encoders", a->encoders,
                  "recordings: the encoder set of the wheel odometry (default: the terrain_map component's)");
  cmd->add_option("--out,-o", a->out, "output directory (created)")->required();
  CLI::Option* res_opt = cmd->add_option("--resolution", a->resolution_m, "m per map cell (map_resolution_m)")
                             ->capture_default_str()
                             ->check(CLI::Range(0.005, 1.0));
  cmd->add_flag("--wheel-only", a->wheel_only, "place the map with the wheel odometry alone (no visual odometry)");
  cmd->add_flag("--quiet,-q", a->quiet, "no per-frame lines");
  cmd->add_option(
      "--config", a->config,
      "YAML file of mapper parameters: the keys of the terrain_map component (components/mapping/README.md)");
  cmd->add_option("--set", a->sets,
                  "one mapper parameter, key=value (repeatable; after --config), e.g. rock_min_frames=4");
  cmd->callback([a, res_opt] {
    mapping::RecordedDrive drive;
    if (fs::path(a->drive).extension() == ".mcap") {
#ifdef REGOLITH_HAVE_HAL_RECORD
      drive = drive_from_recording(a->drive, *a);
#else
      throw ConfigError("map: this build reads no recordings (built without the HAL recording)");
#endif
    } else {
      if (!a->device.empty() || !a->encoders.empty())
        throw ConfigError("map: --device and --encoders are for recordings (.mcap)");
      drive = mapping::read_drive(a->drive);
    }
    const mapping::DriveMapperParams p = mapper_params(*a, res_opt->count() > 0);
    const auto s =
        mapping::map_drive(drive, p, a->out, [&](const mapping::DriveFrame& f, const mapping::FrameReport& r) {
          if (a->quiet) return;
          std::printf("frame %4d  x %8.4f  y %8.4f  yaw %8.4f  sd %.3f m  vo %-4s inliers %5d%s%s\n", f.index, r.pose.x,
                      r.pose.y, r.pose.yaw, std::sqrt(std::max(r.covariance(0, 0), r.covariance(1, 1))),
                      r.vo == mapping::VoStatus::kOk          ? "ok"
                      : r.vo == mapping::VoStatus::kUncertain ? "unc"
                                                              : "-",
                      r.vo_inliers, r.keyframe ? "  keyframe" : "", r.odometry_jump ? "  odometry jump" : "");
        });
    for (const auto& n : s.notes) spdlog::warn("{}", n);
    std::printf(
        "%s: %ld frames (%ld skipped), vision %ld ok / %ld lost / %ld too uncertain, %ld keyframes, path %.3f m, %zu "
        "rocks\n",
        a->drive.c_str(), s.counters.frames, s.skipped, s.counters.vo_ok,
        s.counters.vo_failed - s.counters.vo_uncertain, s.counters.vo_uncertain, s.counters.keyframes, s.path_length_m,
        s.rocks.size());
    for (const auto& w : s.written) std::printf("wrote %s\n", w.string().c_str());
    // The (empty) outputs stay, but a script must not take a drive of which nothing was read for
    // a map of flat, unknown ground.
    if (s.counters.frames == 0)
      throw InputError(a->drive + ": no frame could be mapped (" + std::to_string(s.skipped) +
                       " skipped; the warnings above say why)");
  });

  auto e = std::make_shared<EvalMapArgs>();
  CLI::App* eval = group(app, "eval", "evaluate algorithms against ground truth");
  CLI::App* em = eval->add_subcommand("map", "score a `regolith map` output against a drive's truth (JSON on stdout)");
  em->add_option("drive", e->drive, "drive directory with truth_poses.csv, height.tiff, grid.json, truth.json")
      ->required();
  em->add_option("--map", e->map, "output directory of `regolith map`")->required();
  em->add_option("--overlay", e->overlay,
                 "also draw what was scored into this PNG: true rocks hit / missed, detections matched / false, "
                 "true, corrected and wheel paths, seen cells the map left unknown (blue), over the true terrain");
  em->callback([e] {
    std::cout << regolith::json_text(mapping::evaluate_map(e->drive, e->map, e->overlay), 1) << "\n";
    if (!e->overlay.empty()) std::fprintf(stderr, "wrote %s\n", e->overlay.c_str());
  });
});

}  // namespace
}  // namespace regolith::cli
