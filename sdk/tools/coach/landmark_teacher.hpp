// A landmark recording read as a teacher for `kata coach --webcam --teacher X.npy`: the one piece
// of the coach still on the SDK's private core (io/motion_source: .npy with its .times.npy, or
// .csv, timestamps in s / ms / inferred), because libkata has no public call that reads a landmark
// array file yet. The declarations are std-only so the coach's ABI-only sources can call it; the
// definition builds with the CLI (landmark_teacher.cpp).
#pragma once

#include <string>
#include <vector>

namespace kata::coach {

struct LandmarkTeacher {
  std::vector<float> xyz;   // frames x joints x 3, the layout's joint order and axes
  int frames = 0;
  int joints = 0;
  double frame_time = 0.0;  // seconds (the median step of its timestamps)
};

// Reads `path` as landmarks of `layout` ("mediapipe", "gpd", ...; their axes as recorded, +Y up
// unless the layout fixes them), timestamps in `time_units` ("s", "ms", "auto"). Throws naming
// the file.
LandmarkTeacher load_landmark_teacher(const std::string& path, const std::string& layout, const std::string& time_units);

}  // namespace kata::coach
