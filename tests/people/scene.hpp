// A class in front of one camera, made from real CMU clips: each person's motion as MediaPipe's
// 33 landmarks (metres, Y up), walked along a scripted path, the way a multi-person detector
// reports it: the poses of a frame unlabeled, in a shuffled order, a share of them dropped, and
// a person hidden while another stands in front of them. Through the public C ABI only.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

namespace kata::test::people {

constexpr int kLandmarks = 33;
using Landmarks = std::array<float, 3 * kLandmarks>;

// A clip's poses as MediaPipe landmarks, resampled to `rate` Hz, hips over the origin (x, z),
// turned so that the clip's overall walking direction is +x, played forward then backward (so a
// long scene has no jump at the clip's end).
class Motion {
 public:
  Motion(const std::string& clip, double rate);
  // The pose at `t` seconds, facing +x (facing = +1) or -x (-1), hips at (x, z).
  Landmarks at(double t, double x, double z, int facing) const;

 private:
  std::vector<Landmarks> frames_;  // hip-centred on the floor plane
  double rate_;
};

// A person of the scene: its motion and where it is at time t (x, z metres, the direction it
// faces), or not in the picture (the function returns false).
struct Actor {
  std::string name;
  const Motion* motion = nullptr;
  std::function<bool(double t, double* x, double* z, int* facing)> place;
};

// One frame as the detector gives it.
struct DetectedFrame {
  double time = 0.0;
  std::vector<float> xyz;         // poses x 33 x 3
  std::vector<float> confidence;  // poses x 33
  std::vector<int> actor;         // per pose: which actor it is (the truth, hidden from the tracker)
  std::vector<int> hidden;        // actors in the picture but hidden behind another this frame
};

struct SceneOptions {
  double rate = 30.0;          // detector frames per second
  double seconds = 14.0;
  double drop = 0.05;          // share of poses the detector misses
  double noise = 0.01;         // metres of jitter per landmark
  double occlusion_width = 0.6;  // metres: a person further back is hidden when this close in x
  bool flat = false;           // 2D: every z set to 0 (an image's keypoints)
  uint32_t seed = 1;
};

// Every frame of the scene. A person is hidden while another, nearer the camera (smaller z), is
// within occlusion_width in x; the frame's order is shuffled.
std::vector<DetectedFrame> detect(const std::vector<Actor>& actors, const SceneOptions& options);

}  // namespace kata::test::people
