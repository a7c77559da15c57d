// kata-replay: the kata and bare ZeroMQ phases in this process.
#include "replay.hpp"

#include <sys/wait.h>
#include <unistd.h>
#include <zmq.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "common/error.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "transport/wire.hpp"

namespace kata::replay {

Clips load_clips(const Options& o) {
  Clips c;
  for (const char* name : {"02_02.bvh", "05_02.bvh", "05_03.bvh", "07_01.bvh", "09_01.bvh", "02_01.bvh"}) {
    c.clips.push_back(kata::load_bvh(o.data_dir + "/" + name));
    c.positions.push_back(kata::clip_positions(c.clips.back(), 1));
  }
  c.metric = std::make_shared<const kata::metric::Metric>(kata::metric::load_model(o.model));
  const kata::BvhClip t = kata::load_bvh(o.data_dir + "/" + o.teacher);
  const auto tp = kata::clip_positions(t, 1);
  const kata::GpdMap map = kata::make_gpd_map(t.skeleton, kata::preset_joint_names("cmu"));
  c.teacher = kata::pipeline::Teacher::from_positions(c.metric, t.skeleton,
                                                      kata::stream_config_for(t.skeleton, map, c.metric->stencil()),
                                                      tp.data(), t.frame_count() - 1, t.frame_time);
  return c;
}

kata::runtime::StreamSetup setup_for(const Clips& c, size_t clip) {
  kata::runtime::StreamSetup s;
  const kata::Skeleton& sk = c.clips[clip].skeleton;
  const kata::GpdMap map = kata::make_gpd_map(sk, kata::preset_joint_names("cmu"));
  s.pipeline.stream = kata::stream_config_for(sk, map, c.metric->stencil());
  s.pipeline.student = sk;
  s.teacher = c.teacher;
  return s;
}

double measure_push_us(const Clips& c) {
  const kata::runtime::StreamSetup setup = setup_for(c, 0);
  kata::pipeline::Pipeline p(setup.pipeline);
  p.set_teacher(setup.teacher, setup.teacher_options);
  const int joints = c.clips[0].skeleton.joint_count();
  const int frames = static_cast<int>(c.positions[0].size() / (3 * static_cast<size_t>(joints)));
  std::vector<kata::pipeline::Result> out(256);
  int64_t i = 0;
  auto run = [&](int n) {
    for (int k = 0; k < n; ++k, ++i) {
      p.push(static_cast<double>(i) * c.clips[0].frame_time,
             c.positions[0].data() + static_cast<size_t>(i % frames) * 3 * static_cast<size_t>(joints), joints);
      if (p.pending() >= 128) p.read(out.data(), nullptr, nullptr, out.size());
    }
  };
  run(300);
  std::vector<double> per_frame;
  for (int b = 0; b < 7; ++b) {
    const double t0 = thread_cpu_us();
    run(300);
    per_frame.push_back((thread_cpu_us() - t0) / 300.0);
  }
  std::sort(per_frame.begin(), per_frame.end());
  return per_frame[per_frame.size() / 2];
}
json run_kata(const Options& o, const Clips& c, int streams, double* message_bytes) {
  kata::runtime::RuntimeConfig config;
  config.workers = o.workers;
  config.result_batch = o.result_batch;
  config.drain_burst = o.drain_burst;
  config.max_streams = std::max(streams, 1);
  config.publish.endpoints = {endpoint_for(o, "kata")};
  config.publish.send_hwm = 100000;
  config.skeleton_resend_seconds = 1.0;
  config.idle.kind = o.idle == "park" ? kata::runtime::IdleStrategy::Kind::kPark : kata::runtime::IdleStrategy::Kind::kBackoff;
  if (o.curve) {
    config.publish.security.curve = curve_server();
    config.ingest.security.curve = curve_server();
  }
  if (o.ingest) {
    config.ingest.endpoints = {"bind:" + endpoint_for(o, "ingest")};
    config.ingest.kind = kata::transport::IngestKind::kPull;
    config.ingest.receive_hwm = 1 << 20;
    config.configure_stream = [&c](const kata::transport::SkeletonDefinition& d) {
      return setup_for(c, static_cast<size_t>(d.stream_id % c.clips.size()));
    };
  }
  kata::runtime::Runtime runtime(config);
  for (int s = 0; s < streams && !o.ingest; ++s) {
    kata::transport::SkeletonDefinition d;
    d.stream_id = static_cast<uint64_t>(s);
    d.revision = 1;
    const size_t clip = static_cast<size_t>(s) % c.clips.size();
    d.skeleton = c.clips[clip].skeleton;
    d.layout = "cmu";
    d.frame_rate = static_cast<float>(o.rate);
    runtime.open_stream(d, setup_for(c, clip));
  }
  const int64_t expected = static_cast<int64_t>(o.seconds * o.rate) * streams;
  Child child = spawn_subscriber(runtime.publish_endpoint(), "kata", o.seconds + 30.0, expected, o.soak ? o.window : 0.0,
                                 o.ingest ? streams : 1, o.ingest, o.inject_growth_us_per_s);
  SenderChild sender;
  if (o.ingest) sender = spawn_sender(o, runtime.ingest_endpoint(), streams);
  if (read_line(child.out) != "ready") throw Error(ErrorKind::kIo, "replay: the kata subscriber did not start");
  const int64_t ticks = static_cast<int64_t>(o.seconds * o.rate);
  uint64_t sent = 0, refused_push = 0;
  std::vector<uint64_t> sent_by_stream(static_cast<size_t>(streams), 0);  // in-process path: every push
  std::vector<double> rss_mib;  // soak: resident memory once per second
  rss_mib.reserve(static_cast<size_t>(o.seconds) + 2);
  const int64_t ticks_per_second = std::max<int64_t>(1, static_cast<int64_t>(o.rate));
  const double cpu0 = cpu_seconds();
  const auto threads0 = thread_cpu_ns();
  const auto wall0 = std::chrono::steady_clock::now();
  json sender_report;
  if (o.ingest) {
    // Every stream is open (the subscriber saw its definition); the sender starts its frames.
    std::fputs("go\n", sender.in);
    std::fflush(sender.in);
    paced(o, ticks, [&](int64_t t) {
      if (o.soak && t % ticks_per_second == 0) rss_mib.push_back(resident_mib());
    });
    const std::string line = read_line(sender.out);
    std::fclose(sender.in);
    std::fclose(sender.out);
    int status = 0;
    waitpid(sender.pid, &status, 0);
    if (line.empty()) throw Error(ErrorKind::kIo, "replay: the sender process reported nothing");
    sender_report = json::parse(line);
    sent = sender_report["sent"].get<uint64_t>();
    refused_push = static_cast<uint64_t>(ticks) * static_cast<uint64_t>(streams) - sent;  // the sender's refusals
    // The sender has exited (its linger flushed the socket): wait until ingest has read every
    // frame (bounded), or stop() would leave the last ones unread in the socket.
    const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    auto read_all = [&] { const auto in = runtime.counters().ingest; return in.frames + in.dropped_total() >= sent; };
    while (!read_all() && std::chrono::steady_clock::now() < limit)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (!o.ingest) paced(o, ticks, [&](int64_t t) {
    if (o.soak && t % ticks_per_second == 0) rss_mib.push_back(resident_mib());
    for (int s = 0; s < streams; ++s) {
      int joints = 0;
      const float* xyz = c.frame(s, t, &joints);
      ++sent_by_stream[static_cast<size_t>(s)];
      if (runtime.push(static_cast<uint64_t>(s), static_cast<uint64_t>(t), static_cast<double>(t) / o.rate, xyz,
                       joints) == kata::Status::kOk)
        ++sent;
      else
        ++refused_push;
    }
  });
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  const double cpu = cpu_seconds() - cpu0;
  const auto threads1 = thread_cpu_ns();
  runtime.stop();
  json j = finish_child(child);
  // Per thread: where the process's CPU per frame goes. The workers' share holds the
  // push (the pose's compute); the rest is the runtime's plumbing (ingest: the I/O thread reads
  // and verifies; libzmq's own threads move the bytes).
  json per_thread = json::object(), wakes = json::object(), preempted = json::object();
  for (const auto& [name, use] : threads1) {
    const auto before = threads0.find(name);
    const ThreadUse base = before == threads0.end() ? ThreadUse{} : before->second;
    if (!sent) continue;
    per_thread[name] = 1e-3 * (use.ns - base.ns) / static_cast<double>(sent);
    wakes[name] = (use.sleeps - base.sleeps) / static_cast<double>(sent);
    preempted[name] = (use.preempted - base.preempted) / static_cast<double>(sent);
  }
  j["preemptions_per_frame_by_thread"] = preempted;
  j["cpu_us_per_frame_by_thread"] = per_thread;
  j["wakeups_per_frame_by_thread"] = wakes;
  const auto counters = runtime.counters();
  // The share of the frames the workers drained in bursts (RuntimeConfig::drain_burst).
  j["burst_frames"] = runtime.burst_frames();
  j["sent"] = sent + refused_push;
  j["lost"] = static_cast<int64_t>(sent + refused_push) - j["received"].get<int64_t>();
  // Every drop cause the runtime counts per stream (runtime::kDropCauses: queues, pipeline,
  // publisher, and the frames of a stream the ingest refused: stale, not its owner's, ...).
  uint64_t runtime_drops = 0;
  json by_cause = json::object();
  for (const kata::runtime::DropCause& cause : kata::runtime::kDropCauses) {
    runtime_drops += counters.total.*cause.count;
    by_cause[cause.name] = counters.total.*cause.count;
  }
  j["runtime_drops"] = runtime_drops;
  // Per stream (the in-process path, where this process knows what each stream was
  // sent): frames pushed = results the subscriber received + every drop cause counted on it.
  j["unaccounted"] = json::array();
  if (!o.ingest)
    for (const auto& [id, counts] : runtime.all_stream_counters()) {
      uint64_t dropped = 0;
      for (const kata::runtime::DropCause& cause : kata::runtime::kDropCauses) dropped += counts.*cause.count;
      const std::string key = std::to_string(id);
      const uint64_t got = j.contains("received_by_stream") && j["received_by_stream"].contains(key)
                               ? j["received_by_stream"][key].get<uint64_t>() : 0;
      const uint64_t pushed = id < sent_by_stream.size() ? sent_by_stream[id] : 0;
      if (pushed != got + dropped)
        j["unaccounted"].push_back("stream " + key + ": pushed " + std::to_string(pushed) + " != received " +
                                   std::to_string(got) + " + dropped " + std::to_string(dropped));
    }
  j["publisher_cpu_percent_of_one_core"] = 100.0 * cpu / wall;
  // Every thread of this process (pushing or ingest, workers, the I/O thread, libzmq's) per frame.
  j["cpu_us_per_frame"] = sent ? 1e6 * cpu / static_cast<double>(sent) : 0.0;
  j["runtime_drops_by_cause"] = by_cause;
  if (o.ingest) {
    j["path"] = o.batch ? "ingest: a sender process -> one frame batch message per tick -> ZeroMQ PUSH/PULL -> Ingest (verifier, checksum per frame) -> runtime"
                        : "ingest: a sender process -> ZeroMQ PUSH/PULL -> Ingest (verifier, checksum) -> runtime";
    j["sender_cpu_seconds"] = sender_report["sender_cpu_seconds"];
    j["ingest_dropped"] = counters.ingest.dropped_total();
  } else {
    j["path"] = "in-process push";
  }
  *message_bytes = j["mean_message_bytes"].get<double>();
  if (o.soak) j["rss_mib"] = rss_mib;
  return j;
}

json run_bare(const Options& o, int streams, size_t message_bytes) {
  void* context = zmq_ctx_new();
  void* pub = zmq_socket(context, ZMQ_XPUB);  // XPUB only to see the subscriber join
  int hwm = 100000, linger = 0;
  zmq_setsockopt(pub, ZMQ_SNDHWM, &hwm, sizeof hwm);
  zmq_setsockopt(pub, ZMQ_LINGER, &linger, sizeof linger);
  // --curve: the bare publisher is a CURVE server as the runtime's is (its own ZAP handler).
  std::unique_ptr<kata::transport::ZapHandler> zap;
  if (o.curve) {
    zap = std::make_unique<kata::transport::ZapHandler>(context, std::vector<std::string>{curve_keys().client.public_key});
    kata::transport::apply_curve(pub, curve_server());
  }
  const std::string bind = endpoint_for(o, "bare");
  if (zmq_bind(pub, bind.c_str()) != 0) throw Error(ErrorKind::kIo, "replay: cannot bind " + bind);
  char endpoint[256];
  size_t size = sizeof endpoint;
  zmq_getsockopt(pub, ZMQ_LAST_ENDPOINT, endpoint, &size);
  Child child = spawn_subscriber(endpoint, "bare", o.seconds + 30.0, static_cast<int64_t>(o.seconds * o.rate) * streams);
  read_line(child.out);
  uint8_t join[64];
  zmq_pollitem_t item{pub, 0, ZMQ_POLLIN, 0};
  if (zmq_poll(&item, 1, 10000) <= 0 || zmq_recv(pub, join, sizeof join, 0) < 1)
    throw Error(ErrorKind::kIo, "replay: the bare subscriber did not join");
  std::vector<uint8_t> message(std::max<size_t>(message_bytes, 24), 0);
  const int64_t ticks = static_cast<int64_t>(o.seconds * o.rate);
  uint64_t sent = 0;
  const double cpu0 = cpu_seconds();
  const auto wall0 = std::chrono::steady_clock::now();
  paced(o, ticks, [&](int64_t) {
    for (int s = 0; s < streams; ++s) {
      kata::transport::write_topic(static_cast<uint64_t>(s), reinterpret_cast<char*>(message.data()));
      const int64_t t = now_ns();
      std::memcpy(message.data() + 16, &t, 8);
      zmq_send(pub, message.data(), message.size(), ZMQ_DONTWAIT);
      ++sent;
    }
  });
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  const double cpu = cpu_seconds() - cpu0;
  json j = finish_child(child);
  j["sent"] = sent;
  j["lost"] = static_cast<int64_t>(sent) - j["received"].get<int64_t>();
  j["publisher_cpu_percent_of_one_core"] = 100.0 * cpu / wall;
  // The floor of ZeroMQ's own share of kata's CPU per frame: what bare ZeroMQ spends
  // per message sending (this process, libzmq's thread included) and receiving (the subscriber).
  j["cpu_us_per_message"] = sent ? 1e6 * cpu / static_cast<double>(sent) : 0.0;
  if (j.contains("subscriber_cpu_seconds") && j["received"].get<int64_t>() > 0)
    j["subscriber_cpu_us_per_message"] = 1e6 * j["subscriber_cpu_seconds"].get<double>() / j["received"].get<double>();
  zmq_close(pub);
  zap.reset();  // its socket closes before the context terminates
  zmq_ctx_term(context);
  return j;
}

}  // namespace kata::replay
