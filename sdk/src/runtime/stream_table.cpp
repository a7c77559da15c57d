// The stream table (runtime.hpp, "stream table"): an open-addressing table of stream states that
// push() reads without a lock (ids published with release stores; a closed slot is a tombstone,
// its state retired once its worker is past its last frame, then reused); opening, revising and
// closing under open_mutex_; a definition made into a pipeline setup; the counters.
#include "pipeline/record.hpp"
#include "runtime/runtime_internal.hpp"

namespace kata::runtime {

using namespace internal;

int latency_bucket(int64_t ns) {
  if (ns < 1) return 0;
  const int b = static_cast<int>(8.0 * std::log2(static_cast<double>(ns)));
  return std::min(std::max(b, 0), kLatencyBuckets - 1);
}

double latency_percentile(const uint64_t* histogram, double q) {
  uint64_t total = 0;
  for (int i = 0; i < kLatencyBuckets; ++i) total += histogram[i];
  if (total == 0) return 0.0;
  const double want = q * static_cast<double>(total);
  uint64_t seen = 0;
  for (int i = 0; i < kLatencyBuckets; ++i) {
    seen += histogram[i];
    if (static_cast<double>(seen) >= want) return std::exp2(static_cast<double>(i + 1) / 8.0);
  }
  return std::exp2(static_cast<double>(kLatencyBuckets) / 8.0);
}

StreamSetup setup_from_definition(const transport::SkeletonDefinition& d) {
  StreamSetup setup;
  // A name map, or a built-in layout by name (a preset, or one that synthesises joints and fixes
  // its axes and smoothing, such as "mediapipe").
  Layout layout;
  if (!d.name_map.empty()) {
    std::array<std::string, kGpdJoints> names;
    for (int i = 0; i < kGpdJoints; ++i) names[static_cast<size_t>(i)] = d.name_map[static_cast<size_t>(i)];
    layout.map = make_gpd_map(d.skeleton, names);
  } else {
    layout = resolve_layout(d.skeleton, d.layout.empty() ? "cmu" : d.layout);
  }
  const GpdMap& map = layout.map;
  StreamConfig stream;
  if (d.skeleton.has_rest_pose) {
    stream = stream_config_for(d.skeleton, map, gpd::Stencil::kBackward);
  } else {
    stream.map = map;
    stream.input_joints = d.skeleton.joint_count();
  }
  stream.up_axis = layout.fixed_axes ? layout.axes : d.up_axis;
  stream.smoothing = layout.smooth;
  setup.pipeline.stream = stream;
  setup.pipeline.student = d.skeleton;
  return setup;
}


Runtime::StreamState* Runtime::find(uint64_t stream_id) const {
  const size_t mask = table_keys_.size() - 1;
  for (size_t i = mix(stream_id) & mask, n = 0; n <= mask; i = (i + 1) & mask, ++n) {
    const uint64_t key = table_keys_[i].load(std::memory_order_acquire);
    if (key == stream_id) return table_values_[i].load(std::memory_order_acquire);
    if (key == kEmptyKey) return nullptr;  // tombstones are skipped
  }
  return nullptr;
}

void Runtime::open_stream(const transport::SkeletonDefinition& definition, const StreamSetup& setup) {
  std::lock_guard<std::mutex> lock(open_mutex_);
  open_locked(definition, setup);
}

void Runtime::open_locked(const transport::SkeletonDefinition& definition, const StreamSetup& setup) {
  auto owned = std::make_unique<pipeline::Pipeline>(setup.pipeline);
  if (setup.teacher) owned->set_teacher(setup.teacher, setup.teacher_options);
  add_locked(definition, owned.get(), [](pipeline::Pipeline* p) { delete p; },
             setup.publish_features && setup.pipeline.keep_features);
  owned.release();  // the stream owns it now
}

void Runtime::open_announced(const transport::SkeletonDefinition& d) {
  // Refused before anything is allocated: a flood of definitions costs a counter each.
  {
    std::lock_guard<std::mutex> lock(open_mutex_);
    check_open(d);
  }
  if (config_.build_stream) {
    RuntimeConfig::AdoptedPipeline built = config_.build_stream(d);
    std::lock_guard<std::mutex> lock(open_mutex_);
    try {
      add_locked(d, built.pipeline, built.release, built.publish_features);
    } catch (...) {
      built.release(built.pipeline);  // refused: still the builder's
      throw;
    }
    return;
  }
  const StreamSetup setup = config_.configure_stream ? config_.configure_stream(d) : setup_from_definition(d);
  std::lock_guard<std::mutex> lock(open_mutex_);
  open_locked(d, setup);
}

void Runtime::adopt_stream(const transport::SkeletonDefinition& definition, pipeline::Pipeline* pipeline,
                           std::function<void(pipeline::Pipeline*)> release, bool publish_features) {
  std::lock_guard<std::mutex> lock(open_mutex_);
  add_locked(definition, pipeline, std::move(release), publish_features);
}

void Runtime::check_open(const transport::SkeletonDefinition& definition) const {
  if (stopping_.load()) throw Error(ErrorKind::kInvalidArgument, "runtime: stopping, no new stream");
  if (definition.stream_id >= kTombstone)
    throw Error(ErrorKind::kInvalidArgument, "runtime: stream ids 2^64-2 and 2^64-1 are reserved");
  if (find(definition.stream_id))
    throw Error(ErrorKind::kInvalidArgument, "runtime: stream " + std::to_string(definition.stream_id) + " is open");
  if (stream_count_.load() >= static_cast<uint64_t>(config_.max_streams))
    throw Error(ErrorKind::kInvalidArgument, "runtime: max_streams reached");
  if (definition.skeleton.joint_count() > config_.max_joints)
    throw Error(ErrorKind::kInvalidArgument, "runtime: the skeleton has more joints than max_joints");
}

namespace {
// Two definitions that one pipeline serves alike (a revision may change only what it does not read).
bool same_shape(const transport::SkeletonDefinition& a, const transport::SkeletonDefinition& b) {
  return a.skeleton.names == b.skeleton.names && a.skeleton.parents == b.skeleton.parents &&
         a.skeleton.has_rest_pose == b.skeleton.has_rest_pose && a.skeleton.offsets == b.skeleton.offsets &&
         a.layout == b.layout && a.name_map == b.name_map && a.up_axis == b.up_axis;
}
}  // namespace

bool Runtime::revise_announced(const transport::SkeletonDefinition& d) {
  {
    std::lock_guard<std::mutex> lock(open_mutex_);
    StreamState* s = find(d.stream_id);
    if (!s) return false;
    if (same_shape(s->definition, d)) {
      // The pipeline stays; the ingest marks the next frame a restart. Definitions are read
      // by the I/O thread (this thread) only.
      s->definition = d;
      definitions_dirty_.store(true, std::memory_order_release);
      return true;
    }
  }
  close_stream(d.stream_id);
  open_announced(d);
  return true;
}

bool Runtime::close_stream(uint64_t stream_id) {
  std::lock_guard<std::mutex> lock(open_mutex_);
  StreamState* s = find(stream_id);
  if (!s) return false;
  s->closed.store(true, std::memory_order_seq_cst);
  const size_t mask = table_keys_.size() - 1;
  for (size_t i = mix(stream_id) & mask, n = 0; n <= mask; i = (i + 1) & mask, ++n)
    if (table_keys_[i].load(std::memory_order_relaxed) == stream_id) {
      table_keys_[i].store(kTombstone, std::memory_order_release);
      break;
    }
  // A push that found the state before the close finishes its cell first (a few instructions).
  while (s->counters.in_push.load(std::memory_order_seq_cst) != 0) std::this_thread::yield();
  Worker& w = *workers_[static_cast<size_t>(s->worker)];
  s->retire_pos = w.enqueue_pos.load(std::memory_order_acquire);
  {
    std::lock_guard<std::mutex> owned_lock(w.owned_mutex);
    for (size_t i = 0; i < w.owned.size(); ++i)
      if (w.owned[i] == s) {
        w.owned[i] = w.owned.back();
        w.owned.pop_back();
        break;
      }
  }
  s->live = false;
  retiring_.push_back(s);
  retiring_count_.fetch_add(1, std::memory_order_release);
  ++closed_streams_;
  return true;
}

void Runtime::retire_closed(transport::Encoder& encoder) {
  // A closed stream is retired once its worker handed over the results of its last frame and
  // the I/O thread sent them; then its pipeline is released and its state reused.
  std::vector<StreamState*> ready;
  {
    std::lock_guard<std::mutex> lock(open_mutex_);
    for (size_t i = 0; i < retiring_.size();) {
      StreamState* s = retiring_[i];
      if (workers_[static_cast<size_t>(s->worker)]->done_pos.load(std::memory_order_acquire) >= s->retire_pos) {
        ready.push_back(s);
        retiring_[i] = retiring_.back();
        retiring_.pop_back();
      } else {
        ++i;
      }
    }
  }
  if (ready.empty()) return;
  // Their last results are in the rings or being sent by a worker: the holder's sends finish first.
  acquire_publisher();
  drain_results(encoder);
  // A close is the end of the take: the repetition in progress ends (Pipeline::flush, on this
  // thread: the worker is past the stream's last frame and no longer owns it) and goes out
  // after the stream's last result.
  for (StreamState* s : ready) {
    if (!s->pipeline) continue;
    s->pipeline->flush();
    if (!s->pipeline->flush_ended_repetition()) continue;
    kata_repetition rep;
    pipeline::fill_repetition(s->pipeline->repetitions()->newest(), s->id.load(std::memory_order_relaxed), &rep);
    if (publisher_ && !publisher_->send(encoder.repetition(rep, pipeline::now_ns())))
      s->counters.send_failed.fetch_add(1, std::memory_order_relaxed);
    for (const RepetitionSink& sink : config_.repetition_sinks) sink(rep);
  }
  release_publisher();
  std::lock_guard<std::mutex> lock(open_mutex_);
  for (StreamState* s : ready) {
    const StreamCounters c = read_counters(*s);
    retired_totals_.frames_in += c.frames_in;
    retired_totals_.queue_full += c.queue_full;
    retired_totals_.refused += c.refused;
    retired_totals_.results += c.results;
    retired_totals_.pipeline_dropped += c.pipeline_dropped;
    retired_totals_.result_queue_full += c.result_queue_full;
    retired_totals_.published += c.published;
    retired_totals_.send_failed += c.send_failed;
    retired_totals_.stopped += c.stopped;
    retired_totals_.stale += c.stale;
    retired_totals_.unauthorised += c.unauthorised;
    retired_totals_.out_of_sequence += c.out_of_sequence;
    retired_totals_.wrong_joints += c.wrong_joints;
    s->pipeline.reset();
    s->retired = true;
    s->id.store(kEmptyKey, std::memory_order_release);
    free_states_.push_back(s);
    stream_count_.fetch_sub(1);
    retiring_count_.fetch_sub(1, std::memory_order_release);
  }
}

void Runtime::add_locked(const transport::SkeletonDefinition& definition, pipeline::Pipeline* pipeline,
                         std::function<void(pipeline::Pipeline*)> release, bool publish_features) {
  // Owned only once nothing below can throw: a refused pipeline stays the caller's.
  check_open(definition);
  if (pipeline->ghost_joint_count() > kMaxGhostJoints)
    throw Error(ErrorKind::kInvalidArgument, "runtime: the ghost has more than 64 joints");
  // A retired state is reused (its counters went into retired_totals_); else a new one.
  std::unique_ptr<StreamState> fresh;
  StreamState* reused = nullptr;
  if (!free_states_.empty()) {
    reused = free_states_.back();
  } else {
    fresh = std::make_unique<StreamState>();
  }
  StreamState* state = reused ? reused : fresh.get();
  state->closed.store(false);
  state->retired = false;
  state->retire_pos = 0;
  state->accepted = 0;
  state->time_offset = 0.0;
  state->last_time = 0.0;
  state->next_result_sequence = 0;
  for (auto* c : {&state->counters.frames_in, &state->counters.queue_full, &state->counters.refused,
                  &state->counters.results, &state->counters.pipeline_dropped, &state->counters.result_queue_full,
                  &state->counters.published, &state->counters.send_failed, &state->counters.stopped,
                  &state->counters.stale, &state->counters.unauthorised, &state->counters.out_of_sequence,
                  &state->counters.wrong_joints})
    c->store(0, std::memory_order_relaxed);
  state->definition = definition;
  state->ghost_joints = pipeline->ghost_joint_count();
  // Practice: what the stream's own setup chose (kata serve's [scoring] teacher_start / loop), revision 0.
  practice_section_of(*pipeline, 0, &state->has_practice, &state->practice);
  state->teacher_frames = state->has_practice ? pipeline->scorer()->reference().frames() : 0;
  state->teacher_frame_time = state->has_practice ? pipeline->scorer()->reference().frame_time() : 0.0;
  state->publish_features = publish_features;
  // The worker with the fewest streams (open_mutex_ is held): a burst of every stream's frame
  // splits evenly over the workers whatever the ids (by id % workers, even ids would all land on
  // worker 0 of 2 and a burst would queue twice as deep).
  size_t least = 0;
  for (size_t w = 1; w < workers_.size(); ++w)
    if (workers_[w]->stream_count < workers_[least]->stream_count) least = w;
  ++workers_[least]->stream_count;
  state->worker = static_cast<int>(least);
  state->sequence_ring.assign(256, 0);
  state->capture_ring.assign(256, 0.0);
  Worker& worker = *workers_[static_cast<size_t>(state->worker)];
  if (state->publish_features && worker.features.empty()) {
    std::lock_guard<std::mutex> owned_lock(worker.owned_mutex);
    // Sized once per worker, before the first stream that needs it is visible to the worker.
    worker.features.assign(worker.results.size() * gpd::kDims, 0.0f);
    worker.read_features.assign(kReadBatch * gpd::kDims, 0.0f);
  }
  state->pipeline = std::unique_ptr<pipeline::Pipeline, std::function<void(pipeline::Pipeline*)>>(pipeline, std::move(release));
  StreamState* raw = state;
  if (reused) free_states_.pop_back();
  else streams_.push_back(std::move(fresh));  // reserved: cannot throw
  raw->live = true;
  raw->id.store(definition.stream_id, std::memory_order_release);
  {
    std::lock_guard<std::mutex> owned_lock(worker.owned_mutex);
    worker.owned.push_back(raw);
  }
  const size_t mask = table_keys_.size() - 1;
  for (size_t i = mix(definition.stream_id) & mask;; i = (i + 1) & mask) {
    const uint64_t key = table_keys_[i].load(std::memory_order_relaxed);
    if (key == kEmptyKey || key == kTombstone) {
      table_values_[i].store(raw, std::memory_order_release);
      table_keys_[i].store(definition.stream_id, std::memory_order_release);
      break;
    }
  }
  stream_count_.fetch_add(1);
  definitions_dirty_.store(true, std::memory_order_release);
  const uint64_t one = 1;
  (void)!write(wake_io_fd_, &one, sizeof one);
}

namespace {
template <typename Atomics>
StreamCounters read(const Atomics& a) {
  StreamCounters c;
  c.frames_in = a.frames_in.load();
  c.queue_full = a.queue_full.load();
  c.refused = a.refused.load();
  c.results = a.results.load();
  c.pipeline_dropped = a.pipeline_dropped.load();
  c.result_queue_full = a.result_queue_full.load();
  c.published = a.published.load();
  c.send_failed = a.send_failed.load();
  c.stopped = a.stopped.load();
  c.stale = a.stale.load();
  c.unauthorised = a.unauthorised.load();
  c.out_of_sequence = a.out_of_sequence.load();
  c.wrong_joints = a.wrong_joints.load();
  return c;
}
}  // namespace

StreamCounters Runtime::read_counters(const StreamState& s) { return read(s.counters); }

std::optional<StreamCounters> Runtime::stream_counters(uint64_t stream_id) const {
  const StreamState* s = find(stream_id);
  if (!s) return std::nullopt;
  return read(s->counters);
}

std::vector<std::pair<uint64_t, StreamCounters>> Runtime::all_stream_counters() const {
  std::vector<std::pair<uint64_t, StreamCounters>> out;
  std::lock_guard<std::mutex> lock(open_mutex_);
  for (const auto& s : streams_) out.emplace_back(s->definition.stream_id, read(s->counters));
  return out;
}

RuntimeCounters Runtime::counters() const {
  RuntimeCounters out;
  {
    std::lock_guard<std::mutex> lock(open_mutex_);
    out.streams = 0;
    out.total = retired_totals_;
    out.closed_streams = closed_streams_;
    for (const auto& s : streams_) {
      if (s->retired) continue;  // live or closing: its own counters
      if (s->live) ++out.streams;
      const StreamCounters c = read(s->counters);
      out.total.frames_in += c.frames_in;
      out.total.queue_full += c.queue_full;
      out.total.refused += c.refused;
      out.total.results += c.results;
      out.total.pipeline_dropped += c.pipeline_dropped;
      out.total.result_queue_full += c.result_queue_full;
      out.total.published += c.published;
      out.total.send_failed += c.send_failed;
      out.total.stopped += c.stopped;
      out.total.stale += c.stale;
      out.total.unauthorised += c.unauthorised;
      out.total.out_of_sequence += c.out_of_sequence;
      out.total.wrong_joints += c.wrong_joints;
    }
  }
  std::lock_guard<std::mutex> lock(io_counters_mutex_);
  out.ingest = ingest_snapshot_;
  out.skeletons_sent = skeletons_sent_;
  for (int i = 0; i < kLatencyBuckets; ++i) out.latency_histogram[i] = latency_histogram_[i].load(std::memory_order_relaxed);
  return out;
}


}  // namespace kata::runtime
