// libFuzzer target: ZeroMQ ingest messages (frames, skeleton definitions, anything) through the
// ingest's whole path: topic, size limit, FlatBuffers verifier, version and checksum checks, the
// per-stream bookkeeping (unknown stream, joint count, order, restarts, gaps), then what the
// runtime does with an accepted message: a skeleton definition becomes a stream set up by
// setup_from_definition and scored against a teacher (as `kata serve` does); a frame is pushed
// through that stream's pipeline. Every result is encoded and decoded again.
//
// Input: messages, each a 2-byte little-endian length and that many bytes.
// Asserts: no crash or sanitizer report, only kata::Error escapes a refusal; every message lands
// in exactly one ingest counter; every result of a finite frame is finite (score in 0..100) and
// round-trips through the wire format.
#include <zmq.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "pipeline/pipeline.hpp"
#include "runtime/runtime.hpp"
#include "transport/wire.hpp"
#include "transport/zmq_io.hpp"

namespace {

using namespace kata;

constexpr int kMaxStreams = 4;
constexpr int kMaxJoints = 128;  // the runtime's default max_joints

struct Shared {
  transport::Context context{1};
  std::shared_ptr<const metric::Metric> metric;
  std::shared_ptr<const pipeline::Teacher> teacher;
  uint64_t endpoint_counter = 0;
  Shared() {
    metric = std::make_shared<const metric::Metric>(
        metric::load_model(std::string(KATA_SOURCE_DIR) + "/tests/data/models/v1-minmax-backward.kata"));
    const BvhClip clip = load_bvh(std::string(KATA_SOURCE_DIR) + "/data/cmu/02_01.bvh");
    const int frames = 40;  // a short teacher: the fuzzer's speed is in the ingest, not the alignment
    const auto positions = clip_positions(clip, 1);
    const GpdMap map = make_gpd_map(clip.skeleton, preset_joint_names("cmu"));
    teacher = pipeline::Teacher::from_positions(metric, clip.skeleton,
                                                stream_config_for(clip.skeleton, map, metric->stencil()),
                                                positions.data(), frames, clip.frame_time);
  }
};

Shared& shared() {
  static Shared s;
  return s;
}

void check_finite(float v) {
  if (!std::isfinite(v)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Shared& s = shared();
  std::map<uint64_t, std::unique_ptr<pipeline::Pipeline>> streams;
  std::map<uint64_t, bool> finite_input;  // every frame pushed to the stream so far was finite
  transport::Encoder encoder;
  transport::Decoder round_trip(1 << 22, false);
  std::vector<pipeline::Result> results(16);
  std::vector<float> ghosts(16 * 3 * 64);

  auto drain = [&](uint64_t id, pipeline::Pipeline& p) {
    for (size_t n; (n = p.read(results.data(), ghosts.data(), nullptr, results.size())) > 0;)
      for (size_t i = 0; i < n; ++i) {
        const pipeline::Result& r = results[i];
        transport::ResultFields f;
        f.stream_id = id;
        f.result_sequence = r.sequence;
        f.frame_index = r.frame_index;
        f.scored = r.scored;
        f.distance = r.score.distance;
        f.score = r.score.score;
        for (int k = 0; k < 5; ++k) f.parts[k] = r.score.parts[k];
        f.matched_teacher_frame = r.matched_frame;
        if (finite_input[id] && r.scored) {
          check_finite(f.distance);
          if (!(f.score >= 0.0f && f.score <= 100.0f)) std::abort();
          for (float part : f.parts) check_finite(part);
        }
        const transport::Bytes m = encoder.result(f);
        if (round_trip.decode(m.data, m.size) != transport::MessageKind::kResult) std::abort();
        const transport::ResultFields& back = round_trip.result();
        if (back.stream_id != id || back.frame_index != f.frame_index || back.matched_teacher_frame != f.matched_teacher_frame)
          std::abort();
        if (std::memcmp(&back.score, &f.score, sizeof f.score) != 0) std::abort();
      }
  };

  transport::Ingest::Handlers handlers;
  handlers.on_skeleton = [&](const transport::SkeletonDefinition& d) {
    if (streams.count(d.stream_id) || streams.size() >= kMaxStreams || d.skeleton.joint_count() > kMaxJoints)
      return false;
    runtime::StreamSetup setup = runtime::setup_from_definition(d);  // throws kata::Error: refused
    setup.pipeline.stream.stencil = s.metric->stencil();
    auto p = std::make_unique<pipeline::Pipeline>(setup.pipeline);
    pipeline::TeacherOptions options;
    options.ghost = d.skeleton.has_rest_pose && d.skeleton.joint_count() <= 64;
    try {
      p->set_teacher(s.teacher, options);
    } catch (const Error&) {
      options.ghost = false;  // a skeleton without the ghost's joints is scored without one
      p->set_teacher(s.teacher, options);
    }
    streams[d.stream_id] = std::move(p);
    finite_input[d.stream_id] = true;
    return true;
  };
  handlers.on_frame = [&](const transport::FrameView& f, bool restarted) {
    auto it = streams.find(f.stream_id);
    if (it == streams.end()) std::abort();  // the ingest hands on only frames of accepted streams
    pipeline::Pipeline& p = *it->second;
    if (restarted) {
      p.reset();
      p.restart_teacher();
    }
    for (int i = 0; i < 3 * f.joints; ++i)
      if (!std::isfinite(f.xyz[i])) finite_input[f.stream_id] = false;
    (void)p.push(static_cast<double>(f.capture_ns) * 1e-9, f.xyz, f.joints);
    drain(f.stream_id, p);
  };

  transport::IngestOptions options;
  options.endpoints = {"bind:inproc://fuzz-ingest-" + std::to_string(s.endpoint_counter++)};
  options.max_message_bytes = 1 << 16;
  options.require_checksum = (size & 1) != 0;
  transport::Ingest ingest(s.context, options, handlers);

  uint64_t messages = 0;
  for (size_t at = 0; at + 2 <= size;) {
    const size_t length = std::min<size_t>(data[at] | (static_cast<size_t>(data[at + 1]) << 8), size - at - 2);
    // A copy of exactly the message: the verifier must not read past it (ASan sees an overread).
    std::vector<uint8_t> message(data + at + 2, data + at + 2 + length);
    ingest.handle(message.data(), message.size());
    ++messages;
    at += 2 + length;
  }
  const transport::IngestCounters& c = ingest.counters();
  if (c.frames + c.skeletons + c.repeated_skeletons + c.other_shard + c.dropped_total() != messages) std::abort();
  for (auto& [id, p] : streams) {
    p->flush();
    drain(id, *p);
  }
  return 0;
}
