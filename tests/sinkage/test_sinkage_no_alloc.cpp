// process() must not allocate once constructed: global operator new is counted in this binary.
#include <atomic>
#include <cstdlib>
#include <new>

#include <gtest/gtest.h>

#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new
#include "scene_helpers.hpp"

namespace rs = regolith::sinkage;
namespace ws = regolith::wheel_scene;

namespace {

long allocations_during(rs::SinkageEstimator& est, const std::vector<ws::SequenceFrame>& seq) {
  rs::SinkageResult r;
  est.process(seq.front().bgr, seq.front().truth.encoder_angle_rad, r);  // warm-up
  const std::uint64_t a0 = regolith::testing::allocations();
  for (const auto& f : seq) est.process(f.bgr, f.truth.encoder_angle_rad, r);
  est.process(seq.front().bgr, std::numeric_limits<double>::quiet_NaN(), r);  // invalid path
  return static_cast<long>(regolith::testing::allocations() - a0);
}

}  // namespace

TEST(SinkageNoAlloc, ProcessDoesNotAllocate) {
  for (bool poor : {false, true}) {
    ws::SceneParams sp;
    sp.light = poor ? ws::Illumination::poor() : ws::Illumination::normal();
    sp.misalignment_rad = 3.0 * rs::testing::kDeg;
    ws::WheelSceneGenerator gen(sp);
    ws::SequenceSpec spec;
    spec.frames = 12;
    spec.angle_step_rad = 0.11;
    const auto seq = ws::make_sequence(gen, spec);
    for (auto filter : {rs::TemporalFilter::kNone, rs::TemporalFilter::kMedian, rs::TemporalFilter::kEma}) {
      for (bool masked : {true, false}) {
        rs::SinkageParams p = ws::sinkage_params(sp.wheel);
        p.filter = filter;
        p.use_dynamic_mask = masked;
        rs::SinkageEstimator est(ws::sinkage_geometry(sp.wheel), p, sp.size);
        EXPECT_EQ(allocations_during(est, seq), 0)
            << "poor=" << poor << " filter=" << static_cast<int>(filter) << " masked=" << masked;
      }
    }
  }
  // the counter itself works
  const std::uint64_t a0 = regolith::testing::allocations();
  auto* v = new std::vector<int>(100);
  const std::uint64_t a1 = regolith::testing::allocations();
  delete v;
  EXPECT_GE(a1 - a0, 1u);
}
