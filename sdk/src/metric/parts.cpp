#include "metric/parts.hpp"

#include <cstddef>
#include <initializer_list>

namespace kata::metric {

const char* part_name(int part) {
  static const char* const names[kParts] = {"torso_head", "left_arm", "right_arm", "left_leg", "right_leg"};
  return part >= 0 && part < kParts ? names[part] : "?";
}

int joint_part(int joint) {
  if (joint <= 3) return 0;
  if (joint <= 6) return 1;
  if (joint <= 9) return 2;
  if (joint <= 12) return 3;
  return 4;
}

namespace {

uint8_t bits(std::initializer_list<int> joints) {
  uint8_t m = 0;
  for (int j : joints) m = static_cast<uint8_t>(m | (1u << joint_part(j)));
  return m;
}
uint8_t line_bits(int l) { return bits({gpd::kLineJoints[l][0], gpd::kLineJoints[l][1]}); }
uint8_t plane_bits(int p) { return bits({gpd::kPlaneJoints[p][0], gpd::kPlaneJoints[p][1], gpd::kPlaneJoints[p][2]}); }
bool on_line(int k, int l) { return gpd::kLineJoints[l][0] == k || gpd::kLineJoints[l][1] == k; }
bool on_plane(int k, int p) {
  return gpd::kPlaneJoints[p][0] == k || gpd::kPlaneJoints[p][1] == k || gpd::kPlaneJoints[p][2] == k;
}

// Walks the spec section 4 enumeration, block by block, in order.
std::array<uint8_t, gpd::kDims> build() {
  std::array<uint8_t, gpd::kDims> t{};
  int i = 0;
  auto put = [&](uint8_t m) { t[static_cast<size_t>(i++)] = m; };
  // 1 Jc: joints 1..15 x (x, y, z), then hip height.
  for (int j = 1; j < gpd::kJoints; ++j)
    for (int c = 0; c < 3; ++c) put(bits({j}));
  put(bits({0}));
  // 2 JJd, 3 JJo: pairs i < j.
  for (int j = 0; j < gpd::kJoints; ++j)
    for (int k = j + 1; k < gpd::kJoints; ++k) put(bits({j, k}));
  for (int j = 0; j < gpd::kJoints; ++j)
    for (int k = j + 1; k < gpd::kJoints; ++k)
      for (int c = 0; c < 3; ++c) put(bits({j, k}));
  // 4 JLd: line l, joint k not an endpoint.
  for (int l = 0; l < gpd::kLines; ++l)
    for (int k = 0; k < gpd::kJoints; ++k)
      if (!on_line(k, l)) put(static_cast<uint8_t>(bits({k}) | line_bits(l)));
  // 5 LLa: line pairs.
  for (int l = 0; l < gpd::kLines; ++l)
    for (int m = l + 1; m < gpd::kLines; ++m) put(static_cast<uint8_t>(line_bits(l) | line_bits(m)));
  // 6 JPd: plane p, joint k not a vertex.
  for (int p = 0; p < gpd::kPlanes; ++p)
    for (int k = 0; k < gpd::kJoints; ++k)
      if (!on_plane(k, p)) put(static_cast<uint8_t>(bits({k}) | plane_bits(p)));
  // 7 LPa: plane p, line l whose endpoints are not both vertices of p.
  for (int p = 0; p < gpd::kPlanes; ++p)
    for (int l = 0; l < gpd::kLines; ++l)
      if (!(on_plane(gpd::kLineJoints[l][0], p) && on_plane(gpd::kLineJoints[l][1], p)))
        put(static_cast<uint8_t>(plane_bits(p) | line_bits(l)));
  // 8 PPa: plane pairs.
  for (int p = 0; p < gpd::kPlanes; ++p)
    for (int q = p + 1; q < gpd::kPlanes; ++q) put(static_cast<uint8_t>(plane_bits(p) | plane_bits(q)));
  // 9 Jk: joints 1..15 x (vx, vy, vz, ax, ay, az), then (v, a) of hip height.
  for (int j = 1; j < gpd::kJoints; ++j)
    for (int c = 0; c < 6; ++c) put(bits({j}));
  put(bits({0}));
  put(bits({0}));
  // The enumeration must land exactly on the layout's size; a mismatch is a bug in this file or
  // in the layout tables, caught by the test that checks the block offsets.
  if (i != gpd::kDims) t.fill(0);
  return t;
}

}  // namespace

const std::array<uint8_t, gpd::kDims>& dimension_parts() {
  static const std::array<uint8_t, gpd::kDims> table = build();
  return table;
}

}  // namespace kata::metric
