#include "metric/scorer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <string>

#include "common/error.hpp"

namespace kata::metric {

double score_from_distance(double distance, double delta_star) {
  const double q = distance / delta_star;
  return 100.0 / (1.0 + q * q);
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

  // Rows grouped by (static or kinetic block, part set): a stable sort of the dimensions by that key.
  const auto& masks = dimension_parts();
  auto key = [&](int i) { return (i < gpd::kStaticDims ? 0 : 32) | masks[i]; };
  perm_.resize(gpd::kDims);
  for (int i = 0; i < gpd::kDims; ++i) perm_[i] = i;
  std::stable_sort(perm_.begin(), perm_.end(), [&](int a, int b) { return key(a) < key(b); });
  int prev = -1;
  for (int k = 0; k < gpd::kDims; ++k) {
    if (key(perm_[k]) != prev) {
      prev = key(perm_[k]);
      group_mask_.push_back(masks[perm_[k]]);
      group_static_.push_back(perm_[k] < gpd::kStaticDims ? 1 : 0);
      group_begin_.push_back(k);
    }
  }
  group_begin_.push_back(gpd::kDims);

  // W: column-major kDims x rank in the model -> chunks of kChunk columns, row-major, rows permuted.
  w_ = AlignedFloats(static_cast<size_t>(gpd::kDims) * rank_);
  float* dst = w_.data();
  for (int c0 = 0; c0 < rank_; c0 += detail::kChunk) {
    const int width = std::min(detail::kChunk, rank_ - c0);
    float* chunk = dst + static_cast<size_t>(gpd::kDims) * c0;
    for (int k = 0; k < gpd::kDims; ++k)
      for (int c = 0; c < width; ++c)
        chunk[static_cast<size_t>(k) * width + c] = model.w[static_cast<size_t>(c0 + c) * gpd::kDims + perm_[k]];
  }
  blocked_.data = w_.data();
  blocked_.rows = gpd::kDims;
  blocked_.rank = rank_;
  blocked_.out_stride = stride_;
  blocked_.groups = groups();
  blocked_.group_begin = group_begin_.data();
  blocked_.perm = perm_.data();

  // Part row q takes each group involving part q with share 1 / (number of parts it involves);
  // the static row takes every static-block group whole.
  for (int r = 0; r < kProjectionRows; ++r) {
    combine_begin_.push_back(static_cast<int>(combine_group_.size()));
    for (int g = 0; g < groups(); ++g) {
      const uint8_t m = group_mask_[g];
      if (r < kParts && (m & (1u << r))) {
        combine_group_.push_back(g);
        combine_weight_.push_back(1.0f / static_cast<float>(__builtin_popcount(m)));
      } else if (r == kParts && group_static_[g]) {
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

// ---------------------------------------------------------------------------------------------
// Reference

namespace {
// a . b and |a - b|^2 over n floats (n a multiple of 8: projection rows are padded with zeros),
// in double, in eight independent lanes: one serial chain would cost n x the add latency.
double dot(const float* a, const float* b, int n) {
  double acc[8] = {};
  for (int c = 0; c < n; c += 8)
    for (int l = 0; l < 8; ++l) acc[l] += static_cast<double>(a[c + l]) * b[c + l];
  return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
}
double dist2(const float* a, const float* b, int n) {
  double acc[8] = {};
  for (int c = 0; c < n; c += 8)
    for (int l = 0; l < 8; ++l) {
      const double e = static_cast<double>(a[c + l]) - b[c + l];
      acc[l] += e * e;
    }
  return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
}

// |a - b|^2 in float (eight lanes): the alignment only ranks candidates, and float halves the
// cost of comparing a frame with every teacher frame in the window.
float dist2f(const float* a, const float* b, int n) {
  float acc[8] = {};
  for (int c = 0; c < n; c += 8)
    for (int l = 0; l < 8; ++l) {
      const float e = a[c + l] - b[c + l];
      acc[l] += e * e;
    }
  return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
}

// Sum of the part rows (u = W^T e from the per-part e-projections).
void sum_parts(const float* p, int stride, float* u) {
  for (int c = 0; c < stride; ++c) {
    float s = 0.0f;
    for (int q = 0; q < kParts; ++q) s += p[static_cast<size_t>(q) * stride + c];
    u[c] = s;
  }
}
}  // namespace

Reference::Reference(std::shared_ptr<const Metric> metric, const float* features)
    : metric_(std::move(metric)), kind_(ReferenceKind::kPose), frames_(1) {
  if (!metric_ || !features) throw Error(ErrorKind::kInvalidArgument, "reference: null model or features");
  build(features);
}

Reference::Reference(std::shared_ptr<const Metric> metric, const float* features, int frames, double frame_time)
    : metric_(std::move(metric)), kind_(ReferenceKind::kClip), frames_(frames), frame_time_(frame_time) {
  if (!metric_ || !features) throw Error(ErrorKind::kInvalidArgument, "reference: null model or features");
  if (frames < 1) throw Error(ErrorKind::kInvalidArgument, "reference clip: no frames");
  if (!(frame_time > 0.0) || !std::isfinite(frame_time))
    throw Error(ErrorKind::kInvalidArgument, "reference clip: frame time must be > 0 seconds");
  build(features);
}

void Reference::build(const float* features) {
  stride_ = metric_->stride();
  for (size_t i = 0; i < static_cast<size_t>(frames_) * gpd::kDims; ++i)
    if (!std::isfinite(features[i]))
      throw Error(ErrorKind::kInvalidArgument, "reference: NaN/Inf in the features of frame " +
                                                   std::to_string(i / gpd::kDims));
  rows_ = AlignedFloats(static_cast<size_t>(frames_) * kProjectionRows * stride_);
  Metric::Workspace ws = metric_->make_workspace();
  for (int j = 0; j < frames_; ++j)
    metric_->part_projections(features + static_cast<size_t>(j) * gpd::kDims, ws,
                              rows_.data() + static_cast<size_t>(j) * kProjectionRows * stride_);
  if (frames_ > 1) {
    std::vector<double> steps(static_cast<size_t>(frames_ - 1));
    for (int j = 0; j + 1 < frames_; ++j)
      steps[static_cast<size_t>(j)] = std::sqrt(dist2(alignment_projection(j + 1), alignment_projection(j), stride_));
    std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2), steps.end());
    step_cost_ = steps[steps.size() / 2];
  }
}

Reference Reference::from_joints(std::shared_ptr<const Metric> metric, const float* joints, double body_height) {
  if (!joints) throw Error(ErrorKind::kInvalidArgument, "reference pose: null joints");
  if (!(body_height > 0.0) || !std::isfinite(body_height))
    throw Error(ErrorKind::kInvalidArgument, "reference pose: body height must be > 0");
  for (int i = 0; i < gpd::kJoints * 3; ++i)
    if (!std::isfinite(joints[i])) throw Error(ErrorKind::kInvalidArgument, "reference pose: NaN/Inf in the joints");
  std::vector<float> x(gpd::kDims), local(gpd::kJoints * 3);
  gpd::GeometryState state;
  float hip = 0.0f;
  gpd::to_local_frame(joints, body_height, state, local.data(), &hip);
  gpd::static_features(local.data(), hip, state, x.data());
  gpd::kinetics_zero(x.data() + gpd::kOffsetJk);  // a held pose: no motion
  return Reference(std::move(metric), x.data());
}

// ---------------------------------------------------------------------------------------------
// Scorer

Scorer::Scorer(std::shared_ptr<const Reference> reference, AlignmentOptions options)
    : reference_(std::move(reference)), options_(options) {
  if (!reference_) throw Error(ErrorKind::kInvalidArgument, "scorer: null reference");
  if (!(options_.window > 0.0) || !(options_.max_rate > 0.0) || !(options_.step_penalty >= 0.0))
    throw Error(ErrorKind::kInvalidArgument, "scorer: alignment window and max rate must be > 0, step penalty >= 0");
  const Metric& m = reference_->metric();
  ws_ = m.make_workspace();
  p_ = AlignedFloats(static_cast<size_t>(kProjectionRows) * m.stride());
  u_ = AlignedFloats(static_cast<size_t>(m.stride()));
  if (reference_->kind() == ReferenceKind::kClip) {
    cost_prev_.assign(static_cast<size_t>(reference_->frames()), 0.0);
    cost_cur_.assign(static_cast<size_t>(reference_->frames()), 0.0);
  }
}

void Scorer::reset() {
  lo_ = 0;
  hi_ = -1;
  match_ = 0;
  count_ = 0;
  record_ = ScoreRecord{};
}

const ScoreRecord& Scorer::score(const float* x, double t) {
  reference_->metric().part_projections(x, ws_, p_.data());
  finish(t);
  return record_;
}

void Scorer::score_batch(Scorer* const* scorers, const float* const* x, const double* t, int n) {
  // Small fixed-size pointer tables per kBatch group: no allocation.
  for (int f0 = 0; f0 < n; f0 += detail::kBatch) {
    const int m = std::min(detail::kBatch, n - f0);
    Metric::Workspace* ws[detail::kBatch];
    float* p[detail::kBatch];
    for (int f = 0; f < m; ++f) {
      ws[f] = &scorers[f0 + f]->ws_;
      p[f] = scorers[f0 + f]->p_.data();
    }
    scorers[f0]->reference_->metric().part_projections_batch(x + f0, ws, p, m);
    for (int f = 0; f < m; ++f) scorers[f0 + f]->finish(t[f0 + f]);
  }
}

int Scorer::align(const float* s, double t) {
  const Reference& ref = *reference_;
  const int last = ref.frames() - 1;
  const int stride = ref.metric().stride();
  const int span = std::max(1, static_cast<int>(std::ceil(options_.window / ref.frame_time())));
  auto cost = [&](int j) { return std::sqrt(static_cast<double>(dist2f(s, ref.alignment_projection(j), stride))); };
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (hi_ < 0) {  // first frame after construction or reset: open begin within the window
    lo_ = 0;
    hi_ = std::min(last, span);
    for (int j = lo_; j <= hi_; ++j) cost_cur_[j] = cost(j);
  } else {
    const double dt = t - last_time_;
    const double advance = (dt > 0.0 ? dt : 0.0) / ref.frame_time();  // expected teacher frames
    const int k_max = std::max(1, static_cast<int>(std::ceil(options_.max_rate * advance)));
    const double penalty = options_.step_penalty * ref.step_cost();
    const int plo = lo_, phi = hi_;
    std::swap(cost_prev_, cost_cur_);
    lo_ = match_;
    hi_ = std::min({last, phi + k_max, match_ + span});
    for (int j = lo_; j <= hi_; ++j) {
      double best = kInf;
      for (int k = 0; k <= k_max; ++k) {
        const int i = j - k;
        if (i < plo) break;
        if (i <= phi) best = std::min(best, cost_prev_[i] + penalty * std::max(0.0, k - advance));
      }
      cost_cur_[j] = best == kInf ? kInf : best + cost(j);
    }
  }
  // Open end: the band's cheapest frame is the match; costs are re-based on it so they stay
  // small over long streams.
  int arg = lo_;
  for (int j = lo_ + 1; j <= hi_; ++j)
    if (cost_cur_[j] < cost_cur_[arg]) arg = j;
  const double base = cost_cur_[arg];
  for (int j = lo_; j <= hi_; ++j) cost_cur_[j] -= base;
  match_ = arg;
  return arg;
}

void Scorer::finish(double t) {
  const Reference& ref = *reference_;
  const Metric& m = ref.metric();
  const int stride = m.stride();
  float* p = p_.data();
  const int j = ref.kind() == ReferenceKind::kClip ? align(p + static_cast<size_t>(kParts) * stride, t) : 0;
  // e-projections per part: D_p = P_p(x) - P_p(y_j); u = sum_p D_p; part p = u . D_p.
  const float* py = ref.part_projection(j);
  for (int i = 0; i < kParts * stride; ++i) p[i] -= py[i];
  float* u = u_.data();
  sum_parts(p, stride, u);
  const double d2 = dot(u, u, stride);
  for (int q = 0; q < kParts; ++q) record_.parts[q] = static_cast<float>(dot(u, p + static_cast<size_t>(q) * stride, stride));
  const double d = std::sqrt(d2);
  record_.time = t;
  record_.frame = count_++;
  record_.distance = static_cast<float>(d);
  record_.score = static_cast<float>(score_from_distance(d, m.delta_star()));
  record_.matched = j;
  last_time_ = t;
}

}  // namespace kata::metric
