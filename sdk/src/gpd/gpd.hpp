// GPD v1: the Geometric Pose Descriptor, exactly as ../shared/spec/gpd-v1.md lays it out.
// Stateless per-frame kernels over caller-owned buffers; the only state is the small
// GeometryState a stream carries for degenerate frames (previous yaw, previous plane normals).
#pragma once

#include <cstdint>

namespace kata::gpd {

// Finite-difference stencil of the kinetics block (spec section 5).
enum class Stencil : int { kBackward = 0, kCentral = 1 };

constexpr int kJoints = 16;
constexpr int kLines = 30;
constexpr int kPlanes = 5;
constexpr int kDims = 1683;         // the whole vector
constexpr int kStaticDims = 1591;   // blocks 1..8
constexpr int kJcDims = 46;         // block 1: 15 joints x 3 + hip height
constexpr int kKineticDims = 92;    // block 9

// Block offsets (spec section 4).
constexpr int kOffsetJc = 0;
constexpr int kOffsetJJd = 46;
constexpr int kOffsetJJo = 166;
constexpr int kOffsetJLd = 526;
constexpr int kOffsetLLa = 946;
constexpr int kOffsetJPd = 1381;
constexpr int kOffsetLPa = 1446;
constexpr int kOffsetPPa = 1581;
constexpr int kOffsetJk = 1591;

// Lines (directed first -> second joint) and planes (J1, J2, J3), spec section 3.
extern const int8_t kLineJoints[kLines][2];
extern const int8_t kPlaneJoints[kPlanes][3];

// What a stream remembers between frames for degenerate geometry (spec sections 2 and 4).
struct GeometryState {
  bool has_yaw = false;
  double yaw_cos = 1.0, yaw_sin = 0.0;  // last good yaw rotation
  bool has_normal[kPlanes] = {};
  float normal[kPlanes][3] = {};         // last good plane normals (local frame)
  void reset() { *this = GeometryState{}; }
};

// Spec section 2: from 16 world joint positions (x,y,z interleaved, +Y up, any units) and the
// body height H in the same units, the local-frame positions (hip at origin, yaw so the body's
// left is +X, divided by H; x,y,z interleaved, 48 floats) and the hip height (world hip Y / H).
// Updates the yaw memory in `state`.
void to_local_frame(const float* world, double height, GeometryState& state, float* local, float* hip_height);

// Blocks 1..8 (dims 0..1590) from local positions and hip height. Updates the plane-normal
// memory in `state`. Never produces NaN/Inf for finite input. Picks the AVX2 kernel when the
// CPU has it. Returns largest_magnitude_bits(out, kStaticDims) (below), which the kernels track
// in registers as they write, so a caller's finiteness check of the features costs no second
// pass over them.
uint32_t static_features(const float* local, float hip_height, GeometryState& state, float* out);

// The largest magnitude among n floats, as its IEEE bit pattern with the sign cleared. These
// patterns order as the magnitudes do, with Inf (0x7f800000) above every finite value and NaN
// above Inf: the result is < 0x7f800000 iff every value is finite, and <= the pattern of a
// bound b iff every |v[i]| <= b. One branch-free pass (vectorised; AVX2 when the CPU has it),
// for the per-frame checks that need the offending value only when they fail.
uint32_t largest_magnitude_bits(const float* v, int n);

// Finite-difference weights over three samples f0, f1, f2 (spec section 5): the derivative is
// v = wv[0] f0 + wv[1] f1 + wv[2] f2, likewise a with wa.
struct DifferenceWeights {
  double wv[3];
  double wa[3];
};
// Backward stencil evaluated at t2; central stencil evaluated at t1. h1 = t1 - t0, h2 = t2 - t1 > 0.
DifferenceWeights backward_weights(double h1, double h2);
DifferenceWeights central_weights(double h1, double h2);

// Block 9 (92 dims) from three samples of block 1 (46 values each: 45 coordinates + hip
// height). f0 / f1 may be null when the weights for them are zero (segment starts). Output
// order: joints 1..15 as (vx, vy, vz, ax, ay, az), then (v, a) of the hip height.
// Each returns largest_magnitude_bits(out, kKineticDims), tracked as it computes.
uint32_t kinetics(const float* f0, const float* f1, const float* f2, const DifferenceWeights& w, float* out);
// Block 9 at the start of a segment: v = a = 0.
uint32_t kinetics_zero(float* out);
// Block 9 on a segment's second frame with the backward stencil: v = (f1 - f0) / h1, a = 0.
uint32_t kinetics_two_point(const float* f0, const float* f1, double h1, float* out);

}  // namespace kata::gpd
