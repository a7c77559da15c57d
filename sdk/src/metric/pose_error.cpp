#include "metric/pose_error.hpp"

#include <algorithm>
#include <cmath>

namespace kata::metric {

namespace {

// spec gpd-v1.md section 1: the parent of joints 1..15.
constexpr int kParent[gpd::kJoints] = {-1, 0, 1, 2, 2, 4, 5, 2, 7, 8, 0, 10, 11, 0, 13, 14};
constexpr int kChest = 1, kNeck = 2, kLShoulder = 4, kRShoulder = 7;

// Joint j's local-frame position from the features (the hip is the origin).
void joint(const float* x, int j, double* p) {
  for (int c = 0; c < 3; ++c) p[c] = j == 0 ? 0.0 : static_cast<double>(x[3 * (j - 1) + c]);
}

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

// Bones whose direction is read in the chest frame: the head and both arms.
constexpr bool in_chest_frame(int c) { return c == 3 || (c >= 4 && c <= 9); }

}  // namespace

void bone_directions(const float* x, float* dirs) {
  double p[gpd::kJoints][3];
  for (int j = 0; j < gpd::kJoints; ++j) joint(x, j, p[j]);
  // The chest frame: y = Chest->Neck, x = RShoulder->LShoulder without its y part, z = x cross y.
  double fy[3], fx[3], fz[3];
  for (int c = 0; c < 3; ++c) {
    fy[c] = p[kNeck][c] - p[kChest][c];
    fx[c] = p[kLShoulder][c] - p[kRShoulder][c];
  }
  bool frame = unit(fy);
  const double along = fx[0] * fy[0] + fx[1] * fy[1] + fx[2] * fy[2];
  for (int c = 0; c < 3; ++c) fx[c] -= along * fy[c];
  frame = unit(fx) && frame;
  fz[0] = fx[1] * fy[2] - fx[2] * fy[1];
  fz[1] = fx[2] * fy[0] - fx[0] * fy[2];
  fz[2] = fx[0] * fy[1] - fx[1] * fy[0];
  for (int c = 1; c < gpd::kJoints; ++c) {
    double b[3];
    for (int k = 0; k < 3; ++k) b[k] = p[c][k] - p[kParent[c]][k];
    bool ok = unit(b);
    if (in_chest_frame(c)) {
      const double r[3] = {b[0] * fx[0] + b[1] * fx[1] + b[2] * fx[2], b[0] * fy[0] + b[1] * fy[1] + b[2] * fy[2],
                           b[0] * fz[0] + b[1] * fz[1] + b[2] * fz[2]};
      for (int k = 0; k < 3; ++k) b[k] = r[k];
      ok = ok && frame;
    }
    float* d = dirs + 3 * (c - 1);
    for (int k = 0; k < 3; ++k) d[k] = ok ? static_cast<float>(b[k]) : 0.0f;
  }
}

void part_angles(const float* s, const float* t, float* degrees, int* worst_joint) {
  for (int q = 0; q < kParts; ++q) {
    degrees[q] = 0.0f;
    worst_joint[q] = 3 * q + 1;
  }
  for (int c = 1; c < gpd::kJoints; ++c) {
    const float* a = s + 3 * (c - 1);
    const float* b = t + 3 * (c - 1);
    const double na = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    const double nb = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
    if (!(na > 0.5) || !(nb > 0.5)) continue;  // a degenerate bone: nothing known
    // The angle from the cross and dot products (atan2): accurate near 0 and 180 degrees, where
    // acos of a rounded dot product is not (a 1-degree error reads as 0 or 2 through acos in float).
    const double cx = a[1] * b[2] - a[2] * b[1], cy = a[2] * b[0] - a[0] * b[2], cz = a[0] * b[1] - a[1] * b[0];
    const double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    const double deg = std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), dot) * (180.0 / 3.14159265358979323846);
    const int q = joint_part(c);
    if (deg > degrees[q]) {
      degrees[q] = static_cast<float>(deg);
      worst_joint[q] = c;
    }
  }
}

double angle_score(double degrees) {
  const double a = std::max(0.0, degrees) / kAngle50;
  return 100.0 / (1.0 + std::pow(a, kAngleSlope));
}

}  // namespace kata::metric
