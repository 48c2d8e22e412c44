// What the hardware backends share: the re-open back-off.
#include <gtest/gtest.h>

#include <vector>

#include "regolith/hal/device.hpp"

using namespace regolith;
using namespace regolith::hal;

TEST(Backoff, DoublesToCeilingAndResets) {
  Backoff b(100 * kNsPerMs, 1000 * kNsPerMs);
  std::vector<TimeNs> got;
  for (int i = 0; i < 6; ++i) got.push_back(b.next() / kNsPerMs);
  EXPECT_EQ(got, (std::vector<TimeNs>{100, 200, 400, 800, 1000, 1000}));
  b.reset();
  EXPECT_EQ(b.next(), 100 * kNsPerMs);
  EXPECT_EQ(b.next(), 200 * kNsPerMs);
}

TEST(Backoff, CeilingThatIsNotAPowerOfTwoMultipleIsHit) {
  Backoff c(50 * kNsPerMs, 120 * kNsPerMs);
  EXPECT_EQ(c.next(), 50 * kNsPerMs);
  EXPECT_EQ(c.next(), 100 * kNsPerMs);
  EXPECT_EQ(c.next(), 120 * kNsPerMs);
  EXPECT_EQ(c.next(), 120 * kNsPerMs);
}
