// A warm Pentland solve (FFTW plans made on the first frame) must not allocate: global operator
// new is counted in this binary. Tsai-Shah (the marching default) is held to the same.
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new
#include "regolith/sfs/sfs.hpp"

namespace rs = regolith::sfs;

TEST(SfsNoAlloc, WarmPentlandAndTsaiShahSolvesDoNotAllocate) {
  for (const rs::Method m : {rs::Method::kPentland, rs::Method::kTsaiShah}) {
    for (const cv::Size sz : {cv::Size(640, 480), cv::Size(200, 275)}) {
      rs::SfsParams sp;
      sp.method = m;
      sp.estimate_light = false;
      rs::ShapeFromShading solver(sp);
      cv::Mat e(sz, CV_32F);
      cv::randu(e, 0.2, 0.9);
      rs::LightDirection light;
      light.slant_rad = 0.7;
      light.tilt_rad = 1.0;
      rs::SfsResult out;
      solver.compute(e, light, out);  // first frame of the size: plans and buffers
      light.tilt_rad = 1.3;           // a new sun direction re-makes the filter in place
      const std::uint64_t a0 = regolith::testing::allocations();
      for (int i = 0; i < 3; ++i) solver.compute(e, light, out);
      EXPECT_EQ(regolith::testing::allocations() - a0, 0u) << rs::to_string(m) << " " << sz;
      EXPECT_EQ(out.status, rs::SfsStatus::kSolved);
      EXPECT_EQ(out.height.size(), sz);
    }
  }
}
