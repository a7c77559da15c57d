// kata-replay --sender: the process that sends the streams' frames over ZeroMQ (--ingest).
#include "replay.hpp"

#include <zmq.h>

#include <cstring>

#include "common/error.hpp"
#include "io/clip_features.hpp"
#include "transport/wire.hpp"

namespace kata::replay {

// ---- the sender process (--ingest): what a mocap stage or `kata send` does -------------------
//
// Definitions every 200 ms until the parent writes "go" on stdin, then the streams' frames paced
// at --rate, each stamped with its send time (capture_ns, CLOCK_MONOTONIC) just before zmq_send;
// one JSON line at the end (sent, CPU).

int run_sender(const Options& o) {
  std::vector<kata::BvhClip> clips;
  std::vector<std::vector<float>> positions;
  for (const char* name : {"02_02.bvh", "05_02.bvh", "05_03.bvh", "07_01.bvh", "09_01.bvh", "02_01.bvh"}) {
    clips.push_back(kata::load_bvh(o.data_dir + "/" + name));
    positions.push_back(kata::clip_positions(clips.back(), 1));
  }
  void* context = zmq_ctx_new();
  void* push = zmq_socket(context, ZMQ_PUSH);
  int hwm = 1 << 20, linger = 5000;
  zmq_setsockopt(push, ZMQ_SNDHWM, &hwm, sizeof hwm);
  zmq_setsockopt(push, ZMQ_LINGER, &linger, sizeof linger);
  curve_client(push);
  if (zmq_connect(push, o.sender.c_str()) != 0) {
    std::fprintf(stderr, "sender: cannot connect %s: %s\n", o.sender.c_str(), zmq_strerror(zmq_errno()));
    return 1;
  }
  kata::transport::Encoder encoder;
  std::atomic<bool> go{false};
  std::thread announcer([&] {
    for (int round = 0; !go.load() && round < 600; ++round) {
      for (int s = 0; s < o.streams; ++s) {
        kata::transport::SkeletonDefinition d;
        d.stream_id = static_cast<uint64_t>(s);
        d.revision = 1;
        d.skeleton = clips[static_cast<size_t>(s) % clips.size()].skeleton;
        d.layout = "cmu";
        d.frame_rate = static_cast<float>(o.rate);
        const auto m = encoder.skeleton(d);
        zmq_send(push, m.data, m.size, 0);
      }
      for (int k = 0; k < 20 && !go.load(); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  });
  char line[16] = {};
  const bool started = std::fgets(line, sizeof line, stdin) != nullptr && std::strncmp(line, "go", 2) == 0;
  go.store(true);
  announcer.join();  // the encoder and socket are this thread's from here
  uint64_t sent = 0;
  const double cpu0 = cpu_seconds();
  std::vector<int64_t> last_stamp(static_cast<size_t>(o.streams), 0);
  std::vector<kata::transport::Encoder::BatchFrame> batch(o.batch ? static_cast<size_t>(o.streams) : 0);
  constexpr size_t kBatchChunk = 512;
  if (started) {
    const int64_t ticks = static_cast<int64_t>(o.seconds * o.rate);
    paced(o, ticks, [&](int64_t t) {
      for (int s = 0; s < o.streams; ++s) {
        const size_t clip = static_cast<size_t>(s) % clips.size();
        const int joints = clips[clip].skeleton.joint_count();
        const int frames = static_cast<int>(positions[clip].size() / (3 * static_cast<size_t>(joints)));
        const float* xyz = positions[clip].data() + static_cast<size_t>((t + s) % frames) * 3 * static_cast<size_t>(joints);
        // The send time, but never closer than 20 us to the stream's previous frame: a sender
        // catching up after a stall (a loaded machine) would otherwise stamp two frames of a stream
        // a few us apart, which the pipeline refuses (kMinTimeStep). The clamp acts only then.
        const int64_t stamp = std::max(now_ns(), last_stamp[static_cast<size_t>(s)] + 20'000);
        last_stamp[static_cast<size_t>(s)] = stamp;
        if (o.batch) {  // sent below, with the tick's other frames
          batch[static_cast<size_t>(s)] = {static_cast<uint64_t>(s), static_cast<uint64_t>(t), stamp, xyz, joints,
                                           nullptr, nullptr};
          continue;
        }
        const auto m = encoder.frame(static_cast<uint64_t>(s), static_cast<uint64_t>(t), stamp, xyz, joints);
        if (zmq_send(push, m.data, m.size, ZMQ_DONTWAIT) >= 0) ++sent;
      }
      // --batch: the tick's frames in messages of at most kBatchChunk frames (a stage's one message
      // per tick; 512 frames of 31 joints are ~230 KB, well inside the ingest's 1 MiB).
      for (size_t first = 0; o.batch && first < batch.size(); first += kBatchChunk) {
        const size_t n = std::min(kBatchChunk, batch.size() - first);
        const auto m = encoder.frame_batch(batch.data() + first, n);
        if (zmq_send(push, m.data, m.size, ZMQ_DONTWAIT) >= 0) sent += n;
      }
    });
  }
  json j;
  j["sent"] = sent;
  j["sender_cpu_seconds"] = cpu_seconds() - cpu0;
  std::printf("%s\n", j.dump().c_str());
  std::fflush(stdout);
  zmq_close(push);
  zmq_ctx_term(context);
  return started ? 0 : 1;
}

}  // namespace kata::replay
