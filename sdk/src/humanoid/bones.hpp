// The VRM humanoid bones (kata/humanoid.h): names as Unity's HumanBodyBones spells them, and the
// fixed tree they hang in.
#pragma once

#include <array>

namespace kata::humanoid {

constexpr int kBoneCount = 22;  // KATA_BONE_COUNT

enum Bone : int {
  kHips = 0, kSpine, kChest, kUpperChest, kNeck, kHead,
  kLeftShoulder, kLeftUpperArm, kLeftLowerArm, kLeftHand,
  kRightShoulder, kRightUpperArm, kRightLowerArm, kRightHand,
  kLeftUpperLeg, kLeftLowerLeg, kLeftFoot, kLeftToes,
  kRightUpperLeg, kRightLowerLeg, kRightFoot, kRightToes
};

// "Hips", "Spine", ... (index = Bone).
extern const std::array<const char*, kBoneCount> kBoneNames;
// Each bone's parent (-1 for the hips); parents precede their children.
extern const std::array<int, kBoneCount> kBoneParents;

// The bone named `name` exactly, or -1.
int find_bone(const char* name) noexcept;

}  // namespace kata::humanoid
