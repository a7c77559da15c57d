// Training clips: a clip is named by a spec string, the BVH file (relative to a data folder)
// optionally played on another body:
//   "05_02.bvh"                      the file as captured
//   "05_02.bvh~07_01.bvh"            its rotation channels on 07_01.bvh's skeleton (same joint
//                                    names), root translation scaled by the leg-length ratio
//   "05_02.bvh~s1.100:0.900:1.200"   its own skeleton rescaled: arms, legs, torso factors; root
//                                    translation scaled with the legs
// Features come from kata::Stream (backward stencil by default), frames 1..F-1 streamed with
// t = i x frame time: frame 0 of a CMU file is the converter's T-pose and is never streamed.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "gpd/gpd.hpp"
#include "io/bvh.hpp"

namespace kata::train {

struct BodyScale {
  double arms = 1.0, legs = 1.0, torso = 1.0;
};

struct ClipSpec {
  std::string file;       // motion source
  std::string body_file;  // other skeleton (empty: own)
  bool scaled = false;
  BodyScale scale;
};
ClipSpec parse_clip_spec(const std::string& spec);
std::string format_clip_spec(const ClipSpec& spec);

// The motion of `motion` on another body: either `body`'s offsets (same joint names, in order)
// or `motion`'s own offsets scaled by `scale` (when body is null). `preset` names the GPD map
// (arms = below the shoulders, legs = below the hips, torso = the rest).
BvhClip make_body(const BvhClip& motion, const BvhClip* body, const BodyScale* scale, const std::string& preset);

// Local rotation of joint j at a frame from its rotation channels (BVH order).
Eigen::Matrix3d joint_rotation(const BvhClip& clip, int frame, int joint);

// Joints whose rotation moves a GPD joint (strict ancestors of mapped joints, root excluded).
std::vector<int> posing_joints(const Skeleton& skeleton, const std::string& preset);

struct ClipData {
  std::string spec;
  int frames = 0;            // file frames, including frame 0
  double frame_time = 0.0;
  std::vector<float> features;  // frames x kDims; row 0 is unused (zeros)
  const float* row(int f) const { return features.data() + static_cast<size_t>(f) * gpd::kDims; }
  bool valid(int f) const { return f >= 1 && f < frames; }
  // Mean joint distance (eq. 35) between two poses in the local frame, in body heights: over the
  // 16 GPD joints, hip at the origin (block 1 of the features).
  static double joint_distance(const float* fa, const float* fb);
};

class ClipStore {
 public:
  ClipStore(std::string data_dir, std::string preset = "cmu", gpd::Stencil stencil = gpd::Stencil::kBackward);
  // Computes (in parallel) the features of every spec not yet held.
  void load(const std::vector<std::string>& specs, int threads);
  // A held clip (load() first, or it is computed now).
  const ClipData& get(const std::string& spec);
  const BvhClip& bvh(const std::string& file);
  const std::string& preset() const { return preset_; }
  const std::string& data_dir() const { return dir_; }
  gpd::Stencil stencil() const { return stencil_; }

 private:
  std::unique_ptr<ClipData> compute(const std::string& spec);
  std::string dir_, preset_;
  gpd::Stencil stencil_;
  std::mutex mutex_;
  std::map<std::string, std::unique_ptr<BvhClip>> bvh_;
  std::map<std::string, std::unique_ptr<ClipData>> clips_;
};

// Streams a clip's frames 1..F-1 (kata::clip_features) and returns frames x kDims (row 0 zero).
std::vector<float> clip_feature_rows(const BvhClip& clip, const std::string& preset, gpd::Stencil stencil);

}  // namespace kata::train
