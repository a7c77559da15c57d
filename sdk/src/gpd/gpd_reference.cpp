// The double-precision reference of GPD v1 blocks 1..8: straight loops over the spec's text,
// no tables shared with the fast kernels except the line/plane list, so the tests compare two
// independent readings of the enumeration rules.
#include <algorithm>
#include <cmath>

#include "gpd/gpd_detail.hpp"

namespace kata::gpd::detail {

namespace {

struct V3 {
  double x, y, z;
};
V3 sub(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
double dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double norm(V3 a) { return std::sqrt(dot(a, a)); }
// unit(v), with the spec's rule that a zero vector's unit is (0,0,0).
V3 unit(V3 a) {
  const double n = norm(a);
  return n > 0.0 ? V3{a.x / n, a.y / n, a.z / n} : V3{0.0, 0.0, 0.0};
}
// arccos with its argument clamped to [-1, 1] (spec section 4 notes).
double angle(double c) { return std::acos(std::clamp(c, -1.0, 1.0)); }

}  // namespace

namespace {

// The reference over float or double local positions.
template <class T>
void reference(const T* local, double hip_height, GeometryState& state, double* out) {
  V3 P[kJoints];
  for (int j = 0; j < kJoints; ++j) P[j] = {local[3 * j], local[3 * j + 1], local[3 * j + 2]};
  int o = 0;

  // 1. Jc: joints 1..15, then the hip height.
  for (int j = 1; j < kJoints; ++j) {
    out[o++] = P[j].x;
    out[o++] = P[j].y;
    out[o++] = P[j].z;
  }
  out[o++] = hip_height;

  // 2. JJd, 3. JJo: pairs i < j, lexicographic.
  int o3 = o + kPairCount;
  for (int i = 0; i < kJoints; ++i) {
    for (int j = i + 1; j < kJoints; ++j) {
      const V3 d = sub(P[j], P[i]);
      out[o++] = norm(d);
      const V3 u = unit(d);
      out[o3++] = u.x;
      out[o3++] = u.y;
      out[o3++] = u.z;
    }
  }
  o = o3;

  // Lines: origin point and unit direction.
  V3 dir[kLines];
  for (int l = 0; l < kLines; ++l) dir[l] = unit(sub(P[kLineJoints[l][1]], P[kLineJoints[l][0]]));

  // 4. JLd: for each line, each joint not on it: distance to the infinite line, or to the
  // line's point when the line has zero length.
  for (int l = 0; l < kLines; ++l) {
    const int a = kLineJoints[l][0], b = kLineJoints[l][1];
    const V3 d = sub(P[b], P[a]);
    const double len = norm(d);
    for (int k = 0; k < kJoints; ++k) {
      if (k == a || k == b) continue;
      const V3 w = sub(P[k], P[a]);
      out[o++] = len > 0.0 ? norm(cross(w, d)) / len : norm(w);
    }
  }

  // 5. LLa: pairs of lines l < m.
  for (int l = 0; l < kLines; ++l) {
    for (int m = l + 1; m < kLines; ++m) out[o++] = angle(dot(dir[l], dir[m]));
  }

  // Plane normals; a degenerate plane (sine of the angle at J1 below 1e-3, or a zero edge)
  // keeps the previous normal, or (0,0,0) with none.
  V3 n[kPlanes];
  for (int p = 0; p < kPlanes; ++p) {
    const V3 j1 = P[kPlaneJoints[p][0]];
    const V3 e1 = sub(P[kPlaneJoints[p][1]], j1), e2 = sub(P[kPlaneJoints[p][2]], j1);
    const V3 c = cross(e1, e2);
    const double lc = norm(c), l1 = norm(e1), l2 = norm(e2);
    const bool degenerate = l1 == 0.0 || l2 == 0.0 || lc / (l1 * l2) < 1e-3;
    if (degenerate) {
      n[p] = state.has_normal[p] ? V3{state.normal[p][0], state.normal[p][1], state.normal[p][2]} : V3{0, 0, 0};
    } else {
      n[p] = {c.x / lc, c.y / lc, c.z / lc};
      state.has_normal[p] = true;
      state.normal[p][0] = static_cast<float>(n[p].x);
      state.normal[p][1] = static_cast<float>(n[p].y);
      state.normal[p][2] = static_cast<float>(n[p].z);
    }
  }

  // 6. JPd: for each plane, each joint not a vertex: signed distance to the plane.
  for (int p = 0; p < kPlanes; ++p) {
    const int v[3] = {kPlaneJoints[p][0], kPlaneJoints[p][1], kPlaneJoints[p][2]};
    for (int k = 0; k < kJoints; ++k) {
      if (k == v[0] || k == v[1] || k == v[2]) continue;
      out[o++] = dot(sub(P[k], P[v[0]]), n[p]);
    }
  }

  // 7. LPa: for each plane, each line whose endpoints are not both vertices of the plane.
  for (int p = 0; p < kPlanes; ++p) {
    auto is_vertex = [&](int j) {
      return j == kPlaneJoints[p][0] || j == kPlaneJoints[p][1] || j == kPlaneJoints[p][2];
    };
    for (int l = 0; l < kLines; ++l) {
      if (is_vertex(kLineJoints[l][0]) && is_vertex(kLineJoints[l][1])) continue;
      out[o++] = angle(dot(dir[l], n[p]));
    }
  }

  // 8. PPa: pairs of planes p < q.
  for (int p = 0; p < kPlanes; ++p) {
    for (int q = p + 1; q < kPlanes; ++q) out[o++] = angle(dot(n[p], n[q]));
  }
}

}  // namespace

void static_features_reference(const float* local, float hip_height, GeometryState& state, double* out) {
  reference(local, hip_height, state, out);
}

void static_features_reference(const double* local, double hip_height, GeometryState& state, double* out) {
  reference(local, hip_height, state, out);
}

}  // namespace kata::gpd::detail
