#include "metric/metric.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <new>

#include "common/cpu.hpp"
#include "common/error.hpp"

namespace kata::metric {

double score_from_distance(double distance, double delta_star) {
  const double q = distance / delta_star;
  return 100.0 / (1.0 + q * q);
}

double calibrated_score(double distance, double d50, double slope) {
  if (!(distance > 0.0)) return 100.0;
  const double q = std::pow(distance / d50, slope);
  return std::isfinite(q) ? 100.0 / (1.0 + q) : 0.0;
}

AlignedFloats::AlignedFloats(size_t n) : n_(n) {
  // Rounded up to whole registers so kernels may store a full last vector; zero-filled so
  // padding columns and rows read as 0.
  const size_t bytes = ((n * sizeof(float) + 31) / 32) * 32;
  void* p = std::aligned_alloc(32, bytes > 0 ? bytes : 32);
  if (!p) throw std::bad_alloc();
  std::fill_n(static_cast<float*>(p), bytes / sizeof(float), 0.0f);
  p_.reset(static_cast<float*>(p));
}

void AlignedFloats::Free::operator()(float* p) const { std::free(p); }

// ---------------------------------------------------------------------------------------------
// Metric

Metric::Metric(const Model& model) {
  validate_model(model);
  rank_ = model.rank;
  stride_ = (rank_ + 7) / 8 * 8;
  delta_star_ = model.delta_star;
  calibration_ = model.calibration ? *model.calibration : default_calibration(model.delta_star);
  stencil_ = model.stencil;
  normalisation_ = model.normalisation;

  // Normalisation folded to x' = (x - shift) * gain.
  shift_ = AlignedFloats(gpd::kDims);
  gain_ = AlignedFloats(gpd::kDims);
  for (int i = 0; i < gpd::kDims; ++i) {
    if (normalisation_ == Normalisation::kBlockBalanced) {
      shift_.data()[i] = model.shift[i];
      gain_.data()[i] = model.scale[i];
    } else {
      shift_.data()[i] = model.min[i];
      const double range = static_cast<double>(model.max[i]) - model.min[i];
      const double gain = range > 0.0 ? 1.0 / range : 0.0;
      // A range so small that its inverse overflows a float carries no usable information:
      // treated like max == min (the dimension is dropped) rather than producing Inf.
      gain_.data()[i] = gain <= std::numeric_limits<float>::max() ? static_cast<float>(gain) : 0.0f;
    }
  }

  // Rows grouped by (static or kinetic block, joint coordinate or not, part set): a stable sort of
  // the dimensions by that key. Joint coordinates (block Jc) get groups of their own for the
  // joint-position rows; each involves one part.
  const auto& masks = dimension_parts();
  auto is_joint = [](int i) { return i < gpd::kOffsetJJd; };
  auto key = [&](int i) { return (i < gpd::kStaticDims ? 0 : 64) | (is_joint(i) ? 32 : 0) | masks[i]; };
  perm_.resize(gpd::kDims);
  for (int i = 0; i < gpd::kDims; ++i) perm_[i] = i;
  std::stable_sort(perm_.begin(), perm_.end(), [&](int a, int b) { return key(a) < key(b); });
  int prev = -1;
  for (int k = 0; k < gpd::kDims; ++k) {
    if (key(perm_[k]) != prev) {
      prev = key(perm_[k]);
      group_mask_.push_back(masks[perm_[k]]);
      group_static_.push_back(perm_[k] < gpd::kStaticDims ? 1 : 0);
      group_joint_.push_back(is_joint(perm_[k]) ? 1 : 0);
      group_begin_.push_back(k);
    }
  }
  group_begin_.push_back(gpd::kDims);

  // W: column-major kDims x rank in the model -> 16-bit integers with one scale per column
  // (kernels.hpp), in chunks of kChunk columns, row-major, rows permuted.
  column_scale_ = AlignedFloats(static_cast<size_t>(rank_));
  for (int c = 0; c < rank_; ++c) {
    float largest = 0.0f;
    for (int i = 0; i < gpd::kDims; ++i)
      largest = std::max(largest, std::abs(model.w[static_cast<size_t>(c) * gpd::kDims + i]));
    column_scale_.data()[c] = largest / 32767.0f;
  }
  // Both formats are rounded from W in steps, in the blocked layout (pairs: kernels.hpp).
  std::vector<double> steps(static_cast<size_t>(gpd::kDims) * rank_, 0.0);
  for (int c0 = 0; c0 < rank_; c0 += detail::kChunk) {
    const int width = std::min(detail::kChunk, rank_ - c0);
    double* chunk = steps.data() + static_cast<size_t>(gpd::kDims) * c0;
    for (int k = 0; k < gpd::kDims; ++k)
      for (int c = 0; c < width; ++c) {
        const float step = column_scale_.data()[c0 + c];
        const float value = model.w[static_cast<size_t>(c0 + c) * gpd::kDims + perm_[k]];
        chunk[static_cast<size_t>(k) * width + c] =
            step > 0.0f ? std::clamp(static_cast<double>(value) / step, -32767.0, 32767.0) : 0.0;
      }
  }
  w_.resize(steps.size());
  for (size_t i = 0; i < steps.size(); ++i) w_[i] = static_cast<int16_t>(std::nearbyint(steps[i]));
  // The AVX-512 kernels' copy, only where they run: a frame reads one of the two copies, never both.
  if (cpu_has_avx512()) {
    // 64-byte aligned (kernels.hpp: a row's first 16 words are then one cache line).
    pairs_.resize(detail::pair_words_total(gpd::kDims, rank_) + 15);
    const uintptr_t at = reinterpret_cast<uintptr_t>(pairs_.data());
    uint32_t* aligned = pairs_.data() + ((64 - at % 64) % 64) / sizeof(uint32_t);
    detail::pack_pairs(steps.data(), gpd::kDims, rank_, aligned);
    blocked_.pairs = aligned;
  }
  blocked_.data = w_.data();
  blocked_.column_scale = column_scale_.data();
  blocked_.rows = gpd::kDims;
  blocked_.rank = rank_;
  blocked_.out_stride = stride_;
  blocked_.groups = groups();
  blocked_.group_begin = group_begin_.data();
  blocked_.perm = perm_.data();

  // Part row q takes each group involving part q with share 1 / (number of parts it involves);
  // the static row takes every static-block group whole; joint-position row q takes the joint
  // coordinate group of part q whole.
  for (int r = 0; r < kProjectionRows; ++r) {
    combine_begin_.push_back(static_cast<int>(combine_group_.size()));
    for (int g = 0; g < groups(); ++g) {
      const uint8_t m = group_mask_[g];
      if (r < kParts && (m & (1u << r))) {
        combine_group_.push_back(g);
        combine_weight_.push_back(1.0f / static_cast<float>(__builtin_popcount(m)));
      } else if ((r == kStaticRow && group_static_[g]) ||
                 (r >= kJointRows && group_joint_[g] && m == (1u << (r - kJointRows)))) {
        combine_group_.push_back(g);
        combine_weight_.push_back(1.0f);
      }
    }
  }
  combine_begin_.push_back(static_cast<int>(combine_group_.size()));
  combine_.rows = kProjectionRows;
  combine_.row_begin = combine_begin_.data();
  combine_.group = combine_group_.data();
  combine_.weight = combine_weight_.data();
}

std::vector<float> Metric::weights() const {
  std::vector<float> w(static_cast<size_t>(gpd::kDims) * rank_);
  for (int c0 = 0; c0 < rank_; c0 += detail::kChunk) {
    const int width = std::min(detail::kChunk, rank_ - c0);
    const int16_t* chunk = w_.data() + static_cast<size_t>(gpd::kDims) * c0;
    for (int k = 0; k < gpd::kDims; ++k)
      for (int c = 0; c < width; ++c) {
        const float q = blocked_.pairs ? detail::paired_weight(blocked_.pairs, gpd::kDims, rank_, k, c0 + c)
                                       : static_cast<float>(chunk[static_cast<size_t>(k) * width + c]);
        w[static_cast<size_t>(c0 + c) * gpd::kDims + perm_[k]] = q * column_scale_.data()[c0 + c];
      }
  }
  return w;
}

Metric::Workspace Metric::make_workspace() const {
  Workspace ws;
  ws.xp = AlignedFloats(gpd::kDims);
  ws.v = AlignedFloats(static_cast<size_t>(groups()) * stride_);
  return ws;
}

void Metric::normalise(const float* x, float* out) const {
  double sumsq = 0.0;
  for (int i = 0; i < gpd::kDims; ++i) {
    out[i] = (x[i] - shift_.data()[i]) * gain_.data()[i];
    sumsq += static_cast<double>(out[i]) * out[i];
  }
  const float inv = sumsq > 0.0 ? static_cast<float>(1.0 / std::sqrt(sumsq)) : 0.0f;
  for (int i = 0; i < gpd::kDims; ++i) out[i] *= inv;
}

void Metric::finish(const Workspace& ws, double sumsq, float* p) const {
  // Unit length is applied here, on kProjectionRows x stride values instead of kDims inputs.
  const float inv = sumsq > 0.0 ? static_cast<float>(1.0 / std::sqrt(sumsq)) : 0.0f;
  detail::combine(combine_, ws.v.data(), stride_, inv, p);
}

void Metric::part_projections(const float* x, Workspace& ws, float* p) const {
  const double sumsq = detail::normalise(x, shift_.data(), gain_.data(), gpd::kDims, ws.xp.data());
  detail::project_groups(blocked_, ws.xp.data(), ws.v.data());
  finish(ws, sumsq, p);
}

void Metric::part_projections_batch(const float* const* x, Workspace* const* ws, float* const* p, int n) const {
  for (int f0 = 0; f0 < n; f0 += detail::kBatch) {
    const int m = std::min(detail::kBatch, n - f0);
    double sumsq[detail::kBatch];
    const float* xp[detail::kBatch];
    float* v[detail::kBatch];
    for (int f = 0; f < m; ++f) {
      Workspace& w = *ws[f0 + f];
      sumsq[f] = detail::normalise(x[f0 + f], shift_.data(), gain_.data(), gpd::kDims, w.xp.data());
      xp[f] = w.xp.data();
      v[f] = w.v.data();
    }
    detail::project_groups_batch(blocked_, xp, v, m);
    for (int f = 0; f < m; ++f) finish(*ws[f0 + f], sumsq[f], p[f0 + f]);
  }
}

void Metric::project(const float* x, Workspace& ws, float* u) const {
  const double sumsq = detail::normalise(x, shift_.data(), gain_.data(), gpd::kDims, ws.xp.data());
  detail::project_groups(blocked_, ws.xp.data(), ws.v.data());
  const float inv = sumsq > 0.0 ? static_cast<float>(1.0 / std::sqrt(sumsq)) : 0.0f;
  for (int c = 0; c < rank_; ++c) {
    float s = 0.0f;
    for (int g = 0; g < groups(); ++g) s += ws.v.data()[static_cast<size_t>(g) * stride_ + c];
    u[c] = s * inv;
  }
}

namespace detail {
// dot: kernels.cpp (dispatched to the widest ISA, bit-identical on every one).

double dist2(const float* a, const float* b, int n) {
  double acc[8] = {};
  for (int c = 0; c < n; c += 8)
    for (int l = 0; l < 8; ++l) {
      const double e = static_cast<double>(a[c + l]) - b[c + l];
      acc[l] += e * e;
    }
  return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
}

// Float: the alignment only ranks candidates, and float halves the cost of comparing a frame
// with every teacher frame in the window.
float dist2f(const float* a, const float* b, int n) {
  float acc[8] = {};
  for (int c = 0; c < n; c += 8)
    for (int l = 0; l < 8; ++l) {
      const float e = a[c + l] - b[c + l];
      acc[l] += e * e;
    }
  return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
}
}  // namespace detail

}  // namespace kata::metric
