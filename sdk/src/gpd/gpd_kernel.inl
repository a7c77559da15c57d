// The float32 SIMD kernel of GPD v1 blocks 1..8, written once over an xsimd architecture.
//
// Included by gpd_sse4.cpp and gpd_avx2.cpp INSIDE their own namespace
// (kata::gpd::detail::sse4 / ::avx2) after `using Arch = xsimd::<arch>;`. ODR note: the two
// translation units are compiled for different instruction sets, so they must not share any
// inline function or template instantiation (the linker keeps one copy and could hand the
// AVX2 one to the baseline path). Hence: everything here is in an unnamed namespace nested in
// the ISA namespace, xsimd is used only through batch<float, Arch>, scalar square roots are
// __builtin_sqrt (not std::sqrt), and the tables are plain arrays (gpd_detail.hpp). No heap
// allocation: all scratch is one stack struct.
//
// Data layout: joints, lines and normals as structure-of-arrays (x[], y[], z[]) padded past a
// multiple of the batch width, so each block is a few contiguous batch loops:
// - pair blocks (JJ, LLa) enumerate (i, j > i) lexicographically, so for a fixed i the
//   partners j are contiguous in the SoA arrays and the results contiguous in the output;
// - skip blocks (JLd, JPd, LPa) are computed for every joint/line and then compacted: by lane
//   permutes on AVX2 (KATA_GPD_PERMUTE), by a compile-time source-index table otherwise.
// Square roots, reciprocals and arccos are polynomial/Newton code on the hardware rsqrt
// estimate: float32 results agree with the double reference to ~1e-6 (arccos near 0 or pi:
// ~1e-3, the float rounding of its argument, as the spec allows).

namespace {

using B = xsimd::batch<float, Arch>;
constexpr int W = static_cast<int>(B::size);

// Rounds n up to a multiple of the batch width.
constexpr int padded(int n) { return (n + W - 1) / W * W; }

// Unaligned load / store of one batch.
inline B load(const float* p) { return B::load_unaligned(p); }
inline void store(float* p, const B& v) { v.store_unaligned(p); }

// The largest-magnitude tracker: the kernel folds each batch it writes to `out` into a running
// maximum of the IEEE bit patterns with the sign cleared (the order of the magnitudes, Inf above
// every finite value and NaN above Inf; see gpd::largest_magnitude_bits), so the stream's "is
// the vector finite" check needs no second pass over 1591 values still in flight to memory.
// `lanes` clears the lanes of a batch that the next store overwrites (they are not features).
using U = xsimd::batch<uint32_t, Arch>;
inline U magnitude_bits(const B& v) { return xsimd::bitwise_cast<U>(v) & U(0x7fffffffu); }
inline void track(U& largest, const B& v) { largest = xsimd::max(largest, magnitude_bits(v)); }
inline void track(U& largest, const B& v, const U& lanes) {
  largest = xsimd::max(largest, xsimd::bitwise_cast<U>(v) & lanes);
}
// The sign-clearing mask of the first `valid` (0..W) lanes of a batch, 0 in the others: a
// window into W masks followed by W zeros.
constexpr uint32_t kLaneWindow[16] = {0x7fffffffu, 0x7fffffffu, 0x7fffffffu, 0x7fffffffu, 0x7fffffffu, 0x7fffffffu,
                                      0x7fffffffu, 0x7fffffffu, 0,           0,           0,           0,
                                      0,           0,           0,           0};
static_assert(W <= 8, "kLaneWindow holds batches of up to 8 lanes");
inline U valid_lanes(int valid) { return U::load_unaligned(kLaneWindow + 8 - valid); }
inline uint32_t reduce_max(const U& v) {
  alignas(64) uint32_t m[W];
  v.store_aligned(m);
  uint32_t r = 0;
  for (int l = 0; l < W; ++l) r = r > m[l] ? r : m[l];
  return r;
}

// 1/sqrt(x) to ~3e-7 relative: the hardware estimate (12 bits) and one Newton step, instead of
// sqrt + divide (long-latency, low-throughput units). x is floored at 1e-37 so that x = 0 gives a
// large finite value: then x * rsqrt(x) = 0 and v * rsqrt(|v|^2) = 0, the spec's zero-vector
// rule, with no select. (Only |v| < 3e-19 body heights is affected by the floor.)
// The hardware estimate of 1/sqrt(x): 12 bits on x86 (rsqrtps), but only 8 on ARM (vrsqrte),
// where one extra Newton step brings it to ~16 bits so that the step below ends near float
// precision on every ISA (without it, NEON angles near 0 were off by 2e-3).
inline B rsqrt_estimate(const B& x) {
#if defined(__aarch64__) || defined(__ARM_NEON)
  const B y = xsimd::rsqrt(x);
  return y * xsimd::fnma(B(0.5f) * x, y * y, B(1.5f));
#else
  return xsimd::rsqrt(x);
#endif
}

inline B rsqrt_nr(const B& x) {
  const B xs = xsimd::max(x, B(1e-37f));
  const B y = rsqrt_estimate(xs);
  return y * xsimd::fnma(B(0.5f) * xs, y * y, B(1.5f));
}
// sqrt(x), x >= 0, from the same estimate y ~ 1/sqrt(x) with the Newton step folded into
// g = x y: g + g (1/2 - g y/2) (one op fewer than x * rsqrt_nr(x)); 0 for x = 0.
inline B sqrt_fast(const B& x) {
  const B y = rsqrt_estimate(xsimd::max(x, B(1e-37f)));
  const B g = x * y, h = B(0.5f) * y;
  return xsimd::fma(g, xsimd::fnma(g, h, B(0.5f)), g);
}

// arccos(clamp(x, -1, 1)) in float32, within ~2e-7 (a few float ulps of pi): for a = |x|,
// acos(a) = sqrt(1 - a) P7(a) (Abramowitz & Stegun 4.4.46, |error| <= 2e-8), and
// acos(-a) = pi - acos(a). One branch-free path for the whole range; 1 - a is exact in float.
// The clamp to [-1, 1] matters: sqrt_fast needs 1 - a >= 0.
inline B acos_batch(const B& x) {
  const B a = xsimd::min(xsimd::abs(x), B(1.0f));
  B p(-0.0012624911f);
  p = xsimd::fma(p, a, B(0.0066700901f));
  p = xsimd::fma(p, a, B(-0.0170881256f));
  p = xsimd::fma(p, a, B(0.0308918810f));
  p = xsimd::fma(p, a, B(-0.0501743046f));
  p = xsimd::fma(p, a, B(0.0889789874f));
  p = xsimd::fma(p, a, B(-0.2145988016f));
  p = xsimd::fma(p, a, B(1.5707963050f));
  const B t = sqrt_fast(B(1.0f) - a) * p;
  return xsimd::select(x < B(0.0f), B(3.14159265358979f) - t, t);
}

// dst[0..n) = acos(src[0..n)), n >= W. The tail is one batch ending at n (overlapping the
// previous one), which is only correct because src and dst are different buffers.
// The tail batch's values are features too (recomputed), so all of it is tracked.
inline void acos_block(const float* src, int n, float* dst, U& largest) {
  int i = 0;
  for (; i + W <= n; i += W) {
    const B a = acos_batch(load(src + i));
    track(largest, a);
    store(dst + i, a);
  }
  if (i < n) {
    const B a = acos_batch(load(src + n - W));
    track(largest, a);
    store(dst + n - W, a);
  }
}

#if KATA_GPD_PERMUTE
// Writes one compacted skip-block row (see PermuteTable in gpd_detail.hpp): Out batches of 8
// to dst, the lanes past the row's length (`Length` features) included; tracks the features
// alone when `largest` is given.
template <int In, int Out, int Length>
inline void compact_row(const B (&in)[In], const int32_t (*idx)[8], const int32_t (*next)[8], float* dst,
                        U* largest) {
  static_assert(Length > 8 * (Out - 1) && Length <= 8 * Out, "Out batches hold the row");
  for (int k = 0; k < Out; ++k) {
    const __m256i ix = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(idx[k]));
    __m256 v = _mm256_permutevar8x32_ps(in[k], ix);
    if (k + 1 < In) {
      const __m256 w = _mm256_permutevar8x32_ps(in[k + 1], ix);
      v = _mm256_blendv_ps(v, w, _mm256_loadu_ps(reinterpret_cast<const float*>(next[k])));
    }
    if (largest) {
      if (8 * (k + 1) <= Length) {
        track(*largest, B(v));
      } else {
        track(*largest, B(v), valid_lanes(Length - 8 * k));
      }
    }
    _mm256_storeu_ps(dst + 8 * k, v);
  }
}

// Stores 8 (x, y, z) triples from SoA batches as 24 interleaved floats
//   x0 y0 z0 x1 y1 z1 x2 y2 | z2 x3 y3 z3 x4 y4 z4 x5 | y5 z5 x6 y6 z6 x7 y7 z7
// with in-lane shuffles and 128-bit lane swaps only (cross-lane vpermps is the slow unit).
// Per 128-bit lane: rxy = x0 x2 y0 y2, ryz = y1 y3 z1 z3, rzx = z0 z2 x1 x3, then
// r03 = x0 y0 z0 x1, r14 = y1 z1 x2 y2, r25 = z2 x3 y3 z3 (upper lane: the same for 4..7).
inline void interleave3(const B& x, const B& y, const B& z, float* dst) {
  const __m256 rxy = _mm256_shuffle_ps(x, y, _MM_SHUFFLE(2, 0, 2, 0));
  const __m256 ryz = _mm256_shuffle_ps(y, z, _MM_SHUFFLE(3, 1, 3, 1));
  const __m256 rzx = _mm256_shuffle_ps(z, x, _MM_SHUFFLE(3, 1, 2, 0));
  const __m256 r03 = _mm256_shuffle_ps(rxy, rzx, _MM_SHUFFLE(2, 0, 2, 0));
  const __m256 r14 = _mm256_shuffle_ps(ryz, rxy, _MM_SHUFFLE(3, 1, 2, 0));
  const __m256 r25 = _mm256_shuffle_ps(rzx, ryz, _MM_SHUFFLE(3, 1, 3, 1));
  _mm256_storeu_ps(dst, _mm256_permute2f128_ps(r03, r14, 0x20));
  _mm256_storeu_ps(dst + 8, _mm256_permute2f128_ps(r25, r03, 0x30));
  _mm256_storeu_ps(dst + 16, _mm256_permute2f128_ps(r14, r25, 0x31));
}
#endif

// Per-frame scratch, all on the stack (sizes padded for the overlapping batch stores).
struct Scratch {
  alignas(64) float px[32], py[32], pz[32];                  // joints, zero past 16
  alignas(64) float dx[padded(kPairCount) + W], dy[padded(kPairCount) + W], dz[padded(kPairCount) + W];
  alignas(64) float ux[padded(kPairCount)], uy[padded(kPairCount)], uz[padded(kPairCount)];
  alignas(64) float llen[40];                                // line lengths, zero past 30
  alignas(64) float lux[40], luy[40], luz[40];               // line unit directions
  alignas(64) float ax[32], ay[32], az[32];                  // each line's first joint
  alignas(64) float cax[32], cay[32], caz[32];               // A x u per line
  alignas(64) float jl[kLines * 16];                         // JLd (squared) for every joint
  alignas(64) float ll[kLLCount + W];                        // LLa cosines
  alignas(64) float jp[kPlanes * 16];                        // JPd for every joint
  alignas(64) float lpfull[kPlanes * 32];                    // LPa cosines for every line
  alignas(64) float lp[kLPCount + kPPCount + 8];             // LPa then PPa cosines (+ spill)
  float nx[kPlanes], ny[kPlanes], nz[kPlanes];               // plane normals
};

// Unit normal of plane p from the joints, in double so the degenerate decision and the
// normal are those of the double reference; updates or reads the stream's memory.
inline void plane_normal(const Scratch& s, int p, GeometryState& state, float* n) {
  const int a = kLayout.plane[p][0], b = kLayout.plane[p][1], c = kLayout.plane[p][2];
  const double e1x = double(s.px[b]) - s.px[a], e1y = double(s.py[b]) - s.py[a], e1z = double(s.pz[b]) - s.pz[a];
  const double e2x = double(s.px[c]) - s.px[a], e2y = double(s.py[c]) - s.py[a], e2z = double(s.pz[c]) - s.pz[a];
  const double cx = e1y * e2z - e1z * e2y, cy = e1z * e2x - e1x * e2z, cz = e1x * e2y - e1y * e2x;
  // |c| / (|e1| |e2|) < 1e-3 tested on squares (one square root fewer per plane; the two forms
  // can only disagree within an ulp of the threshold).
  const double c2 = cx * cx + cy * cy + cz * cz;
  const double q = (e1x * e1x + e1y * e1y + e1z * e1z) * (e2x * e2x + e2y * e2y + e2z * e2z);
  if (q == 0.0 || c2 < 1e-6 * q) {
    for (int i = 0; i < 3; ++i) n[i] = state.has_normal[p] ? state.normal[p][i] : 0.0f;
    return;
  }
  const double inv = 1.0 / __builtin_sqrt(c2);
  n[0] = static_cast<float>(cx * inv);
  n[1] = static_cast<float>(cy * inv);
  n[2] = static_cast<float>(cz * inv);
  state.has_normal[p] = true;
  for (int i = 0; i < 3; ++i) state.normal[p][i] = n[i];
}

// out[i] = full[src[i]] for i < n: compaction of a skip block.
inline void compact(const float* full, const int16_t* src, int n, float* out) {
  for (int i = 0; i < n; ++i) out[i] = full[src[i]];
}

// Returns the largest magnitude among out[0..kStaticDims) as its sign-cleared bit pattern
// (what largest_magnitude_bits(out, kStaticDims) returns), tracked as the batches are written.
inline uint32_t kernel(const float* local, float hip_height, GeometryState& state, float* out) {
  Scratch s;
  U largest(0u);
  for (int j = 0; j < kJoints; ++j) {
    s.px[j] = local[3 * j];
    s.py[j] = local[3 * j + 1];
    s.pz[j] = local[3 * j + 2];
  }
  for (int j = kJoints; j < 32; ++j) s.px[j] = s.py[j] = s.pz[j] = 0.0f;

  // 1. Jc: local[3..48) (batches from the input, the last one overlapping) and the hip height.
  for (int i = 0; i < 45; ++i) out[kOffsetJc + i] = local[3 + i];
  out[kOffsetJc + 45] = hip_height;
  static_assert(45 >= W, "Jc is at least one batch");
  for (int i = 0; i + W <= 45; i += W) track(largest, load(local + 3 + i));
  if (45 % W != 0) track(largest, load(local + 3 + 45 - W));
  uint32_t hip_bits;
  __builtin_memcpy(&hip_bits, &hip_height, sizeof hip_bits);
  hip_bits &= 0x7fffffffu;

  // 2-3. JJd, JJo.
#if KATA_GPD_PERMUTE
  // For joint i the partners i+1..15 are contiguous in the SoA arrays and their pairs
  // contiguous in the output, so each i is a run of whole batches written straight out; a
  // run's last batch spills past its n pairs and the next run overwrites the spill. JJo's last
  // spill lands in JLd (written later); JJd's last runs (i >= 12) would spill into JJo, so
  // their batches are stored with a lane mask.
  for (int i = 0; i < kJoints - 1; ++i) {
    const int n = kJoints - 1 - i, base = kLayout.pair_base[i];
    const B bx(s.px[i]), by(s.py[i]), bz(s.pz[i]);
    for (int c = 0; c < n; c += W) {
      const B x = load(s.px + i + 1 + c) - bx, y = load(s.py + i + 1 + c) - by, z = load(s.pz + i + 1 + c) - bz;
      const B sq = xsimd::fma(x, x, xsimd::fma(y, y, z * z));
      const B inv = rsqrt_nr(sq);
      const B d = sq * inv, ux = x * inv, uy = y * inv, uz = z * inv;
      // Lanes past this joint's n pairs are overwritten later: not tracked.
      const U pair_bits = xsimd::max(xsimd::max(magnitude_bits(d), magnitude_bits(ux)),
                                     xsimd::max(magnitude_bits(uy), magnitude_bits(uz)));
      largest = xsimd::max(largest, c + W <= n ? pair_bits : pair_bits & valid_lanes(n - c));
      if (base + c + W <= kPairCount) {
        store(out + kOffsetJJd + base + c, d);
      } else {
        const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        const __m256i keep = _mm256_cmpgt_epi32(_mm256_set1_epi32(kPairCount - base - c), lanes);
        _mm256_maskstore_ps(out + kOffsetJJd + base + c, keep, d);
      }
      interleave3(ux, uy, uz, out + kOffsetJJo + 3 * (base + c));
    }
  }
#else
  // Pair differences: for joint i, the partners i+1..15 are contiguous; each i's batches may
  // spill past its n entries, and the next i overwrites the spill.
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
    const B sq = xsimd::fma(x, x, xsimd::fma(y, y, z * z));
    const B inv = rsqrt_nr(sq);
    const B d = sq * inv, ux = x * inv, uy = y * inv, uz = z * inv;
    track(largest, d);
    track(largest, ux);
    track(largest, uy);
    track(largest, uz);
    store(out + kOffsetJJd + b, d);
    store(s.ux + b, ux);
    store(s.uy + b, uy);
    store(s.uz + b, uz);
  }
  for (int p = 0; p < kPairCount; ++p) {
    out[kOffsetJJo + 3 * p] = s.ux[p];
    out[kOffsetJJo + 3 * p + 1] = s.uy[p];
    out[kOffsetJJo + 3 * p + 2] = s.uz[p];
  }
#endif

  // Lines: every line (a, b) has a < b, so it is JJ pair (a, b): its length and unit
  // direction are that pair's JJd and JJo values (the same float32 numbers).
  for (int l = 0; l < kLines; ++l) {
    const int p = kLayout.line_pair[l];
    s.llen[l] = out[kOffsetJJd + p];
    s.lux[l] = out[kOffsetJJo + 3 * p];
    s.luy[l] = out[kOffsetJJo + 3 * p + 1];
    s.luz[l] = out[kOffsetJJo + 3 * p + 2];
  }
  for (int l = kLines; l < 40; ++l) s.lux[l] = s.luy[l] = s.luz[l] = s.llen[l] = 0.0f;

  // 4. JLd: distance of every joint to every line, |(P - A) x u| with A the line's first joint
  // and u its unit direction (a cross product, not |w|^2 - (w.u)^2, which cancels for joints
  // near the line), expanded as P x u - A x u with A x u computed for all lines at once; |P - A|
  // for a zero-length line. Two passes (squared distances into s.jl, then square roots and the
  // compaction that drops each line's two endpoints) keep each loop's dependency chain short.
  for (int l = 0; l < kLines; ++l) {
    const int a = kLayout.line[l][0];
    s.ax[l] = s.px[a];
    s.ay[l] = s.py[a];
    s.az[l] = s.pz[a];
  }
  for (int l = kLines; l < 32; ++l) s.ax[l] = s.ay[l] = s.az[l] = 0.0f;
  for (int b = 0; b < 32; b += W) {
    const B ax = load(s.ax + b), ay = load(s.ay + b), az = load(s.az + b);
    const B ux = load(s.lux + b), uy = load(s.luy + b), uz = load(s.luz + b);
    store(s.cax + b, xsimd::fms(ay, uz, az * uy));
    store(s.cay + b, xsimd::fms(az, ux, ax * uz));
    store(s.caz + b, xsimd::fms(ax, uy, ay * ux));
  }
  for (int l = 0; l < kLines; ++l) {
    float* dst = s.jl + 16 * l;
    if (s.llen[l] > 0.0f) {
      const B vx(s.lux[l]), vy(s.luy[l]), vz(s.luz[l]);
      const B cax(s.cax[l]), cay(s.cay[l]), caz(s.caz[l]);
      for (int b = 0; b < 16; b += W) {
        const B px = load(s.px + b), py = load(s.py + b), pz = load(s.pz + b);
        const B cx = xsimd::fms(py, vz, xsimd::fma(pz, vy, cax));
        const B cy = xsimd::fms(pz, vx, xsimd::fma(px, vz, cay));
        const B cz = xsimd::fms(px, vy, xsimd::fma(py, vx, caz));
        store(dst + b, xsimd::fma(cx, cx, xsimd::fma(cy, cy, cz * cz)));
      }
    } else {
      const B ax(s.ax[l]), ay(s.ay[l]), az(s.az[l]);
      for (int b = 0; b < 16; b += W) {
        const B wx = load(s.px + b) - ax, wy = load(s.py + b) - ay, wz = load(s.pz + b) - az;
        store(dst + b, xsimd::fma(wx, wx, xsimd::fma(wy, wy, wz * wz)));
      }
    }
  }
#if KATA_GPD_PERMUTE
  for (int l = 0; l < kLines; ++l) {
    const B row[2] = {sqrt_fast(load(s.jl + 16 * l)), sqrt_fast(load(s.jl + 16 * l + 8))};
    // 2 floats past the row are written too; the next line (or, after line 29, LLa) overwrites them.
    compact_row<2, 2, kJoints - 2>(row, kJLPermute.idx[l], kJLPermute.next[l], out + kOffsetJLd + (kJoints - 2) * l,
                                   &largest);
  }
#else
  // Tracked over every joint but the line's two endpoints (the ones compaction drops).
  for (int l = 0; l < kLines; ++l) {
    for (int b = 0; b < 16; b += W) {
      const B r = sqrt_fast(load(s.jl + 16 * l + b));
      track(largest, r, U::load_aligned(kJLFeatureLanes.mask[l] + b));
      store(s.jl + 16 * l + b, r);
    }
  }
  compact(s.jl, kLayout.jl_src, kJLCount, out + kOffsetJLd);
#endif

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
  acos_block(s.ll, kLLCount, out + kOffsetLLa, largest);

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
    B jrow[16 / W], lrow[32 / W];
    for (int b = 0; b < 16; b += W) {
      jrow[b / W] = xsimd::fma(load(s.px + b) - ax, nx, xsimd::fma(load(s.py + b) - ay, ny, (load(s.pz + b) - az) * nz));
    }
    for (int b = 0; b < 32; b += W) {
      lrow[b / W] = xsimd::fma(load(s.lux + b), nx, xsimd::fma(load(s.luy + b), ny, load(s.luz + b) * nz));
    }
#if KATA_GPD_PERMUTE
    // Spills past a row are overwritten by the next row; JPd's last one by LPa's acos pass
    // below, LPa's last one (into s.lp[135..140)) by the PPa cosines.
    compact_row<2, 2, kJoints - 3>(jrow, kJPPermute.idx[p], kJPPermute.next[p], out + kOffsetJPd + (kJoints - 3) * p,
                                   &largest);
    // LPa's cosines go to scratch: their arccos is what is tracked.
    compact_row<4, 4, kLines - 3>(lrow, kLPPermute.idx[p], kLPPermute.next[p], s.lp + (kLines - 3) * p, nullptr);
#else
    for (int b = 0; b < 16; b += W) {
      track(largest, jrow[b / W], U::load_aligned(kJPFeatureLanes.mask[p] + b));
      store(s.jp + 16 * p + b, jrow[b / W]);
    }
    for (int b = 0; b < 32; b += W) store(s.lpfull + 32 * p + b, lrow[b / W]);
#endif
  }
#if !KATA_GPD_PERMUTE
  compact(s.jp, kLayout.jp_src, kJPCount, out + kOffsetJPd);
  compact(s.lpfull, kLayout.lp_src, kLPCount, s.lp);
#endif

  // 8. PPa cosines, after LPa's so that one acos pass covers out[1446..1591).
  for (int i = 0; i < kPPCount; ++i) {
    const int p = kLayout.pp[i][0], q = kLayout.pp[i][1];
    s.lp[kLPCount + i] = s.nx[p] * s.nx[q] + s.ny[p] * s.ny[q] + s.nz[p] * s.nz[q];
  }
  acos_block(s.lp, kLPCount + kPPCount, out + kOffsetLPa, largest);
  const uint32_t r = reduce_max(largest);
  return r > hip_bits ? r : hip_bits;
}

}  // namespace

uint32_t static_features(const float* local, float hip_height, GeometryState& state, float* out) noexcept {
  return kernel(local, hip_height, state, out);
}

uint32_t largest_magnitude_bits(const float* v, int n) noexcept {
  // Sixteen lanes: whole vectors on every ISA, and independent max chains for the vector units.
  uint32_t lane[16] = {};
  int i = 0;
  for (; i + 16 <= n; i += 16)
    for (int l = 0; l < 16; ++l) {
      uint32_t b;
      __builtin_memcpy(&b, v + i + l, sizeof b);
      lane[l] = lane[l] > (b & 0x7fffffffu) ? lane[l] : (b & 0x7fffffffu);
    }
  for (; i < n; ++i) {
    uint32_t b;
    __builtin_memcpy(&b, v + i, sizeof b);
    lane[0] = lane[0] > (b & 0x7fffffffu) ? lane[0] : (b & 0x7fffffffu);
  }
  uint32_t m = 0;
  for (int l = 0; l < 16; ++l) m = m > lane[l] ? m : lane[l];
  return m;
}
