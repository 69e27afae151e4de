// The lane scalar's mask tests (include/wet_curly_hair/core/lane_math.h): anyLane answers for
// every lane of every layout, whichever instruction the build's CPU gives it (a whole-register
// test for 32- and 64-byte masks, a lane by lane OR elsewhere).
#include <gtest/gtest.h>

#include "wet_curly_hair/core/lane_math.h"

using namespace wet_curly_hair;

namespace {

/// A mask of the layout S from a comparison with lane `on` alone (or none, with on < 0) less
/// than the threshold, as the stages form theirs.
template <typename S>
LaneMask<S> maskWithLane(int on) {
  S value = splat<S>(1.0);
  if (on >= 0) setLaneValue(&value, on, -1.0);
  return value < splat<S>(0.0);
}

/// No lane set: false; any one lane set, each in turn: true; every lane: true.
template <typename S>
void expectAnyLaneSeesEveryLane() {
  EXPECT_FALSE(anyLane(maskWithLane<S>(-1)));
  for (int l = 0; l < kLaneWidth<S>; ++l) EXPECT_TRUE(anyLane(maskWithLane<S>(l))) << "lane " << l;
  EXPECT_TRUE(anyLane(splat<S>(-1.0) < splat<S>(0.0)));
}

}  // namespace

TEST(LaneMath, AnyLaneSeesEveryLaneOfFloat16) { expectAnyLaneSeesEveryLane<LaneFloat16>(); }
TEST(LaneMath, AnyLaneSeesEveryLaneOfFloat8) { expectAnyLaneSeesEveryLane<LaneFloat8>(); }
TEST(LaneMath, AnyLaneSeesEveryLaneOfDouble8) { expectAnyLaneSeesEveryLane<LaneDouble8>(); }
TEST(LaneMath, AnyLaneSeesEveryLaneOfDouble4) { expectAnyLaneSeesEveryLane<LaneDouble4>(); }
TEST(LaneMath, AnyLaneSeesTheOneLaneOfDouble) { expectAnyLaneSeesEveryLane<double>(); }
