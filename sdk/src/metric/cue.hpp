// The correction cue (docs/model/scores.md "The cue"): which joint to move, by how many degrees, and how, in a
// coach's words ("left knee: bend 30 deg more").
//
// The joint to move: pose_error.hpp measures each bone against the teacher's in the frame it is
// read in, and names the joint at the bone's END; the joint a student moves is the one the bone
// turns about. Per bone c (parent -> c), the cue joint (cue_joint(c)):
//   Hip->Chest: Hip (the lower back); Chest->Neck: Chest; Neck->Head: Neck;
//   Neck->LShoulder and LShoulder->LElbow: LShoulder (the shoulder's shrug and swing);
//   LElbow->LHand: LElbow; Hip->LHip and LHip->LKnee: LHip; LKnee->LFoot: LKnee; the right side alike.
// A cue joint is always in the part of its bones (parts.hpp), so the cue stays in the part to fix.
//
// The angle at the joint (BoneCue::degrees): a turned hip swings the whole leg, and the shin
// (LKnee->LFoot, read in the local frame) then points 30 degrees off as much as the thigh does,
// though the knee is right. So a bone whose parent bone is read in the same frame (the shin, the
// forearm, Chest->Neck above Hip->Chest) is measured at its joint: the student's parent bone is
// first turned onto the teacher's by the smallest rotation, and the angle is then between the two
// bones c. The other bones (the thighs and upper arms hang from the body frames, the head from
// the chest frame) are measured as pose_error does: the angle between the bones in their frame.
//
// The action (cue_action), from the signed change (BoneCue::change, degrees, student - teacher)
// in the body's frame (x left, y up, z forward; the chest frame's y along the spine):
//   - elbows and knees (the forearm's and shin's bone): the change of the inner angle at the joint
//     (180 - the angle between the parent bone and the bone). Student straighter (change > 0):
//     "bend"; more bent: "straighten".
//   - shoulders and hips (Neck->LShoulder, LShoulder->LElbow, Hip->LHip, LHip->LKnee...): the
//     change of the bone's elevation asin(y) in its frame. Student lower (change < 0): "raise";
//     higher: "lower".
//   - the lower back (Hip->Chest) and the chest (Chest->Neck, less the lower back's lean): the
//     change of the forward lean atan2(z, y). Student leaning forward more (change > 0):
//     "straighten"; leaning back more: "bend".
//   - the neck (Neck->Head in the chest frame): the head's forward lean; student's head forward
//     or down more (change > 0): "raise" (the head); back or up more: "lower".
// When that signed change is under half the angle at the joint, most of the error is sideways or
// a twist: "turn".
//
// Allocation-free; never NaN for finite input.
#pragma once

#include <cstddef>
#include <cstdint>

#include "gpd/gpd.hpp"

namespace kata::metric {

// The cue's actions; the values are kata_cue_action's (kata/result.h).
enum class CueAction : int32_t { kNone = -1, kBend = 0, kStraighten = 1, kRaise = 2, kLower = 3, kTurn = 4 };

// One student pose against one teacher pose, per bone c (1..15; [0] unused, 0), both poses in
// the body's frames (pose_error.hpp pose_frames).
struct BoneCue {
  float degrees[gpd::kJoints];  // the angle at the cue joint, 0..180 (0 for a degenerate bone)
  float change[gpd::kJoints];   // the signed change the action is read from, degrees (see above)
};
void bone_cue(const float* student_pose, const float* teacher_pose, BoneCue& out);

// The GPD joint (0..15) a student moves to correct bone c (1..15).
int cue_joint(int bone);
// The action for a bone c's angle at its joint and signed change, both degrees.
CueAction cue_action(int bone, double degrees, double change);
// Lower-case English words of a cue joint ("left knee", "lower back"); "" for a joint that is
// never a cue joint (Head, the hands and feet) or out of range.
const char* cue_joint_words(int joint);
// The action's word ("bend", ...); "" for kNone or out of range.
const char* cue_action_word(int action);
// The cue's phrase: "left knee: bend 30 deg more" (bend), "right shoulder: raise 25 deg" (the
// others), degrees rounded to whole ones; "" when joint or action is none. Writes at most n bytes
// with the terminating 0 (truncated to fit) and returns the length of the whole phrase, as
// snprintf does. Allocation-free.
int cue_text(int joint, float degrees, int action, char* buf, size_t n);

}  // namespace kata::metric
