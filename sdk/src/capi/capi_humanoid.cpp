// C ABI shim of kata/humanoid.h: the humanoid (VRM) rig.
#include <cstring>

#include "capi/capi_internal.hpp"
#include "common/text.hpp"
#include "humanoid/bones.hpp"

namespace h = kata::humanoid;

static_assert(KATA_BONE_COUNT == h::kBoneCount, "kata_humanoid_bone and humanoid/bones.hpp disagree");
static_assert(static_cast<int>(KATA_BONE_RIGHT_TOES) == static_cast<int>(h::kRightToes), "kata_humanoid_bone and humanoid/bones.hpp disagree");

extern "C" {

KATA_API const char* kata_humanoid_bone_name(int bone) {
  if (bone < 0 || bone >= h::kBoneCount) return nullptr;
  return h::kBoneNames[static_cast<size_t>(bone)];
}

KATA_API int kata_humanoid_bone_find(const char* name) {
  if (!name || ::strnlen(name, kata::kMaxCStringBytes) == kata::kMaxCStringBytes) return -1;  // kata.h: bounded strings
  return h::find_bone(name);
}

KATA_API int kata_humanoid_bone_parent(int bone) {
  if (bone < 0 || bone >= h::kBoneCount) return -2;
  return h::kBoneParents[static_cast<size_t>(bone)];
}

}  // extern "C"
