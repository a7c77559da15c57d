// GPD v1: local frame (spec section 2), kernel dispatch, kinetics (spec section 5).
#include "gpd/gpd.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

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
  // sqrt of the sum of squares, not std::hypot (a library call several times the cost): a
  // stream's joints lie within +-1e9 input units (stream.hpp), where the squares cannot
  // overflow; hypot only for the wild values a caller may hand in directly.
  double norm = std::sqrt(ux * ux + uz * uz);
  if (!(norm < 1e150)) norm = std::hypot(ux, uz);
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

namespace {
// Static blocks of a frame too large for float32 squares, via the double reference. Out of
// line so that its 12 KB of stack stays off the fast path's frame.
[[gnu::noinline]] uint32_t static_features_wide(const float* local, float hip_height, GeometryState& state,
                                                float* out) {
  double ref[kStaticDims];
  detail::static_features_reference(local, hip_height, state, ref);
  for (int d = 0; d < kStaticDims; ++d) out[d] = static_cast<float>(ref[d]);
  return largest_magnitude_bits(out, kStaticDims);
}

uint32_t float_bits(float v) {
  uint32_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

// Whether a frame goes to the double reference: its largest |local coordinate| (NaNs aside) is
// at least kFastPathExtent. From the sign-cleared bit patterns' maximum, which orders as the
// magnitudes with NaN above everything: only a frame holding a NaN needs the values themselves.
[[gnu::noinline]] bool beyond_fast_path_with_nan(const float* local) {
  float extent = 0.0f;
  for (int i = 0; i < 3 * kJoints; ++i) extent = std::max(extent, std::abs(local[i]));  // NaN is skipped
  return !(extent < detail::kFastPathExtent);
}
}  // namespace

uint32_t static_features(const float* local, float hip_height, GeometryState& state, float* out) {
  // The float32 kernels square coordinates, which overflows beyond ~1e19 body heights; such a
  // frame (a wild value, never a real pose) goes through the double reference, which cannot
  // overflow on float input, so every finite input still gives finite features.
  // cpu_has_avx2() is cached, so this is one predictable branch per frame.
  const bool avx2 = detail::avx2::compiled() && cpu_has_avx2();
  const uint32_t extent = avx2 ? detail::avx2::largest_magnitude_bits(local, 3 * kJoints)
                               : detail::sse4::largest_magnitude_bits(local, 3 * kJoints);
  static const uint32_t fast_path_bits = float_bits(detail::kFastPathExtent);
  if (extent >= fast_path_bits && (extent <= 0x7f800000u || beyond_fast_path_with_nan(local)))
    return static_features_wide(local, hip_height, state, out);
  return avx2 ? detail::avx2::static_features(local, hip_height, state, out)
              : detail::sse4::static_features(local, hip_height, state, out);
}

uint32_t largest_magnitude_bits(const float* v, int n) {
  if (detail::avx2::compiled() && cpu_has_avx2()) return detail::avx2::largest_magnitude_bits(v, n);
  return detail::sse4::largest_magnitude_bits(v, n);
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
// Zeros standing in for a null sample (its weight is zero).
constexpr float kZeroSample[kJcDims] = {};

// The largest sign-cleared bit pattern among v[0..kJcDims) and a[0..kJcDims) (the 92 values
// scatter_kinetics writes).
inline uint32_t largest_kinetic_bits(const float* v, const float* a) {
  uint32_t m = 0;
  for (int i = 0; i < kJcDims; ++i) {
    uint32_t bv, ba;
    std::memcpy(&bv, v + i, sizeof bv);
    std::memcpy(&ba, a + i, sizeof ba);
    bv &= 0x7fffffffu;
    ba &= 0x7fffffffu;
    m = std::max(m, std::max(bv, ba));
  }
  return m;
}

// Scatters per-value (v, a) into the block-9 layout: joint coordinates as (vx, vy, vz, ax, ay,
// az) per joint, the hip height (value 45) last.
inline void scatter_kinetics(const float* v, const float* a, float* out) {
  for (int j = 0; j < 15; ++j) {
    for (int c = 0; c < 3; ++c) {
      out[6 * j + c] = v[3 * j + c];
      out[6 * j + 3 + c] = a[3 * j + c];
    }
  }
  out[90] = v[45];
  out[91] = a[45];
}
}  // namespace

uint32_t kinetics(const float* f0, const float* f1, const float* f2, const DifferenceWeights& w, float* out) {
  // The weights are ~1/h^2 (~3e4 at 120 fps) and cancel: a float sum w0 f0 + w1 f1 + w2 f2
  // would lose ~3 digits. Rewritten exactly as w0 (f0 - f1) + w2 (f2 - f1) + (w0 + w1 + w2) f1,
  // the differences of close samples are exact in float and the last term vanishes for every
  // stencil (derivatives of a constant), so float32 keeps ~7 digits and vectorises.
  if (!f0) f0 = kZeroSample;
  if (!f1) f1 = kZeroSample;
  const float v0 = static_cast<float>(w.wv[0]), v2 = static_cast<float>(w.wv[2]);
  const float vs = static_cast<float>(w.wv[0] + w.wv[1] + w.wv[2]);
  const float a0 = static_cast<float>(w.wa[0]), a2 = static_cast<float>(w.wa[2]);
  const float as = static_cast<float>(w.wa[0] + w.wa[1] + w.wa[2]);
  float v[kJcDims], a[kJcDims];
  for (int i = 0; i < kJcDims; ++i) {
    const float d0 = f0[i] - f1[i], d2 = f2[i] - f1[i];
    v[i] = v0 * d0 + v2 * d2 + vs * f1[i];
    a[i] = a0 * d0 + a2 * d2 + as * f1[i];
  }
  scatter_kinetics(v, a, out);
  return largest_kinetic_bits(v, a);
}

uint32_t kinetics_zero(float* out) {
  for (int i = 0; i < kKineticDims; ++i) out[i] = 0.0f;
  return 0;
}

uint32_t kinetics_two_point(const float* f0, const float* f1, double h1, float* out) {
  const float inv = static_cast<float>(1.0 / h1);
  float v[kJcDims], a[kJcDims];
  for (int i = 0; i < kJcDims; ++i) {
    v[i] = (f1[i] - f0[i]) * inv;
    a[i] = 0.0f;
  }
  scatter_kinetics(v, a, out);
  return largest_kinetic_bits(v, a);
}

}  // namespace kata::gpd
