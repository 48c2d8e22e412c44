// regolith map DRIVE_DIR --out DIR: the drive-long terrain map of a recorded drive
// (components/mapping): ground visual odometry fused with the wheel odometry of frames.csv, each
// frame's terrain fused into one world-frame map. Writes map.json, elevation.tiff, hazard.tiff
// (+ the other layers), rocks.csv, odometry.csv and overview.png.
// regolith eval map DRIVE_DIR --map DIR: scores such an output against the drive's truth files.
#include <spdlog/spdlog.h>

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/params.hpp"
#include "regolith/mapping/config.hpp"
#include "regolith/mapping/drive_io.hpp"
#include "regolith/mapping/evaluate.hpp"

namespace regolith::cli {
namespace {

struct MapArgs {
  std::string drive;
  std::string out;
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

struct EvalMapArgs {
  std::string drive;
  std::string map;
};

const bool registered = add_command([](CLI::App& app) {
  auto a = std::make_shared<MapArgs>();
  CLI::App* cmd = app.add_subcommand(
      "map", "drive-long terrain map of a recorded drive: corrected odometry + world-frame map (TIFF, CSV, PNG)");
  cmd->add_option("drive", a->drive, "drive directory: input.json, frames.csv, frames/")->required();
  cmd->add_option("--out,-o", a->out, "output directory (created)")->required();
  CLI::Option* res_opt = cmd->add_option("--resolution", a->resolution_m, "m per map cell (map_resolution_m)")
                             ->capture_default_str()
                             ->check(CLI::Range(0.005, 1.0));
  cmd->add_flag("--wheel-only", a->wheel_only, "place the map with the wheel odometry alone (no visual odometry)");
  cmd->add_flag("--quiet,-q", a->quiet, "no per-frame lines");
  cmd->add_option("--config", a->config,
                  "YAML file of mapper parameters: the keys of the terrain_map component (components/mapping/README.md)");
  cmd->add_option("--set", a->sets, "one mapper parameter, key=value (repeatable; after --config), e.g. rock_min_frames=4");
  cmd->callback([a, res_opt] {
    const mapping::RecordedDrive drive = mapping::read_drive(a->drive);
    const mapping::DriveMapperParams p = mapper_params(*a, res_opt->count() > 0);
    const auto s = mapping::map_drive(drive, p, a->out, [&](const mapping::DriveFrame& f, const mapping::FrameReport& r) {
      if (a->quiet) return;
      std::printf("frame %4d  x %8.4f  y %8.4f  yaw %8.4f  sd %.3f m  vo %-4s inliers %5d%s%s\n", f.index, r.pose.x, r.pose.y,
                  r.pose.yaw, std::sqrt(std::max(r.covariance(0, 0), r.covariance(1, 1))),
                  r.vo == mapping::VoStatus::kOk ? "ok" : "-", r.vo_inliers, r.keyframe ? "  keyframe" : "",
                  r.odometry_jump ? "  odometry jump" : "");
    });
    for (const auto& n : s.notes) spdlog::warn("{}", n);
    std::printf("%s: %ld frames (%ld skipped), vision %ld ok / %ld lost, %ld keyframes, path %.3f m, %zu rocks\n",
                a->drive.c_str(), s.counters.frames, s.skipped, s.counters.vo_ok, s.counters.vo_failed, s.counters.keyframes,
                s.path_length_m, s.rocks.size());
    for (const auto& w : s.written) std::printf("wrote %s\n", w.string().c_str());
  });

  auto e = std::make_shared<EvalMapArgs>();
  CLI::App* eval = group(app, "eval", "evaluate algorithms against ground truth");
  CLI::App* em = eval->add_subcommand("map", "score a `regolith map` output against a drive's truth (JSON on stdout)");
  em->add_option("drive", e->drive, "drive directory with truth_poses.csv, height.tiff, grid.json, truth.json")->required();
  em->add_option("--map", e->map, "output directory of `regolith map`")->required();
  em->callback([e] { std::cout << mapping::evaluate_map(e->drive, e->map).dump(1) << "\n"; });
});

}  // namespace
}  // namespace regolith::cli
