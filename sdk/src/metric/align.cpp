#include "metric/align.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "common/error.hpp"
#include "metric/align_pass.hpp"

namespace kata::metric {

Aligner::Aligner(std::shared_ptr<const Reference> reference, AlignmentOptions options)
    : reference_(std::move(reference)), options_(options) {
  if (!reference_) throw Error(ErrorKind::kInvalidArgument, "scorer: null reference");
  if (!(options_.window > 0.0) || !(options_.max_rate > 0.0) || !(options_.step_penalty >= 0.0) || !(options_.hold_penalty >= 0.0) ||
      !(options_.relocate_time >= 0.0) || !std::isfinite(options_.relocate_time) || !(options_.rematch_time >= 0.0) ||
      !std::isfinite(options_.rematch_time))
    throw Error(ErrorKind::kInvalidArgument,
                "scorer: alignment window and max rate must be > 0, step penalty, relocate and re-match times >= 0");
  if (reference_->kind() != ReferenceKind::kClip) return;
  const int frames = reference_->frames();
  const int last = options_.last_frame < 0 ? frames - 1 : options_.last_frame;
  if (options_.first_frame < 0 || options_.first_frame > last || last >= frames)
    throw Error(ErrorKind::kInvalidArgument, "scorer: practice section " + std::to_string(options_.first_frame) +
                                                 ".." + std::to_string(options_.last_frame) +
                                                 " is not inside the teacher clip's " + std::to_string(frames) +
                                                 " frames");
  first_ = options_.first_frame;
  last_ = last;
  span_ = std::max(1, static_cast<int>(std::ceil(options_.window / reference_->frame_time())));
  const int n = last_ - first_ + 1;
  step_costs_.assign(static_cast<size_t>(span_) + 1, 0.0);
  const size_t stride = static_cast<size_t>(reference_->metric().stride());
  scaled_.assign(stride, 0.0f);
  // The window: one band behind the match (a student who lags or repeats a little), two ahead.
  window_back_ = span_;
  window_size_ = 3 * span_ + 1;
  windowed_ = options_.windowed && n > 2 * window_size_;
  window_.span = span_;
  search_.span = span_;
  search_a_ = first_;
  search_b_ = last_;
  if (windowed_ && n > Reference::kSearchFrames) {  // a long section: the search on a grid
    search_grid_ = (n + Reference::kSearchFrames - 1) / Reference::kSearchFrames;
    search_a_ = (first_ + search_grid_ - 1) / search_grid_;
    search_b_ = last_ / search_grid_;
    search_.grid = search_grid_;
    search_.span = std::max(1, (span_ + search_grid_ - 1) / search_grid_);
  }
  // The search's arrays are indexed by grid index (teacher frame when not on a grid).
  search_.prev.assign(static_cast<size_t>(search_b_) + 1, 0.0);
  search_.cur.assign(static_cast<size_t>(search_b_) + 1, 0.0);
  search_c_.assign(static_cast<size_t>(search_b_) + 1, 0.0f);
  if (windowed_) {
    decimation_ = std::clamp((search_b_ - search_a_ + 1 + 255) / 256, 4, kMaxDecimation);
    search_row_.assign(stride, 0.0f);
    search_pk_.assign(static_cast<size_t>(span_) + 1, 0.0);
    window_.prev.assign(static_cast<size_t>(window_size_), 0.0);
    window_.cur.assign(static_cast<size_t>(window_size_), 0.0);
    window_c_.assign(static_cast<size_t>(window_size_), 0.0f);
  }
  match_ = first_;
}

void Aligner::reset() {
  for (Track* track : {&search_, &window_}) {
    track->started = false;
    track->relocations = 0;
    track->last_time = 0.0;
    track->student_dt = 0.0;
  }
  match_ = first_;
  relocations_ = 0;
  phase_ = 0;
  search_moves_ = 0;
}

int Aligner::wrap(int j) const {
  const int n = last_ - first_ + 1;
  if (j < first_) return j + n;
  if (j > last_) return j - n;
  return j;
}

double Aligner::jump_cost(const Track& track) const {
  return options_.relocate_time > 0.0 ? options_.relocate_time / track.student_dt * reference_->spread()
                                      : std::numeric_limits<double>::infinity();
}

void Aligner::distances(const float* scaled, int a, int b, float* c) const {
  const Reference& ref = *reference_;
  detail::alignment_distances_half(scaled, ref.alignment_rows_half(a), b - a + 1, ref.metric().stride(),
                                   ref.alignment_half_scale(), c);
}

void Aligner::search_distances(const float* scaled, int a, int b, float* c) const {
  if (search_grid_ == 1) return distances(scaled, a, b, c);
  const Reference& ref = *reference_;
  if (ref.search_grid() == search_grid_) {  // the reference's own grid: contiguous rows
    detail::alignment_distances_half(scaled, ref.search_rows_half(a), b - a + 1, ref.metric().stride(),
                                     ref.alignment_half_scale(), c);
    return;
  }
  for (int i = a; i <= b; ++i)  // a section's own grid: one row at a time
    detail::alignment_distances_half(scaled, ref.alignment_rows_half(search_frame(i)), 1, ref.metric().stride(),
                                     ref.alignment_half_scale(), c + (i - a));
}

int Aligner::search_index(int frame) const {
  return std::clamp((frame + search_grid_ / 2) / search_grid_, search_a_, search_b_);
}

int Aligner::follow(Track& tr, const float* c, int a, int b, bool loop, int start, double t, int decimation) {
  const Reference& ref = *reference_;
  const int n = b - a + 1;
  const double ft = ref.frame_time();
  double* cur = tr.cur.data();
  int best = a;
  if (!tr.started) {
    // Open begin: a path starts anywhere, those outside the band after `start` for a tenth of a
    // jump: enough that a student who starts with the teacher is not placed in a look-alike
    // later in the clip (a cyclic walk), little enough that one who joins late is found about
    // as soon as after a skip.
    // A decimated track sees one student frame for R: its costs are 1 / R of a track at the frame
    // rate (and so is its jump), so this first frame's costs and prior are the frame rate's / R
    // (the same best place, and the same head start for the band).
    if (!(tr.student_dt > 0.0)) tr.student_dt = ft;
    const double prior = 0.1 * jump_cost(tr), scale = 1.0 / decimation;
    for (int j = a; j <= b; ++j) cur[j] = (c[j] + (j >= start && j - start <= tr.span ? 0.0 : prior)) * scale;
    tr.student_dt = std::max(tr.student_dt, decimation * ft);
    // Re-based on the cheapest frame, the best place anywhere.
    best = detail::alignment_rebase(cur, a, b);
    tr.match = best;
    tr.started = true;
    tr.last_time = t;
    return tr.match;
  }
  const StepCosts step = begin_step(tr, n, t, decimation, step_costs_.data());
  // One pass per step k (align_pass_kernel.inl; the inner loops vectorise): a jump from the best
  // place (0 after the re-basing), or a step of k from j - k; then re-based on the cheapest
  // frame, the best place anywhere.
  best = detail::alignment_step(tr.prev.data(), tr.cur.data(), c, a, b, step_costs_.data(), step.k_max, step.jump, loop);
  decide(tr, best, a, b, loop, step.jump);
  return tr.match;
}

Aligner::StepCosts Aligner::begin_step(Track& tr, int n, double t, int decimation, double* pk) {
  const Reference& ref = *reference_;
  const double dt = std::max(0.0, t - tr.last_time);
  // The jump cost is set in seconds, so it follows the student's frame rate, smoothed over
  // about 10 frames (a gap after lost tracking counts as at most 0.1 s per frame the track sees).
  if (dt > 0.0) tr.student_dt += 0.1 * (std::min(dt, 0.1 * decimation) - tr.student_dt);
  const double advance = dt / (ref.frame_time() * tr.grid);  // expected teacher frames (grid frames)
  StepCosts step;
  // Steps beyond the band are never needed: further moves are jumps. (The stream refuses a step
  // above kMaxTimeStep, but a teacher of a tiny frame time can still make max_rate x advance
  // exceed an int: bounded by n before the cast.)
  const double k_wanted = std::min(std::ceil(options_.max_rate * advance), static_cast<double>(n));
  step.k_max = std::min({std::max(1, static_cast<int>(k_wanted)), tr.span, n - 1});
  const double penalty = options_.step_penalty * ref.step_cost(), hold = options_.hold_penalty * ref.step_cost();
  for (int k = 0; k <= step.k_max; ++k)
    pk[k] = penalty * std::max(0.0, k - advance) + hold * std::max(0.0, advance - k);
  step.jump = jump_cost(tr);
  std::swap(tr.prev, tr.cur);
  tr.last_time = t;
  return step;
}

void Aligner::decide(Track& tr, int best, int a, int b, bool loop, double jump) {
  // The local band just ahead of the last match, then the move if the best place elsewhere is
  // cheaper by the margin.
  const double* cur = tr.cur.data();
  const int n = b - a + 1;
  int local = tr.match;
  for (int k = 1; k <= std::min(tr.span, n - 1); ++k) {
    const int j = loop && tr.match + k > b ? tr.match + k - n : tr.match + k;
    if (j > b) break;
    if (cur[j] < cur[local]) local = j;
  }
  if (cur[local] > jump) {
    tr.match = best;
    ++tr.relocations;
  } else {
    tr.match = local;
  }
}

int Aligner::teacher_frame(int window_index) const {
  const int j = window_start_ + window_index;
  return options_.loop ? wrap(j) : j;
}

// The window's first section frame for a match at `target`: one band behind it (wrapped when
// looping, else kept inside the section).
int Aligner::window_start_for(int target) const {
  const int start = target - window_back_;
  if (options_.loop) return start < first_ ? start + (last_ - first_ + 1) : start;
  return std::clamp(start, first_, last_ - window_size_ + 1);
}

// Places the window one band behind section frame `target` (inside the section when not looping)
// and starts its programme there: the band after the target free, elsewhere in the window a tenth
// of a jump.
void Aligner::seed_window(int target, double t, const float* scaled) {
  const int n = last_ - first_ + 1;
  window_start_ = window_start_for(target);
  window_.started = false;
  int target_index = target - window_start_;
  if (target_index < 0) target_index += n;  // looping: the window runs over the section's end
  follow_window(scaled, t, target_index);
}

// The search moved to section frame `target`: the window is placed one band behind it and takes
// the search's accumulated costs there (R times its own: the search adds one distance per R
// student frames, the window one per frame), capped at a jump, so the window's paths carry the
// history the search saw; the match restarts at the target, and this frame's step follows it.
void Aligner::move_window(int target) {
  const int n = last_ - first_ + 1;
  window_start_ = window_start_for(target);
  const double jump = jump_cost(window_);
  const double cap = std::isfinite(jump) ? jump : 1e300;
  double* cur = window_.cur.data();
  const double* costs = search_.cur.data();
  for (int i = 0; i < window_size_; ++i)
    cur[i] = std::min(cap, static_cast<double>(decimation_) * costs[search_index(teacher_frame(i))]);
  int index = target - window_start_;
  if (index < 0) index += n;  // looping: the window runs over the section's end
  window_.match = index;
  match_ = target;
}

void Aligner::follow_window(const float* scaled, double t, int seed_index) {
  const int n = last_ - first_ + 1;
  if (seed_index < 0) {
    // The window keeps one band behind the match; the frames it moves onto start from a jump
    // (their path is not known), those it leaves are dropped.
    const int start = window_start_for(match_);
    int delta = start - window_start_;
    if (options_.loop) {  // the shorter way round the section
      if (delta > n / 2) delta -= n;
      if (delta < -n / 2) delta += n;
    }
    if (delta != 0) {
      const double jump = jump_cost(window_);
      const double entering = std::isfinite(jump) ? jump : 1e300;
      double* cur = window_.cur.data();
      const int size = window_size_;
      if (delta >= size || -delta >= size) {
        std::fill(cur, cur + size, entering);
      } else if (delta > 0) {
        std::copy(cur + delta, cur + size, cur);
        std::fill(cur + size - delta, cur + size, entering);
      } else {
        std::copy_backward(cur, cur + size + delta, cur + size);
        std::fill(cur, cur - delta, entering);
      }
      window_.match = std::clamp(window_.match - delta, 0, size - 1);
      window_start_ = start;
    }
  }
  // The window's distances: one run of rows, or two when a looped window runs over the end.
  float* c = window_c_.data();
  const int end = window_start_ + window_size_ - 1;
  if (end <= last_) {
    distances(scaled, window_start_, end, c);
  } else {
    const int head = last_ - window_start_ + 1;
    distances(scaled, window_start_, last_, c);
    distances(scaled, first_, first_ + window_size_ - head - 1, c + head);
  }
  const int64_t before = window_.relocations;
  follow(window_, c, 0, window_size_ - 1, false, seed_index < 0 ? 0 : seed_index, t, 1);
  relocations_ += window_.relocations - before;
  match_ = teacher_frame(window_.match);
}

int Aligner::align(const float* s, double t) {
  if (reference_->kind() != ReferenceKind::kClip) return 0;
  const Reference& ref = *reference_;
  const int a = first_, b = last_, n = b - a + 1;
  const int stride = ref.metric().stride();
  // The passes read the half-precision rows (half the bytes from a cold cache).
  const float inv = 1.0f / ref.alignment_half_scale();  // a power of two: exact
  float* scaled = scaled_.data();
  for (int i = 0; i < stride; ++i) scaled[i] = s[i] * inv;
  float* c = search_c_.data();
  if (!windowed_) {  // the whole section every frame
    distances(scaled, a, b, c + a);
    match_ = follow(search_, c, a, b, options_.loop, a, t, 1);
    relocations_ = search_.relocations;
    return match_;
  }
  // The search's section, on its grid (the teacher's frames unless the section is long).
  const int sa = search_a_, sb = search_b_, sn = sb - sa + 1;
  if (!search_.started) {
    // The first frame: the whole section at once (join anywhere), the window seeded at its best.
    search_distances(scaled, sa, sb, c + sa);
    follow(search_, c, sa, sb, options_.loop, sa, t, decimation_);
    search_moves_ = search_.relocations;
    search_anchor_ = search_.match;
    phase_ = 0;
    seed_window(std::clamp(search_frame(search_.match), a, b), t, scaled);
    return match_;
  }
  // The search: this frame's slice of its pass and of its programme's step (each frame's costs
  // depend only on the last step's, all kept), over the student row of its frame; the re-basing
  // and the decision once the R slices are done.
  if (phase_ == 0) {
    std::copy(scaled, scaled + stride, search_row_.data());
    search_time_ = t;
    search_step_ = begin_step(search_, sn, t, decimation_, search_pk_.data());
  }
  const int slice = (sn + decimation_ - 1) / decimation_;
  const int lo = sa + phase_ * slice, hi = std::min(sb, lo + slice - 1);
  if (lo <= hi) {
    search_distances(search_row_.data(), lo, hi, c + lo);
    detail::alignment_step_range(search_.prev.data(), search_.cur.data(), c, sa, sb, lo, hi, search_pk_.data(),
                                 search_step_.k_max, search_step_.jump, options_.loop);
  }
  if (phase_ == 0) search_anchor_pending_ = true;
  if (++phase_ == decimation_) {
    phase_ = 0;
    const int best = detail::alignment_rebase(search_.cur.data(), sa, sb);
    // The search judges the window's match of its frame: the band after it, against the best
    // place of the whole section by the margin.
    search_.match = search_anchor_;
    decide(search_, best, sa, sb, options_.loop, search_step_.jump);
    if (search_.relocations != search_moves_) {
      search_moves_ = search_.relocations;
      const int target = std::clamp(search_frame(search_.match), a, b);
      int away = std::abs(target - match_);
      if (options_.loop) away = std::min(away, n - away);
      if (away > span_) {
        ++relocations_;
        move_window(target);
      }
    }
  }
  follow_window(scaled, t, -1);
  if (search_anchor_pending_) {
    search_anchor_ = search_index(match_);
    search_anchor_pending_ = false;
  }
  return match_;
}

}  // namespace kata::metric
