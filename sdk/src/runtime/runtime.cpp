// The runtime: construction, stop and destruction, wiring the stream table (stream_table.cpp),
// the workers (worker.cpp) and the I/O thread (io_loop.cpp); their private parts are in
// runtime_internal.hpp and the threading model in runtime.hpp.
#include "runtime/runtime_internal.hpp"

namespace kata::runtime {

using namespace internal;

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
  const bool direct = config_.ingest.kind == transport::IngestKind::kDirect;
  if (!config_.ingest.endpoints.empty() || direct) {
    transport::Ingest::Handlers handlers;
    handlers.on_skeleton = [this](const transport::SkeletonDefinition& d) {
      if (find(d.stream_id)) return false;
      open_announced(d);
      return true;
    };
    // The owner's new revision restarts the stream with it (the ingest restarts the next frame):
    // the same skeleton keeps its pipeline, another one is opened anew.
    handlers.on_revision = [this](const transport::SkeletonDefinition& d) {
      close_people(d.stream_id);
      return revise_announced(d);
    };
    handlers.on_close = [this](uint64_t id) {
      close_people(id);
      close_stream(id);
    };
    // A refused definition goes back to its source on the stream's results topic (a skeleton
    // message with `refused`): a sender watching its results learns it instead of sending into
    // nothing. (Rare: once per definition received; the I/O thread's, holding the publisher.)
    handlers.on_refused_definition = [this](const transport::SkeletonDefinition& d, const std::string& why) {
      if (!publisher_) return;
      transport::SkeletonDefinition refusal = d;
      refusal.refused = why;
      transport::Encoder encoder;
      acquire_publisher();
      publisher_->send(encoder.skeleton(refusal));
      release_publisher();
    };
    // A frame of an open stream the ingest refused is counted on the stream (kDropCauses).
    handlers.on_refused_frame = [this](uint64_t id, transport::TableVerdict cause) {
      StreamState* s = find(id);
      if (!s) return;
      std::atomic<uint64_t>* count = nullptr;
      switch (cause) {
        case transport::TableVerdict::kStale: count = &s->counters.stale; break;
        case transport::TableVerdict::kNotOwner: count = &s->counters.unauthorised; break;
        case transport::TableVerdict::kOutOfOrder:
        case transport::TableVerdict::kOutOfWindow: count = &s->counters.out_of_sequence; break;
        case transport::TableVerdict::kWrongJoints: count = &s->counters.wrong_joints; break;
        default: return;
      }
      count->fetch_add(1, std::memory_order_relaxed);
    };
    // A practice setting from the stream's owner: queued in order with its frames.
    handlers.on_practice = [this](const transport::PracticeSetting& p, std::string* why) { return set_practice(p, why); };
    handlers.on_frame = [this](const transport::FrameView& f, bool restarted) {
      push(f.stream_id, f.sequence, static_cast<double>(f.capture_ns) * 1e-9, f.xyz, f.joints, restarted, f.confidence);
    };
    handlers.on_people = [this](const transport::PeopleFrameView& f, bool restarted) { push_people(f, restarted); };
    ingest_ = std::make_unique<transport::Ingest>(*context_, config_.ingest, std::move(handlers));
    ingest_endpoint_ = ingest_->endpoint();
  }
  if (direct) {
    // Room for two messages of the limit at least (MessageRing::max_message is half the ring).
    direct_ring_ = std::make_unique<transport::MessageRing>(
        std::max(config_.ingest.direct_queue_bytes, 2 * (config_.ingest.max_message_bytes + 64)));
    direct_fd_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (direct_fd_ < 0) throw Error(ErrorKind::kIo, std::string("runtime: eventfd: ") + std::strerror(errno));
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
    worker->encoder = std::make_unique<transport::Encoder>();
    sem_init(&worker->wake, 0, 0);
    workers_.push_back(std::move(worker));
  }
  // Named, so per-thread CPU (kata replay, top -H) tells them apart: kata-worker0.., kata-io.
  for (auto& w : workers_) {
    w->thread = std::thread([this, wp = w.get()] { worker_loop(*wp); });
    const std::string name = "kata-worker" + std::to_string(w->index);
    pthread_setname_np(w->thread.native_handle(), name.c_str());
  }
  io_thread_ = std::thread([this] { io_loop(); });
  pthread_setname_np(io_thread_.native_handle(), "kata-io");
}

Runtime::~Runtime() {
  stop();
  // Here, not in stop(): a push that claimed its cell before stop() closed the queue may still
  // be posting (the worker has finished its frame, the post only wakes nobody).
  for (auto& w : workers_) sem_destroy(&w->wake);
  if (direct_fd_ >= 0) close(direct_fd_);
}

bool Runtime::offer(const void* data, size_t size) {
  if (!direct_ring_) return false;
  // Dekker against stop(): either the I/O thread sees offering_ and waits for this push before
  // its last drain, or this sees ingest_stop_requested_ and refuses (the caller counts it).
  offering_.store(true, std::memory_order_seq_cst);
  if (ingest_stop_requested_.load(std::memory_order_seq_cst)) {
    offering_.store(false, std::memory_order_release);
    return false;
  }
  const bool taken = direct_ring_->push(data, size);
  offering_.store(false, std::memory_order_release);
  if (taken) {
    // Every message: a write is ~1 us here, and a wake-up skipped on a guess of whether the I/O
    // thread is awake would leave a frame waiting for its 100 ms poll timeout.
    const uint64_t one = 1;
    (void)!write(direct_fd_, &one, sizeof one);
  }
  return taken;
}

void Runtime::stop() {
  if (stopped_.exchange(true)) return;
  if (ingest_ && io_thread_.joinable()) {
    // No frame is ingested once the workers may have looked at their queues for the last time.
    ingest_stop_requested_.store(true, std::memory_order_seq_cst);  // seq_cst: offer()'s Dekker
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


}  // namespace kata::runtime
