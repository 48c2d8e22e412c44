// regolith::FrameOrder: out of order within the step-back limit, a clock step beyond it, admit()
// taking what it does not skip. The components that use it are tested in their pipelines
// (TerrainMapComponent, PipelineStamps, SinkagePipeline, SoilComponent, RunRecord).
#include <gtest/gtest.h>

#include "regolith/core/frame_order.hpp"
#include "regolith/core/time.hpp"

using namespace regolith;

TEST(FrameOrder, OutOfOrderWithinTheLimitAClockStepBeyondIt) {
  FrameOrder order(from_seconds(2.0));
  using V = FrameOrder::Verdict;
  EXPECT_EQ(order.judge(from_seconds(5.0)), V::kNext) << "the first frame";
  order.take(from_seconds(5.0));
  EXPECT_EQ(order.judge(from_seconds(5.0)), V::kOutOfOrder) << "the same stamp again";
  EXPECT_EQ(order.judge(from_seconds(3.0)), V::kOutOfOrder) << "2 s back: at the limit";
  EXPECT_EQ(order.judge(from_seconds(5.5)), V::kNext);
  EXPECT_EQ(order.judge(from_seconds(2.9)), V::kClockStep) << "2.1 s back";
  order.take(from_seconds(2.9));
  EXPECT_EQ(order.judge(from_seconds(3.4)), V::kNext) << "on from the new time base";
  EXPECT_EQ(order.out_of_order(), 2);
  EXPECT_EQ(order.clock_steps(), 1);
  // admit(): judged and taken unless out of order.
  EXPECT_EQ(order.admit(from_seconds(3.4)), V::kNext);
  EXPECT_EQ(order.admit(from_seconds(3.4)), V::kOutOfOrder) << "the frame admitted just before";
  EXPECT_EQ(order.admit(from_seconds(0.5)), V::kClockStep);
  EXPECT_EQ(order.admit(from_seconds(0.6)), V::kNext) << "the clock step's frame was taken";
}
