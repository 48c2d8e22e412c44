#pragma once
// Stand-ins that hardware backends return when a deployment is only being validated
// (`regolith config check`, DeviceContext::open_devices == false): parameters are fully checked,
// the device is not touched, and components still see the configured geometry.
#include <memory>
#include <string>
#include <vector>

#include "regolith/hal/camera.hpp"
#include "regolith/hal/wheel_encoders.hpp"

namespace regolith::hal {

std::unique_ptr<Camera> make_unopened_camera(const std::string& id, const CameraFormat& format);
std::unique_ptr<WheelEncoders> make_unopened_encoders(const std::string& id, std::vector<std::string> wheel_names);

}  // namespace regolith::hal
