#include "backends_internal.hpp"
#include "regolith/mocks/backends.hpp"

namespace regolith::mocks {

#ifdef REGOLITH_HAVE_TRACK_SCENE
std::unique_ptr<hal::Camera> make_synthetic_tracks_camera(Params& p,
                                                          const hal::DeviceContext& ctx);  // synthetic_tracks.cpp
#endif

void register_mock_backends(hal::BackendRegistry& registry) {
  hal::BackendRegistry* reg = &registry;
  registry.add_camera("image_files", "images from a directory or glob, served at rate_hz on the process clock",
                      make_image_files_camera);
  registry.add_camera("fault_injection", "wraps `inner:` camera: drop, freeze, corrupt, delay, disconnect/reconnect",
                      [reg](Params& p, const hal::DeviceContext& ctx) { return make_fault_camera(p, ctx, *reg); });
  registry.add_camera("replay",
                      "the frames a camera delivered in a HAL recording (`regolith run --record`), "
                      "at their recorded times",
                      make_replay_camera);
  registry.add_encoders("replay", "the wheel angles (samples and query answers) of a HAL recording",
                        make_replay_encoders);
  registry.add<hal::Imu>("replay", "the IMU samples and attitude answers of a HAL recording", make_replay_imu);
  registry.add_encoders("scripted", "wheel angles from a constant speed or a CSV profile, on a sample grid",
                        make_scripted_encoders);
  registry.add_encoders("candump", "replay of a can-utils `candump -l` log through the CAN decoder",
                        make_candump_encoders);
#ifdef REGOLITH_HAVE_TERRAIN_SCENE
  registry.add_camera("synthetic_terrain",
                      "rover camera over generated Lambertian terrain (frames rendered at configure)",
                      make_synthetic_terrain_camera);
  registry.add_camera("synthetic_drive",
                      "rover camera driving a scripted arc over a generated tile with rocks, craters and cast shadows "
                      "(pair: synthetic_drive encoders and imu)",
                      make_synthetic_drive_camera);
  registry.add_encoders("synthetic_drive",
                        "the wheel rotations of the synthetic_drive path (rover.wheels, optional slip)",
                        make_synthetic_drive_encoders);
  registry.add<hal::Imu>("synthetic_drive", "heading and yaw rate of the synthetic_drive path (level body)",
                         make_synthetic_drive_imu);
#endif
#ifdef REGOLITH_HAVE_WHEEL_SCENE
  registry.add_camera("synthetic_wheel",
                      "wheel-leg scene rendered for a scripted wheel angle (pair: synthetic_wheel encoders)",
                      make_synthetic_wheel_camera);
  registry.add_encoders("synthetic_wheel", "the angles the synthetic_wheel camera frames were rendered at",
                        make_synthetic_wheel_encoders);
#endif
#ifdef REGOLITH_HAVE_TRACK_SCENE
  registry.add_camera("synthetic_tracks",
                      "rear camera over the rover's own wheel tracks (rigid-wheel ruts, known soil k, n)",
                      make_synthetic_tracks_camera);
#endif
  registry.add<hal::Imu>("scripted",
                         "body attitude from a script (roll/pitch/heading, sway, turn rate), on a sample grid",
                         make_scripted_imu);
  registry.add_encoders("fault_injection", "wraps `inner:` encoders: drop, freeze, corrupt, delay, disconnect",
                        [reg](Params& p, const hal::DeviceContext& ctx) { return make_fault_encoders(p, ctx, *reg); });
  registry.add<hal::Imu>("fault_injection", "wraps `inner:` IMU: drop, freeze, corrupt, delay, disconnect",
                         [reg](Params& p, const hal::DeviceContext& ctx) { return make_fault_imu(p, ctx, *reg); });
}

std::vector<std::string> mock_camera_backends() {
  std::vector<std::string> v{"image_files", "fault_injection"};
#ifdef REGOLITH_HAVE_TERRAIN_SCENE
  v.emplace_back("synthetic_terrain");
  v.emplace_back("synthetic_drive");
#endif
#ifdef REGOLITH_HAVE_WHEEL_SCENE
  v.emplace_back("synthetic_wheel");
#endif
#ifdef REGOLITH_HAVE_TRACK_SCENE
  v.emplace_back("synthetic_tracks");
#endif
  return v;
}
std::vector<std::string> mock_encoder_backends() {
  std::vector<std::string> v{"scripted", "candump", "fault_injection"};
#ifdef REGOLITH_HAVE_TERRAIN_SCENE
  v.emplace_back("synthetic_drive");
#endif
#ifdef REGOLITH_HAVE_WHEEL_SCENE
  v.emplace_back("synthetic_wheel");
#endif
  return v;
}

}  // namespace regolith::mocks
