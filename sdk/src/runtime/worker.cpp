// The workers (runtime.hpp, "threads"): each owns the pipelines of its shard of streams and is the
// only thread that touches them. Frames come in through a bounded multi-producer /
// single-consumer queue per worker (push(), any thread, never blocks); results go out to the I/O
// thread through a single-producer / single-consumer ring. A worker parks in its semaphore (or
// backs off first, by the idle strategy) when it has no frame.
#include "runtime/runtime_internal.hpp"
#include "pipeline/record.hpp"

#include <algorithm>
#include <cstdio>

namespace kata::runtime {

using namespace internal;

Runtime::FrameCell* Runtime::claim_cell(StreamState& stream, size_t* claimed, bool* stopped) {
  *stopped = false;
  Worker& w = *workers_[static_cast<size_t>(stream.worker)];
  size_t pos = w.enqueue_pos.load(std::memory_order_relaxed);
  for (;;) {
    if (pos & kQueueClosed) {  // stop() began: refused, and the caller sees it
      *stopped = true;
      return nullptr;
    }
    FrameCell* cell = &w.cells[pos & w.mask];
    const size_t turn = cell->turn.load(std::memory_order_acquire);
    const intptr_t diff = static_cast<intptr_t>(turn) - static_cast<intptr_t>(pos);
    if (diff == 0) {
      if (w.enqueue_pos.compare_exchange_weak(pos, pos + 1, std::memory_order_relaxed)) {
        *claimed = pos;
        return cell;
      }
    } else if (diff < 0) {
      return nullptr;
    } else {
      pos = w.enqueue_pos.load(std::memory_order_relaxed);
    }
  }
}

void Runtime::publish_cell(StreamState& stream, FrameCell& cell, size_t pos) {
  Worker& w = *workers_[static_cast<size_t>(stream.worker)];
  cell.turn.store(pos + 1, std::memory_order_release);
  // Post only to a parked worker (a busy one finds the cell by its turn): against the worker's
  // sleeping store and its last look at the queue (seq_cst fences on both sides), either it sees
  // this cell or this push sees it asleep.
  std::atomic_thread_fence(std::memory_order_seq_cst);
  if (w.sleeping.load(std::memory_order_relaxed) && w.sleeping.exchange(false, std::memory_order_acq_rel))
    sem_post(&w.wake);
}

namespace {
// Against a close on another thread: either close_stream sees this call in flight and waits for
// its cell, or this call sees the close (seq_cst on both sides).
struct InPush {
  std::atomic<int>& n;
  explicit InPush(std::atomic<int>& count) : n(count) { n.fetch_add(1, std::memory_order_seq_cst); }
  ~InPush() { n.fetch_sub(1, std::memory_order_release); }
};
}  // namespace

Status Runtime::push(uint64_t stream_id, uint64_t sequence, double capture_time, const float* xyz, int joints,
                     bool restart, const float* confidence) {
  if (!xyz) return Status::kNullPointer;
  StreamState* stream = find(stream_id);
  if (!stream) return Status::kNotFound;
  if (joints < 0 || joints > config_.max_joints) return Status::kWrongJointCount;
  // A state reused for another stream since find() shows another id.
  const InPush in_push(stream->counters.in_push);
  if (stream->closed.load(std::memory_order_seq_cst) || stream->id.load(std::memory_order_acquire) != stream_id)
    return Status::kNotFound;
  size_t pos = 0;
  bool stopped = false;
  FrameCell* cell = claim_cell(*stream, &pos, &stopped);
  if (!cell) {
    (stopped ? stream->counters.stopped : stream->counters.queue_full).fetch_add(1, std::memory_order_relaxed);
    return stopped ? Status::kStopped : Status::kQueueFull;
  }
  cell->stream = stream;
  cell->practice = false;
  cell->sequence = sequence;
  cell->capture_time = capture_time;
  cell->arrival_ns = pipeline::now_ns();
  cell->joints = joints;
  cell->restart = restart;
  std::memcpy(cell->xyz, xyz, sizeof(float) * 3 * static_cast<size_t>(joints));
  cell->has_confidence = confidence != nullptr;
  if (confidence) std::memcpy(cell->confidence, confidence, sizeof(float) * static_cast<size_t>(joints));
  stream->counters.frames_in.fetch_add(1, std::memory_order_relaxed);  // before the worker can see it
  publish_cell(*stream, *cell, pos);
  if (config_.on_frame)  // the caller's copy: the worker may already be reading the cell's
    config_.on_frame(config_.on_frame_user, stream_id, sequence, capture_time, xyz, static_cast<uint32_t>(joints));
  return Status::kOk;
}

transport::TableVerdict practice_rows(const transport::PracticeSetting& p, int frames, double ft, int32_t* first,
                                      int32_t* last, char* why, size_t size) {
  using transport::TableVerdict;
  if (transport::practice_values_problem(p, why, size)) return TableVerdict::kPracticeValues;
  // Teacher seconds -> the nearest teacher frame, which must be in the clip (the values are finite
  // and >= 0 here; compared as doubles before rounding, so no time overflows a row).
  const double start = p.loop ? p.loop_start : p.teacher_start;
  for (double t : {start, p.loop ? p.loop_end : 0.0})
    if (t / ft > (frames - 1) + 0.5) {
      std::snprintf(why, size, "%g s is outside the teacher clip (0..%g s: %d frames of %g s)", t, (frames - 1) * ft,
                    frames, ft);
      return TableVerdict::kPracticeOutsideClip;
    }
  *first = static_cast<int32_t>(std::lround(start / ft));
  *last = p.loop ? static_cast<int32_t>(std::lround(p.loop_end / ft)) : -1;
  if (p.loop && *last <= *first) {
    std::snprintf(why, size, "the loop %g..%g s is within one teacher frame (%g s)", p.loop_start, p.loop_end, ft);
    return TableVerdict::kPracticeOutsideClip;
  }
  return TableVerdict::kAccepted;
}

transport::TableVerdict Runtime::set_practice(const transport::PracticeSetting& p, std::string* why) {
  using transport::TableVerdict;
  char text[256];
  auto refuse = [&](TableVerdict v) {
    if (why) *why = text;
    return v;
  };
  StreamState* stream = find(p.stream_id);
  if (!stream) return TableVerdict::kUnknownStream;
  const InPush in_push(stream->counters.in_push);
  if (stream->closed.load(std::memory_order_seq_cst) || stream->id.load(std::memory_order_acquire) != p.stream_id)
    return TableVerdict::kUnknownStream;
  if (stream->teacher_frames < 1) {
    std::snprintf(text, sizeof text, "stream %llu has no clip teacher to practise on",
                  static_cast<unsigned long long>(p.stream_id));
    return refuse(TableVerdict::kPracticeNoClip);
  }
  int32_t first = 0, last = -1;
  const TableVerdict rows =
      practice_rows(p, stream->teacher_frames, stream->teacher_frame_time, &first, &last, text, sizeof text);
  if (rows != TableVerdict::kAccepted) return refuse(rows);
  size_t pos = 0;
  bool stopped = false;
  FrameCell* cell = claim_cell(*stream, &pos, &stopped);
  if (!cell) {
    std::snprintf(text, sizeof text, "%s", stopped ? "the runtime is stopping" : "the stream's worker queue is full");
    return refuse(TableVerdict::kPracticeQueueFull);
  }
  cell->stream = stream;
  cell->practice = true;
  cell->practice_first = first;
  cell->practice_last = last;
  cell->practice_loop = p.loop;
  cell->practice_revision = p.revision;
  cell->joints = 0;
  cell->restart = false;
  cell->has_confidence = false;
  publish_cell(*stream, *cell, pos);
  return TableVerdict::kAccepted;
}

uint64_t Runtime::burst_frames() const {
  uint64_t n = 0;
  for (const auto& w : workers_) n += w->burst_frames.load(std::memory_order_relaxed);
  return n;
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
      // The repetitions the batch's frames ended are the counter's newest, the last frame's first.
      int ended_after = 0;
      for (size_t i = 0; i < n; ++i) ended_after += w.read_buffer[i].repetition_ended ? 1 : 0;
      for (size_t i = 0; i < n; ++i) {
        const pipeline::Result& r = w.read_buffer[i];
        if (r.repetition_ended) --ended_after;
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
        cell.has_practice = s.has_practice;
        cell.practice = s.practice;
        cell.repetition_only = false;
        cell.has_repetition = r.repetition_ended && p.repetitions() && ended_after < metric::RepCounter::kKept;
        if (cell.has_repetition) pipeline::fill_repetition(p.repetitions()->newest(ended_after), 0, &cell.repetition);
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
  // Results go out from here, right after their frame (no hand-off to the I/O thread,
  // no wake-up per result): this worker sends them unless another thread holds the publisher,
  // which then sends them before it lets go.
  auto send_results = [&] {
    if (!signalled) return;
    signalled = false;
    flush_results(*w.encoder);
  };
  auto frame_ready = [&] {
    return w.cells[w.dequeue_pos & w.mask].turn.load(std::memory_order_acquire) == w.dequeue_pos + 1;
  };

  // A burst (RuntimeConfig::drain_burst): the frames waiting in turn, of distinct streams, none
  // a practice setting or a restart, drained stage by stage in one Pipeline::push_burst.
  const int bound = std::clamp(config_.drain_burst, 1, pipeline::Pipeline::kMaxBurst);
  // The frames' scratch (scorer and ghost work), one for all this worker's streams: it stays in
  // the caches from one stream's frame to the next (grows on the first frame of a larger model).
  pipeline::Scratch scratch;
  FrameCell* burst_cells[pipeline::Pipeline::kMaxBurst];
  pipeline::Pipeline::BurstFrame burst_frames[pipeline::Pipeline::kMaxBurst];
  const auto plain = [](const FrameCell& c) { return !c.practice && !(c.restart && c.stream->accepted > 0); };
  const auto gather = [&]() {
    int n = 1;
    burst_cells[0] = &w.cells[w.dequeue_pos & w.mask];
    for (; n < bound; ++n) {
      const size_t pos = w.dequeue_pos + static_cast<size_t>(n);
      FrameCell& c = w.cells[pos & w.mask];
      if (c.turn.load(std::memory_order_acquire) != pos + 1 || !plain(c)) break;
      bool repeated = false;
      for (int f = 0; f < n && !repeated; ++f) repeated = burst_cells[f]->stream == c.stream;
      if (repeated) break;
      burst_cells[n] = &c;
    }
    return n;
  };
  // After a frame's push: its source sequence and time kept, its cell given back, its results out.
  const auto after_push = [&](FrameCell& cell, StreamState& s, Status st, double t) {
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
  };

  const IdleStrategy& idle = config_.idle;
  const bool backoff = idle.kind == IdleStrategy::Kind::kBackoff;
  const int batch = std::max(1, config_.result_batch);
  int unsent = 0;  // frames since this worker last sent
  for (;;) {
    // Wait for the frame in turn (backing off first, by the idle strategy); every 50 ms look at
    // the stop flag. A producer posts only while this worker says it sleeps (publish_cell).
    if (!frame_ready() && signalled) {  // nothing more to batch with (a practice setting ended the run)
      unsent = 0;
      send_results();
    }
    if (!frame_ready() && !(backoff && back_off(idle.worker_spin_ns, idle.worker_yield_ns, frame_ready))) {
      w.sleeping.store(true, std::memory_order_relaxed);
      std::atomic_thread_fence(std::memory_order_seq_cst);
      if (!frame_ready()) {
        timespec deadline;
        clock_gettime(CLOCK_REALTIME, &deadline);
        deadline.tv_nsec += 50'000'000;
        if (deadline.tv_nsec >= 1'000'000'000) {
          deadline.tv_sec += 1;
          deadline.tv_nsec -= 1'000'000'000;
        }
        (void)sem_timedwait(&w.wake, &deadline);
      }
      w.sleeping.store(false, std::memory_order_relaxed);
      if (!frame_ready()) {
        if (stopping_.load(std::memory_order_acquire)) {
          // A push that claimed a cell before stop() closed the queue is finished first (its
          // post is on its way): nothing stop() took is left behind.
          if (w.dequeue_pos != (w.enqueue_pos.load(std::memory_order_acquire) & ~kQueueClosed)) continue;
          // Queue empty and stopping: flush every pipeline, hand over what it emits, done.
          std::lock_guard<std::mutex> lock(w.owned_mutex);
          for (StreamState* s : w.owned) {
            s->pipeline->flush();
            move_results(*s);
            // The flush ended the repetition in progress (the take's end): published after the
            // stream's last result, as a repetition alone.
            if (s->pipeline->flush_ended_repetition()) {
              const size_t head = w.result_head.load(std::memory_order_relaxed);
              if (head - w.result_tail.load(std::memory_order_acquire) > w.result_mask) {
                s->counters.result_queue_full.fetch_add(1, std::memory_order_relaxed);
              } else {
                ResultCell& cell = w.results[head & w.result_mask];
                cell.stream = s;
                cell.repetition_only = cell.has_repetition = true;
                pipeline::fill_repetition(s->pipeline->repetitions()->newest(), 0, &cell.repetition);
                w.result_head.store(head + 1, std::memory_order_release);
                signalled = true;
              }
            }
          }
          send_results();
          workers_done_.fetch_add(1, std::memory_order_release);
          const uint64_t one = 1;
          (void)!write(wake_io_fd_, &one, sizeof one);
          return;
        }
        continue;
      }
    }
    FrameCell& cell = w.cells[w.dequeue_pos & w.mask];
    StreamState& s = *cell.stream;
    pipeline::Pipeline& p = *s.pipeline;
    if (cell.practice) {
      // A practice setting, between two frames (the results so far were moved out after the
      // last push, so each result carries the setting it was computed under). Judged against
      // the clip by set_practice; a scorer that refuses all the same keeps its section.
      if (metric::Scorer* scorer = p.scorer()) {
        try {
          scorer->set_section(cell.practice_first, cell.practice_last, cell.practice_loop);
          practice_section_of(p, cell.practice_revision, &s.has_practice, &s.practice);
        } catch (const Error&) {
        }
      }
      cell.turn.store(w.dequeue_pos + w.mask + 1, std::memory_order_release);
      ++w.dequeue_pos;
      w.done_pos.store(w.dequeue_pos, std::memory_order_release);
      continue;
    }
    if (bound > 1 && plain(cell)) {
      const int n = gather();
      if (n > 1) {
        for (int f = 0; f < n; ++f) {
          const FrameCell& c = *burst_cells[f];
          StreamState& bs = *c.stream;
          pipeline::Pipeline::BurstFrame& b = burst_frames[f];
          b.pipeline = bs.pipeline.get();
          b.capture_time = c.capture_time + bs.time_offset;
          b.xyz = c.xyz;
          b.confidence = c.has_confidence ? c.confidence : nullptr;
          b.joint_count = c.joints;
          b.arrival_ns = c.arrival_ns;
        }
        pipeline::Pipeline::push_burst(burst_frames, n, &scratch);
        w.burst_frames.store(w.burst_frames.load(std::memory_order_relaxed) + static_cast<uint64_t>(n),
                             std::memory_order_relaxed);
        for (int f = 0; f < n; ++f) {
          after_push(*burst_cells[f], *burst_cells[f]->stream, burst_frames[f].status, burst_frames[f].capture_time);
          if (++unsent >= batch || !frame_ready()) {
            unsent = 0;
            send_results();
          }
          w.done_pos.store(w.dequeue_pos, std::memory_order_release);
        }
        continue;
      }
    }
    if (cell.restart && s.accepted > 0) {
      p.reset();
      p.restart_teacher();  // ends the repetition in progress, then restarts the count
      move_results(s);
      // That repetition goes out after the results the reset emitted, as a repetition alone.
      if (p.flush_ended_repetition()) {
        const size_t head = w.result_head.load(std::memory_order_relaxed);
        if (head - w.result_tail.load(std::memory_order_acquire) > w.result_mask) {
          s.counters.result_queue_full.fetch_add(1, std::memory_order_relaxed);
        } else {
          ResultCell& rc = w.results[head & w.result_mask];
          rc.stream = &s;
          rc.repetition_only = rc.has_repetition = true;
          pipeline::fill_repetition(p.repetitions()->newest(), 0, &rc.repetition);
          w.result_head.store(head + 1, std::memory_order_release);
          signalled = true;
        }
      }
      // One second after the newest time: past any gap that still joins segments.
      s.time_offset = s.last_time + 1.0 - cell.capture_time;
    }
    const double t = cell.capture_time + s.time_offset;
    const Status st =
        p.push(t, cell.xyz, cell.has_confidence ? cell.confidence : nullptr, cell.joints, cell.arrival_ns, &scratch);
    after_push(cell, s, st, t);
    if (++unsent >= batch || !frame_ready()) {
      unsent = 0;
      send_results();
    }
    w.done_pos.store(w.dequeue_pos, std::memory_order_release);  // closed streams retire past it
  }
}


}  // namespace kata::runtime
