// libFuzzer target: the BVH parser and forward kinematics on arbitrary text. Malformed input
// must end in kata::Error (a status), never a crash, a sanitizer report or another exception.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>

#include "common/error.hpp"
#include "io/bvh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const kata::BvhClip clip = kata::parse_bvh(text, "fuzz.bvh");
    Eigen::MatrixX3d world(clip.skeleton.joint_count(), 3);
    kata::world_positions(clip, 0, world);
    kata::world_positions(clip, clip.frame_count() - 1, world);
  } catch (const kata::Error&) {
    // A refusal with a message: the expected outcome for most inputs.
  }
  return 0;
}
