#include "metric/pose_error.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "common/error.hpp"

namespace kata::metric {

namespace {

// spec gpd-v1.md section 1: the parent of joints 1..15.
constexpr int kParent[gpd::kJoints] = {-1, 0, 1, 2, 2, 4, 5, 2, 7, 8, 0, 10, 11, 0, 13, 14};
constexpr int kChest = 1, kNeck = 2, kLShoulder = 4, kRShoulder = 7;
constexpr int kChestOffset = 3 * gpd::kJoints;
constexpr int kHipHeight = kPoseFloats - 1;
// GPD joints of each part (parts.hpp).
constexpr int kPartFirst[kParts + 1] = {0, 4, 7, 10, 13, 16};

// Joints read in the chest frame: the head and both arms.
constexpr bool in_chest_frame(int j) { return j >= kChestJoint0 && j < kChestJoint0 + kChestJoints; }

// a <- unit(a); false (a zeroed) when |a| is too small to carry a direction.
bool unit(double* a) {
  const double n = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  if (!(n > 1e-9) || !std::isfinite(n)) {
    a[0] = a[1] = a[2] = 0.0;
    return false;
  }
  for (int c = 0; c < 3; ++c) a[c] /= n;
  return true;
}

// Joint j of a pose in its own frame (the neck is the chest frame's origin).
const float* framed(const float* pose, int j) {
  return in_chest_frame(j) ? pose + kChestOffset + 3 * (j - kChestJoint0) : pose + 3 * j;
}

// Unit direction of bone c (parent -> c) in its frame; false when degenerate.
bool bone(const float* pose, int c, double* d) {
  const float* a = framed(pose, c);
  static constexpr float kOrigin[3] = {0.0f, 0.0f, 0.0f};
  // A chest-frame bone starting at the neck starts at that frame's origin.
  const float* b = in_chest_frame(c) && kParent[c] == kNeck ? kOrigin : framed(pose, kParent[c]);
  for (int k = 0; k < 3; ++k) d[k] = static_cast<double>(a[k]) - static_cast<double>(b[k]);
  return unit(d);
}

}  // namespace

void pose_frames(const float* x, float* pose) {
  double p[gpd::kJoints][3];
  for (int j = 0; j < gpd::kJoints; ++j)
    for (int c = 0; c < 3; ++c) p[j][c] = j == 0 ? 0.0 : static_cast<double>(x[3 * (j - 1) + c]);
  for (int j = 0; j < gpd::kJoints; ++j)
    for (int c = 0; c < 3; ++c) pose[3 * j + c] = static_cast<float>(p[j][c]);
  // The chest frame: y = Chest->Neck, x = RShoulder->LShoulder without its y part, z = x cross y.
  // Degenerate (a zero spine or shoulder line): the local frame's axes.
  double fy[3], fx[3], fz[3];
  for (int c = 0; c < 3; ++c) {
    fy[c] = p[kNeck][c] - p[kChest][c];
    fx[c] = p[kLShoulder][c] - p[kRShoulder][c];
  }
  bool ok = unit(fy);
  const double along = fx[0] * fy[0] + fx[1] * fy[1] + fx[2] * fy[2];
  for (int c = 0; c < 3; ++c) fx[c] -= along * fy[c];
  ok = unit(fx) && ok;
  if (!ok) {
    fx[0] = 1.0, fx[1] = 0.0, fx[2] = 0.0;
    fy[0] = 0.0, fy[1] = 1.0, fy[2] = 0.0;
  }
  fz[0] = fx[1] * fy[2] - fx[2] * fy[1];
  fz[1] = fx[2] * fy[0] - fx[0] * fy[2];
  fz[2] = fx[0] * fy[1] - fx[1] * fy[0];
  for (int j = kChestJoint0; j < kChestJoint0 + kChestJoints; ++j) {
    const double v[3] = {p[j][0] - p[kNeck][0], p[j][1] - p[kNeck][1], p[j][2] - p[kNeck][2]};
    float* o = pose + kChestOffset + 3 * (j - kChestJoint0);
    o[0] = static_cast<float>(v[0] * fx[0] + v[1] * fx[1] + v[2] * fx[2]);
    o[1] = static_cast<float>(v[0] * fy[0] + v[1] * fy[1] + v[2] * fy[2]);
    o[2] = static_cast<float>(v[0] * fz[0] + v[1] * fz[1] + v[2] * fz[2]);
  }
  pose[kHipHeight] = x[3 * (gpd::kJoints - 1)];
}

void part_error(const float* s, const float* t, PartError& out) {
  for (int q = 0; q < kParts; ++q) {
    out.degrees[q] = 0.0f;
    out.joint[q] = kPartFirst[q] == 0 ? 1 : kPartFirst[q];
    double sum = 0.0;
    for (int j = kPartFirst[q]; j < kPartFirst[q + 1]; ++j) {
      if (j == 0) {
        sum += std::fabs(static_cast<double>(s[kHipHeight]) - static_cast<double>(t[kHipHeight]));
        continue;
      }
      // The local frame for every joint (pose[3 j]), geometry's own measure (part_fix.py).
      const float* a = s + 3 * j;
      const float* b = t + 3 * j;
      const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
      sum += std::sqrt(dx * dx + dy * dy + dz * dz);
    }
    out.offset[q] = static_cast<float>(sum / (kPartFirst[q + 1] - kPartFirst[q]));
  }
  // The largest angle per part, picked by comparing (sin, cos)-scaled pairs, not angles: the angle
  // of (s, d), s >= 0, is atan2(s, d) in [0, 180] deg, and of two such angles the first is the larger
  // exactly when d2 * s1 - s2 * d1 > 0 (the second pair's direction turned onto the first's is
  // counter-clockwise; both lie in the upper half plane). One atan2 per part instead of one per
  // bone: libm's atan2 was 8 % of a frame's push (15 calls a frame).
  double best_s[kParts], best_d[kParts];
  for (int q = 0; q < kParts; ++q) best_s[q] = 0.0, best_d[q] = 1.0;  // 0 degrees
  for (int c = 1; c < gpd::kJoints; ++c) {
    double a[3], b[3];
    if (!bone(s, c, a) || !bone(t, c, b)) continue;  // a degenerate bone: nothing known
    const double cx = a[1] * b[2] - a[2] * b[1], cy = a[2] * b[0] - a[0] * b[2], cz = a[0] * b[1] - a[1] * b[0];
    const double sine = std::sqrt(cx * cx + cy * cy + cz * cz);
    const double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    const int q = joint_part(c);
    const double turn = best_d[q] * sine - best_s[q] * dot;
    // (turn == 0 with sine == 0 and dot < 0 against 0 degrees: the bones are opposite, 180 deg.)
    if (turn > 0.0 || (turn == 0.0 && sine == 0.0 && dot < 0.0 && best_s[q] == 0.0 && best_d[q] > 0.0)) {
      best_s[q] = sine;
      best_d[q] = dot;
      out.joint[q] = c;
    }
  }
  // The angle from the cross and dot products (atan2): accurate near 0 and 180 degrees, where
  // acos of a rounded dot product is not.
  for (int q = 0; q < kParts; ++q)
    out.degrees[q] = static_cast<float>(std::atan2(best_s[q], best_d[q]) * (180.0 / 3.14159265358979323846));
}

bool bone_direction(const float* pose, int c, double* d) { return bone(pose, c, d); }

void bone_directions(const float* pose, float* dirs) {
  for (int c = 1; c < gpd::kJoints; ++c) {
    double d[3];
    bone(pose, c, d);  // zeroed when degenerate
    for (int k = 0; k < 3; ++k) dirs[3 * (c - 1) + k] = static_cast<float>(d[k]);
  }
}

double trimmed_pose_distance(const float* s, const float* t, double* rest) {
  // In float, one square root a bone (the re-match ranks 13 teacher frames a student frame):
  // |s - t/|t||^2 = 2 - 2 s.t / |t| for a unit s.
  static constexpr float kOrigin[3] = {0.0f, 0.0f, 0.0f};
  static constexpr int kBonePart[gpd::kJoints] = {0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4};
  float part[kParts] = {};
  for (int c = 1; c < gpd::kJoints; ++c) {
    const float* a = s + 3 * (c - 1);
    const float* e = framed(t, c);
    const float* o = in_chest_frame(c) && kParent[c] == kNeck ? kOrigin : framed(t, kParent[c]);
    const float b0 = e[0] - o[0], b1 = e[1] - o[1], b2 = e[2] - o[2];
    const float n2 = b0 * b0 + b1 * b1 + b2 * b2;
    const float dot = a[0] * b0 + a[1] * b1 + a[2] * b2;
    // A degenerate bone on either side (s zeroed, t too short) counts 0.
    if (!(n2 > 1e-18f) || (a[0] == 0.0f && a[1] == 0.0f && a[2] == 0.0f)) continue;
    part[kBonePart[c]] += 2.0f - 2.0f * dot / std::sqrt(n2);
  }
  double sum = 0.0, worst = 0.0;
  for (double v : part) {
    sum += v;
    worst = std::max(worst, v);
  }
  const double others = sum - worst;
  if (rest) *rest = others;
  return others + std::min(worst, kTrimmedCap * others);
}

double angle_score(double degrees) { return angle_score(degrees, Tolerance{}); }

double angle_score(double degrees, const Tolerance& tolerance) {
  const double a = std::max(0.0, degrees) / tolerance.angle50;
  return 100.0 / (1.0 + std::pow(a, tolerance.slope));
}

Tolerance parse_tolerance(const char* text) {
  // The levels' maps, measured in docs/model/tolerance.md (docs/model/tolerance.py): strict catches
  // the balance table's 30-degree turns, lenient is the map chosen there for beginners.
  static constexpr Tolerance kStrict{25.0, 5.0}, kLenient{58.0, 5.0};
  const std::string t = text ? text : "";
  if (t == "normal") return Tolerance{};
  if (t == "strict") return kStrict;
  if (t == "lenient") return kLenient;
  // A number of degrees: the whole text, finite, within the range.
  char* end = nullptr;
  const double deg = t.empty() ? 0.0 : std::strtod(t.c_str(), &end);
  if (!t.empty() && end && *end == '\0' && !std::isspace(static_cast<unsigned char>(t[0])) && std::isfinite(deg) &&
      deg >= kMinToleranceAngle && deg <= kMaxToleranceAngle)
    return Tolerance{deg, kAngleSlope};
  char range[64];
  std::snprintf(range, sizeof range, "%g..%g", kMinToleranceAngle, kMaxToleranceAngle);
  throw Error(ErrorKind::kInvalidArgument, "tolerance \"" + t.substr(0, 40) +
                                               "\": give strict, normal, lenient or the angle in degrees at which a "
                                               "part scores 50 (" + range + ")");
}

}  // namespace kata::metric
