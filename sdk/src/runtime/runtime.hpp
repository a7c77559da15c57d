// The runtime: many per-stream pipelines, a small worker pool and one I/O thread.
//
// Threads and why (cost per frame, measured side by side in docs/runtime.md):
//   producers (any thread; the I/O thread for ZeroMQ ingest) -> push(stream id, frame)
//       the frame is copied into the bounded queue of its stream's worker (the one with the
//       fewest streams when the stream opened, so a burst splits evenly): a lock-free
//       multi-producer ring (per-cell sequence numbers); a full queue drops the frame and counts
//       it on its stream. No lock is shared between streams on this path. The worker's semaphore
//       is posted only while it is parked: a burst costs one wake-up, not a call per frame.
//   workers (N threads) -> each owns the pipelines of its shard, so a pipeline is only ever
//       touched by one thread (no lock); it pushes the frame through features -> score -> ghost
//       (the frames waiting for it, of distinct streams, as one burst stage by stage: drain_burst),
//       moves every result (with its ghost) into its own single-producer ring and sends it
//       itself (run to completion: no hand-off to another thread, no wake-up per result), after
//       RuntimeConfig::result_batch frames or as soon as no frame waits, if it can take the
//       publisher's token; if another thread holds it, that thread sends these results before it
//       lets go (flush_results). A full ring drops the result and counts it.
//   a transport's own thread (a NATS shard's delivery thread) -> offer(message bytes): copied
//       into a bounded single-producer ring (transport/message_ring.hpp, allocated once) and the
//       I/O thread woken by an eventfd; the I/O thread hands each to the ingest (the same
//       verifier, limits, table and counters as a socket's). No local socket, no ZeroMQ I/O
//       threads between them: one wake-up, where the ipc PUSH -> PULL it replaced took three.
//   the I/O thread -> owns the ingest (socket or ring): it reads frames and definitions, sees subscribers
//       join (the publisher's ZMQ_FD, polled as a plain descriptor), re-sends skeleton definitions
//       on join and periodically, sends stats and retires closed streams, taking the token for
//       every use of the publisher.
// The publisher (ZeroMQ sockets are not thread-safe) is used by one thread at a time: the token is
// an atomic exchange, the full memory barrier ZeroMQ asks for when a socket changes thread.
//
// Clock: capture times are the source's (seconds); arrival, computed and published times are
// the host's monotonic clock (steady_clock, CLOCK_MONOTONIC) in nanoseconds, comparable between
// processes on one host, so a subscriber's now - published / arrival is the result's age.
//
// Memory: opening a stream allocates its pipeline; queues are sized at construction; nothing
// on the per-frame path allocates.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "common/status.hpp"
#include "pipeline/pipeline.hpp"
#include "transport/message_ring.hpp"
#include "transport/wire.hpp"
#include "transport/zmq_io.hpp"

namespace kata::runtime {

// What a stream is made of: its pipeline, its teacher, and what is published.
struct StreamSetup {
  pipeline::PipelineConfig pipeline;
  std::shared_ptr<const pipeline::Teacher> teacher;  // null: features only, nothing scored
  pipeline::TeacherOptions teacher_options;
  bool publish_features = false;  // put each result's 1683 features in the message
};

// The default setup for a definition: the GPD map from its preset or layout (skeleton.hpp,
// resolve_layout: "mediapipe" fixes its axes and turns smoothing on) or its name map, its up axis,
// the body height from its rest pose when it has one, the backward stencil; no teacher.
// Throws kata::Error (unknown preset, a joint the map names is missing).
StreamSetup setup_from_definition(const transport::SkeletonDefinition& definition);

// A practice setting's section in the rows of a teacher clip of `frames` frames `frame_time`
// seconds apart (schemas/practice.fbs: each time rounded to the nearest frame, which must be in
// the clip): kAccepted with *first and *last (-1: the clip's end; a loop when practice.loop), or
// kPracticeValues / kPracticeOutsideClip with the reason in why (size bytes). Allocation-free.
transport::TableVerdict practice_rows(const transport::PracticeSetting& practice, int frames, double frame_time,
                                      int32_t* first, int32_t* last, char* why, size_t size);

// A consumer of every result inside the process (a sink plugin, a file writer): called by the
// runtime thread that holds the publisher (a worker or the I/O thread; one at a time, each
// stream's results in order), after the result was sent; must neither block nor allocate.
struct Sink {
  std::function<void(const transport::ResultFields&)> on_result;
  std::function<void()> flush;  // optional; on the I/O thread after the last result (at stop)
};
// A consumer of every repetition that ends (metric/reps.hpp), called as a Sink's on_result is,
// right after the result of the frame that ended it (and its Repetition message).
using RepetitionSink = std::function<void(const kata_repetition&)>;

// How a runtime thread waits for work (docs/runtime.md, "Idle strategy"). A parked thread costs no
// CPU but a wake-up from sleep (a futex or eventfd and the scheduler: tens of us on a VM) each
// time work is handed to it; a thread that backs off keeps looking for a while first.
struct IdleStrategy {
  enum class Kind {
    kPark,     // sleep at once: a worker in its semaphore
    kBackoff,  // a worker spins (cpu pause) for worker_spin_ns, then sched_yield until worker_yield_ns, then parks
  };
  // Park by default: on the 2-core VM shared with other load, backoff measured no better at one
  // stream and no clear gain at 64 (a spinning or yielding thread loses its CPU to the others
  // anyway; docs/runtime.md has the side-by-side figures). Backoff is for dedicated cores.
  Kind kind = Kind::kPark;
  // A worker out of frames backs off this long before it parks (frames of a burst that arrive a
  // little apart find it awake).
  int64_t worker_spin_ns = 5'000;
  int64_t worker_yield_ns = 5'000;
  // Read by nothing now (the workers send their own results, so the I/O thread waits
  // for none); kept so that configurations setting them (kata serve's idle_spin_us) still load.
  int64_t io_spin_ns = 300'000;
  int64_t io_yield_ns = 300'000;
};

struct RuntimeConfig {
  int workers = 2;                 // worker threads (>= 1); streams are sharded by id over them
  int frame_queue_capacity = 4096; // frames queued per worker (rounded up to a power of two)
  int result_queue_capacity = 4096;// results a worker holds before they are sent (power of two)
  int max_joints = 128;            // largest input skeleton (sizes the queue cells)
  int max_streams = 1024;          // streams the runtime can hold
  // Results out (empty endpoints: nothing published; results are still counted).
  transport::PublisherOptions publish;
  // Frames in over ZeroMQ (empty endpoints: none).
  transport::IngestOptions ingest;
  // How a stream announced by ingest is set up (default: setup_from_definition); may attach a
  // teacher. Throwing refuses the stream (counted). Runs on the I/O thread.
  std::function<StreamSetup(const transport::SkeletonDefinition&)> configure_stream;
  // Instead of configure_stream (taking precedence over it): the app builds the announced
  // stream's pipeline itself (the C ABI's kata_runtime_desc.on_stream_open: a kata_stream the app
  // attached a teacher to) and hands it over with the function that releases it. Throwing refuses
  // the stream (counted). Runs on the I/O thread, before the stream's first frame.
  struct AdoptedPipeline {
    pipeline::Pipeline* pipeline = nullptr;
    std::function<void(pipeline::Pipeline*)> release;
    bool publish_features = false;
  };
  std::function<AdoptedPipeline(const transport::SkeletonDefinition&)> build_stream;
  double skeleton_resend_seconds = 1.0;  // periodic re-send of every skeleton definition
  IdleStrategy idle;                     // how workers and the I/O thread wait for work
  // A worker sends its results after this many frames, or as soon as no frame waits for it
  // (a batch wakes libzmq's I/O thread once and goes out in one write: its CPU per
  // frame halved at 64 streams; 1 sends after every frame; docs/runtime.md has the trade).
  // A lone stream never waits: its worker has no next frame, so it sends at once.
  int result_batch = 8;
  // A worker drains the frames already waiting for it (never waiting for more), up to this many
  // of distinct streams, as one burst (pipeline::Pipeline::push_burst: the features of all, the
  // scores of all with one pass over the model's W per 8 frames, then ghosts and results); the
  // results equal the frame-by-frame path's. 1: frame by frame. At most Pipeline::kMaxBurst.
  int drain_burst = 1;
  std::vector<Sink> sinks;               // in-process consumers of every result
  // A consumer of every frame queued (kata_runtime_desc.on_frame): called by push() on the pushing
  // thread right after the frame was queued; must neither block nor allocate. Null: none.
  void (*on_frame)(void* user, uint64_t stream_id, uint64_t sequence, double capture_time, const float* xyz,
                   uint32_t joints) = nullptr;
  void* on_frame_user = nullptr;
  std::vector<RepetitionSink> repetition_sinks;  // and of every repetition that ends
};

// Counters of one stream (monotonic since it was opened).
struct StreamCounters {
  uint64_t frames_in = 0;         // frames queued
  uint64_t queue_full = 0;        // frames dropped: the worker's queue was full
  uint64_t refused = 0;           // frames the pipeline refused (bad values, time not increasing)
  uint64_t results = 0;           // results computed
  uint64_t pipeline_dropped = 0;  // results overwritten in the pipeline's ring before read
  uint64_t result_queue_full = 0; // results dropped: the queue to the I/O thread was full
  uint64_t published = 0;         // results handed to ZeroMQ
  uint64_t send_failed = 0;       // results ZeroMQ refused (never blocks)
  uint64_t stopped = 0;           // frames push() refused (kStopped): stop() had begun
  // Frames of an open stream that ingest dropped before queueing them, by cause:
  uint64_t stale = 0;             // too old to score (the stream's source fell behind)
  uint64_t unauthorised = 0;      // from a sender the stream does not belong to
  uint64_t out_of_sequence = 0;   // out of order, or far outside the sequence window
  uint64_t wrong_joints = 0;      // a joint count other than the stream's definition's
};

// Why a frame of a stream, or its result, did not become a published result: every frame pushed
// or ingested for a stream ends as a published result or as one count of exactly one of these
// (tests/support/accounting.hpp checks it per stream at the end of every live test; kata serve
// --counters writes them by these names). A new cause: a StreamCounters field, its atomic in
// the runtime's stream state (copied by counters()), and a row here.
struct DropCause {
  const char* name;
  uint64_t StreamCounters::*count;
};
inline constexpr DropCause kDropCauses[] = {
    {"queue_full", &StreamCounters::queue_full},
    {"stopped", &StreamCounters::stopped},
    {"stale", &StreamCounters::stale},
    {"unauthorised", &StreamCounters::unauthorised},
    {"out_of_sequence", &StreamCounters::out_of_sequence},
    {"wrong_joints", &StreamCounters::wrong_joints},
    {"refused", &StreamCounters::refused},
    {"pipeline_dropped", &StreamCounters::pipeline_dropped},
    {"result_queue_full", &StreamCounters::result_queue_full},
    {"send_failed", &StreamCounters::send_failed},
};

// Arrival -> published latency histogram: bucket i holds latencies in [2^(i/8), 2^((i+1)/8)) ns
// (12.5 % wide buckets, up to ~70 s).
inline constexpr int kLatencyBuckets = 8 * 36;
int latency_bucket(int64_t ns);
// The latency (ns, bucket's upper edge) below which a fraction q of the counts lies; 0 if empty.
double latency_percentile(const uint64_t* histogram, double q);

struct RuntimeCounters {
  uint64_t streams = 0;           // open now
  uint64_t closed_streams = 0;    // closed since the start (by their owner, idle, a new shape);
                                  // their counters stay in total
  uint64_t latency_histogram[kLatencyBuckets] = {};  // arrival -> published, every published result
  StreamCounters total;           // summed over streams
  transport::IngestCounters ingest;
  uint64_t skeletons_sent = 0;    // definitions published (on open, on join, periodic)
};

// People frames (kata/people.h; people_streams.cpp) since the start, over every group stream (a
// closed group's counts stay). A people frame handed to its group is tracked or refused: every
// pose of a tracked frame is assigned a person or refused by one cause (poses = assigned +
// refused_*); an assigned pose is pushed to its person's stream, or dropped in unopened when the
// runtime could not open that stream (opened + streams_refused = the persons the trackers found).
struct PeopleCounters {
  uint64_t frames = 0;                  // tracked (empty ones included)
  uint64_t empty_frames = 0;            // tracked without a pose
  uint64_t refused_frames = 0;          // not tracked: time not finite or not after the group's previous,
                                        // the group stream gone, the group's joint count changed
  uint64_t poses = 0;                   // in tracked frames
  uint64_t assigned = 0;                // given a person (an open one or a new one)
  uint64_t refused_non_finite = 0;      // a confident joint (or a confidence) NaN or infinite
  uint64_t refused_out_of_range = 0;    // a confident joint beyond KATA_MAX_COORDINATE
  uint64_t refused_few_joints = 0;      // fewer than 3 confident joints, or all on one point
  uint64_t refused_too_many_poses = 0;  // beyond the tracker's max_poses in a frame
  uint64_t refused_table_full = 0;      // a new person while the group's max_people were open
  uint64_t streams_opened = 0;          // person streams opened
  uint64_t streams_closed = 0;          // person streams closed (forgotten, or their group closed)
  uint64_t streams_refused = 0;         // new persons whose stream could not be opened (max_streams)
  uint64_t unopened = 0;                // assigned poses dropped: their person's stream is not open
};

class Runtime {
 public:
  // Binds / connects the sockets and starts the threads. Throws kata::Error.
  explicit Runtime(RuntimeConfig config);
  // Stops: see stop().
  ~Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  // Opens a stream (allocates its pipeline) and publishes its definition. [any thread]
  // Throws kata::Error(kInvalidArgument) for a used id, a full table or a bad setup.
  void open_stream(const transport::SkeletonDefinition& definition, const StreamSetup& setup);
  // Opens a stream announced by its definition, set up by config.configure_stream (or
  // setup_from_definition): what ingest and source plugins do. [any thread] Throws kata::Error.
  void open_announced(const transport::SkeletonDefinition& definition);
  // Opens a stream over a pipeline the caller built (teacher attached or not); the runtime owns
  // it from now on and calls release(pipeline) when it is done with it (at destruction).
  // [any thread] Throws kata::Error(kInvalidArgument) as open_stream does.
  void adopt_stream(const transport::SkeletonDefinition& definition, pipeline::Pipeline* pipeline,
                    std::function<void(pipeline::Pipeline*)> release, bool publish_features);

  // Closes a stream: its id is free at once (push says kNotFound), its pipeline is released
  // once its worker is past its last frame and the results were sent, and its state is reused
  // by a later open. false: no such stream. [any thread but a worker's]
  bool close_stream(uint64_t stream_id);

  // Queues a frame of a stream: sequence is the source's, capture_time its timestamp
  // (seconds), xyz joints x 3 floats. restart: the source restarted (the stream's kinetics and
  // teacher alignment restart first). [any thread; one producer per stream keeps its order]
  // kOk, kNotFound (no such stream), kWrongJointCount (more than max_joints), kState (queue
  // full: dropped and counted), kStopped (stop() has begun: not taken, counted) or kNullPointer.
  // Never blocks, never allocates. confidence: joints floats (a frame message's confidence,
  // MediaPipe's visibility) or null (all confident).
  Status push(uint64_t stream_id, uint64_t sequence, double capture_time, const float* xyz, int joints,
              bool restart = false, const float* confidence = nullptr);

  // Sets where a stream follows its teacher clip (a Practice message, schemas/practice.fbs:
  // teacher seconds from the teacher's first frame, each rounded to the nearest teacher frame):
  // queued to the stream's worker like a frame, so the frames pushed before it from this thread
  // are followed under the old setting and those after it under the new one (the alignment
  // restarts in the new section; the score calibration is kept). Every result then says the
  // setting it was computed under (ResultFields::practice, revision = practice.revision).
  // kAccepted, or the refusal with *why (when not null): kUnknownStream (no such stream),
  // kPracticeValues (a time not finite or negative, an empty loop, a start and a loop),
  // kPracticeNoClip (no clip teacher), kPracticeOutsideClip (a time outside the clip, or a loop
  // within one teacher frame), kPracticeQueueFull (the worker's queue is full, or stop() has
  // begun). A refused setting changes nothing. [any thread] Never blocks; allocates only a
  // refusal's text. The worker applies it between two frames (Scorer::set_section allocates the
  // alignment's rows there: a change of setting, not a per-frame cost).
  transport::TableVerdict set_practice(const transport::PracticeSetting& practice, std::string* why = nullptr);

  // Hands one ingest message (the ZeroMQ wire bytes: topic + FlatBuffer, wire.hpp) to a direct
  // ingest (RuntimeConfig::ingest.kind = kDirect): copied into the ring the I/O thread reads, and
  // judged there as a socket's message is (malformed ones counted by cause, never touching another
  // stream). [one thread at a time: the producer; it must stop calling before the runtime is
  // destroyed, stop() may run meanwhile] Never blocks, never allocates. False when not taken: no
  // direct ingest, the ring is full (the I/O thread fell behind), or stop() has begun; the caller
  // counts it (a message taken is handled before stop() returns: counted in the ingest's counters).
  bool offer(const void* data, size_t size);

  // Lets workers finish every queued frame, flushes every pipeline, sends every result, then
  // stops the threads and closes the sockets (idempotent). [any thread but a runtime thread]
  // A push racing it is either taken (kOk; its result is sent before stop returns) or refused
  // (kStopped); from then on every push is refused.
  void stop();

  // A snapshot of the counters. [any thread]
  RuntimeCounters counters() const;
  // Frames the workers drained in bursts of two or more (RuntimeConfig::drain_burst) since the
  // start. [any thread]
  uint64_t burst_frames() const;
  std::optional<StreamCounters> stream_counters(uint64_t stream_id) const;
  // The people frames' counters (people_streams.cpp). [any thread] Lock-free.
  PeopleCounters people_counters() const;
  // Every stream's counters, by stream id, in the order they were opened (allocates). [any thread]
  std::vector<std::pair<uint64_t, StreamCounters>> all_stream_counters() const;
  // The resolved endpoint the publisher bound last ("" without one) and the ingest's.
  std::string publish_endpoint() const { return publish_endpoint_; }
  std::string ingest_endpoint() const { return ingest_endpoint_; }
  const char* publish_endpoint_cstr() const { return publish_endpoint_.c_str(); }
  const char* ingest_endpoint_cstr() const { return ingest_endpoint_.c_str(); }

 private:
  struct StreamState;
  struct Worker;
  struct FrameCell;
  StreamState* find(uint64_t stream_id) const;
  // Claims the next cell of the stream's worker queue for a frame or a practice setting
  // (null: the queue is full, or closed by stop() when *stopped). [any thread, inside in_push]
  FrameCell* claim_cell(StreamState& stream, size_t* pos, bool* stopped);
  void publish_cell(StreamState& stream, FrameCell& cell, size_t pos);
  // The stream table (ingest-driven lifetimes): refusals before any allocation, revisions, retiring.
  void check_open(const transport::SkeletonDefinition& definition) const;
  bool revise_announced(const transport::SkeletonDefinition& definition);
  void retire_closed(transport::Encoder& encoder);
  static StreamCounters read_counters(const StreamState& s);
  void open_locked(const transport::SkeletonDefinition& definition, const StreamSetup& setup);
  void add_locked(const transport::SkeletonDefinition& definition, pipeline::Pipeline* pipeline,
                  std::function<void(pipeline::Pipeline*)> release, bool publish_features);
  void worker_loop(Worker& worker);
  void io_loop();
  // Sends every result waiting in the workers' rings (holder of the publisher only).
  bool drain_results(transport::Encoder& encoder);
  bool results_pending() const;
  // The publisher (and the sinks, and the result rings' read side) belong to whichever thread
  // holds publisher_token_: a worker after its frame, the I/O thread for definitions, stats,
  // joins and retiring. try: never waits (a worker); acquire: waits for the holder's sends (the
  // I/O thread only). flush_results: sends what waits unless another thread holds the publisher,
  // which then sends it before it lets go (nothing is left behind: see the fences).
  bool try_acquire_publisher();
  void acquire_publisher();
  void release_publisher();
  void flush_results(transport::Encoder& encoder);
  void send_definitions(const uint8_t* prefix, size_t prefix_size);
  void send_stats(transport::Encoder& encoder);  // schemas/stats.fbs, with the periodic definitions

  RuntimeConfig config_;
  std::string publish_endpoint_, ingest_endpoint_;
  std::unique_ptr<transport::Context> context_;
  // Streams: an insert-only open-addressing table (ids and states published with release
  // stores), so push() finds a stream without a lock.
  std::vector<std::atomic<uint64_t>> table_keys_;
  std::vector<std::atomic<StreamState*>> table_values_;
  std::vector<std::unique_ptr<StreamState>> streams_;  // owned (live, retiring, free); guarded by open_mutex_
  std::vector<StreamState*> retiring_;                 // closed, waiting for their worker; open_mutex_
  std::vector<StreamState*> free_states_;              // retired, reused by the next open; open_mutex_
  std::atomic<int> retiring_count_{0};
  StreamCounters retired_totals_;                      // counters of retired streams; open_mutex_
  uint64_t closed_streams_ = 0;                        // open_mutex_
  mutable std::mutex open_mutex_;                      // open_stream and counters only
  std::atomic<uint64_t> stream_count_{0};
  std::atomic<bool> definitions_dirty_{false};
  std::vector<std::unique_ptr<Worker>> workers_;
  int wake_io_fd_ = -1;
  alignas(64) std::atomic<bool> publisher_token_{false};
  // The holder saw subscriptions waiting on the publisher (its sends read ZeroMQ's commands, so
  // the socket's descriptor may not wake the I/O thread): the I/O thread reads them.
  std::atomic<bool> joins_pending_{false};
  std::atomic<bool> stopping_{false};
  // stop() asks the I/O thread to read no more ingest messages and waits for its answer before
  // the workers are told to finish: a frame ingested after a worker's last look would be lost.
  std::atomic<bool> ingest_stop_requested_{false};
  std::atomic<bool> ingest_stopped_{false};
  std::atomic<int> workers_done_{0};
  std::thread io_thread_;
  std::atomic<bool> stopped_{false};
  // Snapshot of the I/O thread's counters for other threads.
  mutable std::mutex io_counters_mutex_;
  transport::IngestCounters ingest_snapshot_;
  std::atomic<uint64_t> latency_histogram_[kLatencyBuckets] = {};  // written by the I/O thread only
  uint64_t skeletons_sent_ = 0;
  // Created (bound) in the constructor so errors reach the caller, then used only by the I/O
  // thread (starting it is the full memory barrier ZeroMQ asks for when a socket changes thread).
  std::unique_ptr<transport::Publisher> publisher_;
  std::unique_ptr<transport::Ingest> ingest_;
  // A direct ingest's ring (offer) and the eventfd that wakes the I/O thread for it; both live
  // until the destructor, so a producer racing stop() never touches a freed ring or a closed fd.
  std::unique_ptr<transport::MessageRing> direct_ring_;
  int direct_fd_ = -1;
  // The producer is inside offer(): stop()'s I/O thread waits for it to leave before its last
  // drain of the ring (seq_cst against ingest_stop_requested_), so no message is left behind.
  alignas(64) std::atomic<bool> offering_{false};
  // Drains the ring into the ingest (at most max messages; all of them when max < 0). [I/O thread]
  void drain_direct(int max);
  // People frames (people_streams.cpp): a people tracker per group stream, each person's poses
  // pushed to their own stream, opened and closed as the tracker says. [I/O thread]
  struct PeopleGroup;
  void push_people(const transport::PeopleFrameView& frame, bool restarted);
  void close_people(uint64_t group_id);
  std::vector<std::shared_ptr<PeopleGroup>> people_groups_;  // I/O thread; one per live group stream
  // PeopleCounters' fields, in order: written by the I/O thread only (no read-modify-write), read by any.
  static constexpr int kPeopleCounts = static_cast<int>(sizeof(PeopleCounters) / sizeof(uint64_t));
  std::atomic<uint64_t> people_counts_[kPeopleCounts] = {};
  void count_people(int index, uint64_t n);
};

}  // namespace kata::runtime
