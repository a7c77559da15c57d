#include "coach/landmark_teacher.hpp"

#include "common/time_units.hpp"
#include "io/motion_source.hpp"

namespace kata::coach {

LandmarkTeacher load_landmark_teacher(const std::string& path, const std::string& layout, const std::string& time_units) {
  const MotionSource m = load_motion(path, layout, 0.0, UpAxis::kY, 0, parse_time_units(time_units));
  LandmarkTeacher t;
  t.xyz = m.xyz;
  t.frames = m.frames;
  t.joints = m.skeleton.joint_count();
  t.frame_time = m.frame_time;
  return t;
}

}  // namespace kata::coach
