// DriveMapper::add_frame (VO, fusion, parallax, map fusion, window moves) and WorldMap::finish
// must not allocate once running: global operator new is counted in this binary.
#include <atomic>
#include <cstdlib>
#include <new>

#include <gtest/gtest.h>

#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new
#include "regolith/mapping/drive_mapper.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"

namespace {
using namespace regolith;
using namespace regolith::mapping;

TEST(DriveMapperNoAlloc, AddFrameAndFinishDoNotAllocateOnceRunning) {
  terrain_scene::SceneParams sp;
  sp.seed = 21;
  sp.resolution_m = 0.01;
  sp.fractal_rms_m = 0.01;
  sp.x_min_m = -1;
  sp.x_max_m = 8;
  sp.y_min_m = -4;
  sp.y_max_m = 4;
  const terrain_scene::Terrain t(sp);
  const terrain_scene::Sun sun{2.3, 0.8};
  terrain_scene::CameraPose cam;
  cam.fx = cam.fy = 220;
  cam.cx = 159.5;
  cam.cy = 119.5;
  cam.width = 320;
  cam.height = 240;
  cam.height_m = 0.67;
  cam.pitch_rad = 0.6;
  direct_depth::CameraModel m;
  m.fx = m.fy = 220;
  m.cx = 159.5;
  m.cy = 119.5;
  m.width = 320;
  m.height = 240;
  m.mount_height_m = 0.67;
  m.pitch_rad = 0.6;
  std::vector<cv::Mat> frames;
  std::vector<Pose2> odo;
  Pose2 p{};
  for (int k = 0; k < 14; ++k) {
    if (k) p = compose(p, Pose2{0.07, 0, 0.004});
    cam.x_m = p.x, cam.y_m = p.y, cam.yaw_rad = p.yaw;
    frames.push_back(terrain_scene::to_u8(terrain_scene::render_camera(t, cam, sun).image));
    odo.push_back(p);
  }
  frames[9] = cv::Mat(240, 320, CV_8U, cv::Scalar(0));  // a black frame
  odo[11].x += 2.0;                                     // an odometry spike
  DriveMapperParams params;
  params.map.length_x_m = params.map.length_y_m = 6;  // small: the window must move
  params.fuse_shading = true;                         // every path
  DriveMapper dm(m, CameraMount{0.3, 0.05, 0.0}, sun.vector(), params, {0, 0});
  dm.add_frame(frames[0], odo[0]);
  dm.add_frame(frames[1], odo[1]);
  dm.map().finish();
  const std::uint64_t a0 = regolith::testing::allocations();
  for (std::size_t k = 2; k < frames.size(); ++k) dm.add_frame(frames[k], odo[k]);
  dm.add_frame(frames[2], Pose2{std::nan(""), 0, 0});
  dm.map().finish();
  EXPECT_EQ(regolith::testing::allocations() - a0, 0u);
  // The vision path ran (and did not allocate). x86-64 accepts more than 5 of these fits, arm64 (qemu)
  // only 2: the 9-unknown fit sits near its 1 cm "no texture" gate on 7 cm steps without noise,
  // and rounding (FMA contraction) tips it (noted in the issue 13 note as a gap).
  EXPECT_GE(dm.counters().vo_ok, 1);
  EXPECT_GE(dm.counters().odometry_jumps, 2);
}

}  // namespace
