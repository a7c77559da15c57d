#include "metric/scorer.hpp"

#include <algorithm>
#include <cmath>

#include "common/error.hpp"

namespace kata::metric {

namespace {
// Sum of the part rows (u = W^T e from the per-part e-projections).
void sum_parts(const float* p, int stride, float* u) {
  for (int c = 0; c < stride; ++c) {
    float s = 0.0f;
    for (int q = 0; q < kParts; ++q) s += p[static_cast<size_t>(q) * stride + c];
    u[c] = s;
  }
}
}  // namespace

Scorer::Scorer(std::shared_ptr<const Reference> reference, AlignmentOptions options)
    : reference_(std::move(reference)), aligner_(reference_, options) {
  const Metric& m = reference_->metric();
  ws_ = m.make_workspace();
  p_ = AlignedFloats(static_cast<size_t>(kProjectionRows) * m.stride());
  u_ = AlignedFloats(static_cast<size_t>(m.stride()));
}

void Scorer::reset() {
  aligner_.reset();
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

void Scorer::finish(double t) {
  const Reference& ref = *reference_;
  const Metric& m = ref.metric();
  const int stride = m.stride();
  float* p = p_.data();
  const int j = aligner_.align(p + static_cast<size_t>(kParts) * stride, t);
  // e-projections per part: D_p = P_p(x) - P_p(y_j); u = sum_p D_p; part p = u . D_p.
  const float* py = ref.part_projection(j);
  for (int i = 0; i < kParts * stride; ++i) p[i] -= py[i];
  float* u = u_.data();
  sum_parts(p, stride, u);
  const double d2 = detail::dot(u, u, stride);
  for (int q = 0; q < kParts; ++q)
    record_.parts[q] = static_cast<float>(detail::dot(u, p + static_cast<size_t>(q) * stride, stride));
  const double d = std::sqrt(d2);
  record_.time = t;
  record_.frame = count_++;
  record_.distance = static_cast<float>(d);
  record_.score = static_cast<float>(score_from_distance(d, m.delta_star()));
  record_.matched = j;
}

}  // namespace kata::metric
