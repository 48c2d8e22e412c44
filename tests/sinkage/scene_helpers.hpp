#pragma once
// Shared helpers for the sinkage tests (the estimator's set-up for a rendered wheel is
// regolith/wheel_scene/sinkage_setup.hpp).
#include "regolith/sinkage/sinkage.hpp"
#include "regolith/wheel_scene/sinkage_setup.hpp"

namespace regolith::sinkage::testing {

inline constexpr double kDeg = 3.14159265358979323846 / 180.0;

}  // namespace regolith::sinkage::testing
