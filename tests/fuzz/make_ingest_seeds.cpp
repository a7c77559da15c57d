// Writes seed inputs for fuzz_ingest (its input layout: messages, each a 2-byte little-endian
// header, the length in its low 14 bits and the sender in its high 2, then the bytes) from real motion: a CMU clip's skeleton definition and frames, made by
// the encoder every sender uses. Usage: make_ingest_seeds OUT_DIR CLIP.bvh
#include <cstdio>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "transport/wire.hpp"

namespace {

void add(std::vector<uint8_t>& out, kata::transport::Bytes m, int sender = 0) {
  const size_t header = m.size | (static_cast<size_t>(sender) << 14);
  out.push_back(static_cast<uint8_t>(header & 0xff));
  out.push_back(static_cast<uint8_t>((header >> 8) & 0xff));
  out.insert(out.end(), m.data, m.data + m.size);
}

void write(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s OUT_DIR CLIP.bvh\n", argv[0]);
    return 2;
  }
  const std::string out = argv[1];
  const kata::BvhClip clip = kata::load_bvh(argv[2]);
  const auto positions = kata::clip_positions(clip, 1);
  const int joints = clip.skeleton.joint_count();
  kata::transport::Encoder encoder;
  kata::transport::SkeletonDefinition d;
  d.stream_id = 7;
  d.revision = 1;
  d.skeleton = clip.skeleton;
  d.layout = "cmu";
  d.frame_rate = static_cast<float>(1.0 / clip.frame_time);
  const int64_t dt = static_cast<int64_t>(clip.frame_time * 1e9);
  auto frame = [&](uint64_t id, uint64_t seq, int f) {
    return encoder.frame(id, seq, static_cast<int64_t>(seq) * dt, positions.data() + static_cast<size_t>(f) * 3 * static_cast<size_t>(joints), joints);
  };
  {  // a definition, then 12 frames in order
    std::vector<uint8_t> s;
    add(s, encoder.skeleton(d));
    for (int f = 0; f < 12; ++f) add(s, frame(7, static_cast<uint64_t>(f), f));
    write(out + "/definition-then-frames", s);
  }
  {  // a frame before its definition, a gap, a repeat, a restart, a second stream without rest pose
    std::vector<uint8_t> s;
    add(s, frame(7, 0, 0));
    add(s, encoder.skeleton(d));
    add(s, frame(7, 0, 0));
    add(s, frame(7, 3, 3));
    add(s, encoder.skeleton(d));
    add(s, frame(7, 2, 2));
    add(s, frame(7, 0, 10));
    add(s, frame(7, 1, 11));
    kata::transport::SkeletonDefinition bare = d;
    bare.stream_id = 9;
    bare.skeleton.has_rest_pose = false;
    bare.up_axis = kata::UpAxis::kZ;
    add(s, encoder.skeleton(bare));
    for (int f = 0; f < 6; ++f) add(s, frame(9, static_cast<uint64_t>(f), 20 + f));
    write(out + "/gaps-restart-two-streams", s);
  }
  {  // forged: sender 1 redefines, restarts, pushes into and closes sender 0's stream; wild sequences
    std::vector<uint8_t> s;
    add(s, encoder.skeleton(d));
    for (int f = 0; f < 6; ++f) add(s, frame(7, static_cast<uint64_t>(f), f));
    kata::transport::SkeletonDefinition forged = d;
    forged.revision = 9;
    add(s, encoder.skeleton(forged), 1);
    add(s, frame(7, 0, 30), 1);
    add(s, frame(7, 1ULL << 62, 31), 1);
    add(s, frame(7, 1ULL << 62, 6), 0);
    add(s, frame(7, ~0ULL, 7), 0);
    add(s, frame(7, 6, 8), 0);
    kata::transport::SkeletonDefinition close = d;
    close.closed = true;
    add(s, encoder.skeleton(close), 1);
    add(s, frame(7, 7, 9), 0);
    forged.revision = 2;  // the owner's own revision: a restart
    add(s, encoder.skeleton(forged), 0);
    add(s, frame(7, 0, 10), 0);
    add(s, encoder.skeleton(close), 0);  // the owner closes; the id is free for sender 2
    add(s, encoder.skeleton(d), 2);
    add(s, frame(7, 0, 11), 2);
    write(out + "/forged-definitions-and-sequences", s);
  }
  {  // a flood: sender 3 defines more streams than its limit, sender 0 one stream beside it
    std::vector<uint8_t> s;
    for (uint64_t id = 100; id < 108; ++id) {
      kata::transport::SkeletonDefinition flood = d;
      flood.stream_id = id;
      add(s, encoder.skeleton(flood), 3);
    }
    add(s, encoder.skeleton(d), 0);
    for (int f = 0; f < 4; ++f) add(s, frame(7, static_cast<uint64_t>(f), f), 0);
    write(out + "/definition-flood", s);
  }
  {  // practice settings (schemas/practice.fbs) of stream 7 between its frames: a loop, its re-send,
     // values no clip holds, a start beyond the clip, another sender's, a start, the whole clip
    std::vector<uint8_t> s;
    add(s, encoder.skeleton(d));
    auto practice = [&](uint32_t revision, double start, bool loop, double a, double b) {
      kata::transport::PracticeSetting p;
      p.stream_id = 7;
      p.revision = revision;
      p.teacher_start = start;
      p.loop = loop;
      p.loop_start = a;
      p.loop_end = b;
      return encoder.practice(p);
    };
    add(s, practice(1, 0.0, true, 0.05, 0.2));
    for (int f = 0; f < 4; ++f) add(s, frame(7, static_cast<uint64_t>(f), f));
    add(s, practice(1, 0.0, true, 0.05, 0.2));
    add(s, practice(2, 0.0, true, 0.2, 0.1));
    add(s, practice(3, 5.0, false, 0.0, 0.0));
    add(s, practice(4, 0.1, false, 0.0, 0.0), 1);
    for (int f = 4; f < 8; ++f) add(s, frame(7, static_cast<uint64_t>(f), f));
    add(s, practice(5, 0.1, false, 0.0, 0.0));
    for (int f = 8; f < 12; ++f) add(s, frame(7, static_cast<uint64_t>(f), f));
    add(s, practice(6, 0.0, false, 0.0, 0.0));
    add(s, frame(7, 12, 12));
    write(out + "/practice-settings", s);
  }
  {  // frame batches (schemas/frame_batch.fbs): streams 7 and 9 of sender 0 a batch per tick; a batch
     // from sender 1 with a frame of its own stream 11 beside one of sender 0's stream 7; 7 twice in
     // one batch (the same sequence, then the next); a batch's frame of a stream never defined
    std::vector<uint8_t> s;
    add(s, encoder.skeleton(d));
    kata::transport::SkeletonDefinition nine = d, eleven = d;
    nine.stream_id = 9;
    eleven.stream_id = 11;
    add(s, encoder.skeleton(nine));
    add(s, encoder.skeleton(eleven), 1);
    using Frame = kata::transport::Encoder::BatchFrame;
    auto at = [&](uint64_t id, uint64_t seq, int f) {
      return Frame{id, seq, static_cast<int64_t>(seq) * dt,
                   positions.data() + static_cast<size_t>(f) * 3 * static_cast<size_t>(joints), joints, nullptr, nullptr};
    };
    for (int f = 0; f < 4; ++f) {
      const Frame tick[2] = {at(7, static_cast<uint64_t>(f), f), at(9, static_cast<uint64_t>(f), 10 + f)};
      add(s, encoder.frame_batch(tick, 2));
    }
    const Frame forged[2] = {at(11, 0, 20), at(7, 4, 21)};
    add(s, encoder.frame_batch(forged, 2), 1);
    const Frame twice[3] = {at(7, 4, 4), at(7, 4, 4), at(7, 5, 5)};
    add(s, encoder.frame_batch(twice, 3));
    const Frame unknown[2] = {at(9, 4, 14), at(12, 0, 0)};
    add(s, encoder.frame_batch(unknown, 2));
    write(out + "/frame-batches", s);
  }
  return 0;
}
