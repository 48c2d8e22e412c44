#pragma once
// The parts of the `regolith` front-end that need no command-line parser: what tests, benchmarks
// and fuzzers that load a deployment in-process use (tools/cli.hpp, which every sub-command
// includes, adds CLI11 and the command registry: parsing its header costs seconds per file).
#include <string>

namespace regolith::cli {

/// Register every component type and HAL backend compiled into this build.
void register_everything();

/// The embedded default deployment (config/mock_rover.yaml at build time).
const char* embedded_mock_rover();

/// Exit codes: 0 ok, 1 runtime failure, 2 bad configuration or input (a restart cannot fix it:
/// regolith.service's RestartPreventExitStatus), 3 a device unavailable at start-up (missing,
/// busy, no permission, CAN interface absent or down: regolith.service restarts and retries).
inline constexpr int kExitConfig = 2;
inline constexpr int kExitDeviceUnavailable = 3;

/// The ROS node a tool process announces in the ROS 2 graph (`ros2 node list`):
/// "regolith_<command>_<pid>", so that two echoes at once are two nodes.
std::string tool_node_name(const std::string& command);

}  // namespace regolith::cli
