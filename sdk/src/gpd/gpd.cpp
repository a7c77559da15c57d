// GPD v1: local frame (spec section 2), kernel dispatch, kinetics (spec section 5).
#include "gpd/gpd.hpp"

#include <cmath>

#include "common/cpu.hpp"
#include "gpd/gpd_detail.hpp"

namespace kata::gpd {

const int8_t kLineJoints[kLines][2] = {
#define KATA_GPD_LINE(l) {detail::kLayout.line[l][0], detail::kLayout.line[l][1]}
    KATA_GPD_LINE(0),  KATA_GPD_LINE(1),  KATA_GPD_LINE(2),  KATA_GPD_LINE(3),  KATA_GPD_LINE(4),
    KATA_GPD_LINE(5),  KATA_GPD_LINE(6),  KATA_GPD_LINE(7),  KATA_GPD_LINE(8),  KATA_GPD_LINE(9),
    KATA_GPD_LINE(10), KATA_GPD_LINE(11), KATA_GPD_LINE(12), KATA_GPD_LINE(13), KATA_GPD_LINE(14),
    KATA_GPD_LINE(15), KATA_GPD_LINE(16), KATA_GPD_LINE(17), KATA_GPD_LINE(18), KATA_GPD_LINE(19),
    KATA_GPD_LINE(20), KATA_GPD_LINE(21), KATA_GPD_LINE(22), KATA_GPD_LINE(23), KATA_GPD_LINE(24),
    KATA_GPD_LINE(25), KATA_GPD_LINE(26), KATA_GPD_LINE(27), KATA_GPD_LINE(28), KATA_GPD_LINE(29),
#undef KATA_GPD_LINE
};

const int8_t kPlaneJoints[kPlanes][3] = {
#define KATA_GPD_PLANE(p) {detail::kLayout.plane[p][0], detail::kLayout.plane[p][1], detail::kLayout.plane[p][2]}
    KATA_GPD_PLANE(0), KATA_GPD_PLANE(1), KATA_GPD_PLANE(2), KATA_GPD_PLANE(3), KATA_GPD_PLANE(4),
#undef KATA_GPD_PLANE
};

namespace {
// Joint indices used by the yaw rule (spec section 2, step 3).
constexpr int kLShoulder = 4, kRShoulder = 7, kLHip = 10, kRHip = 13;
}  // namespace

void to_local_frame(const float* world, double height, GeometryState& state, float* local, float* hip_height) {
  const double hx = world[0], hy = world[1], hz = world[2];
  // u = (LHip - RHip) + (LShoulder - RShoulder), on the XZ plane.
  const double ux = (double(world[3 * kLHip]) - world[3 * kRHip]) + (double(world[3 * kLShoulder]) - world[3 * kRShoulder]);
  const double uz =
      (double(world[3 * kLHip + 2]) - world[3 * kRHip + 2]) + (double(world[3 * kLShoulder + 2]) - world[3 * kRShoulder + 2]);
  const double norm = std::hypot(ux, uz);
  double c = 1.0, s = 0.0;
  if (norm >= 1e-6) {
    c = ux / norm;
    s = uz / norm;
    state.has_yaw = true;
    state.yaw_cos = c;
    state.yaw_sin = s;
  } else if (state.has_yaw) {  // body lying across the vertical: keep the previous yaw
    c = state.yaw_cos;
    s = state.yaw_sin;
  }
  // Rotation about +Y taking (ux, uz) to (|u|, 0): x' = c x + s z, z' = -s x + c z. It is a
  // proper rotation (det +1), so with the left along +X and up along +Y the body faces +Z.
  const double inv_h = 1.0 / height;
  for (int j = 0; j < kJoints; ++j) {
    const double x = world[3 * j] - hx, y = world[3 * j + 1] - hy, z = world[3 * j + 2] - hz;
    local[3 * j] = static_cast<float>((c * x + s * z) * inv_h);
    local[3 * j + 1] = static_cast<float>(y * inv_h);
    local[3 * j + 2] = static_cast<float>((c * z - s * x) * inv_h);
  }
  *hip_height = static_cast<float>(hy * inv_h);
}

void static_features(const float* local, float hip_height, GeometryState& state, float* out) {
  // cpu_has_avx2() is cached, so this is one predictable branch per frame.
  if (detail::avx2::compiled() && cpu_has_avx2()) {
    detail::avx2::static_features(local, hip_height, state, out);
  } else {
    detail::sse4::static_features(local, hip_height, state, out);
  }
}

DifferenceWeights backward_weights(double h1, double h2) {
  const double s = h1 + h2;
  DifferenceWeights w{};
  w.wv[0] = h2 / (h1 * s);
  w.wv[1] = -s / (h1 * h2);
  w.wv[2] = (h1 + 2.0 * h2) / (h2 * s);
  w.wa[0] = 2.0 / (h1 * s);
  w.wa[1] = -2.0 / (h1 * h2);
  w.wa[2] = 2.0 / (h2 * s);
  return w;
}

DifferenceWeights central_weights(double h1, double h2) {
  const double s = h1 + h2;
  DifferenceWeights w{};
  w.wv[0] = -h2 / (h1 * s);
  w.wv[1] = (h2 - h1) / (h1 * h2);
  w.wv[2] = h1 / (h2 * s);
  w.wa[0] = 2.0 / (h1 * s);
  w.wa[1] = -2.0 / (h1 * h2);
  w.wa[2] = 2.0 / (h2 * s);
  return w;
}

namespace {
// Writes one block-1 value's (v, a) pair into the block-9 layout: joint coordinates go to
// (vx, vy, vz, ax, ay, az) per joint, the hip height (index 45) to the last two dims.
inline void put_kinetic(float* out, int i, double v, double a) {
  if (i < 45) {
    const int j = i / 3, c = i % 3;
    out[6 * j + c] = static_cast<float>(v);
    out[6 * j + 3 + c] = static_cast<float>(a);
  } else {
    out[90] = static_cast<float>(v);
    out[91] = static_cast<float>(a);
  }
}
}  // namespace

void kinetics(const float* f0, const float* f1, const float* f2, const DifferenceWeights& w, float* out) {
  // Double accumulation: the weights are ~1/h^2 (~3e4 at 120 fps) and the terms cancel, so a
  // float sum would lose about 3 digits of the acceleration.
  for (int i = 0; i < kJcDims; ++i) {
    double v = w.wv[2] * f2[i], a = w.wa[2] * f2[i];
    if (f1) {
      v += w.wv[1] * f1[i];
      a += w.wa[1] * f1[i];
    }
    if (f0) {
      v += w.wv[0] * f0[i];
      a += w.wa[0] * f0[i];
    }
    put_kinetic(out, i, v, a);
  }
}

void kinetics_zero(float* out) {
  for (int i = 0; i < kKineticDims; ++i) out[i] = 0.0f;
}

void kinetics_two_point(const float* f0, const float* f1, double h1, float* out) {
  const double inv = 1.0 / h1;
  for (int i = 0; i < kJcDims; ++i) put_kinetic(out, i, (double(f1[i]) - f0[i]) * inv, 0.0);
}

}  // namespace kata::gpd
