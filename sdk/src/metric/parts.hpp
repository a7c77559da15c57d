// Body parts for per-part blame (which part of the pose makes the distance), and the fixed
// assignment of every GPD v1 dimension to the parts whose joints it involves.
//
// Grouping, exactly:
//   joint -> part: Hip, Chest, Neck, Head -> torso+head; LShoulder, LElbow, LHand -> left arm;
//   RShoulder, RElbow, RHand -> right arm; LHip, LKnee, LFoot -> left leg; RHip, RKnee, RFoot ->
//   right leg (spec gpd-v1.md section 1 joint indices 0-3, 4-6, 7-9, 10-12, 13-15).
//   dimension -> joints it involves (spec section 4 enumeration):
//     Jc, Jk: the joint whose coordinate it is (hip height and its derivatives: Hip);
//     JJd, JJo: the pair (i, j);  JLd: joint k and line l's two endpoints;
//     LLa: both lines' endpoints;  JPd: joint k and plane p's three vertices;
//     LPa: plane p's three vertices and line l's two endpoints;  PPa: both planes' vertices.
//   dimension -> parts: the set S of distinct parts of those joints; each part in S receives an
//   equal share 1/|S| of the dimension's term (shares count parts, not joints).
// The breakdown of d^2 = sum_i e_i (M e)_i (e = x'' - y'', M = W W^T) gives part p the sum over
// dimensions i of share_p(i) * e_i (M e)_i; the five parts sum to d^2 exactly (up to rounding).
// A part can be slightly negative: e_i (M e)_i is a term of a quadratic form, not a square.
#pragma once

#include <array>
#include <cstdint>

#include "gpd/gpd.hpp"

namespace kata::metric {

// The five parts, in the order of every breakdown array.
enum class Part : int { kTorsoHead = 0, kLeftArm = 1, kRightArm = 2, kLeftLeg = 3, kRightLeg = 4 };
constexpr int kParts = 5;

// Short stable name of a part ("torso_head", "left_arm", ...), e.g. for CSV headers.
const char* part_name(int part);
// The part a GPD joint (0..15) belongs to.
int joint_part(int joint);

// Per dimension of the GPD v1 vector, the bit set of parts it involves (bit p = part p).
// Computed once from the layout (gpd::kLineJoints, gpd::kPlaneJoints); never empty.
const std::array<uint8_t, gpd::kDims>& dimension_parts();

}  // namespace kata::metric
