// libFuzzer target: landmark arrays (the .npy and .csv readers of kata features/score/retarget
// --layout) through parse_landmarks, then every frame through a live stream (motion_features).
// The first byte picks the format (bit 0: .npy / .csv) and the layout (bit 1: "gpd" / "mediapipe");
// the rest is the file. Parsing may only fail with kata::Error(kParse); a parsed array's frames
// may be refused (kInvalidArgument, naming the frame) but every feature they give is finite.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "io/motion_source.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const kata::LandmarkFormat format = (data[0] & 1) ? kata::LandmarkFormat::kCsv : kata::LandmarkFormat::kNpy;
  const char* layout = (data[0] & 2) ? "mediapipe" : "gpd";
  const std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  kata::MotionSource motion;
  try {
    motion = kata::parse_landmarks(bytes, format, "fuzz", layout, 30.0, kata::UpAxis::kY);
  } catch (const kata::Error& e) {
    if (e.kind() != kata::ErrorKind::kParse) std::abort();
    return 0;
  }
  const size_t joints = static_cast<size_t>(motion.skeleton.joint_count());
  if (motion.xyz.size() != static_cast<size_t>(motion.frames) * joints * 3) std::abort();
  if (!motion.confidence.empty() && motion.confidence.size() != static_cast<size_t>(motion.frames) * joints) std::abort();
  try {
    std::vector<int> rows;
    int lost = 0;
    const std::vector<float> features = kata::motion_features(motion, kata::gpd::Stencil::kBackward, &rows, &lost);
    for (float v : features)
      if (!std::isfinite(v)) std::abort();
    if (rows.size() * static_cast<size_t>(kata::gpd::kDims) != features.size()) std::abort();
  } catch (const kata::Error& e) {
    if (e.kind() != kata::ErrorKind::kInvalidArgument) std::abort();
  }
  return 0;
}
