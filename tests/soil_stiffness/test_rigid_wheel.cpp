#include <cmath>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "regolith/soil_stiffness/mission_table.hpp"
#include "regolith/soil_stiffness/rigid_wheel.hpp"

using namespace regolith::soil;

namespace {
std::string message_of(const RoverConfig& c) {
  try {
    c.validate();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// Numerical load-sinkage integral W = b * int_0^l k z(x)^n dx with z(x) = z0 - x^2 / D.
double numeric_load(double k, double n, double b, double D, double z0) {
  const double l = std::sqrt(D * z0);
  const int steps = 200000;
  double acc = 0.0;
  for (int i = 0; i < steps; ++i) {
    const double x = (i + 0.5) * l / steps;
    const double z = z0 - x * x / D;
    if (z > 0) acc += k * std::pow(z, n);
  }
  return b * acc * l / steps;
}
}  // namespace

TEST(RigidWheel, RoundTripFixedN) {
  for (SinkageModel model : {SinkageModel::kBekker, SinkageModel::kBeta}) {
    for (double n : {0.5, 0.8, 1.0, 1.3}) {
      for (double k : {2e5, 8.2e5, 3e6}) {
        const double z = sinkage_from_soil(k, n, 40.0, 0.15, 0.3, model);
        EXPECT_GT(z, 0.0);
        EXPECT_NEAR(stiffness_from_sinkage(z, n, 40.0, 0.15, 0.3, model) / k, 1.0, 1e-9);
      }
    }
  }
}

TEST(RigidWheel, JointRoundTripFromThreeLoads) {
  for (SinkageModel model : {SinkageModel::kBekker, SinkageModel::kBeta}) {
    for (double n : {0.6, 1.0, 1.4}) {
      const double k = 6e5;
      std::vector<SinkageSample> s;
      for (double w : {30.0, 60.0, 120.0}) s.push_back({sinkage_from_soil(k, n, w, 0.1, 0.3, model), w, 0.1, 0.3});
      const JointFit f = fit_joint(s, model);
      ASSERT_TRUE(f.ok) << f.reason;
      EXPECT_NEAR(f.n, n, 1e-9);
      EXPECT_NEAR(f.k / k, 1.0, 1e-9);
      EXPECT_LT(f.rms_log_residual, 1e-12);
    }
  }
}

TEST(RigidWheel, JointFitNeedsDistinctLoads) {
  std::vector<SinkageSample> s{{0.02, 50.0, 0.1, 0.3}, {0.021, 51.0, 0.1, 0.3}};
  const JointFit f = fit_joint(s);
  EXPECT_FALSE(f.ok);
  EXPECT_NE(std::string(f.reason).find("distinct wheel loads"), std::string::npos) << f.reason;
}

TEST(RigidWheel, ClosedFormsMatchTheIntegral) {
  // Beta form is exact for the parabolic rim; Bekker's two-term form is exact at n = 0 and 1.
  for (double n : {0.5, 1.0, 1.3}) {
    const double k = 5e5, b = 0.1, D = 0.3, z0 = 0.03;
    const double w = numeric_load(k, n, b, D, z0);
    const double zb = sinkage_from_soil(k, n, w, b, D, SinkageModel::kBeta);
    EXPECT_NEAR(zb / z0, 1.0, 2e-3) << "n = " << n;
    const double zk = sinkage_from_soil(k, n, w, b, D, SinkageModel::kBekker);
    EXPECT_NEAR(zk / z0, 1.0, n == 1.0 ? 2e-3 : 0.07) << "n = " << n;
  }
  EXPECT_NEAR(load_factor(1.0, SinkageModel::kBekker), load_factor(1.0, SinkageModel::kBeta), 1e-12);
  EXPECT_NEAR(load_factor(0.0, SinkageModel::kBekker), load_factor(0.0, SinkageModel::kBeta), 1e-12);
}

TEST(RigidWheel, SpecFormulaValue) {
  // z = [3W/((3-n) b k sqrt(D))]^(2/(2n+1)); Yutu-like wheel on Lunar Sourcebook soil.
  const double W = 140.0 * 1.62 / 6.0, k = 1400.0 / 0.15 + 820000.0;
  const double z = std::pow(3 * W / (2.0 * 0.15 * k * std::sqrt(0.3)), 2.0 / 3.0);
  EXPECT_NEAR(sinkage_from_soil(k, 1.0, W, 0.15, 0.3), z, 1e-15);
  EXPECT_NEAR(z, 0.00886, 2e-4);
}

TEST(RoverConfig, RejectsBadFieldsNamingThem) {
  RoverConfig ok;
  EXPECT_NO_THROW(ok.validate());
  RoverConfig c = ok;
  c.wheel_count = 0;
  EXPECT_NE(message_of(c).find("wheel_count"), std::string::npos);
  c = ok;
  c.wheel_diameter_m = -0.3;
  EXPECT_NE(message_of(c).find("wheel_diameter_m"), std::string::npos);
  c = ok;
  c.wheel_width_m = 0.0;
  EXPECT_NE(message_of(c).find("wheel_width_m"), std::string::npos);
  c = ok;
  c.mass_kg = std::nan("");
  EXPECT_NE(message_of(c).find("mass_kg"), std::string::npos);
  c = ok;
  c.gravity_mps2 = -9.81;
  EXPECT_NE(message_of(c).find("gravity_mps2"), std::string::npos);
  EXPECT_THROW(sinkage_from_soil(-1.0, 1.0, 10, 0.1, 0.3), std::invalid_argument);
  EXPECT_THROW(load_factor(3.5, SinkageModel::kBekker), std::invalid_argument);
}

TEST(MissionTable, ThreeMissionsWithPlausibleSinkage) {
  const auto t = mission_table();
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0].vehicle, "Lunokhod 1");
  EXPECT_EQ(t[1].mission, "Apollo 15");
  EXPECT_EQ(t[2].vehicle, "Yutu");
  for (const auto& m : t) {
    EXPECT_NO_THROW(m.rover.validate());
    EXPECT_NEAR(m.k_traditional(), 1400.0 / m.rover.wheel_width_m + 820000.0, 1e-6);
    const double z = m.predicted_sinkage_m();
    EXPECT_GT(z, 0.002) << m.vehicle;
    EXPECT_LT(z, 0.05) << m.vehicle;
    EXPECT_FALSE(m.vehicle_source.empty());
    EXPECT_FALSE(m.soil_source.empty());
  }
  // LRV: k from its reported 1.25 cm rut with n = 1 is of the same order as the Sourcebook k.
  const double k_img = t[1].k_from_reported_sinkage();
  EXPECT_GT(k_img / t[1].k_traditional(), 0.1);
  EXPECT_LT(k_img / t[1].k_traditional(), 10.0);
  EXPECT_TRUE(std::isnan(t[0].k_from_reported_sinkage()));
  const auto c = pz_curve(8.2e5, 1.0, 0.05, 11);
  ASSERT_EQ(c.size(), 11u);
  EXPECT_NEAR(c[10].second, 8.2e5 * 0.05, 1e-6);
  EXPECT_EQ(c[0].second, 0.0);
}
