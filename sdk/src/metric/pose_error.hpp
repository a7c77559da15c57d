// Joint-level pose error (docs/model/scores.md "The coaching total"): how far each bone of the student points from the teacher's,
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
// total"): 15 deg -> 99, 30 deg -> 81, 45 deg -> 36.
#pragma once

#include <cstdint>

#include "gpd/gpd.hpp"
#include "metric/parts.hpp"

namespace kata::metric {

constexpr int kBones = gpd::kJoints - 1;  // bone c - 1 ends at joint c (1..15)
constexpr double kAngle50 = 40.0;        // degrees: a part this far off scores 50
constexpr double kAngleSlope = 5.0;
// A pose in the frames above, from its features: [0, 48) the 16 joints in the local frame (the hip
// at the origin), [48, 69) joints 3..9 (head, arms) in the chest frame with the neck at the
// origin, [69] the hip height. Body heights.
constexpr int kChestJoint0 = 3, kChestJoints = 7;
constexpr int kPoseFloats = 3 * gpd::kJoints + 3 * kChestJoints + 1;

// The pose (kPoseFloats floats) of GPD features x (the Jc block: x[0..44] = joints 1..15 in the
// local frame, x[45] the hip height). Allocation-free; never NaN for finite input.
void pose_frames(const float* features, float* pose);

// What one student pose differs from one teacher pose by, per part (parts.hpp order).
struct PartError {
  // Angle, degrees: the largest angle between a student bone of the part and the teacher's, each
  // in its frame (0..180; a degenerate bone on either side counts 0), and the GPD joint (1..15)
  // at the end of that bone (the bone's parent joint is the one to move).
  float degrees[kParts];
  int32_t joint[kParts];
  // Offset, body heights: the mean over the part's joints of the student-teacher distance, every
  // joint in the local frame (the torso's hip by its height): the local-frame mean joint distance
  // that docs/model/part_fix.py calls geometry. The part to fix ranks by it among the parts below
  // kBandScore within kOffsetBand points of the lowest part score, the torso's weighed while it is
  // below good (scorer.cpp update_part_to_fix). Until
  // 2026-12-04 the head and arms were read in the chest frame here, so that a bent spine did not
  // move the arms it carries; the band now keeps an arm at 100 out instead.
  float offset[kParts];
};
void part_error(const float* student_pose, const float* teacher_pose, PartError& out);

// Unit direction of bone c (1..15: joint c's parent -> joint c) of a pose, in the frame it is
// read in above (the chest frame for the head and arms, the local frame otherwise); false (d
// zeroed) for a degenerate bone. Allocation-free.
bool bone_direction(const float* pose, int c, double* d);

// The 15 bones' unit directions of a pose (bone_direction; 3 floats per bone, bone c at 3 (c - 1),
// a degenerate bone zero). Allocation-free.
void bone_directions(const float* pose, float* dirs);

// The trimmed pose distance of a student (its bone_directions) to a teacher pose, a robust
// distance that a joint held wrong throughout does not dominate: per part the sum over its bones
// of |s_c - t_c|^2 (unit directions: 2 - 2 cos of the bone angle; a degenerate bone on either side
// counts 0); the parts but the worst summed (`rest`, if not null, gets it), plus the worst part
// capped at kTrimmedCap times that rest. Where the rest of the body agrees exactly (a copy with one
// joint turned, at its own frame) the distance is 0 whatever the worst part; where the parts
// differ alike (another person's style) it is their plain sum. Scorer's re-match ranks teacher
// frames by it (AlignmentOptions::rematch_time). Allocation-free.
constexpr double kTrimmedCap = 2.0;
double trimmed_pose_distance(const float* student_dirs, const float* teacher_pose, double* rest = nullptr);

// The per-part coaching score of a part angle (degrees): 100 / (1 + (a / kAngle50)^kAngleSlope).
double angle_score(double degrees);

// The lesson's tolerance (docs/model/tolerance.md has the levels' figures): the part map's angle at
// which a part scores 50 and its slope, part score = 100 / (1 + (angle / angle50)^slope). The
// levels (their numbers in pose_error.cpp parse_tolerance):
//   strict   a 30-degree error at one joint scores <= 50 (a coach checking a form already learnt);
//   normal   kAngle50, kAngleSlope (the default, the map above): a 45-degree error scores <= 50;
//   lenient  for beginners: another person's same motion scores higher, and a 45-degree error at
//            one joint is no longer caught (docs/model/tolerance.md says what it reaches and what
//            bounds it);
// or a number of degrees in [kMinToleranceAngle, kMaxToleranceAngle]: that angle scores 50, with
// the normal slope. The gate (the model map of the distance) is the same at every level: another
// motion scores low at each of them.
struct Tolerance {
  double angle50 = kAngle50;
  double slope = kAngleSlope;
};
constexpr double kMinToleranceAngle = 5.0, kMaxToleranceAngle = 120.0;
// The tolerance a text names: "strict", "normal", "lenient" or a number of degrees (e.g. "45",
// "37.5"). Throws kata::Error(kInvalidArgument) naming the text and the accepted forms. Allocates
// (the message) only on error.
Tolerance parse_tolerance(const char* text);
// The part score of an angle under a tolerance; angle_score(d) == angle_score(d, Tolerance{}).
double angle_score(double degrees, const Tolerance& tolerance);

}  // namespace kata::metric
