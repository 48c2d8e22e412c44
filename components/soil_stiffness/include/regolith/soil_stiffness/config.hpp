#pragma once
// YAML for the soil stiffness estimator, shared by the "soil_stiffness" component and
// `regolith soil IMAGE --config ROVER.yaml --out DIR`. Every key is declared once here with its
// unit, default and range (README "Parameters"). Errors are ConfigError naming file:line:col and
// the field path, e.g. "rover.yaml:4:17: soil_stiffness.rover.wheel_count: must be >= 1 (got 0)".
#include <filesystem>
#include <string>

#include "regolith/core/params.hpp"
#include "regolith/core/rover.hpp"
#include "regolith/soil_stiffness/run.hpp"
#include "regolith/soil_stiffness/scene.hpp"
#include "regolith/soil_stiffness/sinkage_layer.hpp"
#include "regolith/soil_stiffness/track_analysis.hpp"

namespace regolith::soil {

struct SoilConfig : SoilSetup {
  LayerPose mount;  ///< camera ground frame in the body frame (sinkage layer)
};

/// Reads the estimator keys of one mapping (a component section or the `soil_stiffness` section
/// of a ROVER.yaml): children region, tracks, profile, fit, quality, soil_class (each finished:
/// unknown keys rejected). The geometry comes from the rover description: the camera's
/// calibration and mount (its size must match the frames, width_px x height_px), the sun in the
/// camera's ground frame, the rover mass and wheels. Keys an older format had here (rover,
/// camera_model, sun, mount) are located errors saying where they go. Validates the structs and
/// reports their errors at the right key.
SoilConfig read_soil_config(Params& p, const RoverDescription& rover, const RoverCamera& camera, int width_px,
                            int height_px);

/// `regolith soil`: loads IMAGE (InputError naming the file when unreadable), reads ROVER.yaml
/// (ConfigError), runs run_soil_analysis into `out_dir`. ROVER.yaml holds the rover description
/// (`rover:` with cameras, mass and wheels, and `sun:`) and either a top-level `soil_stiffness:`
/// mapping or is a deployment file (the first component of type soil_stiffness is used; its
/// `camera` key picks rover.cameras.<name>; rate-group and DDS keys are ignored).
SoilAnalysisFiles run_soil_file(const std::filesystem::path& image, const std::filesystem::path& rover_yaml,
                                const std::filesystem::path& out_dir);

}  // namespace regolith::soil
