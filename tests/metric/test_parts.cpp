// The dimension -> body part table (parts.hpp), checked against hand-derived entries of the
// spec's enumeration (gpd-v1.md sections 3-4).
#include <gtest/gtest.h>

#include "metric/parts.hpp"

namespace kata {
namespace {

using metric::dimension_parts;
constexpr uint8_t T = 1, LA = 2, RA = 4, LL = 8, RL = 16;

TEST(Parts, EveryDimensionHasAPart) {
  for (int i = 0; i < gpd::kDims; ++i) {
    EXPECT_NE(dimension_parts()[i], 0) << i;
    EXPECT_LT(dimension_parts()[i], 32) << i;
  }
}

TEST(Parts, HandDerivedEntries) {
  const auto& t = dimension_parts();
  // Jc: joint 1 (Chest) x,y,z -> torso; joint 5 (LElbow) -> left arm; hip height -> torso.
  EXPECT_EQ(t[0], T);
  EXPECT_EQ(t[3 * 4 + 1], LA);  // joint 5 is the 4th of 1..15 -> dims 12..14
  EXPECT_EQ(t[45], T);
  // JJd pair (0, 6) Hip-LHand: pairs (0,1)..(0,15) are dims 46..60, (0,6) is 46 + 5.
  EXPECT_EQ(t[gpd::kOffsetJJd + 5], T | LA);
  // JJd last pair (14, 15) RKnee-RFoot -> right leg only.
  EXPECT_EQ(t[gpd::kOffsetJJo - 1], RL);
  // JJo pair (0, 1), 3 dims -> torso.
  EXPECT_EQ(t[gpd::kOffsetJJo + 2], T);
  // JLd line 0 (bone Hip->Chest), first joint not on it is 2 (Neck) -> torso;
  // its 4th joint not on it is 5 (LElbow) -> torso + left arm.
  EXPECT_EQ(t[gpd::kOffsetJLd], T);
  EXPECT_EQ(t[gpd::kOffsetJLd + 3], T | LA);
  // LLa first pair: lines 0 (Hip->Chest) and 1 (Chest->Neck) -> torso.
  EXPECT_EQ(t[gpd::kOffsetLLa], T);
  // PPa: planes 3 (LHip, LKnee, LFoot) and 4 (RHip, RKnee, RFoot) -> left leg + right leg.
  EXPECT_EQ(t[gpd::kOffsetJk - 1], LL | RL);
  // PPa first: planes 0 (torso) and 1 (left arm).
  EXPECT_EQ(t[gpd::kOffsetPPa], T | LA);
  // JPd plane 0 (Chest, Neck, Head), first joint not a vertex is 0 (Hip) -> torso.
  EXPECT_EQ(t[gpd::kOffsetJPd], T);
  // LPa plane 0, first line not inside the plane: line 0 (Hip->Chest) -> torso.
  EXPECT_EQ(t[gpd::kOffsetLPa], T);
  // Jk: joint 15 (RFoot) acceleration z (last of joints 1..15), then hip (v, a) -> torso.
  EXPECT_EQ(t[gpd::kOffsetJk + 89], RL);
  EXPECT_EQ(t[gpd::kDims - 1], T);
  EXPECT_EQ(t[gpd::kDims - 2], T);
  // LLa last pair: lines 28 and 29, end-site pairs in the order
  // (H,LH) (H,RH) (H,LF) (H,RF) (LH,RH) (LH,LF) (LH,RF) (RH,LF) (RH,RF) (LF,RF) -> 28 = (RH,RF),
  // 29 = (LF,RF): joints RHand, RFoot, LFoot -> right arm + right leg + left leg.
  EXPECT_EQ(t[gpd::kOffsetJPd - 1], RA | RL | LL);
}

TEST(Parts, JointPartsFollowTheSkeleton) {
  const int expect[16] = {0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4};
  for (int j = 0; j < 16; ++j) EXPECT_EQ(metric::joint_part(j), expect[j]) << j;
  EXPECT_STREQ(metric::part_name(1), "left_arm");
}

}  // namespace
}  // namespace kata
