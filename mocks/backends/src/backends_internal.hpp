#pragma once
// Factories of the mock backends (registered by register_mock_backends).
#include <memory>

#include "regolith/core/params.hpp"
#include "regolith/hal/registry.hpp"

namespace regolith::mocks {

std::unique_ptr<hal::Camera> make_image_files_camera(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::WheelEncoders> make_scripted_encoders(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::WheelEncoders> make_candump_encoders(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::Camera> make_synthetic_terrain_camera(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::Camera> make_synthetic_drive_camera(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::WheelEncoders> make_synthetic_drive_encoders(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::Imu> make_synthetic_drive_imu(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::Camera> make_synthetic_wheel_camera(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::WheelEncoders> make_synthetic_wheel_encoders(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::Imu> make_scripted_imu(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::Camera> make_replay_camera(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::WheelEncoders> make_replay_encoders(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::Imu> make_replay_imu(Params& p, const hal::DeviceContext& ctx);
std::unique_ptr<hal::Camera> make_fault_camera(Params& p, const hal::DeviceContext& ctx,
                                               const hal::BackendRegistry& registry);
std::unique_ptr<hal::WheelEncoders> make_fault_encoders(Params& p, const hal::DeviceContext& ctx,
                                                        const hal::BackendRegistry& registry);
std::unique_ptr<hal::Imu> make_fault_imu(Params& p, const hal::DeviceContext& ctx,
                                         const hal::BackendRegistry& registry);

}  // namespace regolith::mocks
