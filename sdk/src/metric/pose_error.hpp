// Joint-level pose error (issue 34): how far each bone of the student points from the teacher's,
// in degrees, in the body's own frames, and the per-part coaching score built on it.
//
// Why: the learned W was trained to tell motions apart, not to say how far a pose is from the
// teacher's joint by joint: a knee bent 42 degrees more moved its total by 1 point, the head not at
// all, and the left elbow five times as much as the right (docs/model/scores.md). An angle is what a
// coach sees, and the same angle means the same error at every joint, left or right.
//
// Bones: the 15 GPD bones, bone c = joint c's parent -> joint c (spec gpd-v1.md section 1), taken
// from the GPD block Jc (the local-frame joint coordinates, spec section 2: hip at the origin, yaw
// removed, body heights; a direction does not depend on the scale). Each bone's direction is read
// in the frame of the body segment it hangs from, so one turned joint changes the angle of the
// bones it turns and of no other:
//   - the spine (Hip->Chest, Chest->Neck) and the legs (Hip->LHip ... RKnee->RFoot): the local
//     frame (the hips' and shoulders' yaw removed);
//   - the head (Neck->Head) and the arms (Neck->LShoulder ... RElbow->RHand): the chest frame,
//     y along Chest->Neck, x along RShoulder->LShoulder made orthogonal to y, z = x cross y.
//     A bent spine then counts once, in the torso, not again in both arms it carries.
// Parts (parts.hpp): torso/head = bones 1, 2, 3; left arm 4, 5, 6; right arm 7, 8, 9; left leg
// 10, 11, 12; right leg 13, 14, 15. A part's angle is its largest bone angle: a bent knee is as
// wrong as a bent hip, whatever the part's other bones do.
//
// The map: part score = 100 / (1 + (angle / kAngle50)^kAngleSlope), the same map for every part
// (the same angle, the same score), fixed by measurement (docs/model/scores.md "The coaching
// total"): 15 deg -> 98, 30 deg -> 76, 45 deg -> 39.
#pragma once

#include "gpd/gpd.hpp"
#include "metric/parts.hpp"

namespace kata::metric {

constexpr int kBones = gpd::kJoints - 1;  // bone c - 1 ends at joint c (1..15)
constexpr int kBoneFloats = kBones * 3;  // unit directions, bone order
constexpr double kAngle50 = 36.0;        // degrees: a part this far off scores 50
constexpr double kAngleSlope = 5.0;

// The 15 bone directions (kBoneFloats floats, unit or all-zero for a degenerate bone) of a pose
// given by its GPD features (at least the Jc block: x[0..44] = joints 1..15 in the local frame).
// Allocation-free; never NaN for finite input.
void bone_directions(const float* features, float* dirs);

// Per part: its angle, degrees (the largest angle between a student bone and the teacher's, 0..180)
// and the GPD joint at the end of that bone (1..15; the bone's parent joint is the one to move).
// A degenerate bone on either side counts 0 (nothing known). Allocation-free.
void part_angles(const float* student_dirs, const float* teacher_dirs, float* degrees, int* worst_joint);

// The per-part coaching score of a part angle (degrees): 100 / (1 + (a / kAngle50)^kAngleSlope).
double angle_score(double degrees);

}  // namespace kata::metric
