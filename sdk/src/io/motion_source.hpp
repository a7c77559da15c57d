// A recorded motion from any supported source, for the CLI: a BVH clip, or a landmark array as a
// NumPy .npy of shape (frames, joints, 3) or (frames, joints, 4) (x, y, z, confidence), or a CSV
// with one row per frame of joints x 3 (or x 4) numbers (a first line that is not numeric is a
// header). Landmark arrays name their layout (skeleton.hpp: "mediapipe", "gpd", "azure-kinect",
// "xsens") and their frame rate; their joints are in the layout's order.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "gpd/gpd.hpp"
#include "skeleton/skeleton.hpp"

namespace kata {

struct MotionSource {
  std::string path;
  Skeleton skeleton;               // the BVH hierarchy, or the layout's joint list
  Layout layout;                   // map onto the 16 GPD joints and the frames' axes
  int frames = 0;
  double frame_time = 0.0;         // seconds
  std::vector<float> xyz;          // frames x joints x 3
  std::vector<float> confidence;   // frames x joints, empty when the source has none
};

// Loads `path` (.bvh, .npy or .csv by extension). layout: the layout name ("" = "cmu" for a BVH;
// required for arrays); fps: frame rate of an array (required, > 0; a BVH has its own); up: the
// axes of a layout that does not fix them. `first` skips frames at the start. Errors name the
// file (and line for CSV).
MotionSource load_motion(const std::string& path, const std::string& layout, double fps, UpAxis up, int first = 0);

// Bounds of landmark arrays (a larger input is refused, naming the file).
constexpr uint64_t kMaxLandmarkCsvBytes = uint64_t{1} << 30;  // 1 GiB of CSV text
constexpr int kMaxLandmarkFrames = 1 << 24;                    // 39 h at 120 Hz

enum class LandmarkFormat { kNpy, kCsv, kUnknown };
// A landmark array from its bytes in memory (the parser of load_motion; `name` stands for the
// file in messages). Throws kata::Error: kParse for malformed bytes (CSV: with the line),
// kNotFound for an unknown layout, kInvalidArgument for fps <= 0.
MotionSource parse_landmarks(const std::string& bytes, LandmarkFormat format, const std::string& name,
                             const std::string& layout, double fps, UpAxis up);
// The same from a parsed .npy's values and shape.
MotionSource landmarks_from_values(const std::vector<double>& values, const std::vector<size_t>& shape,
                                   const std::string& name, const std::string& layout, double fps, UpAxis up);

// GPD features of every frame through a live Stream with the source's confidences (the layout's
// smoothing default applies): one row per emitted vector (frames x gpd::kDims), and the frame index
// of each row. A NaN coordinate marks its joint missing (as pose estimators emit a lost joint),
// held by the stream's confidence gate; frames reported "tracking lost" have no row, *lost
// counts them. Other refused frames throw kata::Error(kInvalidArgument) naming file and frame.
std::vector<float> motion_features(const MotionSource& motion, gpd::Stencil stencil, std::vector<int>* frame_of_row,
                                   int* lost);

}  // namespace kata
