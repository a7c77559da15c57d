// The runtime (threading model in runtime.hpp).
#include "runtime/runtime.hpp"

#include <sched.h>
#include <semaphore.h>
#include <sys/eventfd.h>
#include <unistd.h>
#include <zmq.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>

#include "common/error.hpp"
#include "skeleton/skeleton.hpp"

namespace kata::runtime {

namespace {

size_t round_up_pow2(size_t n) {
  size_t p = 1;
  while (p < n) p <<= 1;
  return p;
}

uint64_t mix(uint64_t x) {  // splitmix64 finaliser: spreads sequential ids over the table
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

constexpr uint64_t kEmptyKey = ~0ULL;      // stream ids the table cannot hold: a free slot,
constexpr uint64_t kTombstone = ~0ULL - 1;  // and a closed stream's slot (reused by a later open)
// Set in a worker's enqueue_pos by stop(): the queue takes no more frames. The position below it
// is then final: exactly the pushes that claimed a cell before, which the worker finishes.
constexpr size_t kQueueClosed = size_t{1} << (8 * sizeof(size_t) - 1);

inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

// Backs off until ready() or the budget is spent: spins (pause) for spin_ns, then yields the
// CPU until yield_ns. True when ready() became true.
template <typename Ready>
bool back_off(int64_t spin_ns, int64_t yield_ns, Ready ready) {
  const int64_t start = pipeline::now_ns();
  for (unsigned n = 0;; ++n) {
    if (ready()) return true;
    if ((n & 15) != 15) {  // look at the clock every 16 turns
      cpu_relax();
      continue;
    }
    const int64_t spent = pipeline::now_ns() - start;
    if (spent >= yield_ns && spent >= spin_ns) return ready();
    if (spent >= spin_ns) sched_yield();
  }
}

}  // namespace

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
    layout = resolve_layout(d.skeleton, d.preset.empty() ? "cmu" : d.preset);
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

// ---------------------------------------------------------------------------------------------

struct Runtime::StreamState {
  // Closing (stream table in runtime.hpp): a closed state is retired once its worker is past its
  // last frame, then reused by a later open; push() checks both after it found the state.
  std::atomic<uint64_t> id{kEmptyKey};
  std::atomic<bool> closed{false};
  bool live = false;                             // open_mutex_: open (in the table)
  bool retired = false;                          // open_mutex_: counters moved to retired_totals_
  size_t retire_pos = 0;                         // the worker's enqueue position at the close
  transport::SkeletonDefinition definition;
  std::unique_ptr<pipeline::Pipeline, std::function<void(pipeline::Pipeline*)>> pipeline;  // its worker only
  bool publish_features = false;
  int worker = 0;
  int ghost_joints = 0;
  // Source sequence of each accepted frame, by frame index (results may trail their frame).
  std::vector<uint64_t> sequence_ring;
  std::vector<double> capture_ring;              // the source's capture time, by frame index
  int64_t accepted = 0;                          // worker only
  // A source that restarts sends its clock from 0 again, but a pipeline's time only increases:
  // the worker adds an offset (the source's times are what results carry).
  double time_offset = 0.0;                      // worker only
  double last_time = 0.0;                        // worker only: newest pipeline time
  // Worker -> I/O thread: the per-stream result counter lives with the I/O thread.
  uint64_t next_result_sequence = 0;             // I/O thread only
  struct alignas(64) Atomics {
    std::atomic<uint64_t> frames_in{0}, queue_full{0}, refused{0}, results{0}, pipeline_dropped{0},
        result_queue_full{0}, published{0}, send_failed{0}, stopped{0}, stale{0}, unauthorised{0};
    std::atomic<int> in_push{0};  // pushes between find() and their published cell
  } counters;
};

struct Runtime::FrameCell {
  std::atomic<size_t> turn{0};
  StreamState* stream = nullptr;
  uint64_t sequence = 0;
  double capture_time = 0.0;
  int64_t arrival_ns = 0;
  int joints = 0;
  bool restart = false;
  float* xyz = nullptr;         // points into Worker::frame_data
  float* confidence = nullptr;  // points into Worker::confidence_data
  bool has_confidence = false;
};

// A result on its way to the I/O thread.
struct ResultCell {
  void* stream = nullptr;
  pipeline::Result result;
  uint64_t frame_sequence = 0;
  int64_t computed_ns = 0;
};

struct Runtime::Worker {
  int index = 0;
  // Frames in: bounded multi-producer / single-consumer ring (Vyukov's bounded queue).
  std::vector<FrameCell> cells;
  std::vector<float> frame_data;
  std::vector<float> confidence_data;  // cells x max_joints
  size_t mask = 0;
  alignas(64) std::atomic<size_t> enqueue_pos{0};  // | kQueueClosed once stop() began
  alignas(64) size_t dequeue_pos = 0;
  std::atomic<size_t> done_pos{0};  // dequeue_pos once the frame's results were handed over
  sem_t wake;
  // Between taking a frame and handing over its results (the I/O thread backs off on it).
  alignas(64) std::atomic<bool> busy{false};
  // Results out: single-producer (this worker) / single-consumer (I/O thread) ring.
  std::vector<ResultCell> results;
  std::vector<float> ghosts;     // result cells x max ghost joints x 3
  std::vector<float> features;   // result cells x kDims (only filled for streams that publish them)
  size_t result_mask = 0;
  alignas(64) std::atomic<size_t> result_head{0};  // written by the worker
  alignas(64) std::atomic<size_t> result_tail{0};  // written by the I/O thread
  std::vector<StreamState*> owned;  // the streams of this shard (for the final flush)
  size_t stream_count = 0;          // streams assigned here (under open_mutex_)
  std::mutex owned_mutex;           // open_stream vs the final flush only
  std::thread thread;
  // Scratch for Pipeline::read.
  std::vector<pipeline::Result> read_buffer;
  std::vector<float> read_ghosts, read_features;
};

static constexpr int kMaxGhostJoints = 64;
static constexpr size_t kReadBatch = 64;

Runtime::Runtime(RuntimeConfig config) : config_(std::move(config)) {
  if (config_.workers < 1 || config_.max_joints < 1 || config_.max_streams < 1)
    throw Error(ErrorKind::kInvalidArgument, "runtime: workers, max_joints and max_streams must be >= 1");
  const size_t table_size = round_up_pow2(static_cast<size_t>(config_.max_streams) * 2);
  table_keys_ = std::vector<std::atomic<uint64_t>>(table_size);
  table_values_ = std::vector<std::atomic<StreamState*>>(table_size);
  for (auto& k : table_keys_) k.store(kEmptyKey, std::memory_order_relaxed);
  for (auto& v : table_values_) v.store(nullptr, std::memory_order_relaxed);

  streams_.reserve(static_cast<size_t>(config_.max_streams));
  context_ = std::make_unique<transport::Context>(1);
  // CURVE servers ask the context's ZAP handler about every client (curve.hpp).
  {
    const auto& in = config_.ingest.security.curve;
    const auto& out = config_.publish.security.curve;
    const bool in_server = in.enabled() && in.remote_server.empty() && !config_.ingest.endpoints.empty();
    const bool out_server = out.enabled() && out.remote_server.empty() && !config_.publish.endpoints.empty();
    if (in_server || out_server) {
      std::vector<std::string> allowed;
      if (in_server) allowed = in.allowed_clients;
      if (out_server) allowed.insert(allowed.end(), out.allowed_clients.begin(), out.allowed_clients.end());
      context_->authenticate(std::move(allowed));
    }
  }
  if (!config_.publish.endpoints.empty()) {
    publisher_ = std::make_unique<transport::Publisher>(*context_, config_.publish);
    publish_endpoint_ = publisher_->endpoint();
  }
  if (!config_.ingest.endpoints.empty()) {
    transport::Ingest::Handlers handlers;
    handlers.on_skeleton = [this](const transport::SkeletonDefinition& d) {
      if (find(d.stream_id)) return false;
      open_announced(d);
      return true;
    };
    // The owner's new revision restarts the stream with it (the ingest restarts the next frame):
    // the same skeleton keeps its pipeline, another one is opened anew.
    handlers.on_revision = [this](const transport::SkeletonDefinition& d) { return revise_announced(d); };
    handlers.on_close = [this](uint64_t id) { close_stream(id); };
    handlers.on_frame = [this](const transport::FrameView& f, bool restarted) {
      push(f.stream_id, f.sequence, static_cast<double>(f.capture_ns) * 1e-9, f.xyz, f.joints, restarted, f.confidence);
    };
    ingest_ = std::make_unique<transport::Ingest>(*context_, config_.ingest, std::move(handlers));
    ingest_endpoint_ = ingest_->endpoint();
  }

  wake_io_fd_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_io_fd_ < 0) throw Error(ErrorKind::kIo, std::string("runtime: eventfd: ") + std::strerror(errno));

  const size_t frame_cells = round_up_pow2(static_cast<size_t>(std::max(2, config_.frame_queue_capacity)));
  const size_t result_cells = round_up_pow2(static_cast<size_t>(std::max(2, config_.result_queue_capacity)));
  for (int w = 0; w < config_.workers; ++w) {
    auto worker = std::make_unique<Worker>();
    worker->index = w;
    worker->cells = std::vector<FrameCell>(frame_cells);
    worker->frame_data.assign(frame_cells * static_cast<size_t>(config_.max_joints) * 3, 0.0f);
    worker->confidence_data.assign(frame_cells * static_cast<size_t>(config_.max_joints), 0.0f);
    worker->mask = frame_cells - 1;
    for (size_t i = 0; i < frame_cells; ++i) {
      worker->cells[i].turn.store(i, std::memory_order_relaxed);
      worker->cells[i].xyz = worker->frame_data.data() + i * static_cast<size_t>(config_.max_joints) * 3;
      worker->cells[i].confidence = worker->confidence_data.data() + i * static_cast<size_t>(config_.max_joints);
    }
    worker->results.resize(result_cells);
    worker->ghosts.assign(result_cells * kMaxGhostJoints * 3, 0.0f);
    worker->result_mask = result_cells - 1;
    worker->read_buffer.resize(kReadBatch);
    worker->read_ghosts.assign(kReadBatch * kMaxGhostJoints * 3, 0.0f);
    worker->owned.reserve(static_cast<size_t>(config_.max_streams));
    sem_init(&worker->wake, 0, 0);
    workers_.push_back(std::move(worker));
  }
  for (auto& w : workers_) w->thread = std::thread([this, wp = w.get()] { worker_loop(*wp); });
  io_thread_ = std::thread([this] { io_loop(); });
}

Runtime::~Runtime() {
  stop();
  // Here, not in stop(): a push that claimed its cell before stop() closed the queue may still
  // be posting (the worker has finished its frame, the post only wakes nobody).
  for (auto& w : workers_) sem_destroy(&w->wake);
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
         a.preset == b.preset && a.name_map == b.name_map && a.up_axis == b.up_axis;
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
  drain_results(encoder);
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
                  &state->counters.published, &state->counters.send_failed})
    c->store(0, std::memory_order_relaxed);
  state->definition = definition;
  state->ghost_joints = pipeline->ghost_joint_count();
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

Status Runtime::push(uint64_t stream_id, uint64_t sequence, double capture_time, const float* xyz, int joints,
                     bool restart, const float* confidence) {
  if (!xyz) return Status::kNullPointer;
  StreamState* stream = find(stream_id);
  if (!stream) return Status::kNotFound;
  if (joints < 0 || joints > config_.max_joints) return Status::kWrongJointCount;
  // Against a close on another thread: either close_stream sees this push in flight and waits
  // for its cell, or this push sees the close (seq_cst on both sides); a state reused for
  // another stream since find() shows another id.
  stream->counters.in_push.fetch_add(1, std::memory_order_seq_cst);
  struct Leave {
    std::atomic<int>& n;
    ~Leave() { n.fetch_sub(1, std::memory_order_release); }
  } leave{stream->counters.in_push};
  if (stream->closed.load(std::memory_order_seq_cst) || stream->id.load(std::memory_order_acquire) != stream_id)
    return Status::kNotFound;
  Worker& w = *workers_[static_cast<size_t>(stream->worker)];
  size_t pos = w.enqueue_pos.load(std::memory_order_relaxed);
  FrameCell* cell;
  for (;;) {
    if (pos & kQueueClosed) {  // stop() began: refused, and the caller sees it
      stream->counters.stopped.fetch_add(1, std::memory_order_relaxed);
      return Status::kStopped;
    }
    cell = &w.cells[pos & w.mask];
    const size_t turn = cell->turn.load(std::memory_order_acquire);
    const intptr_t diff = static_cast<intptr_t>(turn) - static_cast<intptr_t>(pos);
    if (diff == 0) {
      if (w.enqueue_pos.compare_exchange_weak(pos, pos + 1, std::memory_order_relaxed)) break;
    } else if (diff < 0) {
      stream->counters.queue_full.fetch_add(1, std::memory_order_relaxed);
      return Status::kState;
    } else {
      pos = w.enqueue_pos.load(std::memory_order_relaxed);
    }
  }
  cell->stream = stream;
  cell->sequence = sequence;
  cell->capture_time = capture_time;
  cell->arrival_ns = pipeline::now_ns();
  cell->joints = joints;
  cell->restart = restart;
  std::memcpy(cell->xyz, xyz, sizeof(float) * 3 * static_cast<size_t>(joints));
  cell->has_confidence = confidence != nullptr;
  if (confidence) std::memcpy(cell->confidence, confidence, sizeof(float) * static_cast<size_t>(joints));
  stream->counters.frames_in.fetch_add(1, std::memory_order_relaxed);  // before the worker can see it
  cell->turn.store(pos + 1, std::memory_order_release);
  sem_post(&w.wake);
  return Status::kOk;
}

void Runtime::worker_loop(Worker& w) {
  bool signalled = false;
  auto move_results = [&](StreamState& s) {
    pipeline::Pipeline& p = *s.pipeline;
    for (;;) {
      float* features = s.publish_features ? w.read_features.data() : nullptr;
      const size_t n = p.read(w.read_buffer.data(), w.read_ghosts.data(), features, kReadBatch);
      if (n == 0) break;
      const int64_t computed = pipeline::now_ns();
      for (size_t i = 0; i < n; ++i) {
        const pipeline::Result& r = w.read_buffer[i];
        s.counters.results.fetch_add(1, std::memory_order_relaxed);
        const size_t head = w.result_head.load(std::memory_order_relaxed);
        if (head - w.result_tail.load(std::memory_order_acquire) > w.result_mask) {
          s.counters.result_queue_full.fetch_add(1, std::memory_order_relaxed);
          continue;
        }
        const size_t k = head & w.result_mask;
        ResultCell& cell = w.results[k];
        cell.stream = &s;
        cell.result = r;
        cell.computed_ns = r.computed_ns ? r.computed_ns : computed;  // the pipeline's stamp
        const size_t ring = static_cast<size_t>(r.frame_index) % s.sequence_ring.size();
        cell.frame_sequence = s.sequence_ring[ring];
        cell.result.capture_time = s.capture_ring[ring];
        const size_t ghost_floats = 3 * static_cast<size_t>(s.ghost_joints);
        if (ghost_floats)
          std::memcpy(w.ghosts.data() + k * kMaxGhostJoints * 3, w.read_ghosts.data() + i * ghost_floats,
                      ghost_floats * sizeof(float));
        if (features)
          std::memcpy(w.features.data() + k * gpd::kDims, features + i * gpd::kDims, gpd::kDims * sizeof(float));
        w.result_head.store(head + 1, std::memory_order_release);
        signalled = true;
      }
    }
    s.counters.pipeline_dropped.store(p.dropped(), std::memory_order_relaxed);
  };
  // Wakes the I/O thread after every result (so it sends while this worker computes the next),
  // with a syscall only when it is asleep in zmq_poll.
  auto wake_io = [&] {
    if (!signalled) return;
    signalled = false;
    if (!io_sleeping_.exchange(false)) return;
    const uint64_t one = 1;
    (void)!write(wake_io_fd_, &one, sizeof one);
  };

  const IdleStrategy& idle = config_.idle;
  const bool backoff = idle.kind == IdleStrategy::Kind::kBackoff;
  for (;;) {
    // Wait for a frame (backing off first, by the idle strategy); every 50 ms look at the stop flag.
    if (sem_trywait(&w.wake) != 0 &&
        !(backoff && (wake_io(), w.busy.store(false, std::memory_order_release),
                      back_off(idle.worker_spin_ns, idle.worker_yield_ns, [&] { return sem_trywait(&w.wake) == 0; })))) {
      wake_io();
      w.busy.store(false, std::memory_order_release);
      timespec deadline;
      clock_gettime(CLOCK_REALTIME, &deadline);
      deadline.tv_nsec += 50'000'000;
      if (deadline.tv_nsec >= 1'000'000'000) {
        deadline.tv_sec += 1;
        deadline.tv_nsec -= 1'000'000'000;
      }
      if (sem_timedwait(&w.wake, &deadline) != 0) {
        if (stopping_.load(std::memory_order_acquire)) {
          // A push that claimed a cell before stop() closed the queue is finished first (its
          // post is on its way): nothing stop() took is left behind.
          if (w.dequeue_pos != (w.enqueue_pos.load(std::memory_order_acquire) & ~kQueueClosed)) continue;
          // Queue empty and stopping: flush every pipeline, hand over what it emits, done.
          std::lock_guard<std::mutex> lock(w.owned_mutex);
          for (StreamState* s : w.owned) {
            s->pipeline->flush();
            move_results(*s);
          }
          wake_io();
          workers_done_.fetch_add(1, std::memory_order_release);
          const uint64_t one = 1;
          (void)!write(wake_io_fd_, &one, sizeof one);
          return;
        }
        continue;
      }
    }
    if (backoff) {
      // The I/O thread's wake-up, if it sleeps, overlaps this frame's compute; it then backs off
      // on busy until the result is there instead of parking again.
      w.busy.store(true, std::memory_order_seq_cst);
      if (io_sleeping_.exchange(false)) {
        const uint64_t one = 1;
        (void)!write(wake_io_fd_, &one, sizeof one);
      }
    }
    FrameCell& cell = w.cells[w.dequeue_pos & w.mask];
    // A post means some producer published a cell, not necessarily this one (two producers may
    // finish out of order): wait the few instructions until the one in turn is published.
    while (cell.turn.load(std::memory_order_acquire) != w.dequeue_pos + 1) std::this_thread::yield();
    StreamState& s = *cell.stream;
    pipeline::Pipeline& p = *s.pipeline;
    if (cell.restart && s.accepted > 0) {
      p.reset();
      p.restart_teacher();
      move_results(s);
      // One second after the newest time: past any gap that still joins segments.
      s.time_offset = s.last_time + 1.0 - cell.capture_time;
    }
    const double t = cell.capture_time + s.time_offset;
    const Status st = p.push(t, cell.xyz, cell.has_confidence ? cell.confidence : nullptr, cell.joints, cell.arrival_ns);
    // kInternal: the pipeline kept the frame (its frame index moved on) but withheld a non-finite
    // vector; the frame keeps its sequence slot so that later results map to their own frames.
    if (st == Status::kOk || st == Status::kInternal) {
      const size_t ring = static_cast<size_t>(s.accepted) % s.sequence_ring.size();
      s.sequence_ring[ring] = cell.sequence;
      s.capture_ring[ring] = cell.capture_time;
      s.last_time = t;
      ++s.accepted;
    }
    if (st != Status::kOk && st != Status::kTrackingLost) {  // tracking lost: accepted, no features (the confidence gate)
      s.counters.refused.fetch_add(1, std::memory_order_relaxed);
    }
    cell.turn.store(w.dequeue_pos + w.mask + 1, std::memory_order_release);
    ++w.dequeue_pos;
    move_results(s);
    w.done_pos.store(w.dequeue_pos, std::memory_order_release);  // closed streams retire past it
    wake_io();
  }
}

void Runtime::send_definitions(const uint8_t* prefix, size_t prefix_size) {
  if (!publisher_) return;
  transport::Encoder encoder;  // rare path (joins, periodic): its own builder is fine
  std::vector<StreamState*> streams;
  {
    std::lock_guard<std::mutex> lock(open_mutex_);
    for (const auto& s : streams_)
    if (s->live) streams.push_back(s.get());
  }
  char topic[transport::kTopicBytes];
  for (StreamState* s : streams) {
    transport::write_topic(s->definition.stream_id, topic);
    if (prefix_size > transport::kTopicBytes || (prefix_size > 0 && std::memcmp(topic, prefix, prefix_size) != 0))
      continue;
    if (publisher_->send(encoder.skeleton(s->definition))) {
      std::lock_guard<std::mutex> lock(io_counters_mutex_);
      ++skeletons_sent_;
    }
  }
}

void Runtime::send_stats(transport::Encoder& encoder) {
  if (!publisher_) return;
  if (ingest_) {
    std::lock_guard<std::mutex> lock(io_counters_mutex_);
    ingest_snapshot_ = ingest_->counters();
  }
  const RuntimeCounters c = counters();
  const transport::IngestCounters& in = c.ingest;
  transport::StatsFields f;
  f.streams = c.streams;
  f.closed_streams = c.closed_streams;
  f.received = in.received;
  f.frames = in.frames;
  f.definitions = in.skeletons;
  f.repeated_definitions = in.repeated_skeletons;
  f.closes = in.closes;
  f.other_shard = in.other_shard;
  f.dropped = in.dropped_total();
  f.malformed = in.malformed_total();
  f.not_owner = in.not_owner;
  f.refused_limit = in.refused_limit;
  f.refused_definitions = in.refused_skeletons;
  f.unknown_stream = in.unknown_stream;
  f.wrong_joint_count = in.wrong_joint_count;
  f.out_of_order = in.out_of_order;
  f.out_of_window = in.out_of_window;
  f.stale = in.stale;
  f.other_kind = in.other_kind;
  f.sequence_gaps = in.sequence_gaps;
  f.restarts = in.restarts;
  f.connections = in.connections;
  f.connections_refused = in.connections_refused;
  f.frames_in = c.total.frames_in;
  f.queue_full = c.total.queue_full;
  f.refused = c.total.refused;
  f.results = c.total.results;
  f.results_dropped = c.total.pipeline_dropped + c.total.result_queue_full;
  f.published = c.total.published;
  f.send_failed = c.total.send_failed;
  {
    std::lock_guard<std::mutex> lock(open_mutex_);
    for (const auto& s : streams_) {
      if (!s->live) continue;
      const StreamCounters k = read_counters(*s);
      f.per_stream.push_back({s->definition.stream_id, k.frames_in, k.queue_full, k.refused, k.results,
                              k.pipeline_dropped + k.result_queue_full, k.published});
    }
  }
  f.published_ns = pipeline::now_ns();
  publisher_->send(encoder.stats(f));
}

bool Runtime::results_pending() const {
  for (const auto& w : workers_)
    if (w->result_head.load(std::memory_order_acquire) != w->result_tail.load(std::memory_order_relaxed)) return true;
  return false;
}

bool Runtime::workers_busy() const {
  for (const auto& w : workers_)
    if (w->busy.load(std::memory_order_acquire)) return true;
  return false;
}

bool Runtime::drain_results(transport::Encoder& encoder) {
  bool any = false;
  for (auto& wp : workers_) {
    Worker& w = *wp;
    size_t tail = w.result_tail.load(std::memory_order_relaxed);
    const size_t head = w.result_head.load(std::memory_order_acquire);
    for (; tail != head; ++tail) {
      const size_t k = tail & w.result_mask;
      const ResultCell& cell = w.results[k];
      auto& s = *static_cast<StreamState*>(cell.stream);
      const pipeline::Result& r = cell.result;
      transport::ResultFields f;
      f.stream_id = s.definition.stream_id;
      f.result_sequence = s.next_result_sequence++;
      f.frame_sequence = cell.frame_sequence;
      f.frame_index = r.frame_index;
      f.capture_ns = static_cast<int64_t>(r.capture_time * 1e9);
      f.arrival_ns = r.arrival_ns;
      f.computed_ns = cell.computed_ns;
      f.scored = r.scored;
      if (r.scored) {
        f.distance = r.score.distance;
        f.score = r.score.score;
        for (int i = 0; i < 5; ++i) f.parts[i] = r.score.parts[i];
        for (int i = 0; i < 5; ++i) f.part_scores[i] = r.score.part_scores[i];
        f.part_to_fix = r.score.part_to_fix;
        f.state = static_cast<int32_t>(r.score.state);
      }
      f.matched_teacher_frame = r.matched_frame;
      f.matched_teacher_time = r.scored ? r.score.matched_time : -1.0;
      if (r.has_ghost) {
        f.ghost = w.ghosts.data() + k * kMaxGhostJoints * 3;
        f.ghost_joints = s.ghost_joints;
      }
      if (s.publish_features) {
        f.features = w.features.data() + k * gpd::kDims;
        f.feature_count = gpd::kDims;
      }
      if (publisher_) {
        f.published_ns = pipeline::now_ns();
        if (publisher_->send(encoder.result(f))) {
          s.counters.published.fetch_add(1, std::memory_order_relaxed);
          latency_histogram_[latency_bucket(f.published_ns - f.arrival_ns)].fetch_add(1, std::memory_order_relaxed);
        }
        else
          s.counters.send_failed.fetch_add(1, std::memory_order_relaxed);
      }
      for (const Sink& sink : config_.sinks) sink.on_result(f);  // after the send: no added latency
      any = true;
    }
    w.result_tail.store(tail, std::memory_order_release);
  }
  return any;
}

void Runtime::io_loop() {
  transport::Encoder encoder;
  using clock = std::chrono::steady_clock;
  const auto resend_every = std::chrono::duration_cast<clock::duration>(
      std::chrono::duration<double>(config_.skeleton_resend_seconds > 0 ? config_.skeleton_resend_seconds : 1.0));
  auto next_resend = clock::now() + resend_every;
  auto last_snapshot = clock::now();
  const IdleStrategy& idle = config_.idle;
  const bool backoff = idle.kind == IdleStrategy::Kind::kBackoff;
  for (;;) {
    // A frame in a worker: wait for its result awake (bounded) rather than park and be woken.
    if (backoff && !results_pending() && workers_busy() &&
        back_off(idle.io_spin_ns, idle.io_yield_ns, [&] { return results_pending() || !workers_busy(); }) &&
        results_pending()) {
      drain_results(encoder);
    }
    zmq_pollitem_t items[3];
    int n = 0;
    items[n++] = zmq_pollitem_t{nullptr, wake_io_fd_, ZMQ_POLLIN, 0};
    const int publisher_item = publisher_ ? n : -1;
    if (publisher_) items[n++] = zmq_pollitem_t{publisher_->socket(), 0, ZMQ_POLLIN, 0};
    const int ingest_item = ingest_ ? n : -1;
    if (ingest_) items[n++] = zmq_pollitem_t{ingest_->socket(), 0, ZMQ_POLLIN, 0};
    const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(next_resend - clock::now()).count();
    // Announce the sleep, then look once more: a result queued before the flag was set is sent
    // now; one queued after it comes with an eventfd write.
    io_sleeping_.store(true);
    const bool pending = results_pending();
    zmq_poll(items, n, pending ? 0 : static_cast<long>(std::max<long long>(0, std::min<long long>(wait, 100))));
    io_sleeping_.store(false);

    if (items[0].revents & ZMQ_POLLIN) {
      uint64_t value;
      (void)!read(wake_io_fd_, &value, sizeof value);
    }
    if (definitions_dirty_.exchange(false, std::memory_order_acq_rel)) send_definitions(nullptr, 0);
    drain_results(encoder);
    if (retiring_count_.load(std::memory_order_acquire) > 0) retire_closed(encoder);
    if (publisher_item >= 0 && (items[publisher_item].revents & ZMQ_POLLIN))
      publisher_->poll_joins([this](const uint8_t* prefix, size_t size) { send_definitions(prefix, size); });
    if (ingest_stop_requested_.load(std::memory_order_acquire)) {
      ingest_stopped_.store(true, std::memory_order_release);
    } else if (ingest_item >= 0 && (items[ingest_item].revents & ZMQ_POLLIN)) {
      ingest_->poll(256);
    } else if (ingest_) {
      ingest_->housekeeping();  // connection events and idle expiry, also while no frame comes
    }
    const auto now = clock::now();
    if (now >= next_resend) {
      send_definitions(nullptr, 0);
      send_stats(encoder);
      next_resend = now + resend_every;
    }
    if (ingest_ && now - last_snapshot > std::chrono::milliseconds(50)) {
      std::lock_guard<std::mutex> lock(io_counters_mutex_);
      ingest_snapshot_ = ingest_->counters();
      last_snapshot = now;
    }
    if (workers_done_.load(std::memory_order_acquire) == static_cast<int>(workers_.size())) {
      drain_results(encoder);
      for (const Sink& sink : config_.sinks)
        if (sink.flush) sink.flush();
      if (ingest_) {
        std::lock_guard<std::mutex> lock(io_counters_mutex_);
        ingest_snapshot_ = ingest_->counters();
      }
      return;
    }
  }
}

void Runtime::stop() {
  if (stopped_.exchange(true)) return;
  if (ingest_ && io_thread_.joinable()) {
    // No frame is ingested once the workers may have looked at their queues for the last time.
    ingest_stop_requested_.store(true, std::memory_order_release);
    const uint64_t one = 1;
    while (!ingest_stopped_.load(std::memory_order_acquire)) {
      (void)!write(wake_io_fd_, &one, sizeof one);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  // Every queue closed before the workers are told to finish: a racing push either claimed its
  // cell before (taken: the worker finishes it, its result is sent before stop returns) or sees
  // the closed queue (refused: kStopped). Under open_mutex_: a stream opens before or not at all.
  {
    std::lock_guard<std::mutex> lock(open_mutex_);
    for (auto& w : workers_) w->enqueue_pos.fetch_or(kQueueClosed, std::memory_order_acq_rel);
    stopping_.store(true, std::memory_order_release);
  }
  for (auto& w : workers_) w->thread.join();
  if (io_thread_.joinable()) io_thread_.join();
  // Sockets close on this thread after the I/O thread ended (join is the memory barrier).
  ingest_.reset();
  publisher_.reset();
  if (wake_io_fd_ >= 0) close(wake_io_fd_);
  wake_io_fd_ = -1;
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
    }
  }
  std::lock_guard<std::mutex> lock(io_counters_mutex_);
  out.ingest = ingest_snapshot_;
  out.skeletons_sent = skeletons_sent_;
  for (int i = 0; i < kLatencyBuckets; ++i) out.latency_histogram[i] = latency_histogram_[i].load(std::memory_order_relaxed);
  return out;
}

}  // namespace kata::runtime
