// The projection kernels of the scorer, written once over an xsimd architecture.
//
// Included by kernels_base.cpp, kernels_avx2.cpp and kernels_avx512.cpp INSIDE their own
// namespace (kata::metric::detail::base / ::avx2 / ::avx512) after `using Arch = xsimd::<arch>;`.
// ODR note (as for gpd_kernel.inl): the translation units are compiled for different instruction
// sets, so nothing here may be an inline function or template instantiation shared between them:
// every helper lives in an unnamed namespace nested in the ISA namespace and xsimd is used only
// through batch<float, Arch>.
//
// Columns that do not fill a whole batch: rows of the blocked W are unpadded (kernels.hpp), so
// instead of masked loads (which xsimd does not offer on every architecture) the last vector of
// a row is loaded so that it ENDS at the row's last column, overlapping the vector before it.
// Both vectors compute the overlapped columns with the same operations in the same order, so
// they hold identical values and storing both is harmless. Nothing is read or written outside
// the row or the output. Chunks narrower than one batch take a scalar loop.
//
// Bit-for-bit: within one ISA every output column is the same sequence of (fused, where the ISA
// has FMA) multiply-adds over the rows in order, starting from 0, in the single-frame, batched
// and scalar paths alike; so the batched kernel equals the single-frame one exactly.

namespace {

using B = xsimd::batch<float, Arch>;
constexpr int W = static_cast<int>(B::size);
// Accumulator vectors per pass of the single-frame kernel (16 registers on SSE/AVX2/NEON-32
// would spill beyond 8 with the row loads; AVX-512 has 32 but a 64-column chunk needs only 4).
constexpr int kMaxNV = 8;
// Frames per pass of the batched kernel: every W vector is converted once per pass, so more frames
// per pass leave the multiply-adds alone (4 x 16-column vectors per row and frame). AVX-512 has
// 32 registers and takes 8 (the conversion, 2 of the 6 vector operations per row and frame at
// 4 frames, is 1 of 5 at 8); the 16-register ISAs take 4 (more would spill the accumulators).
constexpr int kPassFrames = W >= 16 ? 8 : 4;
// Column vectors per slab of the batched kernel: F x NV accumulators + NV row vectors + one
// broadcast must fit the register file (16 on AVX2, 32 on AVX-512: 8 x 3 + 3 + 1 = 28).
template <int F>
constexpr int slab_nv() {
  return W >= 16 ? (F <= 4 ? 4 : 3) : 2;
}
// Rows per tile of the batched kernel: a tile of W (64 x 50 floats, 12.8 KB) stays in L1 while
// every column slab of every frame passes over it, so W streams from L2 once per batch.
constexpr int kTile = 64;

inline B load(const float* p) { return B::load_unaligned(p); }
// W values: W 16-bit integers widened and converted in registers (one load of half the bytes).
inline B load_w(const int16_t* p) {
#if defined(__AVX512F__)
  static_assert(W == 16, "AVX-512 batches hold 16 floats");
  // (the maskz forms: GCC 12 warns on the plain ones, whose pass-through lanes are undefined)
  const __m512i q = _mm512_maskz_cvtepi16_epi32(0xFFFF, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)));
  return B(_mm512_maskz_cvtepi32_ps(0xFFFF, q));
#elif defined(__AVX2__)
  static_assert(W == 8, "AVX2 batches hold 8 floats");
  return B(_mm256_cvtepi32_ps(_mm256_cvtepi16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)))));
#elif defined(__SSE4_1__)
  static_assert(W == 4, "SSE batches hold 4 floats");
  return B(_mm_cvtepi32_ps(_mm_cvtepi16_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)))));
#elif defined(__aarch64__)
  static_assert(W == 4, "NEON batches hold 4 floats");
  return B(vcvtq_f32_s32(vmovl_s16(vld1_s16(p))));
#else
  alignas(64) float f[W];
  for (int i = 0; i < W; ++i) f[i] = static_cast<float>(p[i]);
  return B::load_aligned(f);
#endif
}
inline void store(float* p, const B& v) { v.store_unaligned(p); }
// acc + w * x with the ISA's multiply-add (fused where it exists); the same everywhere below.
// xsimd 8 has no fused AVX-512 fma (its generic x * y + z may or may not be contracted), so
// that one ISA names the instruction; every other build takes xsimd's.
inline B madd(const B& w, const B& x, const B& acc) {
#if defined(__AVX512F__)
  return B(_mm512_fmadd_ps(w, x, acc));
#else
  return xsimd::fma(w, x, acc);
#endif
}
// The scalar twin of madd, for chunks narrower than a batch: fused iff the ISA fuses.
inline float madd1(float w, float x, float acc) {
#if defined(__FMA__) || defined(__aarch64__)
  return __builtin_fmaf(w, x, acc);
#else
  return w * x + acc;
#endif
}

// Column offsets of the nv vectors covering [c0, c0 + n) (n >= 1, c0 + n - W >= 0): full
// vectors from c0, the last one ending at c0 + n.
inline void vector_offsets(int c0, int n, int nv, int* off) {
  for (int v = 0; v + 1 < nv; ++v) off[v] = c0 + W * v;
  off[nv - 1] = c0 + n - W;
}

// One pass of one group of one chunk: NV vectors at columns off[] over rows [begin, end).
// How far ahead of the row being multiplied W is prefetched, bytes. A paced frame finds W in
// memory, and the hardware prefetchers stop at every 4 KiB page: without a software prefetch each
// page would begin with a demand miss (and, under a hypervisor, a cold two-level page walk). One
// page ahead covers the memory latency at the rate the rows are consumed; in a hot frame the
// prefetches hit L1/L2 and cost an issue slot each.
constexpr int kPrefetchAhead = 4096;
inline void prefetch_row(const int16_t* row, int stride) {
  const char* p = reinterpret_cast<const char*>(row) + kPrefetchAhead;
  // Two lines per row: rows up to 64 int16 columns (128 bytes) stay covered.
  __builtin_prefetch(p);
  if (stride > 32) __builtin_prefetch(p + 64);
}
// The first page of a pass, which no earlier row prefetched.
inline void prefetch_start(const int16_t* rows) {
  const char* p = reinterpret_cast<const char*>(rows);
  for (int b = 0; b < kPrefetchAhead; b += 64) __builtin_prefetch(p + b);
}

// The sums are multiplied by the column scales (scale: the chunk's first column) as they are
// stored: the same single rounding as the batched kernel's last tile (slab, kLast).
template <int NV>
void group_pass(const int16_t* rows, int stride, const float* xp, const int* perm, int begin, int end, const int* off,
                const float* scale, float* out) {
  B acc[NV];
  for (int v = 0; v < NV; ++v) acc[v] = B(0.0f);
  for (int i = begin; i < end; ++i) {
    const B xi(xp[perm[i]]);
    const int16_t* row = rows + static_cast<ptrdiff_t>(i) * stride;
    prefetch_row(row, stride);
    for (int v = 0; v < NV; ++v) acc[v] = madd(load_w(row + off[v]), xi, acc[v]);
  }
  for (int v = 0; v < NV; ++v) store(out + off[v], acc[v] * load(scale + off[v]));
}

using PassFn = void (*)(const int16_t*, int, const float*, const int*, int, int, const int*, const float*, float*);

PassFn pick_pass(int nv) {
  switch (nv) {
    case 1: return &group_pass<1>;
    case 2: return &group_pass<2>;
    case 3: return &group_pass<3>;
    case 4: return &group_pass<4>;
    case 5: return &group_pass<5>;
    case 6: return &group_pass<6>;
    case 7: return &group_pass<7>;
    default: return &group_pass<8>;
  }
}

// A chunk narrower than one batch: scalar, the accumulator row on the stack.
void group_narrow(const int16_t* rows, int width, const float* xp, const int* perm, int begin, int end,
                  const float* scale, float* out) {
  float acc[W] = {};
  for (int i = begin; i < end; ++i) {
    const float xi = xp[perm[i]];
    const int16_t* row = rows + static_cast<ptrdiff_t>(i) * width;
    for (int c = 0; c < width; ++c) acc[c] = madd1(static_cast<float>(row[c]), xi, acc[c]);
  }
  for (int c = 0; c < width; ++c) out[c] = acc[c] * scale[c];
}

// Zeroes the padding columns [width, round8(width)) of one output row.
inline void zero_padding(float* out, int width) {
  const int padded = (width + 7) / 8 * 8;
  for (int c = width; c < padded; ++c) out[c] = 0.0f;
}

// F frames x NV vectors at columns off[] over rows [begin, end), accumulated into out[f] (which
// holds the running sums of the previous tiles; the first tile starts from 0 instead, so the
// outputs need no zeroing pass: a fused multiply-add onto 0 rounds exactly as onto a loaded 0).
// The group's last tile (kLast) multiplies the sums by the column scales as it stores them, the
// single rounding of group_pass's store (scale: the chunk's first column); no separate pass over
// the outputs. The overlapped vectors of a row hold identical sums, so both scaled stores agree.
template <int F, int NV, bool kFirst, bool kLast>
void slab(const int16_t* rows, int stride, const float* const* xp, const int* perm, int begin, int end, const int* off,
          const float* scale, float* const* out) {
  B acc[F][NV];
  for (int f = 0; f < F; ++f)
    for (int v = 0; v < NV; ++v) acc[f][v] = kFirst ? B(0.0f) : load(out[f] + off[v]);
  for (int i = begin; i < end; ++i) {
    const int16_t* row = rows + static_cast<ptrdiff_t>(i) * stride;
    B w[NV];
    for (int v = 0; v < NV; ++v) w[v] = load_w(row + off[v]);
    const int src = perm[i];
    for (int f = 0; f < F; ++f) {
      const B xi(xp[f][src]);
      for (int v = 0; v < NV; ++v) acc[f][v] = madd(w[v], xi, acc[f][v]);
    }
  }
  if constexpr (kLast) {
    B s[NV];
    for (int v = 0; v < NV; ++v) s[v] = load(scale + off[v]);
    for (int f = 0; f < F; ++f)
      for (int v = 0; v < NV; ++v) store(out[f] + off[v], acc[f][v] * s[v]);
  } else {
    for (int f = 0; f < F; ++f)
      for (int v = 0; v < NV; ++v) store(out[f] + off[v], acc[f][v]);
  }
}

template <int F>
using SlabFn = void (*)(const int16_t*, int, const float* const*, const int*, int, int, const int*, const float*,
                        float* const*);

template <int F, bool kFirst, bool kLast>
SlabFn<F> pick_slab_of(int nv) {
  constexpr int kSlabMax = slab_nv<F>();
  static_assert(kSlabMax >= 2 && kSlabMax <= 4, "pick_slab covers 1..4 vectors");
  switch (nv) {
    case 1: return &slab<F, 1, kFirst, kLast>;
    case 2: return &slab<F, 2, kFirst, kLast>;
    case 3: if constexpr (kSlabMax >= 3) return &slab<F, 3, kFirst, kLast>; [[fallthrough]];
    default: return &slab<F, kSlabMax, kFirst, kLast>;
  }
}

template <int F>
SlabFn<F> pick_slab(int nv, bool first, bool last) {
  if (first) return last ? pick_slab_of<F, true, true>(nv) : pick_slab_of<F, true, false>(nv);
  return last ? pick_slab_of<F, false, true>(nv) : pick_slab_of<F, false, false>(nv);
}

void project_one(const BlockedW& w, const float* xp, float* v) {
  for (int c0 = 0; c0 < w.rank; c0 += kChunk) {
    const int width = w.rank - c0 < kChunk ? w.rank - c0 : kChunk;
    const int16_t* rows = w.data + static_cast<ptrdiff_t>(w.rows) * c0;
    const float* scale = w.column_scale + c0;
    prefetch_start(rows);
    for (int g = 0; g < w.groups; ++g) {
      float* out = v + static_cast<ptrdiff_t>(g) * w.out_stride + c0;
      if (width < W) {
        group_narrow(rows, width, xp, w.perm, w.group_begin[g], w.group_begin[g + 1], scale, out);
      } else {
        for (int p0 = 0; p0 < width; p0 += kMaxNV * W) {
          const int n = width - p0 < kMaxNV * W ? width - p0 : kMaxNV * W;
          const int nv = (n + W - 1) / W;
          int off[kMaxNV];
          vector_offsets(p0, n, nv, off);
          pick_pass(nv)(rows, width, xp, w.perm, w.group_begin[g], w.group_begin[g + 1], off, scale, out);
        }
      }
      zero_padding(out, width);
    }
  }
}

template <int F>
void project_many(const BlockedW& w, const float* const* xp, float* const* v) {
  float* out[F];
  for (int c0 = 0; c0 < w.rank; c0 += kChunk) {
    const int width = w.rank - c0 < kChunk ? w.rank - c0 : kChunk;
    const int16_t* rows = w.data + static_cast<ptrdiff_t>(w.rows) * c0;
    const float* scale = w.column_scale + c0;
    for (int g = 0; g < w.groups; ++g) {
      for (int f = 0; f < F; ++f) out[f] = v[f] + static_cast<ptrdiff_t>(g) * w.out_stride + c0;
      if (width < W) {
        for (int f = 0; f < F; ++f) {
          group_narrow(rows, width, xp[f], w.perm, w.group_begin[g], w.group_begin[g + 1], scale, out[f]);
          zero_padding(out[f], width);
        }
        continue;
      }
      const int nv = (width + W - 1) / W;
      int off[kChunk / W + 1];
      vector_offsets(0, width, nv, off);
      constexpr int kNV = slab_nv<F>();
      const int lead = nv % kNV != 0 ? nv % kNV : kNV;  // vectors of the first slab
      if (w.group_begin[g] == w.group_begin[g + 1])  // an empty group: no tile writes its sums
        for (int f = 0; f < F; ++f)
          for (int c = 0; c < width; ++c) out[f][c] = 0.0f;
      for (int t0 = w.group_begin[g]; t0 < w.group_begin[g + 1]; t0 += kTile) {
        const int t1 = t0 + kTile < w.group_begin[g + 1] ? t0 + kTile : w.group_begin[g + 1];
        // Slabs are cut from the END of the vector list: the last vector overlaps the one before
        // it, and both must be in one slab (a later slab would reload sums the earlier slab had
        // already advanced through this tile, and add the tile twice).
        for (int v0 = 0, n = lead; v0 < nv; v0 += n, n = kNV)
          pick_slab<F>(n, t0 == w.group_begin[g], t1 == w.group_begin[g + 1])(rows, width, xp, w.perm, t0, t1,
                                                                              off + v0, scale, out);
      }
      for (int f = 0; f < F; ++f) zero_padding(out[f], width);
    }
  }
}

#if defined(__AVX512F__)
// ---- The pair-packed W (kernels.hpp BlockedW::pairs), AVX-512 only ----
// Per 16 words (32 columns) and frame: one load, a byte shuffle moving each word's low half to
// its high half (the low column's integer x 2^16, exact), two conversions (the raw word is the
// high column's integer x 2^16 plus the low half's bits, compensated by pack_pair) and two
// multiply-adds. The sums are multiplied by scale / 2^16 (exact) as they are stored. A chunk's
// h words per row are covered by vectors at word 0 and 16, each from its own block, whole: the
// lanes past the row's words read the next row (or the padding after W, kernels.hpp) and are
// never stored (masked stores). No overlap, so the batched kernel's one-vector slabs never add a tile twice; single
// and batched run the same lane operations in the same row order, so they agree bit for bit.
// (Masked loads in the loops would be cleaner, but GCC 12 then keeps every accumulator in memory.)
// (xsimd's batch as the accumulator type: GCC 12 keeps arrays of raw __m512 in memory here.)
using PB = B;
using PI = __m512i;

inline PI low_half_up() {
  // Per dword: bytes 0, 1 -> 2, 3; bytes 0, 1 zeroed (a control byte with its top bit set).
  return _mm512_set4_epi32(0x0D0C8080, 0x09088080, 0x05048080, 0x01008080);
}
inline __mmask16 lanes(int n) {
  return n >= 16 ? static_cast<__mmask16>(0xFFFF) : n <= 0 ? static_cast<__mmask16>(0) : static_cast<__mmask16>((1u << n) - 1u);
}
inline __m512 cvt(PI q) { return _mm512_maskz_cvtepi32_ps(0xFFFF, q); }

// The column layout of one chunk's word vectors: vector v covers words [16 v, 16 v + 16) of the
// h words of a row, read from block v of the chunk (kernels.hpp: block[v] words from the chunk's
// start, stride[v] words per row); load[v] its words, high[v] the columns its high halves write.
struct PairVectors {
  int nv = 0, h = 0;
  int stride[2] = {0, 0};
  ptrdiff_t block[2] = {0, 0};
  __mmask16 load[2] = {0, 0}, high[2] = {0, 0};
};
inline PairVectors pair_vectors(int width, int rows) {
  PairVectors p;
  p.h = pair_words(width);
  p.nv = (p.h + 15) / 16;
  for (int v = 0; v < p.nv; ++v) {
    p.load[v] = lanes(p.h - 16 * v);
    p.high[v] = lanes(width - p.h - 16 * v);  // high halves of words k < width - h are columns
    p.stride[v] = p.h - 16 * v < 16 ? p.h - 16 * v : 16;
    p.block[v] = static_cast<ptrdiff_t>(rows) * 16 * v;
  }
  return p;
}
inline void prefetch_pair_row(const uint32_t* row) { __builtin_prefetch(reinterpret_cast<const char*>(row) + kPrefetchAhead); }
// The first page of each block of a chunk, which no earlier row prefetched.
inline void prefetch_pair_start(const uint32_t* rows, const PairVectors& pv) {
  for (int v = 0; v < pv.nv; ++v) prefetch_start(reinterpret_cast<const int16_t*>(rows + pv.block[v]));
}

// The words at p, in a register: without the empty asm GCC folds the load into the conversion
// and loads every vector twice (the shuffle needs it too), two loads that mostly cross a line.
inline PI load_words(const uint32_t* p) {
  PI q = _mm512_loadu_si512(p);
  asm("" : "+v"(q));
  return q;
}
// One word vector's multiply-adds: lo / hi accumulate the low / high columns.
inline void pair_madd(PI q, PI up, PB xi, PB& lo, PB& hi) {
  hi = PB(_mm512_fmadd_ps(cvt(q), xi, hi));
  lo = PB(_mm512_fmadd_ps(cvt(_mm512_shuffle_epi8(q, up)), xi, lo));
}
// The sums of word vector v scaled by scale / 2^16 and stored to their columns.
inline void pair_store(const PairVectors& pv, int v, const float* scale, PB lo, PB hi, float* out) {
  const __m512 unit = _mm512_set1_ps(1.0f / 65536.0f);
  const __m512 sl = _mm512_mul_ps(_mm512_maskz_loadu_ps(pv.load[v], scale + 16 * v), unit);
  const __m512 sh = _mm512_mul_ps(_mm512_maskz_loadu_ps(pv.high[v], scale + pv.h + 16 * v), unit);
  _mm512_mask_storeu_ps(out + 16 * v, pv.load[v], _mm512_mul_ps(lo, sl));
  _mm512_mask_storeu_ps(out + pv.h + 16 * v, pv.high[v], _mm512_mul_ps(hi, sh));
}

// (Named accumulators, not arrays: GCC 12 keeps an array of __m512 in memory here.)
template <int NV>
void pair_pass(const uint32_t* rows, const PairVectors& pv, const float* xp, const int* perm, int begin, int end,
               const float* scale, float* out) {
  const PI up = low_half_up();
  const int s0 = pv.stride[0], s1 = pv.stride[1];
  const uint32_t* rows0 = rows + pv.block[0];
  const uint32_t* rows1 = rows + pv.block[1];
  PB lo0(0.0f), hi0(0.0f), lo1(0.0f), hi1(0.0f);
  for (int i = begin; i < end; ++i) {
    const PB xi(xp[perm[i]]);
    const uint32_t* row0 = rows0 + static_cast<ptrdiff_t>(i) * s0;
    prefetch_pair_row(row0);
    pair_madd(load_words(row0), up, xi, lo0, hi0);
    if constexpr (NV == 2) {
      const uint32_t* row1 = rows1 + static_cast<ptrdiff_t>(i) * s1;
      prefetch_pair_row(row1);
      pair_madd(load_words(row1), up, xi, lo1, hi1);
    }
  }
  pair_store(pv, 0, scale, lo0, hi0, out);
  if constexpr (NV == 2) pair_store(pv, 1, scale, lo1, hi1, out);
}

void project_one_pairs(const BlockedW& w, const float* xp, float* v) {
  for (int c0 = 0; c0 < w.rank; c0 += kChunk) {
    const int width = w.rank - c0 < kChunk ? w.rank - c0 : kChunk;
    const PairVectors pv = pair_vectors(width, w.rows);
    const uint32_t* rows = w.pairs + static_cast<ptrdiff_t>(w.rows) * (c0 / 2);
    const float* scale = w.column_scale + c0;
    prefetch_pair_start(rows, pv);
    for (int g = 0; g < w.groups; ++g) {
      float* out = v + static_cast<ptrdiff_t>(g) * w.out_stride + c0;
      (pv.nv == 1 ? &pair_pass<1> : &pair_pass<2>)(rows, pv, xp, w.perm, w.group_begin[g], w.group_begin[g + 1], scale,
                                                   out);
      zero_padding(out, width);
    }
  }
}

// F frames x one word vector (2 x 16 columns) over rows [begin, end) of a tile, accumulated into
// out[f] as slab() does (kFirst: from 0; kLast: scaled as stored).
template <int F, bool kFirst, bool kLast>
void pair_slab(const uint32_t* rows, const PairVectors& pv, int v, const float* const* xp, const int* perm, int begin,
               int end, const float* scale, float* const* out) {
  const PI up = low_half_up();
  const __mmask16 m[2] = {pv.load[v], pv.high[v]};
  const int off[2] = {16 * v, pv.h + 16 * v};
  const int stride = pv.stride[v];
  const uint32_t* block = rows + pv.block[v];
  B acc[F][2];  // [f][0]: the low columns, [f][1]: the high ones
  for (int f = 0; f < F; ++f)
    for (int k = 0; k < 2; ++k) acc[f][k] = kFirst ? B(0.0f) : B(_mm512_maskz_loadu_ps(m[k], out[f] + off[k]));
  for (int i = begin; i < end; ++i) {
    const PI q = load_words(block + static_cast<ptrdiff_t>(i) * stride);
    B wv[2];
    wv[0] = B(cvt(_mm512_shuffle_epi8(q, up)));
    wv[1] = B(cvt(q));
    const int src = perm[i];
    for (int f = 0; f < F; ++f) {
      const B xi(xp[f][src]);
      for (int k = 0; k < 2; ++k) acc[f][k] = madd(wv[k], xi, acc[f][k]);
    }
  }
  if constexpr (kLast) {
    const __m512 unit = _mm512_set1_ps(1.0f / 65536.0f);
    B s[2];
    for (int k = 0; k < 2; ++k) s[k] = B(_mm512_mul_ps(_mm512_maskz_loadu_ps(m[k], scale + off[k]), unit));
    for (int f = 0; f < F; ++f)
      for (int k = 0; k < 2; ++k) acc[f][k] = acc[f][k] * s[k];
  }
  for (int f = 0; f < F; ++f)
    for (int k = 0; k < 2; ++k) _mm512_mask_storeu_ps(out[f] + off[k], m[k], acc[f][k]);
}

template <int F>
void project_many_pairs(const BlockedW& w, const float* const* xp, float* const* v) {
  float* out[F];
  for (int c0 = 0; c0 < w.rank; c0 += kChunk) {
    const int width = w.rank - c0 < kChunk ? w.rank - c0 : kChunk;
    const PairVectors pv = pair_vectors(width, w.rows);
    const uint32_t* rows = w.pairs + static_cast<ptrdiff_t>(w.rows) * (c0 / 2);
    const float* scale = w.column_scale + c0;
    for (int g = 0; g < w.groups; ++g) {
      for (int f = 0; f < F; ++f) out[f] = v[f] + static_cast<ptrdiff_t>(g) * w.out_stride + c0;
      const int begin = w.group_begin[g], end = w.group_begin[g + 1];
      if (begin == end)  // an empty group: no tile writes its sums
        for (int f = 0; f < F; ++f)
          for (int c = 0; c < width; ++c) out[f][c] = 0.0f;
      for (int t0 = begin; t0 < end; t0 += kTile) {
        const int t1 = t0 + kTile < end ? t0 + kTile : end;
        const bool first = t0 == begin, last = t1 == end;
        for (int vec = 0; vec < pv.nv; ++vec) {
          if (first && last) pair_slab<F, true, true>(rows, pv, vec, xp, w.perm, t0, t1, scale, out);
          else if (first) pair_slab<F, true, false>(rows, pv, vec, xp, w.perm, t0, t1, scale, out);
          else if (last) pair_slab<F, false, true>(rows, pv, vec, xp, w.perm, t0, t1, scale, out);
          else pair_slab<F, false, false>(rows, pv, vec, xp, w.perm, t0, t1, scale, out);
        }
      }
      for (int f = 0; f < F; ++f) zero_padding(out[f], width);
    }
  }
}
#endif  // __AVX512F__

}  // namespace

void project_groups(const BlockedW& w, const float* xp, float* v) {
#if defined(__AVX512F__)
  if (w.pairs) return project_one_pairs(w, xp, v);
#endif
  project_one(w, xp, v);
}

void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n) {
#if defined(__AVX512F__)
  if (w.pairs) {
    for (; n > 8; n -= 8, xp += 8, v += 8) project_many_pairs<8>(w, xp, v);
    switch (n) {
      case 1: project_one_pairs(w, xp[0], v[0]); break;
      case 2: project_many_pairs<2>(w, xp, v); break;
      case 3: project_many_pairs<3>(w, xp, v); break;
      case 4: project_many_pairs<4>(w, xp, v); break;
      case 5: project_many_pairs<5>(w, xp, v); break;
      case 6: project_many_pairs<6>(w, xp, v); break;
      case 7: project_many_pairs<7>(w, xp, v); break;
      case 8: project_many_pairs<8>(w, xp, v); break;
      default: break;
    }
    return;
  }
#endif
  // More frames than one pass takes: passes of kPassFrames (each frame's sums are the same
  // operations whatever pass it is in).
  for (; n > kPassFrames; n -= kPassFrames, xp += kPassFrames, v += kPassFrames)
    project_many<kPassFrames>(w, xp, v);
  switch (n) {
    case 1: project_one(w, xp[0], v[0]); break;
    case 2: project_many<2>(w, xp, v); break;
    case 3: project_many<3>(w, xp, v); break;
    case 4: project_many<4>(w, xp, v); break;
    default:
      if constexpr (kPassFrames == 8) {
        switch (n) {
          case 5: project_many<5>(w, xp, v); break;
          case 6: project_many<6>(w, xp, v); break;
          case 7: project_many<7>(w, xp, v); break;
          case 8: project_many<8>(w, xp, v); break;
          default: break;
        }
      }
      break;
  }
}

namespace {
// One output row with all NV column vectors in registers: NV independent FMA chains through the
// row's groups (one vector at a time would wait on the FMA latency at every group).
template <int NV>
void combine_row(const Combine& c, int r, const float* v, int stride, float scale, const int* off, float* o) {
  B acc[NV];
  for (int i = 0; i < NV; ++i) acc[i] = B(0.0f);
  for (int k = c.row_begin[r]; k < c.row_begin[r + 1]; ++k) {
    const B wk(c.weight[k] * scale);
    const float* vg = v + static_cast<ptrdiff_t>(c.group[k]) * stride;
    for (int i = 0; i < NV; ++i) acc[i] = madd(wk, load(vg + off[i]), acc[i]);
  }
  for (int i = 0; i < NV; ++i) store(o + off[i], acc[i]);
}

using CombineRowFn = void (*)(const Combine&, int, const float*, int, float, const int*, float*);

CombineRowFn pick_combine_row(int nv) {
  switch (nv) {
    case 1: return &combine_row<1>;
    case 2: return &combine_row<2>;
    case 3: return &combine_row<3>;
    case 4: return &combine_row<4>;
    case 5: return &combine_row<5>;
    case 6: return &combine_row<6>;
    case 7: return &combine_row<7>;
    case 8: return &combine_row<8>;
    default: return nullptr;
  }
}
}  // namespace

void combine(const Combine& c, const float* v, int stride, float scale, float* out) {
  // Each output row: the weighted groups added in registers, every column the same chain of
  // multiply-adds in group order (the last vector ends at the row's end, as in the projection).
  const int nv = (stride + W - 1) / W;
  const CombineRowFn row_fn = stride >= W ? pick_combine_row(nv) : nullptr;
  int off[kMaxNV];
  if (row_fn) vector_offsets(0, stride, nv, off);
  for (int r = 0; r < c.rows; ++r) {
    float* o = out + static_cast<ptrdiff_t>(r) * stride;
    if (row_fn) {
      row_fn(c, r, v, stride, scale, off, o);
    } else if (stride < W) {
      for (int i = 0; i < stride; ++i) {
        float acc = 0.0f;
        for (int k = c.row_begin[r]; k < c.row_begin[r + 1]; ++k)
          acc = madd1(c.weight[k] * scale, v[static_cast<ptrdiff_t>(c.group[k]) * stride + i], acc);
        o[i] = acc;
      }
    } else {
      for (int i0 = 0; i0 < stride; i0 += W) {
        const int i = i0 + W <= stride ? i0 : stride - W;
        B acc(0.0f);
        for (int k = c.row_begin[r]; k < c.row_begin[r + 1]; ++k)
          acc = madd(B(c.weight[k] * scale), load(v + static_cast<ptrdiff_t>(c.group[k]) * stride + i), acc);
        store(o + i, acc);
      }
    }
  }
}

// acc[l] += xn[i + l]^2 for l < 8 over the 8-aligned prefix of xn; returns the length covered.
// A float times a float is exact in double, so fused or not the products are the same and the
// sums follow the same order on every ISA: the results are bit-identical across ISAs.
int sum_squares8(const float* xn, int n, double* acc) {
  int i = 0;
#if defined(__AVX512F__)
  __m512d s = _mm512_loadu_pd(acc);
  for (; i + 16 <= n; i += 16) {
    // (the maskz form: GCC 12 warns on the plain one, whose pass-through lanes are undefined)
    const __m512d lo = _mm512_maskz_cvtps_pd(0xFF, _mm256_loadu_ps(xn + i));
    const __m512d hi = _mm512_maskz_cvtps_pd(0xFF, _mm256_loadu_ps(xn + i + 8));
    s = _mm512_fmadd_pd(lo, lo, s);
    s = _mm512_fmadd_pd(hi, hi, s);
  }
  _mm512_storeu_pd(acc, s);
#elif defined(__AVX2__) && defined(__FMA__)
  __m256d s0 = _mm256_loadu_pd(acc), s1 = _mm256_loadu_pd(acc + 4);
  for (; i + 8 <= n; i += 8) {
    const __m256d lo = _mm256_cvtps_pd(_mm_loadu_ps(xn + i));
    const __m256d hi = _mm256_cvtps_pd(_mm_loadu_ps(xn + i + 4));
    s0 = _mm256_fmadd_pd(lo, lo, s0);
    s1 = _mm256_fmadd_pd(hi, hi, s1);
  }
  _mm256_storeu_pd(acc, s0);
  _mm256_storeu_pd(acc + 4, s1);
#endif
  // The portable path (and the AVX-512 remainder): the same lanes, the same order.
  for (; i + 8 <= n; i += 8)
    for (int l = 0; l < 8; ++l) acc[l] += static_cast<double>(xn[i + l]) * xn[i + l];
  return i;
}

double dot(const float* a, const float* b, int n) {
  // Eight double lanes over n (a multiple of 8) floats, summed pairwise: a float times a float
  // is exact in double, so fused or not every ISA rounds the same sums in the same order.
  double acc[8] = {};
  int i = 0;
#if defined(__AVX512F__)
  __m512d s = _mm512_setzero_pd();
  for (; i + 8 <= n; i += 8)
    s = _mm512_fmadd_pd(_mm512_maskz_cvtps_pd(0xFF, _mm256_loadu_ps(a + i)),
                        _mm512_maskz_cvtps_pd(0xFF, _mm256_loadu_ps(b + i)), s);
  _mm512_storeu_pd(acc, s);
#elif defined(__AVX2__) && defined(__FMA__)
  __m256d s0 = _mm256_setzero_pd(), s1 = _mm256_setzero_pd();
  for (; i + 8 <= n; i += 8) {
    s0 = _mm256_fmadd_pd(_mm256_cvtps_pd(_mm_loadu_ps(a + i)), _mm256_cvtps_pd(_mm_loadu_ps(b + i)), s0);
    s1 = _mm256_fmadd_pd(_mm256_cvtps_pd(_mm_loadu_ps(a + i + 4)), _mm256_cvtps_pd(_mm_loadu_ps(b + i + 4)), s1);
  }
  _mm256_storeu_pd(acc, s0);
  _mm256_storeu_pd(acc + 4, s1);
#endif
  for (; i + 8 <= n; i += 8)
    for (int l = 0; l < 8; ++l) acc[l] += static_cast<double>(a[i + l]) * b[i + l];
  return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
}

double normalise(const float* x, const float* a, const float* b, int n, float* xn) {
  // x' in float batches; the sum of squares in double over eight independent partial sums (one
  // serial double chain would cost n x add latency), the same order on every ISA.
  int i = 0;
  for (; i + W <= n; i += W) store(xn + i, (load(x + i) - load(a + i)) * load(b + i));
  for (; i < n; ++i) xn[i] = (x[i] - a[i]) * b[i];
  double acc[8] = {};
  i = sum_squares8(xn, n, acc);
  double sum = ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
  for (; i < n; ++i) sum += static_cast<double>(xn[i]) * xn[i];
  return sum;
}
