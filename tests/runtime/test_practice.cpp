// Practice settings in the runtime's messages (schemas/practice.fbs): a source
// sets, for its own stream, where the teacher starts or a section looped, and changes it
// mid-stream; every result says the setting it was computed under beside its matched teacher
// time. Over loopback TCP: a runtime with a PULL ingest in this process, each sender on its own
// PUSH socket (its own connection), a SUB reading the results. The students are the teacher's own
// frames (05_18, a dance that does not repeat itself), sent as fast as ZeroMQ takes them with the
// clip's capture times (nothing is judged stale, so a loaded machine changes no result), so the
// truth of every frame is known. Every wait is bounded.
#include <gtest/gtest.h>
#include <zmq.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "pipeline/pipeline.hpp"
#include "runtime/runtime.hpp"
#include "support/live_clip.hpp"
#include "support/runtime_waits.hpp"
#include "support/accounting.hpp"
#include "support/zmq_subscriber.hpp"
#include "transport/wire.hpp"

namespace kata::runtime {
namespace {

using test::wait_received;

using Clock = std::chrono::steady_clock;
using transport::PracticeSetting;
using transport::ResultFields;
using transport::SkeletonDefinition;

// The teacher and the students: 05_18 from clip frame 1 (the CMU T-pose skipped), teacher row i
// = student frame i.
struct Lesson : test::LiveClip {
  std::shared_ptr<const metric::Metric> metric = test::default_metric();
  std::shared_ptr<const pipeline::Teacher> teacher = test::clip_teacher(metric, "05_18");
  Lesson() : test::LiveClip("05_18") {}
};

const Lesson& lesson() {
  static Lesson l;
  return l;
}

constexpr uint64_t kNoTeacher = 9;  // the one stream set up without a teacher

RuntimeConfig config_with_teacher() {
  RuntimeConfig config;
  config.workers = 2;
  config.publish.endpoints = {"tcp://127.0.0.1:*"};
  config.ingest.kind = transport::IngestKind::kPull;
  config.ingest.endpoints = {"bind:tcp://127.0.0.1:*"};
  config.ingest.limits.max_frame_age_ns = 0;  // frames go out unpaced: never judged stale
  config.ingest.log_refusals = false;
  config.configure_stream = [](const SkeletonDefinition& d) {
    StreamSetup s = setup_from_definition(d);
    s.pipeline.stream.stencil = lesson().metric->stencil();
    if (d.stream_id != kNoTeacher) {
      s.teacher = lesson().teacher;
      s.teacher_options.ghost = false;
    }
    return s;
  };
  return config;
}

// One sender: its own PUSH socket (its own connection); frames carry the clip's times, sequence k
// at k frame times.
struct Sender {
  void* socket;
  transport::Encoder encoder;
  uint64_t sent = 0, frames = 0;           // messages, and frames of every stream
  std::map<uint64_t, uint64_t> sequence;   // per stream
  Sender(void* context, const std::string& endpoint) : socket(zmq_socket(context, ZMQ_PUSH)) {
    int linger = 2000;
    zmq_setsockopt(socket, ZMQ_LINGER, &linger, sizeof linger);
    zmq_connect(socket, endpoint.c_str());
  }
  ~Sender() { zmq_close(socket); }
  void send(transport::Bytes m) {
    zmq_send(socket, m.data, m.size, 0);
    ++sent;
  }
  void frame(uint64_t id, int row) {
    const uint64_t k = sequence[id]++;
    send(encoder.frame(id, k, static_cast<int64_t>(static_cast<double>(k) * lesson().frame_time() * 1e9), lesson().frame(row),
                       lesson().joints()));
    ++frames;
  }
  void practice(uint64_t id, uint32_t revision, double teacher_start, bool loop = false, double a = 0, double b = 0) {
    PracticeSetting p;
    p.stream_id = id;
    p.revision = revision;
    p.teacher_start = teacher_start;
    p.loop = loop;
    p.loop_start = a;
    p.loop_end = b;
    send(encoder.practice(p));
  }
};

// Every result of the streams it reads, by stream.
struct Results {
  test::ZmqSubscriber sub;
  transport::Decoder decoder;
  std::map<uint64_t, std::vector<ResultFields>> of;
  Results(void* context, const std::string& endpoint) : sub(context, endpoint) {}
  bool joined(uint64_t id) {
    const auto end = Clock::now() + std::chrono::seconds(10);
    while (Clock::now() < end)
      if (sub.next(decoder, 100) == transport::MessageKind::kSkeleton && decoder.stream_id() == id) return true;
    return false;
  }
  // Reads until every stream in `want` has its count of results, or 60 s (a loaded machine).
  void until(const std::map<uint64_t, size_t>& want) {
    const auto end = Clock::now() + std::chrono::seconds(60);
    auto done = [&] {
      for (const auto& [id, n] : want)
        if (of[id].size() < n) return false;
      return true;
    };
    while (!done() && Clock::now() < end)
      if (sub.next(decoder, 100) == transport::MessageKind::kResult) of[decoder.result().stream_id].push_back(decoder.result());
  }
};

// Of the results computed under `revision` whose student frame's truth (row_of) is settled (at
// least 1.5 s after `entered`, the frame at which the truth entered the section), the share
// matched within 0.25 s of it.
double share_found(const std::vector<ResultFields>& results, uint32_t revision, int (*row_of)(uint64_t),
                   uint64_t entered) {
  int near = 0, judged = 0;
  const double ft = lesson().frame_time();
  for (const ResultFields& r : results) {
    if (r.practice_revision != revision || !r.scored || r.frame_sequence < entered + static_cast<uint64_t>(1.5 / ft))
      continue;
    ++judged;
    near += std::abs(r.matched_teacher_time - row_of(r.frame_sequence) * ft) <= 0.25 ? 1 : 0;
  }
  return judged > 0 ? static_cast<double>(near) / judged : 0.0;
}

// The section: teacher rows 600..900 looped; then "again from row 1200" (teacher_start).
constexpr int kLoopFirst = 600, kLoopLast = 900, kStart = 1200;
// Phase 1: the student dances rows 0..1499, far beyond the section on both sides. Phase 2: rows
// 1000..1799, starting before the new start.
constexpr int kPhase1 = 1500, kPhase2Begin = 1000, kPhase2 = 800;

TEST(runtime_practice, ALoopHoldsTheMatchInsideItAndAChangeMidStreamMovesIt) {
  const Lesson& l = lesson();
  ASSERT_GE(l.rows(), kPhase2Begin + kPhase2);
  Runtime runtime(config_with_teacher());
  void* context = zmq_ctx_new();
  {
    Results results(context, runtime.publish_endpoint());
    Sender source(context, runtime.ingest_endpoint());
    source.send(source.encoder.skeleton(l.definition(7)));
    ASSERT_TRUE(results.joined(7));
    source.practice(7, 1, 0.0, true, kLoopFirst * l.frame_time(), kLoopLast * l.frame_time());
    for (int i = 0; i < kPhase1; ++i) source.frame(7, i);
    // A coach: "again from row 1200", mid-stream.
    source.practice(7, 2, kStart * l.frame_time());
    for (int i = 0; i < kPhase2; ++i) source.frame(7, kPhase2Begin + i);
    results.until({{7, static_cast<size_t>(kPhase1 + kPhase2)}});
    wait_received(runtime, source.sent);
    runtime.stop();
    const std::vector<ResultFields>& r = results.of[7];
    ASSERT_EQ(r.size(), static_cast<size_t>(kPhase1 + kPhase2)) << "every frame's result";

    const double last_time = (l.rows() - 1) * l.frame_time();
    int scored[3] = {0, 0, 0};
    for (const ResultFields& f : r) {
      ASSERT_TRUE(f.has_practice) << "a stream with a clip teacher says its practice in every result";
      const uint32_t rev = f.practice_revision;
      // The setting is the one in force when the frame was computed: the frames sent after the
      // change are computed under it (a central stencil emits a frame one push late: the frame
      // just before the change may already be computed under it).
      if (f.frame_sequence + 1 < static_cast<uint64_t>(kPhase1)) {
        ASSERT_EQ(rev, 1u) << "frame " << f.frame_sequence;
      } else if (f.frame_sequence >= static_cast<uint64_t>(kPhase1)) {
        ASSERT_EQ(rev, 2u) << "frame " << f.frame_sequence;
      }
      if (rev == 1) {
        EXPECT_DOUBLE_EQ(f.practice_start_time, kLoopFirst * l.frame_time());
        EXPECT_DOUBLE_EQ(f.practice_end_time, kLoopLast * l.frame_time());
        EXPECT_TRUE(f.practice_loop);
      } else {
        EXPECT_DOUBLE_EQ(f.practice_start_time, kStart * l.frame_time());
        EXPECT_DOUBLE_EQ(f.practice_end_time, last_time);
        EXPECT_FALSE(f.practice_loop);
      }
      if (!f.scored) continue;
      ++scored[rev];
      // The matched teacher time stays in the section, wherever the student is.
      ASSERT_GE(f.matched_teacher_time, f.practice_start_time - 1e-9) << "frame " << f.frame_sequence;
      ASSERT_LE(f.matched_teacher_time, f.practice_end_time + 1e-9) << "frame " << f.frame_sequence;
      EXPECT_EQ(f.matched_teacher_frame, static_cast<int>(std::lround(f.matched_teacher_time / l.frame_time())));
    }
    EXPECT_GT(scored[1], kPhase1 * 9 / 10);
    EXPECT_GT(scored[2], kPhase2 * 9 / 10);
    // Inside the section the student is followed: within 0.25 s of the truth on >= 90 % of the
    // frames from 1.5 s after the truth entered it (the criterion for a skip).
    const uint64_t loop_entered = kLoopFirst, start_entered = kPhase1 + (kStart - kPhase2Begin);
    int near_loop = 0, judged_loop = 0;
    for (const ResultFields& f : r)
      if (f.scored && f.practice_revision == 1 && f.frame_sequence >= loop_entered + 180 &&
          f.frame_sequence <= static_cast<uint64_t>(kLoopLast)) {
        ++judged_loop;
        near_loop += std::abs(f.matched_teacher_time - static_cast<double>(f.frame_sequence) * l.frame_time()) <= 0.25;
      }
    ASSERT_GT(judged_loop, 100);
    EXPECT_GE(static_cast<double>(near_loop) / judged_loop, 0.9) << near_loop << " of " << judged_loop;
    const double found = share_found(
        r, 2, [](uint64_t k) { return kPhase2Begin + static_cast<int>(k) - kPhase1; }, start_entered);
    EXPECT_GE(found, 0.9);
    std::printf("loop %d..%d: %d of %d settled frames within 0.25 s; from %d: %.3f\n", kLoopFirst, kLoopLast, near_loop,
                judged_loop, kStart, found);

    const RuntimeCounters c = runtime.counters();
    EXPECT_EQ(c.ingest.practices, 2u);
    EXPECT_EQ(c.ingest.dropped_total(), 0u);
    EXPECT_TRUE(test::every_frame_accounted(runtime, {{7, {source.sequence[7], r.size(), 0}}}));
  }
  zmq_ctx_term(context);
}

// A bad practice setting is refused and counted by its cause, changes nothing on its stream, and
// no other stream sees anything of it; another sender cannot set a stream it does not own.
TEST(runtime_practice, BadSettingsAreRefusedByCauseAndNoOtherStreamIsTouched) {
  const Lesson& l = lesson();
  Runtime runtime(config_with_teacher());
  void* context = zmq_ctx_new();
  {
    Results results(context, runtime.publish_endpoint());
    Sender a(context, runtime.ingest_endpoint()), b(context, runtime.ingest_endpoint()),
        forger(context, runtime.ingest_endpoint());
    a.send(a.encoder.skeleton(l.definition(7)));
    a.send(a.encoder.skeleton(l.definition(kNoTeacher)));
    b.send(b.encoder.skeleton(l.definition(8)));
    ASSERT_TRUE(results.joined(8));
    a.practice(7, 1, 0.0, true, kLoopFirst * l.frame_time(), kLoopLast * l.frame_time());
    a.practice(7, 1, 0.0, true, kLoopFirst * l.frame_time(), kLoopLast * l.frame_time());  // a re-send: not applied again
    constexpr int kFrames = 1200;
    for (int i = 0; i < kFrames; ++i) {
      if (i == 400) {
        a.practice(7, 2, 0.0, true, 5.0, 4.0);          // an empty loop
        a.practice(7, 3, std::nan(""));                 // not finite
        a.practice(7, 4, 1000.0);                       // beyond the clip's end
        a.practice(7, 5, 0.0, true, 2.0, 2.0 + l.frame_time() / 4);  // within one teacher frame
        a.practice(kNoTeacher, 6, 1.0);                 // no clip teacher
        forger.practice(8, 7, 3.0);                     // not its stream
        forger.practice(7, 7, 3.0);
        wait_received(runtime, a.sent + b.sent + forger.sent);
      }
      a.frame(7, i);
      b.frame(8, i);
      if (i < 20) a.frame(kNoTeacher, i);
    }
    results.until({{7, static_cast<size_t>(kFrames)}, {8, static_cast<size_t>(kFrames)}, {kNoTeacher, 20}});
    wait_received(runtime, a.sent + b.sent + forger.sent);
    // The same causes in the published stats message (every second), part of its dropped.
    bool stats_seen = false;
    const auto stats_end = Clock::now() + std::chrono::seconds(10);
    while (!stats_seen && Clock::now() < stats_end) {
      if (results.sub.next(results.decoder, 100) != transport::MessageKind::kStats) continue;
      const transport::StatsFields st = results.decoder.stats();
      if (st.received != a.sent + b.sent + forger.sent) continue;
      stats_seen = true;
      EXPECT_EQ(st.practices, 1u);
      EXPECT_EQ(st.repeated_practices, 1u);
      EXPECT_EQ(st.practice_bad_values, 2u);
      EXPECT_EQ(st.practice_outside_clip, 2u);
      EXPECT_EQ(st.practice_no_clip, 1u);
      EXPECT_EQ(st.practice_queue_full, 0u);
      EXPECT_EQ(st.malformed + st.not_owner + st.refused_limit + st.refused_definitions + st.unknown_stream +
                    st.wrong_joint_count + st.out_of_order + st.out_of_window + st.stale + st.other_kind +
                    st.practice_bad_values + st.practice_outside_clip + st.practice_no_clip + st.practice_queue_full,
                st.dropped);
    }
    EXPECT_TRUE(stats_seen) << "a stats message with every message counted";
    runtime.stop();
    ASSERT_EQ(results.of[7].size(), static_cast<size_t>(kFrames));
    ASSERT_EQ(results.of[8].size(), static_cast<size_t>(kFrames));
    for (const ResultFields& f : results.of[7]) {
      ASSERT_EQ(f.practice_revision, 1u) << "stream 7 keeps its setting, frame " << f.frame_sequence;
      if (f.scored) {
        ASSERT_GE(f.matched_teacher_time, kLoopFirst * l.frame_time() - 1e-9);
        ASSERT_LE(f.matched_teacher_time, kLoopLast * l.frame_time() + 1e-9);
      }
    }
    // Stream 8 is followed along the whole clip, as it would be alone: its own frames, in order,
    // under its configured setting, found on >= 90 % of the frames after the first 1.5 s.
    for (size_t k = 0; k < results.of[8].size(); ++k) {
      const ResultFields& f = results.of[8][k];
      ASSERT_EQ(f.frame_sequence, k);
      ASSERT_TRUE(f.has_practice);
      ASSERT_EQ(f.practice_revision, 0u);
      ASSERT_EQ(f.practice_start_time, 0.0);
      ASSERT_DOUBLE_EQ(f.practice_end_time, (l.rows() - 1) * l.frame_time());
      ASSERT_FALSE(f.practice_loop);
    }
    EXPECT_GE(share_found(results.of[8], 0, [](uint64_t k) { return static_cast<int>(k); }, 0), 0.9);

    const RuntimeCounters c = runtime.counters();
    const transport::IngestCounters& in = c.ingest;
    EXPECT_EQ(in.practices, 1u);
    EXPECT_EQ(in.repeated_practices, 1u);
    EXPECT_EQ(in.practice_bad_values, 2u) << "the empty loop and the time that is not finite";
    EXPECT_EQ(in.practice_outside_clip, 2u) << "beyond the end, and a loop within one frame";
    EXPECT_EQ(in.practice_no_clip, 1u);
    EXPECT_EQ(in.not_owner, 2u);
    EXPECT_EQ(in.received, a.sent + b.sent + forger.sent);
    EXPECT_EQ(in.frames + in.skeletons + in.repeated_skeletons + in.closes + in.practices + in.repeated_practices +
                  in.other_shard + in.dropped_total(),
              in.received);
    EXPECT_TRUE(test::every_frame_accounted(runtime, {{7, {a.sequence[7], results.of[7].size(), 0}},
                                                      {8, {b.sequence[8], results.of[8].size(), 0}},
                                                      {kNoTeacher, {a.sequence[kNoTeacher], results.of[kNoTeacher].size(), 0}}}));
    // A stream without a clip teacher has no practice to say.
    ASSERT_EQ(results.of[kNoTeacher].size(), 20u);
    for (const ResultFields& f : results.of[kNoTeacher]) EXPECT_FALSE(f.has_practice);
  }
  zmq_ctx_term(context);
}

}  // namespace
}  // namespace kata::runtime
