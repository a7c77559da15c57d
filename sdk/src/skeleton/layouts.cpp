// Built-in joint layouts beyond pure name maps: MediaPipe Pose world landmarks (synthesised
// pelvis, chest, neck, head), the skeletons of sources that stream bare landmark arrays, and the
// GPD mapping of a frame (skeleton.hpp documents each).
#include <cmath>
#include <cstddef>


#include "common/error.hpp"
#include "common/text.hpp"
#include "skeleton/skeleton.hpp"

namespace kata {

// MediaPipe Pose landmark ids 0..32, as listed in the Pose Landmarker model card / guide
// (https://ai.google.dev/edge/mediapipe/solutions/vision/pose_landmarker, "Pose landmarker
// model"): world landmarks are in metres with the origin at the centre of the hips (MediaPipe
// v0.8.6 release notes), z smaller = closer to the camera (tasks-vision Landmark reference).
const std::array<const char*, kMediaPipeLandmarkCount> kMediaPipeLandmarks = {
    "nose",           "left_eye_inner", "left_eye",        "left_eye_outer",   "right_eye_inner",
    "right_eye",      "right_eye_outer", "left_ear",       "right_ear",        "mouth_left",
    "mouth_right",    "left_shoulder",  "right_shoulder",  "left_elbow",       "right_elbow",
    "left_wrist",     "right_wrist",    "left_pinky",      "right_pinky",      "left_index",
    "right_index",    "left_thumb",     "right_thumb",     "left_hip",         "right_hip",
    "left_knee",      "right_knee",     "left_ankle",      "right_ankle",      "left_heel",
    "right_heel",     "left_foot_index", "right_foot_index"};

namespace {

// A parent for each landmark that precedes it (Skeleton needs topological order; MediaPipe's
// order starts at the nose, so the tree hangs from it). Only the order matters: retargeting and
// bone lengths use the GPD tree.
constexpr int kMediaPipeParents[kMediaPipeLandmarkCount] = {
    -1, 0, 1, 2, 0, 4, 5, 3, 6, 0, 0,  // face
    0,  0, 11, 12, 13, 14, 15, 16, 15, 16, 15, 16,  // shoulders, elbows, wrists, hand points
    11, 12, 23, 24, 25, 26, 27, 28, 27, 28};        // hips, knees, ankles, heels, foot index

// Synthesis fractions (skeleton.hpp): measured on the CMU rest skeleton (data/cmu/02_01.bvh):
// Hips sits 0.264, Spine1 0.868 of the way from the hip-joint midpoint to the shoulder midpoint.
constexpr float kHipFraction = 0.264f, kChestFraction = 0.868f;
// The pelvis sits behind the hip joints: GpdBlend::offset of Hip, the least-squares fit of CMU's
// Hips against the in-plane synthesis (-0.075, -0.068, -0.037, -0.077 on clips 02_01, 07_01,
// 05_02, 09_01). Neck1's fitted offset changes sign from clip to clip: none is applied.
constexpr float kHipOffset = -0.07f;

GpdBlend blend4(int a, int b, int c, int d, float wab, float wcd) {
  GpdBlend x;
  x.count = 4;
  x.joint = {a, b, c, d};
  x.weight = {0.5f * wab, 0.5f * wab, 0.5f * wcd, 0.5f * wcd};
  return x;
}

GpdMap mediapipe_map(const Skeleton& skeleton) {
  std::array<int, kMediaPipeLandmarkCount> at{};
  std::string missing;
  for (int i = 0; i < kMediaPipeLandmarkCount; ++i) {
    at[static_cast<size_t>(i)] = skeleton.find(kMediaPipeLandmarks[static_cast<size_t>(i)]);
    if (at[static_cast<size_t>(i)] < 0)
      missing += std::string(missing.empty() ? "" : ", ") + "'" + kMediaPipeLandmarks[static_cast<size_t>(i)] + "'";
  }
  if (!missing.empty())
    throw Error(ErrorKind::kNotFound, "layout mediapipe: skeleton has no landmark " + missing +
                                          " (kata_skeleton_create_layout makes the 33-landmark skeleton)");
  auto j = [&](int landmark) { return at[static_cast<size_t>(landmark)]; };
  GpdMap map;
  // GPD order: Hip Chest Neck Head LShoulder LElbow LHand RShoulder RElbow RHand LHip LKnee LFoot
  // RHip RKnee RFoot.
  const int direct[kGpdJoints] = {-1, -1, -1, -1, 11, 13, 15, 12, 14, 16, 23, 25, 27, 24, 26, 28};
  for (int g = 0; g < kGpdJoints; ++g) map.source[static_cast<size_t>(g)] = direct[g] < 0 ? -1 : j(direct[g]);
  map.blend[0] = blend4(j(23), j(24), j(11), j(12), 1.0f - kHipFraction, kHipFraction);
  map.blend[1] = blend4(j(23), j(24), j(11), j(12), 1.0f - kChestFraction, kChestFraction);
  // Neck halfway from the chest to the head: CMU's Neck1 sits at 0.42..0.56 of Spine1 -> Head
  // over clips 02_01, 02_02, 05_02, 05_03, 07_01, 09_01 (least squares), steadier than any point
  // on the shoulders -> ears line (0.14..0.42).
  {
    GpdBlend neck;
    neck.count = 6;
    const float hw = 0.5f * (1.0f - kChestFraction), sw = 0.5f * kChestFraction;
    neck.joint = {j(23), j(24), j(11), j(12), j(7), j(8)};
    neck.weight = {0.5f * hw, 0.5f * hw, 0.5f * sw, 0.5f * sw, 0.25f, 0.25f};
    map.blend[2] = neck;
  }
  map.blend[0].offset = kHipOffset;
  map.blend[0].offset_joint = {j(23), j(24), j(11), j(12)};
  GpdBlend head;
  head.count = 2;
  head.joint = {j(7), j(8), 0, 0};
  head.weight = {0.5f, 0.5f, 0.0f, 0.0f};
  map.blend[3] = head;
  map.floor_count = 6;
  map.floor_joints = {j(27), j(28), j(29), j(30), j(31), j(32)};
  return map;
}

// Azure Kinect's 32 joints in k4abt_joint_id_t order with the parents of Microsoft's joint
// hierarchy table (https://learn.microsoft.com/azure/kinect-dk/body-joints).
const char* const kAzureKinectJoints[32] = {
    "PELVIS",        "SPINE_NAVEL",    "SPINE_CHEST",  "NECK",          "CLAVICLE_LEFT", "SHOULDER_LEFT",
    "ELBOW_LEFT",    "WRIST_LEFT",     "HAND_LEFT",    "HANDTIP_LEFT",  "THUMB_LEFT",    "CLAVICLE_RIGHT",
    "SHOULDER_RIGHT", "ELBOW_RIGHT",   "WRIST_RIGHT",  "HAND_RIGHT",    "HANDTIP_RIGHT", "THUMB_RIGHT",
    "HIP_LEFT",      "KNEE_LEFT",      "ANKLE_LEFT",   "FOOT_LEFT",     "HIP_RIGHT",     "KNEE_RIGHT",
    "ANKLE_RIGHT",   "FOOT_RIGHT",     "HEAD",         "NOSE",          "EYE_LEFT",      "EAR_LEFT",
    "EYE_RIGHT",     "EAR_RIGHT"};
constexpr int kAzureKinectParents[32] = {-1, 0, 1, 2, 2, 4, 5, 6, 7, 8, 7, 2, 11, 12, 13, 14,
                                         15, 14, 0, 18, 19, 20, 0, 22, 23, 24, 3, 26, 26, 26, 26, 26};
// Xsens MVN's 23 segments in MVN's segment order (MVN User Manual MV0319P; segment 9 is the right
// upper arm, 13 the left) with MVN's segment tree.
const char* const kXsensSegments[23] = {
    "Pelvis",       "L5",           "L3",           "T12",         "T8",           "Neck",
    "Head",         "RightShoulder", "RightUpperArm", "RightForeArm", "RightHand",   "LeftShoulder",
    "LeftUpperArm", "LeftForeArm",  "LeftHand",     "RightUpperLeg", "RightLowerLeg", "RightFoot",
    "RightToe",     "LeftUpperLeg", "LeftLowerLeg", "LeftFoot",    "LeftToe"};
constexpr int kXsensParents[23] = {-1, 0, 1, 2, 3, 4, 5, 4, 7, 8, 9, 4, 11, 12, 13, 0, 15, 16, 17, 0, 19, 20, 21};
// The CMU Motion Capture Database's 31 joints in its BVH files' order (data/cmu), so an array
// exported from one (frames, 31, 3) reads with the "cmu" preset as the BVH does.
const char* const kCmuJoints[31] = {
    "Hips",          "LHipJoint",      "LeftUpLeg",    "LeftLeg",       "LeftFoot",       "LeftToeBase",
    "RHipJoint",     "RightUpLeg",     "RightLeg",     "RightFoot",     "RightToeBase",   "LowerBack",
    "Spine",         "Spine1",         "Neck",         "Neck1",         "Head",           "LeftShoulder",
    "LeftArm",       "LeftForeArm",    "LeftHand",     "LeftFingerBase", "LeftHandIndex1", "LThumb",
    "RightShoulder", "RightArm",       "RightForeArm", "RightHand",     "RightFingerBase", "RightHandIndex1",
    "RThumb"};
constexpr int kCmuParents[31] = {-1, 0, 1, 2, 3, 4, 0, 6, 7, 8, 9, 0, 11, 12, 13, 14,
                                 15, 13, 17, 18, 19, 20, 21, 20, 13, 24, 25, 26, 27, 28, 27};

}  // namespace

// VRM humanoid bones (VRM 1.0 humanoid.humanBones; VMC sends Unity's HumanBodyBones names).
const std::array<const char*, kVrmJointCount> kVrmJoints = {
    "Hips",          "Spine",         "Chest",         "UpperChest",    "Neck",          "Head",
    "LeftShoulder",  "LeftUpperArm",  "LeftLowerArm",  "LeftHand",      "RightShoulder", "RightUpperArm",
    "RightLowerArm", "RightHand",     "LeftUpperLeg",  "LeftLowerLeg",  "LeftFoot",      "LeftToes",
    "RightUpperLeg", "RightLowerLeg", "RightFoot",     "RightToes"};
const std::array<int, kVrmJointCount> kVrmParents = {-1, 0, 1, 2, 3, 4, 3, 6, 7, 8, 3, 10, 11, 12, 0, 14, 15, 16, 0, 18, 19, 20};
// Proportions of a typical 1.65 m VRM avatar (hips 0.95 m above the floor, arms 0.62 m from the
// shoulder joint to the wrist, legs 0.88 m from the hip joint to the ankle).
const std::array<std::array<float, 3>, kVrmJointCount> kVrmRestOffsets = {{
    {0.0f, 0.95f, 0.0f},  {0.0f, 0.07f, 0.0f},   {0.0f, 0.12f, 0.0f},  {0.0f, 0.12f, 0.0f},   // hips .. upper chest
    {0.0f, 0.13f, 0.0f},  {0.0f, 0.10f, 0.0f},                                                // neck, head
    {-0.03f, 0.09f, 0.0f}, {-0.12f, 0.0f, 0.0f}, {-0.26f, 0.0f, 0.0f}, {-0.24f, 0.0f, 0.0f},  // left arm
    {0.03f, 0.09f, 0.0f}, {0.12f, 0.0f, 0.0f},   {0.26f, 0.0f, 0.0f},  {0.24f, 0.0f, 0.0f},   // right arm
    {-0.09f, -0.05f, 0.0f}, {0.0f, -0.42f, 0.0f}, {0.0f, -0.41f, 0.0f}, {0.0f, -0.06f, 0.13f}, // left leg
    {0.09f, -0.05f, 0.0f}, {0.0f, -0.42f, 0.0f},  {0.0f, -0.41f, 0.0f}, {0.0f, -0.06f, 0.13f}, // right leg
}};
const std::array<bool, kVrmJointCount> kVrmOptional = {false, false, false, true,  false, false, true,  false,
                                                       false, false, true,  false, false, false, false, false,
                                                       false, true,  false, false, false, true};

namespace {

Skeleton bare_skeleton(const char* const* names, const int* parents, int n) {
  Skeleton s;
  for (int i = 0; i < n; ++i) {
    s.names.emplace_back(names[i]);
    s.parents.push_back(parents[i]);
    s.offsets.emplace_back(Eigen::Vector3d::Zero());
  }
  s.has_rest_pose = false;
  s.validate();
  return s;
}

}  // namespace

std::vector<std::string> layout_names() {
  std::vector<std::string> out = preset_names();
  out.emplace_back("mediapipe");
  return out;
}

Layout resolve_layout(const Skeleton& skeleton, const std::string& name) {
  Layout layout;
  if (name == "mediapipe") {
    layout.map = mediapipe_map(skeleton);
    layout.axes = UpAxis::kYDown;
    layout.fixed_axes = true;
    layout.smooth = true;
    return layout;
  }
  std::array<std::string, kGpdJoints> names;
  try {
    names = preset_joint_names(name);
  } catch (const Error&) {
    std::string known;
    for (const std::string& n : layout_names()) known += (known.empty() ? "" : ", ") + n;
    throw Error(ErrorKind::kNotFound, "unknown layout '" + bounded(name) + "' (known: " + known + ")");
  }
  try {
    layout.map = make_gpd_map(skeleton, names);
  } catch (const Error& e) {
    throw Error(e.kind(), "layout '" + bounded(name) + "': " + e.what());
  }
  return layout;
}

Skeleton layout_skeleton(const std::string& name) {
  if (name == "mediapipe") return bare_skeleton(kMediaPipeLandmarks.data(), kMediaPipeParents, kMediaPipeLandmarkCount);
  if (name == "gpd") return bare_skeleton(kGpdJointNames.data(), kGpdParents.data(), kGpdJoints);
  if (name == "azure-kinect") return bare_skeleton(kAzureKinectJoints, kAzureKinectParents, 32);
  if (name == "xsens") return bare_skeleton(kXsensSegments, kXsensParents, 23);
  if (name == "cmu") return bare_skeleton(kCmuJoints, kCmuParents, 31);
  if (name == "vrm") return bare_skeleton(kVrmJoints.data(), kVrmParents.data(), kVrmJointCount);
  throw Error(ErrorKind::kNotFound, "layout '" + bounded(name) +
                                        "' has no built-in joint list (known: mediapipe, gpd, azure-kinect, xsens, cmu, vrm); "
                                        "build the skeleton "
                                        "from your source's joint names instead");
}

GpdMap trunk_as_student(const GpdMap& teacher, const GpdMap& student) {
  GpdMap out = teacher;
  // The GPD joint a student input joint is read as directly (-1: none).
  auto direct = [&](int joint) {
    for (int g = 0; g < kGpdJoints; ++g)
      if (student.source[static_cast<size_t>(g)] == joint) return g;
    return -1;
  };
  // The teacher's own joint for the student's input joint `joint`, or -1.
  auto teacher_joint = [&](int joint) {
    const int g = direct(joint);
    return g >= 0 && !teacher.synthesised(g) ? teacher.source[static_cast<size_t>(g)] : -1;
  };
  std::array<bool, kGpdJoints> remade{};
  // Pass 0: rules made of points the teacher has (Hip, Chest); pass 1: rules that also hold
  // another synthesised joint's blend (the Neck: the ears of the Head), read as that joint.
  for (int pass = 0; pass < 2; ++pass) {
    for (int g = 0; g < kGpdJoints; ++g) {
      const size_t gi = static_cast<size_t>(g);
      if (!student.synthesised(g) || teacher.synthesised(g) || remade[gi]) continue;
      const GpdBlend& b = student.blend[gi];
      if (b.count < 1 || b.count > kMaxBlendTerms) continue;
      GpdBlend t;
      std::array<bool, kMaxBlendTerms> used{};
      bool ok = true;
      auto add = [&](int joint, float weight) {
        if (t.count >= kMaxBlendTerms) {
          ok = false;
          return;
        }
        t.joint[static_cast<size_t>(t.count)] = joint;
        t.weight[static_cast<size_t>(t.count)] = weight;
        ++t.count;
      };
      for (int k = 0; k < b.count; ++k) {
        const int tj = teacher_joint(b.joint[static_cast<size_t>(k)]);
        if (tj < 0) continue;
        add(tj, b.weight[static_cast<size_t>(k)]);
        used[static_cast<size_t>(k)] = true;
      }
      for (int g2 = 0; pass == 1 && ok && g2 < kGpdJoints; ++g2) {
        const GpdBlend& c = student.blend[static_cast<size_t>(g2)];
        if (g2 == g || !student.synthesised(g2) || teacher.synthesised(g2) || remade[static_cast<size_t>(g2)] ||
            c.count < 1 || c.count > kMaxBlendTerms || c.offset != 0.0f)
          continue;
        // Every term of c among b's unused terms, with one ratio of weights.
        std::array<int, kMaxBlendTerms> at{};
        float ratio = 0.0f;
        bool group = true;
        for (int m = 0; m < c.count && group; ++m) {
          int found = -1;
          for (int k = 0; k < b.count; ++k)
            if (!used[static_cast<size_t>(k)] && b.joint[static_cast<size_t>(k)] == c.joint[static_cast<size_t>(m)])
              found = k;
          const float cw = c.weight[static_cast<size_t>(m)];
          if (found < 0 || cw == 0.0f) {
            group = false;
            break;
          }
          const float r = b.weight[static_cast<size_t>(found)] / cw;
          if (m == 0) ratio = r;
          else if (std::fabs(r - ratio) > 1e-5f * std::fabs(ratio)) group = false;
          at[static_cast<size_t>(m)] = found;
        }
        if (!group) continue;
        for (int m = 0; m < c.count; ++m) used[static_cast<size_t>(at[static_cast<size_t>(m)])] = true;
        add(teacher.source[static_cast<size_t>(g2)], ratio);
      }
      for (int k = 0; k < b.count; ++k) ok = ok && used[static_cast<size_t>(k)];
      if (b.offset != 0.0f) {
        for (size_t k = 0; k < t.offset_joint.size() && ok; ++k) {
          t.offset_joint[k] = teacher_joint(b.offset_joint[k]);
          ok = t.offset_joint[k] >= 0;
        }
        t.offset = b.offset;
      }
      if (!ok) continue;
      t.rest_joint = teacher.source[gi];
      out.source[gi] = -1;
      out.blend[gi] = t;
      remade[gi] = true;
    }
  }
  return out;
}

void map_to_gpd(const GpdMap& map, UpAxis axes, const float* xyz, float* out) {
  for (int g = 0; g < kGpdJoints; ++g) map_gpd_joint(map, axes, g, xyz, out + 3 * g);
}

void map_gpd_joint(const GpdMap& map, UpAxis axes, int g, const float* xyz, float* out) {
  {
    float p[3];
    const int src = map.source[static_cast<size_t>(g)];
    if (src >= 0) {
      p[0] = xyz[3 * src];
      p[1] = xyz[3 * src + 1];
      p[2] = xyz[3 * src + 2];
    } else {
      const GpdBlend& b = map.blend[static_cast<size_t>(g)];
      p[0] = p[1] = p[2] = 0.0f;
      for (int k = 0; k < b.count; ++k) {
        const float* q = xyz + 3 * b.joint[static_cast<size_t>(k)];
        const float w = b.weight[static_cast<size_t>(k)];
        p[0] += w * q[0];
        p[1] += w * q[1];
        p[2] += w * q[2];
      }
      if (b.offset != 0.0f) {
        const float* pa = xyz + 3 * b.offset_joint[0];
        const float* pb = xyz + 3 * b.offset_joint[1];
        const float* pc = xyz + 3 * b.offset_joint[2];
        const float* pd = xyz + 3 * b.offset_joint[3];
        float lat[3], up[3];
        for (int k = 0; k < 3; ++k) {
          lat[k] = pa[k] - pb[k];
          up[k] = 0.5f * (pc[k] + pd[k]) - 0.5f * (pa[k] + pb[k]);
        }
        const float n = std::sqrt(lat[0] * lat[0] + lat[1] * lat[1] + lat[2] * lat[2]);
        if (n > 0.0f) {
          const float s = b.offset / n;
          p[0] += s * (lat[1] * up[2] - lat[2] * up[1]);
          p[1] += s * (lat[2] * up[0] - lat[0] * up[2]);
          p[2] += s * (lat[0] * up[1] - lat[1] * up[0]);
        }
      }
    }
    to_y_up(axes, p, out);
  }
}

}  // namespace kata
