// regolith soil IMAGE (--config ROVER.yaml | --scene input.json) --out DIR: retrospective soil stiffness from a
// rear-camera image of the rover's tracks (components/soil_stiffness). Writes track_dtm.png,
// sinkage_profiles.png, pz_curves.png and result.json. Bad input (unreadable image, bad YAML
// field, size mismatch) -> message naming the file / field, exit code 2. A frame without usable
// tracks is a result, not an error: result.json says why (ok = false) and the exit code is 0.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "cli.hpp"
#include "regolith/soil_stiffness/config.hpp"
#include "regolith/soil_stiffness/scene.hpp"

namespace regolith::cli {
namespace {

struct SoilArgs {
  std::string image;
  std::string config;
  std::string scene;
  std::string out;
};

const bool registered = add_command([](CLI::App& app) {
  auto a = std::make_shared<SoilArgs>();
  CLI::App* cmd = app.add_subcommand(
      "soil", "soil stiffness k (and n) from an image of the rover's wheel tracks -> PNG plots + JSON");
  cmd->add_option("image", a->image,
                  "rear-camera image of the tracks (8- or 16-bit grey or colour: PNG, JPEG, TIFF, BMP, PNM, WebP)")
      ->required();
  CLI::Option* config =
      cmd->add_option("--config,-c", a->config,
                      "ROVER.yaml: `soil_stiffness:` section (see components/soil_stiffness/example_rover.yaml) "
                      "or a deployment with a soil_stiffness component");
  CLI::Option* scene = cmd->add_option("--scene", a->scene,
                                       "a recorded scene's input.json (camera, sun, wheel, per-track load and "
                                       "x_nominal_m; the development set's tracks format) instead of a YAML");
  config->excludes(scene);
  scene->excludes(config);
  cmd->add_option("--out,-o", a->out, "output directory (created)")->required();
  cmd->callback([a] {
    if (a->config.empty() && a->scene.empty()) throw CLI::RequiredError("--config or --scene");
    const soil::SoilAnalysisFiles f = a->scene.empty() ? soil::run_soil_file(a->image, a->config, a->out)
                                                       : soil::run_soil_scene(a->image, a->scene, a->out);
    const soil::SoilEstimate& e = f.estimate;
    if (e.ok) {
      std::printf("%s: %zu track(s), mean sinkage %.2f mm, %d samples\n", a->image.c_str(), e.tracks.size(),
                  e.mean_sinkage_m * 1e3, e.samples_used);
      std::printf("  n fixed %.2f: k = %.4g +- %.2g N/m^(n+2)\n", e.n_fixed, e.k_fixed, e.k_fixed_std);
      if (e.joint_ok)
        std::printf("  joint: k = %.4g +- %.2g, n = %.3f +- %.3f\n", e.k_joint, e.k_joint_std, e.n_joint,
                    e.n_joint_std);
      std::printf("  reported: k = %.4g +- %.2g, n = %.3f +- %.3f%s\n", e.k, e.k_std, e.n, e.n_std,
                  e.n_data_std > 0 ? " (joint fit with the prior on n)" : " (n fixed)");
      std::printf("  soil class: %s (p(z_ref) = %.0f Pa)\n", soil::to_string(e.soil_class), e.class_pressure_pa);
    } else {
      std::printf("%s: no estimate: %s\n", a->image.c_str(), e.reason.c_str());
    }
    std::printf("wrote %s\n", f.json.string().c_str());
    for (const auto& p : {f.dtm_png, f.profiles_png, f.pz_png, f.overlay_png})
      if (!p.empty()) std::printf("wrote %s\n", p.string().c_str());
  });
});

}  // namespace
}  // namespace regolith::cli
