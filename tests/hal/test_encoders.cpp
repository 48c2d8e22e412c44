// AngleHistory: interpolation, bounded extrapolation, velocity, ordering.
#include <gtest/gtest.h>

#include "regolith/hal/wheel_encoders.hpp"

using namespace regolith;
using namespace regolith::hal;

TEST(AngleHistory, InterpolatesBetweenSamples) {
  AngleHistory h;
  for (int i = 0; i <= 10; ++i) ASSERT_TRUE(h.push({i * 10 * kNsPerMs, i * 0.1}));
  double a = 0;
  ASSERT_TRUE(h.at(25 * kNsPerMs, 0, a));
  EXPECT_NEAR(a, 0.25, 1e-12);
  ASSERT_TRUE(h.at(0, 0, a));
  EXPECT_NEAR(a, 0.0, 1e-12);
  EXPECT_FALSE(h.at(-1, 0, a)) << "before the history";
  EXPECT_FALSE(h.at(105 * kNsPerMs, 0, a)) << "extrapolation not allowed";
  ASSERT_TRUE(h.at(105 * kNsPerMs, 10 * kNsPerMs, a));
  EXPECT_NEAR(a, 1.05, 1e-12);
  double v = 0;
  ASSERT_TRUE(h.velocity(v));
  EXPECT_NEAR(v, 10.0, 1e-9);
  AngleSample s;
  ASSERT_TRUE(h.latest(s));
  EXPECT_EQ(s.stamp, 100 * kNsPerMs);
}

TEST(AngleHistory, RejectsOutOfOrderAndKeepsTheLastWindow) {
  AngleHistory h;
  ASSERT_TRUE(h.push({100, 1.0}));
  EXPECT_FALSE(h.push({50, 0.5}));
  for (int i = 0; i < 200; ++i) h.push({200 + i, static_cast<double>(i)});
  double a = 0;
  EXPECT_FALSE(h.at(100, 0, a)) << "older than the 64-sample window";
  ASSERT_TRUE(h.at(399, 0, a));
  EXPECT_DOUBLE_EQ(a, 199.0);
}
