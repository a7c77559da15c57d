// The I/O thread (runtime.hpp, "threads"): it owns the ingest (its socket, or a direct ingest's
// ring: the ring's read side is this thread's, its write side offer()'s one producer). It reads
// the ingest, sends skeleton definitions (on a subscriber's join and periodically) and stats,
// retires closed streams, and sleeps in zmq_poll beside an eventfd (stop, opened streams), the
// direct ring's eventfd and the publisher's descriptor (subscriptions). Results are sent by the
// workers (flush_results): the publisher belongs to whichever thread holds its token.
#include "runtime/runtime_internal.hpp"

#include "pipeline/record.hpp"

namespace kata::runtime {

using namespace internal;

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
  f.practices = in.practices;
  f.repeated_practices = in.repeated_practices;
  f.practice_bad_values = in.practice_bad_values;
  f.practice_outside_clip = in.practice_outside_clip;
  f.practice_no_clip = in.practice_no_clip;
  f.practice_queue_full = in.practice_queue_full;
  f.batches = in.batches;
  f.batch_frames = in.batch_frames;
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

bool Runtime::try_acquire_publisher() {
  return !publisher_token_.load(std::memory_order_relaxed) &&
         !publisher_token_.exchange(true, std::memory_order_seq_cst);
}

void Runtime::acquire_publisher() {
  // The holder is a worker sending a burst's results (bounded); on a loaded machine it may have
  // lost its CPU, so yield rather than spin long.
  for (unsigned n = 0; !try_acquire_publisher(); ++n) {
    if (n < 64)
      cpu_relax();
    else
      std::this_thread::yield();
  }
}

void Runtime::release_publisher() {
  // Subscriptions the sends read out of ZeroMQ's command queue: the publisher's descriptor may
  // not signal them again, so the I/O thread is told (rare: a subscriber joining).
  if (publisher_ && publisher_->joins_waiting()) {
    if (!joins_pending_.exchange(true, std::memory_order_relaxed)) {
      const uint64_t one = 1;
      (void)!write(wake_io_fd_, &one, sizeof one);
    }
  }
  publisher_token_.store(false, std::memory_order_seq_cst);
}

void Runtime::flush_results(transport::Encoder& encoder) {
  // Store-load against another thread's flush: a result queued by a thread that found the token
  // held is seen by the holder's look after its release (both sides fence), so it never waits
  // for a later frame.
  for (;;) {
    std::atomic_thread_fence(std::memory_order_seq_cst);
    if (!results_pending()) return;
    if (!try_acquire_publisher()) return;  // the holder sends it
    drain_results(encoder);
    release_publisher();
  }
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
      if (cell.repetition_only) {  // the repetition a stream's last flush ended (stop)
        kata_repetition rep = cell.repetition;
        rep.stream_id = s.id.load(std::memory_order_relaxed);
        if (publisher_ && !publisher_->send(encoder.repetition(rep, pipeline::now_ns())))
          s.counters.send_failed.fetch_add(1, std::memory_order_relaxed);
        for (const RepetitionSink& sink : config_.repetition_sinks) sink(rep);
        any = true;
        continue;
      }
      const pipeline::Result& r = cell.result;
      transport::ResultFields f;
      pipeline::fill_record(r, static_cast<uint32_t>(s.ghost_joints), &f);
      // The id, not the definition: a revision rewrites the definition on the I/O thread while a
      // worker may be sending here; the id stays until the stream is retired (after this ring).
      f.stream_id = s.id.load(std::memory_order_relaxed);
      f.result_sequence = s.next_result_sequence++;
      f.frame_sequence = cell.frame_sequence;
      f.computed_ns = cell.computed_ns;
      if (cell.has_practice) {
        f.has_practice = 1;
        f.practice_start_time = cell.practice.start_time;
        f.practice_end_time = cell.practice.end_time;
        f.practice_loop = cell.practice.loop ? 1 : 0;
        f.practice_revision = cell.practice.revision;
      }
      if (r.has_ghost) f.ghost = w.ghosts.data() + k * kMaxGhostJoints * 3;
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
      if (cell.has_repetition) {  // the repetition this frame ended, right after it
        kata_repetition rep = cell.repetition;
        rep.stream_id = f.stream_id;
        if (publisher_ && !publisher_->send(encoder.repetition(rep, pipeline::now_ns())))
          s.counters.send_failed.fetch_add(1, std::memory_order_relaxed);
        for (const RepetitionSink& sink : config_.repetition_sinks) sink(rep);
      }
      any = true;
    }
    w.result_tail.store(tail, std::memory_order_release);
  }
  return any;
}

void Runtime::drain_direct(int max) {
  // The eventfd first, then the ring: a message pushed after this read wakes the next poll.
  uint64_t value;
  (void)!read(direct_fd_, &value, sizeof value);
  const uint8_t* data = nullptr;
  size_t size = 0;
  int n = 0;
  for (; (max < 0 || n < max) && direct_ring_->front(&data, &size); ++n) {
    ingest_->receive(data, size);
    direct_ring_->pop();
  }
  // Left for the next turn (a burst beyond max): the next poll must not sleep on it.
  if (!direct_ring_->empty()) {
    const uint64_t one = 1;
    (void)!write(direct_fd_, &one, sizeof one);
  }
}

void Runtime::io_loop() {
  transport::Encoder encoder;
  using clock = std::chrono::steady_clock;
  const auto resend_every = std::chrono::duration_cast<clock::duration>(
      std::chrono::duration<double>(config_.skeleton_resend_seconds > 0 ? config_.skeleton_resend_seconds : 1.0));
  auto next_resend = clock::now() + resend_every;
  auto last_snapshot = clock::now();
  // The publisher's descriptor (ZMQ_FD), polled as a plain descriptor: a worker may be sending
  // on the socket meanwhile, and polling the descriptor does not touch the socket.
  const int publisher_fd = publisher_ ? publisher_->descriptor() : -1;
  for (;;) {
    zmq_pollitem_t items[3];
    int n = 0;
    items[n++] = zmq_pollitem_t{nullptr, wake_io_fd_, ZMQ_POLLIN, 0};
    const int publisher_item = publisher_ ? n : -1;
    if (publisher_) items[n++] = zmq_pollitem_t{nullptr, publisher_fd, ZMQ_POLLIN, 0};
    const int ingest_item = ingest_ ? n : -1;
    if (direct_ring_)
      items[n++] = zmq_pollitem_t{nullptr, direct_fd_, ZMQ_POLLIN, 0};
    else if (ingest_)
      items[n++] = zmq_pollitem_t{ingest_->socket(), 0, ZMQ_POLLIN, 0};
    const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(next_resend - clock::now()).count();
    zmq_poll(items, n, static_cast<long>(std::max<long long>(0, std::min<long long>(wait, 100))));

    if (items[0].revents & ZMQ_POLLIN) {
      uint64_t value;
      (void)!read(wake_io_fd_, &value, sizeof value);
    }
    const bool dirty = definitions_dirty_.exchange(false, std::memory_order_acq_rel);
    const bool joins = publisher_item >= 0 && ((items[publisher_item].revents & ZMQ_POLLIN) ||
                                               joins_pending_.exchange(false, std::memory_order_relaxed));
    if (publisher_ && (dirty || joins)) {
      acquire_publisher();
      if (dirty) send_definitions(nullptr, 0);
      // Edge-triggered: read every subscription now (the descriptor fires once).
      if (joins) publisher_->poll_joins([this](const uint8_t* prefix, size_t size) { send_definitions(prefix, size); });
      release_publisher();
    }
    if (retiring_count_.load(std::memory_order_acquire) > 0) retire_closed(encoder);
    if (ingest_stop_requested_.load(std::memory_order_seq_cst)) {
      if (direct_ring_ && !ingest_stopped_.load(std::memory_order_relaxed)) {
        // Every message offer() took is handled before the workers' queues close (offer refuses
        // from now on; one already inside finishes its push first): none is left uncounted.
        while (offering_.load(std::memory_order_seq_cst)) std::this_thread::yield();
        drain_direct(-1);
      }
      ingest_stopped_.store(true, std::memory_order_release);
    } else if (ingest_item >= 0 && (items[ingest_item].revents & ZMQ_POLLIN)) {
      if (direct_ring_) {
        ingest_->housekeeping();
        drain_direct(256);
      } else {
        ingest_->poll(256);
      }
    } else if (ingest_) {
      ingest_->housekeeping();  // connection events and idle expiry, also while no frame comes
    }
    const auto now = clock::now();
    if (now >= next_resend) {
      if (publisher_) {
        acquire_publisher();
        send_definitions(nullptr, 0);
        // The periodic look at subscriptions: a join whose signal a worker's send consumed
        // before release_publisher could see it is answered within a resend period at most.
        publisher_->poll_joins([this](const uint8_t* prefix, size_t size) { send_definitions(prefix, size); });
        send_stats(encoder);
        release_publisher();
      }
      next_resend = now + resend_every;
    }
    // Results a worker left while this thread held the publisher.
    flush_results(encoder);
    if (ingest_ && now - last_snapshot > std::chrono::milliseconds(50)) {
      std::lock_guard<std::mutex> lock(io_counters_mutex_);
      ingest_snapshot_ = ingest_->counters();
      last_snapshot = now;
    }
    if (workers_done_.load(std::memory_order_acquire) == static_cast<int>(workers_.size())) {
      acquire_publisher();
      drain_results(encoder);
      for (const Sink& sink : config_.sinks)
        if (sink.flush) sink.flush();
      release_publisher();
      if (ingest_) {
        std::lock_guard<std::mutex> lock(io_counters_mutex_);
        ingest_snapshot_ = ingest_->counters();
      }
      return;
    }
  }
}


}  // namespace kata::runtime
