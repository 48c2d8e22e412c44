#pragma once
// The drive mapper's parameters read by name from YAML: one reader for the `terrain_map`
// component (its `params:` block) and `regolith map` (`--config FILE`, `--set key=value`), so a
// key means the same in both. Keys, units and defaults: components/mapping/README.md
// ("Parameters"); `regolith config check` lists them for a deployment.
#include "regolith/core/params.hpp"
#include "regolith/mapping/drive_mapper.hpp"

namespace regolith::mapping {

/// The DriveMapperParams keys of `p`, each defaulting to `defaults`' value (located ConfigError
/// on a bad value; unknown keys are the caller's p.finish()).
DriveMapperParams read_drive_mapper_params(Params& p, DriveMapperParams defaults = {});

}  // namespace regolith::mapping
