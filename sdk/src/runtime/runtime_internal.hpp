// The runtime's private parts, shared by its rooms (runtime.hpp has the threading model):
//   stream_table.cpp  the stream table: find, open, revise, close, retire; definitions -> setups;
//                     the counters
//   worker.cpp        the frame queues in (push) and the worker loop
//   io_loop.cpp       the I/O thread: definitions, stats, results out, the ingest
//   runtime.cpp       construction, stop and destruction, which wire the three together
// Never included outside sdk/src/runtime/.
#pragma once

#include "runtime/runtime.hpp"

#include <pthread.h>
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
namespace internal {

inline size_t round_up_pow2(size_t n) {
  size_t p = 1;
  while (p < n) p <<= 1;
  return p;
}

inline uint64_t mix(uint64_t x) {  // splitmix64 finaliser: spreads sequential ids over the table
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

inline constexpr uint64_t kEmptyKey = ~0ULL;      // stream ids the table cannot hold: a free slot,
inline constexpr uint64_t kTombstone = ~0ULL - 1;  // and a closed stream's slot (reused by a later open)
// Set in a worker's enqueue_pos by stop(): the queue takes no more frames. The position below it
// is then final: exactly the pushes that claimed a cell before, which the worker finishes.
inline constexpr size_t kQueueClosed = size_t{1} << (8 * sizeof(size_t) - 1);

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
inline bool back_off(int64_t spin_ns, int64_t yield_ns, Ready ready) {
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

}  // namespace internal

struct Runtime::StreamState {
  // Closing (stream table in runtime.hpp): a closed state is retired once its worker is past its
  // last frame, then reused by a later open; push() checks both after it found the state.
  std::atomic<uint64_t> id{internal::kEmptyKey};
  std::atomic<bool> closed{false};
  bool live = false;                             // open_mutex_: open (in the table)
  bool retired = false;                          // open_mutex_: counters moved to retired_totals_
  size_t retire_pos = 0;                         // the worker's enqueue position at the close
  transport::SkeletonDefinition definition;
  std::unique_ptr<pipeline::Pipeline, std::function<void(pipeline::Pipeline*)>> pipeline;  // its worker only
  bool publish_features = false;
  int worker = 0;
  int ghost_joints = 0;
  // The clip teacher's frames (0: no clip teacher) and frame time, for judging practice settings
  // on the caller's thread; fixed at open.
  int teacher_frames = 0;
  double teacher_frame_time = 0.0;
  // The practice setting results are computed under (worker only after open; has_practice: the
  // stream has a clip teacher).
  bool has_practice = false;
  transport::PracticeSection practice;
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
        result_queue_full{0}, published{0}, send_failed{0}, stopped{0}, stale{0}, unauthorised{0},
        out_of_sequence{0}, wrong_joints{0};
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
  // Not a frame but a practice setting (set_practice): the section in teacher rows, checked.
  bool practice = false;
  int32_t practice_first = 0, practice_last = -1;
  bool practice_loop = false;
  uint32_t practice_revision = 0;
};

// A result on its way to the I/O thread.
struct ResultCell {
  void* stream = nullptr;
  pipeline::Result result;
  uint64_t frame_sequence = 0;
  int64_t computed_ns = 0;
  bool has_practice = false;  // the setting it was computed under (StreamState::practice)
  transport::PracticeSection practice;
  bool has_repetition = false;  // the frame ended a repetition: published after the result
  kata_repetition repetition{};
  // Not a result but the repetition a stream's last flush ended (the runtime's stop: the take's
  // end); only `stream` and `repetition` are set.
  bool repetition_only = false;
};

// The section a stream's scorer follows, in teacher seconds (has = false: no clip teacher).
inline void practice_section_of(pipeline::Pipeline& p, uint32_t revision, bool* has, transport::PracticeSection* out) {
  const metric::Scorer* scorer = p.scorer();
  *has = scorer && scorer->reference().kind() == metric::ReferenceKind::kClip;
  if (!*has) return;
  const double ft = scorer->reference().frame_time();
  *out = transport::PracticeSection{scorer->aligner().first() * ft, scorer->aligner().last() * ft,
                                    scorer->aligner().options().loop, revision};
}

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
  // Parked in its semaphore (or about to be): a producer posts only then, so a burst of frames
  // costs one wake-up, not a futex call per frame.
  alignas(64) std::atomic<bool> sleeping{false};
  sem_t wake;
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
  // The worker sends results itself when it holds the publisher (Runtime::flush_results).
  std::unique_ptr<transport::Encoder> encoder;
  // Frames this worker drained in bursts of two or more (RuntimeConfig::drain_burst); written
  // by the worker only.
  std::atomic<uint64_t> burst_frames{0};
  // Scratch for Pipeline::read.
  std::vector<pipeline::Result> read_buffer;
  std::vector<float> read_ghosts, read_features;
};

inline constexpr int kMaxGhostJoints = 64;
inline constexpr size_t kReadBatch = 64;

}  // namespace kata::runtime
