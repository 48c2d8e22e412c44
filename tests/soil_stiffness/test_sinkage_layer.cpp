// The sinkage layer: body-frame placement of the rut profiles and rasterisation on a grid with the
// traversability GridMap convention (row 0 = +x edge, column 0 = +y edge).
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "regolith/soil_stiffness/sinkage_layer.hpp"

using namespace regolith;

namespace {
soil::SoilEstimate two_ruts() {
  soil::SoilEstimate e;
  e.ok = true;
  for (double lat : {0.4, -0.4}) {
    soil::TrackProfile t;
    t.lateral_m = lat;
    t.load_n = 40.0;
    for (int i = 0; i < 1000; ++i) {  // 1.0 .. 2.998 m, longer than kLayerMaxSamples
      t.range_m.push_back(1.0 + 0.002 * i);
      t.sinkage_m.push_back(i < 500 ? 0.010 : 0.020);
    }
    t.sinkage_m[10] = std::numeric_limits<double>::quiet_NaN();
    t.mean_sinkage_m = 0.015;
    e.tracks.push_back(t);
  }
  return e;
}
}  // namespace

TEST(SinkageLayer, PlacesRearProfilesBehindTheRover) {
  soil::SinkageLayer layer;
  soil::LayerPose pose;  // rear camera: x = -0.5 m, yaw = pi
  soil::fill_sinkage_layer(two_ruts(), 0.15, pose, 1234, 7, layer);
  ASSERT_TRUE(layer.valid);
  EXPECT_EQ(layer.stamp_ns, 1234);
  EXPECT_EQ(layer.sequence, 7u);
  ASSERT_EQ(layer.track_count, 2u);
  const auto& t0 = layer.tracks[0];
  EXPECT_EQ(t0.count, 500u);  // 1000 samples averaged in pairs
  // range 1.001 m behind a camera 0.5 m behind base_link, looking back: x = -1.501; the rut on
  // the camera's left (+0.4) is on the rover's right (y = -0.4)
  EXPECT_NEAR(t0.x_m[0], -1.501, 1e-4);
  EXPECT_NEAR(t0.y_m[0], -0.4, 1e-4);
  EXPECT_NEAR(t0.sinkage_m[0], 0.010, 1e-6);
  EXPECT_NEAR(t0.sinkage_m[5], 0.010, 1e-6);  // pair (10, 11): one NaN, the other sample kept
  EXPECT_NEAR(t0.sinkage_m[499], 0.020, 1e-6);
  EXPECT_DOUBLE_EQ(t0.width_m, 0.15);
}

TEST(SinkageLayer, RasterisesRutsOntoTheGrid) {
  soil::SinkageLayer layer;
  soil::fill_sinkage_layer(two_ruts(), 0.16, soil::LayerPose{}, 0, 0, layer);
  soil::GridGeometry g;
  g.resolution_m = 0.05;
  g.length_x_m = 4.0;
  g.length_y_m = 2.0;
  g.center_x_m = -2.0;  // covers x in [-4, 0], y in [-1, 1]
  cv::Mat m;
  const int set = soil::rasterise_sinkage(layer, g, m);
  ASSERT_EQ(m.rows, 80);
  ASSERT_EQ(m.cols, 40);
  // each rut covers x in [-3.497, -1.501] and +-0.08 m across: 40 rows x 4 columns of centres
  EXPECT_EQ(set, 2 * 40 * 4);
  auto at = [&](double x, double y) {
    const int i = static_cast<int>((g.center_x_m + 0.5 * g.length_x_m - x) / g.resolution_m);
    const int j = static_cast<int>((g.center_y_m + 0.5 * g.length_y_m - y) / g.resolution_m);
    return m.at<float>(i, j);
  };
  EXPECT_NEAR(at(-1.8, -0.4), 0.010, 1e-6);  // range 1.3 m
  EXPECT_NEAR(at(-3.2, 0.4), 0.020, 1e-6);   // range 2.7 m
  EXPECT_TRUE(std::isnan(at(-1.8, 0.0)));    // between the ruts
  EXPECT_TRUE(std::isnan(at(-0.5, -0.4)));   // nearer than the measured profile
  // no estimate -> an all-NaN layer
  soil::SoilEstimate none;
  soil::fill_sinkage_layer(none, 0.15, soil::LayerPose{}, 0, 0, layer);
  EXPECT_FALSE(layer.valid);
  EXPECT_EQ(soil::rasterise_sinkage(layer, g, m), 0);
  g.resolution_m = 0.0;
  EXPECT_THROW(soil::rasterise_sinkage(layer, g, m), std::invalid_argument);
}
