// The float32 SIMD kernel of GPD v1 blocks 1..8, written once over an xsimd architecture.
//
// Included by gpd_sse4.cpp and gpd_avx2.cpp INSIDE their own namespace
// (kata::gpd::detail::sse4 / ::avx2) after `using Arch = xsimd::<arch>;`. ODR note: the two
// translation units are compiled for different instruction sets, so they must not share any
// inline function or template instantiation (the linker keeps one copy and could hand the
// AVX2 one to the baseline path). Hence: everything here is in an unnamed namespace nested in
// the ISA namespace, xsimd is used only through batch<float, Arch>, square roots are
// __builtin_sqrt, and the tables are plain arrays (gpd_detail.hpp). No heap allocation.
//
// Data layout: joints, lines and normals as structure-of-arrays (x[], y[], z[]) padded past a
// multiple of the batch width, so each block is a few contiguous batch loops:
// - pair blocks (JJ, LLa) enumerate (i, j > i) lexicographically, so for a fixed i the
//   partners j are contiguous in the SoA arrays and the results contiguous in the output;
// - skip blocks (JLd, JPd, LPa) are computed for every joint/line and then compacted by a
//   compile-time source-index table.

namespace {

using B = xsimd::batch<float, Arch>;
constexpr int W = static_cast<int>(B::size);

// Rounds n up to a multiple of the batch width.
constexpr int padded(int n) { return (n + W - 1) / W * W; }

// Unaligned load / store of one batch.
inline B load(const float* p) { return B::load_unaligned(p); }
inline void store(float* p, const B& v) { v.store_unaligned(p); }

// |v| components with the spec's zero rule applied by the caller: 1/len, or 0 for len == 0.
inline B inverse_or_zero(const B& len) { return xsimd::select(len > B(0.0f), B(1.0f) / len, B(0.0f)); }

// arccos(clamp(x, -1, 1)) in float32, about 1 ulp of pi: the Cephes asinf polynomial on
// [0, 0.5], with acos(x) = pi/2 - asin(x) for |x| <= 0.5 and 2 asin(sqrt((1-|x|)/2)) above.
// Branch-free, so a batch mixing both ranges costs the same as one that does not.
inline B acos_batch(const B& x) {
  const B one(1.0f), half(0.5f);
  const B a = xsimd::min(xsimd::abs(x), one);
  const auto big = a > half;
  const B z = xsimd::select(big, half * (one - a), a * a);
  const B s = xsimd::select(big, xsimd::sqrt(z), a);
  B p(4.2163199048e-2f);
  p = xsimd::fma(p, z, B(2.4181311049e-2f));
  p = xsimd::fma(p, z, B(4.5470025998e-2f));
  p = xsimd::fma(p, z, B(7.4953002686e-2f));
  p = xsimd::fma(p, z, B(1.6666752422e-1f));
  const B r = xsimd::fma(s * z, p, s);          // asin(s), s in [0, 0.5]
  const B rs = r ^ (x & B(-0.0f));              // copysign(r, x)
  const B pi(3.14159265358979f), half_pi(1.57079632679490f);
  const B big_result = rs + rs + xsimd::select(x < B(0.0f), pi, B(0.0f));
  return xsimd::select(big, big_result, half_pi - rs);
}

// dst[0..n) = acos(src[0..n)), n >= W. The tail is one batch ending at n (overlapping the
// previous one), which is only correct because src and dst are different buffers.
inline void acos_block(const float* src, int n, float* dst) {
  int i = 0;
  for (; i + W <= n; i += W) store(dst + i, acos_batch(load(src + i)));
  if (i < n) store(dst + n - W, acos_batch(load(src + n - W)));
}

// Per-frame scratch, all on the stack (sizes padded for the overlapping batch stores).
struct Scratch {
  alignas(64) float px[32], py[32], pz[32];                  // joints, zero past 16
  alignas(64) float dx[padded(kPairCount) + W], dy[padded(kPairCount) + W], dz[padded(kPairCount) + W];
  alignas(64) float ux[padded(kPairCount)], uy[padded(kPairCount)], uz[padded(kPairCount)];
  alignas(64) float lx[40], ly[40], lz[40], llen[40];        // line vectors, zero past 30
  alignas(64) float lux[40], luy[40], luz[40];               // line unit directions
  alignas(64) float jl[kLines * 16];                         // JLd for every joint
  alignas(64) float ll[kLLCount + W];                        // LLa cosines
  alignas(64) float jp[kPlanes * 16];                        // JPd for every joint
  alignas(64) float lpfull[kPlanes * 32];                    // LPa cosines for every line
  alignas(64) float lp[kLPCount + kPPCount];                 // LPa then PPa cosines
  float nx[kPlanes], ny[kPlanes], nz[kPlanes];               // plane normals
};

// Unit normal of plane p from the joints, in double so the degenerate decision and the
// normal are those of the double reference; updates or reads the stream's memory.
inline void plane_normal(const Scratch& s, int p, GeometryState& state, float* n) {
  const int a = kLayout.plane[p][0], b = kLayout.plane[p][1], c = kLayout.plane[p][2];
  const double e1x = double(s.px[b]) - s.px[a], e1y = double(s.py[b]) - s.py[a], e1z = double(s.pz[b]) - s.pz[a];
  const double e2x = double(s.px[c]) - s.px[a], e2y = double(s.py[c]) - s.py[a], e2z = double(s.pz[c]) - s.pz[a];
  const double cx = e1y * e2z - e1z * e2y, cy = e1z * e2x - e1x * e2z, cz = e1x * e2y - e1y * e2x;
  const double lc = __builtin_sqrt(cx * cx + cy * cy + cz * cz);
  const double l1 = __builtin_sqrt(e1x * e1x + e1y * e1y + e1z * e1z);
  const double l2 = __builtin_sqrt(e2x * e2x + e2y * e2y + e2z * e2z);
  if (l1 == 0.0 || l2 == 0.0 || lc / (l1 * l2) < 1e-3) {
    for (int i = 0; i < 3; ++i) n[i] = state.has_normal[p] ? state.normal[p][i] : 0.0f;
    return;
  }
  n[0] = static_cast<float>(cx / lc);
  n[1] = static_cast<float>(cy / lc);
  n[2] = static_cast<float>(cz / lc);
  state.has_normal[p] = true;
  for (int i = 0; i < 3; ++i) state.normal[p][i] = n[i];
}

// out[i] = full[src[i]] for i < n: compaction of a skip block.
inline void compact(const float* full, const int16_t* src, int n, float* out) {
  for (int i = 0; i < n; ++i) out[i] = full[src[i]];
}

inline void kernel(const float* local, float hip_height, GeometryState& state, float* out) {
  Scratch s;
  for (int j = 0; j < kJoints; ++j) {
    s.px[j] = local[3 * j];
    s.py[j] = local[3 * j + 1];
    s.pz[j] = local[3 * j + 2];
  }
  for (int j = kJoints; j < 32; ++j) s.px[j] = s.py[j] = s.pz[j] = 0.0f;

  // 1. Jc.
  for (int i = 0; i < 45; ++i) out[kOffsetJc + i] = local[3 + i];
  out[kOffsetJc + 45] = hip_height;

  // 2-3. JJd, JJo. Pair differences: for joint i, the partners i+1..15 are contiguous; each
  // i's batches may spill past its n entries, and the next i overwrites the spill.
  for (int i = 0; i < kJoints - 1; ++i) {
    const int n = kJoints - 1 - i, base = kLayout.pair_base[i];
    const B bx(s.px[i]), by(s.py[i]), bz(s.pz[i]);
    for (int c = 0; c < n; c += W) {
      store(s.dx + base + c, load(s.px + i + 1 + c) - bx);
      store(s.dy + base + c, load(s.py + i + 1 + c) - by);
      store(s.dz + base + c, load(s.pz + i + 1 + c) - bz);
    }
  }
  static_assert(kPairCount % W == 0, "JJd is written in whole batches");
  for (int b = 0; b < kPairCount; b += W) {
    const B x = load(s.dx + b), y = load(s.dy + b), z = load(s.dz + b);
    const B len = xsimd::sqrt(xsimd::fma(x, x, xsimd::fma(y, y, z * z)));
    const B inv = inverse_or_zero(len);
    store(out + kOffsetJJd + b, len);
    store(s.ux + b, x * inv);
    store(s.uy + b, y * inv);
    store(s.uz + b, z * inv);
  }
  for (int p = 0; p < kPairCount; ++p) {
    out[kOffsetJJo + 3 * p] = s.ux[p];
    out[kOffsetJJo + 3 * p + 1] = s.uy[p];
    out[kOffsetJJo + 3 * p + 2] = s.uz[p];
  }

  // Lines: vectors, lengths, unit directions (zero for a zero-length line).
  for (int l = 0; l < kLines; ++l) {
    const int a = kLayout.line[l][0], b = kLayout.line[l][1];
    s.lx[l] = s.px[b] - s.px[a];
    s.ly[l] = s.py[b] - s.py[a];
    s.lz[l] = s.pz[b] - s.pz[a];
  }
  for (int l = kLines; l < 40; ++l) s.lx[l] = s.ly[l] = s.lz[l] = 0.0f;
  for (int b = 0; b < 40; b += W) {
    if (b >= 32) {  // entries 32..39 are padding only
      for (int k = 0; k < W; ++k) s.lux[b + k] = s.luy[b + k] = s.luz[b + k] = s.llen[b + k] = 0.0f;
      continue;
    }
    const B x = load(s.lx + b), y = load(s.ly + b), z = load(s.lz + b);
    const B len = xsimd::sqrt(xsimd::fma(x, x, xsimd::fma(y, y, z * z)));
    const B inv = inverse_or_zero(len);
    store(s.llen + b, len);
    store(s.lux + b, x * inv);
    store(s.luy + b, y * inv);
    store(s.luz + b, z * inv);
  }

  // 4. JLd: distance of every joint to every line, |w x u| with w = P - A and u the unit
  // direction (cross product, not |w|^2 - (w.u)^2, which cancels for joints near the line);
  // |w| for a zero-length line. Then drop each line's two endpoints.
  for (int l = 0; l < kLines; ++l) {
    const int a = kLayout.line[l][0];
    const B ax(s.px[a]), ay(s.py[a]), az(s.pz[a]);
    float* dst = s.jl + 16 * l;
    if (s.llen[l] > 0.0f) {
      const B vx(s.lux[l]), vy(s.luy[l]), vz(s.luz[l]);
      for (int b = 0; b < 16; b += W) {
        const B wx = load(s.px + b) - ax, wy = load(s.py + b) - ay, wz = load(s.pz + b) - az;
        const B cx = xsimd::fms(wy, vz, wz * vy);
        const B cy = xsimd::fms(wz, vx, wx * vz);
        const B cz = xsimd::fms(wx, vy, wy * vx);
        store(dst + b, xsimd::sqrt(xsimd::fma(cx, cx, xsimd::fma(cy, cy, cz * cz))));
      }
    } else {
      for (int b = 0; b < 16; b += W) {
        const B wx = load(s.px + b) - ax, wy = load(s.py + b) - ay, wz = load(s.pz + b) - az;
        store(dst + b, xsimd::sqrt(xsimd::fma(wx, wx, xsimd::fma(wy, wy, wz * wz))));
      }
    }
  }
  compact(s.jl, kLayout.jl_src, kJLCount, out + kOffsetJLd);

  // 5. LLa cosines: for line l the partners l+1..29 are contiguous (spill overwritten as in JJ).
  for (int l = 0; l < kLines - 1; ++l) {
    const int n = kLines - 1 - l, base = kLayout.line_pair_base[l];
    const B vx(s.lux[l]), vy(s.luy[l]), vz(s.luz[l]);
    for (int c = 0; c < n; c += W) {
      const B d = xsimd::fma(load(s.lux + l + 1 + c), vx,
                             xsimd::fma(load(s.luy + l + 1 + c), vy, load(s.luz + l + 1 + c) * vz));
      store(s.ll + base + c, d);
    }
  }
  acos_block(s.ll, kLLCount, out + kOffsetLLa);

  // Plane normals (degenerate rule and memory as the reference).
  for (int p = 0; p < kPlanes; ++p) {
    float n[3];
    plane_normal(s, p, state, n);
    s.nx[p] = n[0];
    s.ny[p] = n[1];
    s.nz[p] = n[2];
  }

  // 6. JPd: signed distance of every joint to every plane, then drop the 3 vertices.
  // 7. LPa cosines of every line with every plane, then drop the 3 lines inside the plane.
  for (int p = 0; p < kPlanes; ++p) {
    const int a = kLayout.plane[p][0];
    const B nx(s.nx[p]), ny(s.ny[p]), nz(s.nz[p]);
    const B ax(s.px[a]), ay(s.py[a]), az(s.pz[a]);
    for (int b = 0; b < 16; b += W) {
      store(s.jp + 16 * p + b,
            xsimd::fma(load(s.px + b) - ax, nx, xsimd::fma(load(s.py + b) - ay, ny, (load(s.pz + b) - az) * nz)));
    }
    for (int b = 0; b < 32; b += W) {
      store(s.lpfull + 32 * p + b, xsimd::fma(load(s.lux + b), nx, xsimd::fma(load(s.luy + b), ny, load(s.luz + b) * nz)));
    }
  }
  compact(s.jp, kLayout.jp_src, kJPCount, out + kOffsetJPd);
  compact(s.lpfull, kLayout.lp_src, kLPCount, s.lp);

  // 8. PPa cosines, after LPa's so that one acos pass covers out[1446..1591).
  for (int i = 0; i < kPPCount; ++i) {
    const int p = kLayout.pp[i][0], q = kLayout.pp[i][1];
    s.lp[kLPCount + i] = s.nx[p] * s.nx[q] + s.ny[p] * s.ny[q] + s.nz[p] * s.nz[q];
  }
  acos_block(s.lp, kLPCount + kPPCount, out + kOffsetLPa);
}

}  // namespace

void static_features(const float* local, float hip_height, GeometryState& state, float* out) noexcept {
  kernel(local, hip_height, state, out);
}
