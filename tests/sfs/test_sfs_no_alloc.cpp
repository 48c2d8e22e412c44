// A warm Pentland solve (FFTW plans made on the first frame) must not allocate: global operator
// new is counted in this binary. Tsai-Shah (the marching default) is held to the same.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include <opencv2/core.hpp>

#include "regolith/sfs/sfs.hpp"

namespace {
std::atomic<long> g_news{0};
std::atomic<bool> g_counting{false};
}  // namespace

void* operator new(std::size_t n) {
  if (g_counting.load(std::memory_order_relaxed)) g_news.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

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
      g_news = 0;
      g_counting = true;
      for (int i = 0; i < 3; ++i) solver.compute(e, light, out);
      g_counting = false;
      EXPECT_EQ(g_news.load(), 0) << rs::to_string(m) << " " << sz;
      EXPECT_EQ(out.status, rs::SfsStatus::kSolved);
      EXPECT_EQ(out.height.size(), sz);
    }
  }
}
