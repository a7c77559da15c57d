#include "people/scene.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include "kata/kata.h"

namespace kata::test::people {
namespace {

constexpr double kMetresPerUnit = 0.056444;  // CMU BVH units (1/0.45 inch) to metres

struct V3 {
  double x = 0, y = 0, z = 0;
};
V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3 operator*(double s, V3 a) { return {s * a.x, s * a.y, s * a.z}; }

// MediaPipe's landmarks on a CMU skeleton's joints (face and hand points offset by fixed vectors,
// as tests/api/test_anybody.cpp places them).
std::array<V3, kLandmarks> landmarks(const std::map<std::string, V3>& j) {
  std::array<V3, kLandmarks> l;
  const V3 head = j.at("Head");
  const V3 face[11] = {{0, 0.02, 0.10},  {0.02, 0.05, 0.09}, {0.03, 0.05, 0.09}, {0.04, 0.05, 0.08},
                       {-0.02, 0.05, 0.09}, {-0.03, 0.05, 0.09}, {-0.04, 0.05, 0.08}, {0.07, 0, 0},
                       {-0.07, 0, 0},   {0.02, -0.02, 0.09}, {-0.02, -0.02, 0.09}};
  for (int i = 0; i < 11; ++i) l[static_cast<size_t>(i)] = head + face[i];
  l[11] = j.at("LeftArm");
  l[12] = j.at("RightArm");
  l[13] = j.at("LeftForeArm");
  l[14] = j.at("RightForeArm");
  l[15] = j.at("LeftHand");
  l[16] = j.at("RightHand");
  l[17] = l[15] + V3{0.06, -0.02, -0.02};
  l[18] = l[16] + V3{-0.06, -0.02, -0.02};
  l[19] = l[15] + V3{0.08, 0, 0};
  l[20] = l[16] + V3{-0.08, 0, 0};
  l[21] = l[15] + V3{0.03, 0, 0.03};
  l[22] = l[16] + V3{-0.03, 0, 0.03};
  l[23] = j.at("LeftUpLeg");
  l[24] = j.at("RightUpLeg");
  l[25] = j.at("LeftLeg");
  l[26] = j.at("RightLeg");
  l[27] = j.at("LeftFoot");
  l[28] = j.at("RightFoot");
  l[29] = l[27] + V3{0, -0.05, -0.05};
  l[30] = l[28] + V3{0, -0.05, -0.05};
  l[31] = j.at("LeftToeBase");
  l[32] = j.at("RightToeBase");
  return l;
}

}  // namespace

Motion::Motion(const std::string& name, double rate) : rate_(rate) {
  kata_context ctx = nullptr;
  kata_clip clip = nullptr;
  kata_skeleton skel = nullptr;
  const std::string path = std::string(KATA_DATA_DIR) + "/cmu/" + name + ".bvh";
  if (kata_context_create(&ctx) != KATA_OK || kata_clip_load_bvh(ctx, path.c_str(), &clip) != KATA_OK ||
      kata_clip_skeleton(clip, &skel) != KATA_OK)
    throw std::runtime_error("cannot load " + path);
  const uint32_t n = kata_skeleton_joint_count(skel), frames = kata_clip_frame_count(clip);
  const double dt = kata_clip_frame_time(clip);
  std::vector<float> p(3 * n);
  std::vector<std::array<V3, kLandmarks>> raw;
  std::vector<V3> hips;
  for (double t = 0.0;; t += 1.0 / rate) {
    const uint32_t f = 1 + static_cast<uint32_t>(std::lround(t / dt));  // frame 0 is the converter's T-pose
    if (f >= frames) break;
    kata_clip_positions(clip, f, p.data(), p.size());
    std::map<std::string, V3> joints;
    for (uint32_t j = 0; j < n; ++j)
      joints[kata_skeleton_joint_name(skel, j)] = {kMetresPerUnit * p[3 * j], kMetresPerUnit * p[3 * j + 1],
                                                    kMetresPerUnit * p[3 * j + 2]};
    raw.push_back(landmarks(joints));
    hips.push_back(0.5 * (raw.back()[23] + raw.back()[24]));
  }
  kata_skeleton_destroy(skel);
  kata_clip_destroy(clip);
  kata_context_destroy(ctx);
  // The clip's overall direction of travel -> +x.
  const V3 travel = hips.back() - hips.front();
  const double angle = std::atan2(travel.z, travel.x);
  const double c = std::cos(angle), s = std::sin(angle);
  for (size_t f = 0; f < raw.size(); ++f) {
    Landmarks out;
    for (int i = 0; i < kLandmarks; ++i) {
      const V3 q = raw[f][static_cast<size_t>(i)] - V3{hips[f].x, 0.0, hips[f].z};
      // Rotate about +y by -angle: the travel direction (cos a, sin a) in (x, z) onto +x.
      out[static_cast<size_t>(3 * i)] = static_cast<float>(c * q.x + s * q.z);
      out[static_cast<size_t>(3 * i + 1)] = static_cast<float>(q.y);
      out[static_cast<size_t>(3 * i + 2)] = static_cast<float>(-s * q.x + c * q.z);
    }
    frames_.push_back(out);
  }
}

Landmarks Motion::at(double t, double x, double z, int facing) const {
  const size_t n = frames_.size(), period = 2 * n - 2;
  size_t f = static_cast<size_t>(std::lround(t * rate_)) % period;
  if (f >= n) f = period - f;  // played backward
  Landmarks out = frames_[f];
  for (int i = 0; i < kLandmarks; ++i) {
    float& px = out[static_cast<size_t>(3 * i)];
    float& pz = out[static_cast<size_t>(3 * i + 2)];
    if (facing < 0) px = -px, pz = -pz;  // turned half round about +y
    px += static_cast<float>(x);
    pz += static_cast<float>(z);
  }
  return out;
}

std::vector<DetectedFrame> detect(const std::vector<Actor>& actors, const SceneOptions& o) {
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> jitter(0.0, o.noise);
  std::vector<DetectedFrame> frames;
  const int count = static_cast<int>(std::lround(o.seconds * o.rate));
  for (int k = 0; k < count; ++k) {
    DetectedFrame frame;
    frame.time = 100.0 + k / o.rate;
    const double t = k / o.rate;
    const size_t a_count = actors.size();
    std::vector<double> xs(a_count), zs(a_count);
    std::vector<int> facing(a_count), in(a_count);
    for (size_t a = 0; a < a_count; ++a) in[a] = actors[a].place(t, &xs[a], &zs[a], &facing[a]) ? 1 : 0;
    std::vector<int> shown;
    for (size_t a = 0; a < a_count; ++a) {
      if (!in[a]) continue;
      bool behind = false;
      for (size_t b = 0; b < a_count; ++b)
        if (b != a && in[b] && zs[b] < zs[a] && std::fabs(xs[b] - xs[a]) < o.occlusion_width) behind = true;
      if (behind) {
        frame.hidden.push_back(static_cast<int>(a));
        continue;
      }
      if (unit(rng) < o.drop) continue;
      shown.push_back(static_cast<int>(a));
    }
    std::shuffle(shown.begin(), shown.end(), rng);
    for (int a : shown) {
      const Landmarks l = actors[static_cast<size_t>(a)].motion->at(t, xs[static_cast<size_t>(a)],
                                                                    zs[static_cast<size_t>(a)], facing[static_cast<size_t>(a)]);
      for (int i = 0; i < 3 * kLandmarks; ++i) {
        const bool depth = i % 3 == 2;
        frame.xyz.push_back(o.flat && depth ? 0.0f : static_cast<float>(l[static_cast<size_t>(i)] + jitter(rng)));
      }
      for (int i = 0; i < kLandmarks; ++i) frame.confidence.push_back(static_cast<float>(0.6 + 0.4 * unit(rng)));
      frame.actor.push_back(a);
    }
    frames.push_back(std::move(frame));
  }
  return frames;
}

}  // namespace kata::test::people
