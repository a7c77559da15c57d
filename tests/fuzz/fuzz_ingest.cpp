// libFuzzer target: ZeroMQ ingest messages (frames, skeleton definitions, anything) from up to
// four senders through the ingest's whole path: topic, size limit, FlatBuffers verifier, version
// and checksum checks, who owns which stream (forged definitions, revisions, closes and frames
// from another sender), the sequence window, stale frames, limits; then what the runtime does with
// an accepted message: a skeleton definition becomes a stream set up by setup_from_definition and
// scored against a teacher (as `kata serve` does); an owner's revision restarts it (a new skeleton
// reopens it); a close ends it; a practice setting moves its scorer's section; a frame is pushed
// through its pipeline. Every result is encoded and decoded again.
//
// Frame batches (schemas/frame_batch.fbs) go through the same path, each frame judged alone.
// Input: messages, each a 2-byte little-endian header and that many bytes: the low 14 bits are the
// length, the high 2 bits the sender (0..3). The arrival clock advances 8.3 ms per message.
// Asserts: no crash or sanitizer report, only kata::Error escapes a refusal; every message lands
// in exactly one ingest counter; only frames of accepted streams reach the pipelines; every result
// of a finite frame is finite (score in 0..100) and round-trips through the wire format.
//
// Speed: the ingests (one with checksums required, one without), the encoder and the round-trip
// decoder are made once and reset per input (a new 4 MiB decoder per input cost 10 ms).
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

// What one input has opened so far.
struct InputState {
  std::map<uint64_t, std::unique_ptr<pipeline::Pipeline>> streams;
  std::map<uint64_t, int> joints;
  std::map<uint64_t, bool> finite_input;  // every frame pushed to the stream so far was finite
};

struct Shared {
  transport::Context context{1};
  std::shared_ptr<const metric::Metric> metric;
  std::shared_ptr<const pipeline::Teacher> teacher;
  transport::Encoder encoder;
  transport::Decoder round_trip{1 << 22, false};
  std::vector<pipeline::Result> results = std::vector<pipeline::Result>(16);
  std::vector<float> ghosts = std::vector<float>(16 * 3 * 64);
  InputState* input = nullptr;
  std::unique_ptr<transport::Ingest> ingest[2];  // [require_checksum]

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
    for (int checksum = 0; checksum < 2; ++checksum) {
      transport::IngestOptions options;
      options.endpoints = {"bind:inproc://fuzz-ingest-" + std::to_string(checksum)};
      options.max_message_bytes = 8192;  // reachable by a 14-bit length: oversized is fuzzed too
      options.require_checksum = checksum != 0;
      options.limits.max_streams = 6;
      options.limits.max_streams_per_sender = 3;
      options.log_refusals = false;
      ingest[checksum] = std::make_unique<transport::Ingest>(context, options, handlers());
    }
  }

  std::unique_ptr<pipeline::Pipeline> open(const transport::SkeletonDefinition& d) {
    runtime::StreamSetup setup = runtime::setup_from_definition(d);  // throws kata::Error: refused
    setup.pipeline.stream.stencil = metric->stencil();
    auto p = std::make_unique<pipeline::Pipeline>(setup.pipeline);
    pipeline::TeacherOptions options;
    options.ghost = d.skeleton.has_rest_pose && d.skeleton.joint_count() <= 64;
    try {
      p->set_teacher(teacher, options);
    } catch (const Error&) {
      options.ghost = false;  // a skeleton without the ghost's joints is scored without one
      p->set_teacher(teacher, options);
    }
    return p;
  }

  transport::Ingest::Handlers handlers() {
    transport::Ingest::Handlers h;
    h.on_skeleton = [this](const transport::SkeletonDefinition& d) {
      InputState& in = *input;
      if (in.streams.count(d.stream_id) || in.streams.size() >= kMaxStreams || d.skeleton.joint_count() > kMaxJoints)
        return false;
      in.streams[d.stream_id] = open(d);
      in.joints[d.stream_id] = d.skeleton.joint_count();
      in.finite_input[d.stream_id] = true;
      return true;
    };
    h.on_revision = [this](const transport::SkeletonDefinition& d) {
      InputState& in = *input;
      auto it = in.streams.find(d.stream_id);
      if (it == in.streams.end()) std::abort();  // a revision only of an accepted stream
      if (d.skeleton.joint_count() > kMaxJoints) return false;
      it->second = open(d);  // a new skeleton: the stream anew
      in.joints[d.stream_id] = d.skeleton.joint_count();
      in.finite_input[d.stream_id] = true;
      return true;
    };
    h.on_close = [this](uint64_t id) {
      if (!input->streams.erase(id)) std::abort();  // a close only of an accepted stream
    };
    // A practice setting of an accepted stream from its owner, values already judged: its rows in
    // the teacher clip as the runtime judges them (runtime::practice_rows), then the scorer's section.
    h.on_practice = [this](const transport::PracticeSetting& practice, std::string* why) {
      InputState& in = *input;
      auto it = in.streams.find(practice.stream_id);
      if (it == in.streams.end()) std::abort();  // only an accepted stream's owner gets here
      metric::Scorer* scorer = it->second->scorer();
      char text[256];
      if (transport::practice_values_problem(practice, text, sizeof text)) std::abort();  // judged before
      int32_t first = 0, last = -1;
      const transport::TableVerdict v = runtime::practice_rows(practice, scorer->reference().frames(),
                                                               scorer->reference().frame_time(), &first, &last, text,
                                                               sizeof text);
      if (v != transport::TableVerdict::kAccepted) {
        *why = text;
        return v;
      }
      scorer->set_section(first, last, practice.loop);  // throws kata::Error only for a section outside the clip
      return v;
    };
    h.on_frame = [this](const transport::FrameView& f, bool restarted) {
      InputState& in = *input;
      auto it = in.streams.find(f.stream_id);
      if (it == in.streams.end()) std::abort();  // the ingest hands on only frames of accepted streams
      if (f.joints != in.joints[f.stream_id]) std::abort();
      pipeline::Pipeline& p = *it->second;
      if (restarted) {
        p.reset();
        p.restart_teacher();
      }
      for (int i = 0; i < 3 * f.joints; ++i)
        if (!std::isfinite(f.xyz[i])) in.finite_input[f.stream_id] = false;
      (void)p.push(static_cast<double>(f.capture_ns) * 1e-9, f.xyz, f.joints);
      drain(f.stream_id, p);
    };
    return h;
  }

  void drain(uint64_t id, pipeline::Pipeline& p) {
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
        if (input->finite_input[id] && r.scored) {
          if (!std::isfinite(f.distance)) std::abort();
          if (!(f.score >= 0.0f && f.score <= 100.0f)) std::abort();
          for (float part : f.parts)
            if (!std::isfinite(part)) std::abort();
        }
        const transport::Bytes m = encoder.result(f);
        if (round_trip.decode(m.data, m.size) != transport::MessageKind::kResult) std::abort();
        const transport::ResultFields& back = round_trip.result();
        if (back.stream_id != id || back.frame_index != f.frame_index || back.matched_teacher_frame != f.matched_teacher_frame)
          std::abort();
        if (std::memcmp(&back.score, &f.score, sizeof f.score) != 0) std::abort();
      }
  }
};

Shared& shared() {
  static Shared s;
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Shared& s = shared();
  InputState input;
  s.input = &input;
  transport::Ingest& ingest = *s.ingest[size & 1];
  ingest.reset();

  uint64_t messages = 0;
  std::vector<uint8_t> message;
  for (size_t at = 0; at + 2 <= size;) {
    const size_t header = data[at] | (static_cast<size_t>(data[at + 1]) << 8);
    const size_t length = std::min<size_t>(header & 0x3fff, size - at - 2);
    const transport::SenderToken sender = transport::connection_sender(static_cast<int>(header >> 14), 0);
    // A copy of exactly the message: the verifier must not read past it (ASan sees an overread).
    message.assign(data + at + 2, data + at + 2 + length);
    ingest.handle(message.data(), message.size(), sender,
                  1'000'000'000'000 + static_cast<int64_t>(messages) * 8'333'333);
    ++messages;
    at += 2 + length;
  }
  const transport::IngestCounters& c = ingest.counters();
  // A verified frame batch counts as its frames (IngestCounters::items).
  if (c.frames + c.skeletons + c.repeated_skeletons + c.closes + c.practices + c.repeated_practices + c.other_shard +
          c.dropped_total() !=
      messages - c.batches + c.batch_frames)
    std::abort();
  for (auto& [id, p] : input.streams) {
    p->flush();
    s.drain(id, *p);
  }
  s.input = nullptr;
  return 0;
}
