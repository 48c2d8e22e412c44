#pragma once
// Mock HAL backends for hardware-free runs and tests. They follow the process clock (also the
// simulated one) lazily: a query at time `now` returns what a real device started at `start()`
// would have delivered by `now`; everything is preloaded at construction (= configure time).
//
// Cameras : image_files, synthetic_terrain, synthetic_drive, fault_injection
// Encoders: scripted, candump, synthetic_drive, fault_injection
// IMUs    : scripted, synthetic_drive
// (synthetic_wheel only when the wheel scene library is available; see README.md)
#include <string>
#include <vector>

#include "regolith/hal/registry.hpp"

namespace regolith::mocks {

/// Add every mock backend to `registry` (idempotent: re-registering replaces the same entries).
/// Fault-injection wrappers build their `inner:` device through the same registry.
void register_mock_backends(hal::BackendRegistry& registry);

/// Names registered by register_mock_backends (for documentation and tests).
std::vector<std::string> mock_camera_backends();
std::vector<std::string> mock_encoder_backends();

}  // namespace regolith::mocks
