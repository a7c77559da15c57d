// The VRM humanoid bone table (bones.hpp).
#include "humanoid/bones.hpp"

#include <cstring>

namespace kata::humanoid {

// Unity's HumanBodyBones names, which the VMC protocol sends (protocol.vmc.info, "Bone/Pos").
const std::array<const char*, kBoneCount> kBoneNames = {
    "Hips",          "Spine",         "Chest",        "UpperChest",   "Neck",          "Head",
    "LeftShoulder",  "LeftUpperArm",  "LeftLowerArm", "LeftHand",     "RightShoulder", "RightUpperArm",
    "RightLowerArm", "RightHand",     "LeftUpperLeg", "LeftLowerLeg", "LeftFoot",      "LeftToes",
    "RightUpperLeg", "RightLowerLeg", "RightFoot",    "RightToes"};

// VRM 1.0's humanoid tree: the shoulders and the neck hang from the upper chest.
const std::array<int, kBoneCount> kBoneParents = {
    -1, kHips, kSpine, kChest, kUpperChest, kNeck,
    kUpperChest, kLeftShoulder, kLeftUpperArm, kLeftLowerArm,
    kUpperChest, kRightShoulder, kRightUpperArm, kRightLowerArm,
    kHips, kLeftUpperLeg, kLeftLowerLeg, kLeftFoot,
    kHips, kRightUpperLeg, kRightLowerLeg, kRightFoot};

int find_bone(const char* name) noexcept {
  if (!name) return -1;
  for (int b = 0; b < kBoneCount; ++b)
    if (std::strcmp(name, kBoneNames[static_cast<size_t>(b)]) == 0) return b;
  return -1;
}

}  // namespace kata::humanoid
