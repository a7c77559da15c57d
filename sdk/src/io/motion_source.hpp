// A recorded motion from any supported source, for the CLI: a BVH clip, or a landmark array as a
// NumPy .npy of shape (frames, joints, 3), (frames, joints, 4) (x, y, z, confidence) or
// (frames, joints, 5) (MediaPipe's x, y, z, visibility, presence: the confidence is the smaller of
// visibility and presence, so a joint counts only when it is both in the picture and unoccluded),
// or a CSV with one row per frame of joints x 3, 4 or 5 numbers, optionally after a leading
// timestamp column (a first line that is not numeric is a header). Landmark arrays name their
// layout (skeleton.hpp: "mediapipe", "gpd", "azure-kinect", "xsens") and their timing: a frame
// rate, or timestamps (the CSV's first column, or for `X.npy` a 1-D `X.times.npy` beside it) in
// seconds or milliseconds (stated, or inferred from the steps; see common/time_units.hpp).
// Their joints are in the layout's order.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/time_units.hpp"
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
  // Capture time of each frame, seconds from the first frame; empty: frame i at i x frame_time.
  // (With timestamps, frame_time is their median step.)
  std::vector<double> times;

  double time_of(int frame) const { return times.empty() ? frame * frame_time : times[static_cast<size_t>(frame)]; }
};

// Loads `path` (.bvh, .npy or .csv by extension). layout: the layout name ("" = "cmu" for a BVH;
// required for arrays); fps: frame rate of an array without timestamps (required then, > 0; a BVH
// has its own; ignored when the array has timestamps); up: the axes of a layout that does not fix
// them; units: of the array's timestamps (kAuto: inferred, refused naming the file when the steps
// fit neither unit). `first` skips frames at the start. Errors name the file (and line for CSV).
MotionSource load_motion(const std::string& path, const std::string& layout, double fps, UpAxis up, int first = 0,
                         TimeUnits units = TimeUnits::kAuto);

// A MediaPipe recording (the "mediapipe" layout: metres, y down) that shows a person: the median
// distance from the nose to the ankles' midpoint at most kMaxPersonMetres (pixels are hundreds),
// and the nose above the ankles (not below by more than half that distance). Else kata::Error(kInvalidArgument)
// naming the file, the figure and the likely cause (pixel coordinates; y-up landmarks: "the body is
// upside down"). load_motion applies it to every "mediapipe" array; frames without the nose and
// both ankles (non-finite, confidence below 0.5) are not counted, none: nothing is checked.
constexpr double kMaxPersonMetres = 3.0;
void check_person_in_metres(const MotionSource& m);

// The sidecar timestamps of a landmark .npy: "X.npy" -> "X.times.npy".
std::string times_path_of(const std::string& npy_path);

// Bounds of landmark arrays (a larger input is refused, naming the file).
constexpr uint64_t kMaxLandmarkCsvBytes = uint64_t{1} << 30;  // 1 GiB of CSV text
constexpr int kMaxLandmarkFrames = 1 << 24;                    // 39 h at 120 Hz

enum class LandmarkFormat { kNpy, kCsv, kUnknown };
// A landmark array from its bytes in memory (the parser of load_motion; `name` stands for the
// file in messages). Throws kata::Error: kParse for malformed bytes (CSV: with the line),
// kNotFound for an unknown layout, kInvalidArgument for fps <= 0 (without timestamps) or for
// timestamps whose units are ambiguous.
MotionSource parse_landmarks(const std::string& bytes, LandmarkFormat format, const std::string& name,
                             const std::string& layout, double fps, UpAxis up, TimeUnits units = TimeUnits::kAuto);
// The same from a parsed .npy's values and shape.
MotionSource landmarks_from_values(const std::vector<double>& values, const std::vector<size_t>& shape,
                                   const std::string& name, const std::string& layout, double fps, UpAxis up);
// Gives an array its timestamps (`count` = frames, raw values in `units`, kAuto: inferred), as
// seconds from the first one; frame_time becomes their median step. Throws kata::Error naming
// m.path for a wrong count, a timestamp that does not increase or ambiguous units.
void set_timestamps(MotionSource& m, const double* raw, size_t count, TimeUnits units);

// GPD features of every frame through a live Stream with the source's confidences (the layout's
// smoothing default applies): one row per emitted vector (frames x gpd::kDims), and the frame index
// of each row. A NaN coordinate marks its joint missing (as pose estimators emit a lost joint),
// held by the stream's confidence gate; frames reported "tracking lost" have no row, *lost
// counts them. Other refused frames throw kata::Error(kInvalidArgument) naming file and frame.
std::vector<float> motion_features(const MotionSource& motion, gpd::Stencil stencil, std::vector<int>* frame_of_row,
                                   int* lost);

}  // namespace kata
