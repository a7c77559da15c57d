// C ABI of the runtime (kata.h section "runtime"): handle checks, exceptions -> status, copies.
#include <atomic>
#include <cmath>
#include <mutex>
#include <sstream>

#include "capi/capi_internal.hpp"
#include "common/text.hpp"
#include "runtime/plugin.hpp"
#include "runtime/plugin_host.hpp"
#include "runtime/runtime.hpp"

struct kata_runtime_s {
  // Plugins (kata_runtime_desc.plugins): declared before the runtime, so that they outlive it
  // (its threads call the sinks until it is destroyed); the sources are stopped first (below).
  std::shared_ptr<kata::runtime::PluginHostTarget> plugin_target = std::make_shared<kata::runtime::PluginHostTarget>();
  std::vector<std::unique_ptr<kata::runtime::PluginInstance>> plugin_sinks, plugin_sources;
  std::mutex sources_mutex;  // kata_runtime_stop may race kata_runtime_destroy's stop
  std::unique_ptr<kata::runtime::Runtime> runtime;
  kata_context context = nullptr;  // where the runtime's calls report their errors
  bool direct_ingest = false;      // fed by kata_runtime_offer
  // Definitions the app's on_stream_open refused (written by the I/O thread).
  std::shared_ptr<std::atomic<uint64_t>> refused_by_app = std::make_shared<std::atomic<uint64_t>>(0);

  // A source plugin pushes into the runtime: stopped before the runtime stops.
  void stop_sources() {
    std::lock_guard<std::mutex> lock(sources_mutex);
    for (auto& s : plugin_sources) s->stop();
  }
  ~kata_runtime_s() {
    stop_sources();
    runtime.reset();  // its last result reaches the sinks before they are deactivated
    plugin_target->runtime = nullptr;
  }
};

namespace {

std::vector<std::string> split_endpoints(const char* text) {
  std::vector<std::string> out;
  if (!text) return out;
  std::stringstream in(text);
  for (std::string e; std::getline(in, e, ',');) {
    const size_t b = e.find_first_not_of(" \t"), f = e.find_last_not_of(" \t");
    if (b != std::string::npos) out.push_back(e.substr(b, f - b + 1));
  }
  return out;
}

}  // namespace

namespace {
// The defaults kata.h lists for kata_runtime_desc.
kata_runtime_desc runtime_desc_defaults() {
  kata_runtime_desc d;
  std::memset(&d, 0, sizeof d);
  d.struct_size = sizeof d;
  d.workers = 2;
  d.max_streams = 1024;
  d.max_joints = 128;
  d.queue_capacity = 4096;
  d.send_hwm = 10000;
  d.max_message_bytes = 1u << 20;
  d.skeleton_resend_seconds = 1.0;
  d.max_streams_per_sender = 64;
  d.max_connections = 256;
  d.max_frame_age_seconds = 0.25;
  d.idle_stream_seconds = 300.0;
  d.shard_count = 1;
  d.require_checksum = 1;
  d.sequence_window = 1u << 16;
  return d;
}
// What the unsized init writes, for ever: 1.0's struct (programs built before the sized init
// call it by that name). When the struct grows, this stays at 112.
constexpr uint32_t kRuntimeDescSize10 = 112;
static_assert(sizeof(kata_runtime_desc) >= kRuntimeDescSize10, "the struct only grows");
}  // namespace

extern "C" {

KATA_API void kata_runtime_desc_init_sized(kata_runtime_desc* desc, uint32_t struct_size) {
  kata::capi::init_sized(desc, struct_size, runtime_desc_defaults());
}

// In parentheses: kata.h's macro of the same name is not expanded here.
KATA_API kata_status kata_runtime_create(kata_context context, const kata_runtime_desc* desc, kata_runtime* out) {
  const kata::capi::ContextScope scope(context);
  if (!context || !out) return KATA_E_NULL_POINTER;
  *out = nullptr;
  return kata::capi::guarded_context([&] {
    kata_runtime_desc d = runtime_desc_defaults();
    if (desc && !kata::capi::read_sized(desc, runtime_desc_defaults(), kata::capi::kRuntimeDesc10, &d))
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_runtime_create: desc->struct_size is below 1.0's kata_runtime_desc (call kata_runtime_desc_init)");
    if (d.workers < 1 || d.workers > 256 || d.max_streams < 1 || d.max_joints < 1 || d.queue_capacity < 2 ||
        d.max_message_bytes < 64 || !(d.skeleton_resend_seconds > 0.0))
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_runtime_create: workers 1..256, max_streams, max_joints >= 1, queue_capacity >= 2, "
                        "max_message_bytes >= 64 and skeleton_resend_seconds > 0");
    kata::runtime::RuntimeConfig config;
    config.workers = static_cast<int>(d.workers);
    config.max_streams = static_cast<int>(d.max_streams);
    config.max_joints = static_cast<int>(d.max_joints);
    if (d.result_queue_capacity == 1 || d.result_queue_capacity > (1u << 24) || d.queue_capacity > (1u << 24))
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_runtime_create: queue_capacity 2..2^24, result_queue_capacity 0 (queue_capacity) or 2..2^24");
    config.frame_queue_capacity = static_cast<int>(d.queue_capacity);
    config.result_queue_capacity = static_cast<int>(d.result_queue_capacity ? d.result_queue_capacity : d.queue_capacity);
    if (d.shard_count < 1 || d.shard_count > 65536 || d.shard_index >= d.shard_count)
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_runtime_create: shard_count 1..65536 and shard_index below it");
    config.ingest.shard_count = d.shard_count;
    config.ingest.shard_index = d.shard_index;
    if ((d.require_checksum != 0 && d.require_checksum != 1) || (d.idle_backoff != 0 && d.idle_backoff != 1))
      throw kata::Error(kata::ErrorKind::kInvalidArgument, "kata_runtime_create: require_checksum and idle_backoff are 0 or 1");
    config.ingest.require_checksum = d.require_checksum != 0;
    config.idle.kind = d.idle_backoff ? kata::runtime::IdleStrategy::Kind::kBackoff : kata::runtime::IdleStrategy::Kind::kPark;
    if (d.sequence_window < 1)
      throw kata::Error(kata::ErrorKind::kInvalidArgument, "kata_runtime_create: sequence_window >= 1");
    config.publish.endpoints = split_endpoints(d.publish_endpoints);
    config.publish.send_hwm = d.send_hwm;
    config.ingest.endpoints = split_endpoints(d.ingest_endpoints);
    config.ingest.kind = d.ingest_pull ? kata::transport::IngestKind::kPull : kata::transport::IngestKind::kSub;
    if (d.direct_ingest != 0 && d.direct_ingest != 1)
      throw kata::Error(kata::ErrorKind::kInvalidArgument, "kata_runtime_create: direct_ingest must be 0 or 1");
    if (d.direct_ingest) {
      // The app's own transport hands the messages in (kata_runtime_offer): no ingest socket.
      if (!config.ingest.endpoints.empty())
        throw kata::Error(kata::ErrorKind::kInvalidArgument,
                          "kata_runtime_create: direct_ingest takes its messages from kata_runtime_offer, not "
                          "ingest_endpoints (give one of the two)");
      config.ingest.kind = kata::transport::IngestKind::kDirect;
    }
    config.ingest.max_message_bytes = d.max_message_bytes;
    config.skeleton_resend_seconds = d.skeleton_resend_seconds;
    // The published record is a kata_result_record (transport::ResultFields derives from it): the
    // callback gets it as is, no translation and no copy on the live path.
    if (d.on_result) {
      const kata_result_callback callback = d.on_result;
      void* const user = d.on_result_user;
      config.sinks.push_back({[callback, user](const kata::transport::ResultFields& f) {
                                callback(user, static_cast<const kata_result_record*>(&f));
                              },
                              {}});
    }
    if (d.on_repetition) {
      const kata_repetition_callback callback = d.on_repetition;
      void* const user = d.on_result_user;
      config.repetition_sinks.push_back([callback, user](const kata_repetition& r) { callback(user, &r); });
    }
    config.on_frame = d.on_frame;
    config.on_frame_user = d.on_frame_user;
    if (d.max_streams_per_sender < 1 || !(d.max_frame_age_seconds >= 0.0) || !(d.idle_stream_seconds >= 0.0) ||
        d.max_frame_age_seconds > 3600.0 || d.idle_stream_seconds > 1e7)
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_runtime_create: max_streams_per_sender >= 1, max_frame_age_seconds 0..3600, "
                        "idle_stream_seconds 0..1e7");
    auto& limits = config.ingest.limits;
    limits.max_streams = d.max_streams;
    limits.max_streams_per_sender = d.max_streams_per_sender;
    limits.max_frame_age_ns = static_cast<int64_t>(d.max_frame_age_seconds * 1e9);
    limits.idle_ns = static_cast<int64_t>(d.idle_stream_seconds * 1e9);
    limits.sequence_window = d.sequence_window;
    config.ingest.max_connections = d.max_connections;
    if (d.key_file && d.key_file[0]) {
      const kata::transport::KeyPair own = kata::transport::read_key_file(d.key_file);
      if (own.secret_key.empty())
        throw kata::Error(kata::ErrorKind::kInvalidArgument, std::string(d.key_file) + ": not a .secret key file");
      std::vector<std::string> allowed;
      if (d.client_keys_dir && d.client_keys_dir[0]) allowed = kata::transport::read_key_directory(d.client_keys_dir);
      for (auto* curve : {&config.ingest.security.curve, &config.publish.security.curve}) {
        curve->own = own;
        curve->allowed_clients = allowed;
      }
      if (d.ingest_server_key_file && d.ingest_server_key_file[0])
        config.ingest.security.curve.remote_server = kata::transport::read_key_file(d.ingest_server_key_file).public_key;
      if (d.publish_server_key_file && d.publish_server_key_file[0])
        config.publish.security.curve.remote_server = kata::transport::read_key_file(d.publish_server_key_file).public_key;
    } else if ((d.client_keys_dir && d.client_keys_dir[0]) || (d.ingest_server_key_file && d.ingest_server_key_file[0]) ||
               (d.publish_server_key_file && d.publish_server_key_file[0])) {
      throw kata::Error(kata::ErrorKind::kInvalidArgument, "kata_runtime_create: CURVE keys need key_file");
    }
    auto r = std::make_unique<kata_runtime_s>();
    if (d.stream_stencil != KATA_STENCIL_BACKWARD && d.stream_stencil != KATA_STENCIL_CENTRAL)
      throw kata::Error(kata::ErrorKind::kInvalidArgument, "kata_runtime_create: stream_stencil is not a kata_stencil");
    const auto stencil = d.stream_stencil == KATA_STENCIL_CENTRAL ? kata::gpd::Stencil::kCentral
                                                                  : kata::gpd::Stencil::kBackward;
    if (d.on_stream_open) {
      // The app configures each announced stream as a kata_stream of its own before the runtime
      // adopts its pipeline (as kata_runtime_add_stream adopts one).
      const kata_stream_open_callback callback = d.on_stream_open;
      void* const user = d.on_stream_open_user;
      std::shared_ptr<std::atomic<uint64_t>> refused = r->refused_by_app;
      config.build_stream = [callback, user, stencil, refused](const kata::transport::SkeletonDefinition& def) {
        kata::runtime::StreamSetup setup = kata::runtime::setup_from_definition(def);
        setup.pipeline.stream.stencil = stencil;
        auto stream = std::make_unique<kata_stream_s>(setup.pipeline);
        stream->layout_name = def.layout;
        stream->name_map = def.name_map;
        kata_skeleton_s skeleton{def.skeleton};
        kata_stream_open_info info;
        std::memset(&info, 0, sizeof info);
        info.struct_size = sizeof info;
        info.joint_count = static_cast<uint32_t>(def.skeleton.joint_count());
        info.stream_id = def.stream_id;
        info.revision = def.revision;
        info.has_rest_pose = def.skeleton.has_rest_pose ? 1 : 0;
        info.layout = def.layout.c_str();
        info.frame_rate = def.frame_rate;
        info.skeleton = &skeleton;
        const kata_status status = callback(user, &info, stream.get());
        if (status != KATA_OK) {
          refused->fetch_add(1, std::memory_order_relaxed);
          throw kata::Error(kata::ErrorKind::kInvalidArgument,
                            "on_stream_open refused the stream (" + std::string(kata_status_string(status)) + ")");
        }
        kata_stream_s* owned = stream.release();
        return kata::runtime::RuntimeConfig::AdoptedPipeline{
            &owned->pipeline, [owned](kata::pipeline::Pipeline*) { delete owned; }, false};
      };
    }
    if (d.plugin_count > 0 && !d.plugins)
      throw kata::Error(kata::ErrorKind::kInvalidArgument, "kata_runtime_create: plugin_count without plugins");
    if (d.plugin_count > 1024)
      throw kata::Error(kata::ErrorKind::kInvalidArgument, "kata_runtime_create: plugin_count above 1024");
    // Each plugin sink gets every result before on_result (as kata serve hands them on), and
    // every repetition before on_repetition when it takes them (plugin ABI 2.1).
    std::vector<kata::runtime::Sink> plugin_sinks;
    std::vector<kata::runtime::RepetitionSink> plugin_repetition_sinks;
    for (uint32_t i = 0; i < d.plugin_count; ++i) {
      const kata_runtime_plugin& p = d.plugins[i];
      if (!p.path || !p.path[0])
        throw kata::Error(kata::ErrorKind::kInvalidArgument,
                          "kata_runtime_create: plugins[" + std::to_string(i) + "].path is empty");
      std::shared_ptr<kata::runtime::LoadedPlugin> loaded =
          kata::runtime::LoadedPlugin::load(kata::c_string(p.path, "plugin path"));
      auto instance = std::make_unique<kata::runtime::PluginInstance>(
          loaded, p.config ? kata::c_string(p.config, "plugin config") : std::string(), r->plugin_target);
      if (loaded->is_sink()) plugin_sinks.push_back(instance->sink());
      if (kata::runtime::RepetitionSink r_sink = instance->repetition_sink()) plugin_repetition_sinks.push_back(r_sink);
      (loaded->is_source() ? r->plugin_sources : r->plugin_sinks).push_back(std::move(instance));
    }
    config.sinks.insert(config.sinks.begin(), plugin_sinks.begin(), plugin_sinks.end());
    config.repetition_sinks.insert(config.repetition_sinks.begin(), plugin_repetition_sinks.begin(),
                                   plugin_repetition_sinks.end());
    r->runtime = std::make_unique<kata::runtime::Runtime>(std::move(config));
    r->plugin_target->runtime = r->runtime.get();
    {
      std::lock_guard<std::mutex> lock(r->sources_mutex);
      for (auto& source : r->plugin_sources) source->start();  // a failure: r's destructor stops the rest
    }
    r->context = context;
    r->direct_ingest = d.direct_ingest != 0;
    *out = r.release();
    return KATA_OK;
  });
}

KATA_API void kata_runtime_destroy(kata_runtime runtime) { delete runtime; }

KATA_API kata_status kata_runtime_add_stream(kata_runtime runtime, uint64_t stream_id, kata_stream* stream,
                                             const char* layout, int32_t publish_features) {
  return kata_runtime_add_stream_ex(runtime, stream_id, stream, layout, publish_features, 0.0f, 0.0f);
}

KATA_API kata_status kata_runtime_add_stream_ex(kata_runtime runtime, uint64_t stream_id, kata_stream* stream,
                                                const char* layout, int32_t publish_features, float frame_rate,
                                                float metres_per_unit) {
  if (!runtime || !stream || !*stream) return KATA_E_NULL_POINTER;
  const kata::capi::ContextScope scope(runtime->context);
  if (!std::isfinite(frame_rate) || !std::isfinite(metres_per_unit)) {
    kata::capi::set_context_error("kata_runtime_add_stream_ex: frame_rate and metres_per_unit must be finite");
    return KATA_E_NON_FINITE;
  }
  return kata::capi::guarded_context([&] {
    if (frame_rate < 0.0f || metres_per_unit < 0.0f)
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_runtime_add_stream_ex: frame_rate and metres_per_unit are >= 0 (0: unknown)");
    kata_stream s = *stream;
    kata::transport::SkeletonDefinition d;
    d.stream_id = stream_id;
    d.revision = 1;
    d.frame_rate = frame_rate;
    d.metres_per_unit = metres_per_unit;
    d.skeleton = s->pipeline.student();
    // The stream's own layout, so subscribers and shards rebuild the map it was opened with;
    // a layout that names another contradicts the stream and is refused.
    if (layout && layout[0] && (s->name_map.size() || s->layout_name != kata::c_string(layout, "layout")))
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_runtime_add_stream: layout '" + kata::bounded(kata::c_string(layout, "layout")) +
                            "' is not the layout the stream was opened with (" +
                            (s->name_map.empty() ? "'" + s->layout_name + "'" : std::string("a name map")) +
                            "); pass NULL to announce the stream's own");
    d.layout = s->layout_name;
    d.name_map = s->name_map;
    d.up_axis = s->pipeline.stream().config().up_axis;
    // The runtime owns the stream from here; it closes it when it is done with the pipeline.
    runtime->runtime->adopt_stream(
        d, &s->pipeline, [s](kata::pipeline::Pipeline*) { delete s; }, publish_features != 0);
    *stream = nullptr;
    return KATA_OK;
  });
}

KATA_API kata_status kata_runtime_push(kata_runtime runtime, uint64_t stream_id, uint64_t sequence,
                                       double capture_time, const float* positions, uint32_t joint_count) {
  if (!runtime || !positions) return KATA_E_NULL_POINTER;
  if (joint_count > (1u << 20)) return KATA_E_WRONG_JOINT_COUNT;
  return kata::capi::to_status(runtime->runtime->push(stream_id, sequence, capture_time, positions,
                                                      static_cast<int>(joint_count)));
}

KATA_API kata_status kata_runtime_push_confidence(kata_runtime runtime, uint64_t stream_id, uint64_t sequence,
                                                  double capture_time, const float* positions,
                                                  const float* confidences, uint32_t joint_count) {
  if (!runtime || !positions) return KATA_E_NULL_POINTER;
  if (joint_count > (1u << 20)) return KATA_E_WRONG_JOINT_COUNT;
  return kata::capi::to_status(runtime->runtime->push(stream_id, sequence, capture_time, positions,
                                                      static_cast<int>(joint_count), false, confidences));
}

KATA_API kata_status kata_runtime_set_practice(kata_runtime runtime, uint64_t stream_id, uint32_t revision,
                                               double teacher_start, int32_t loop, double loop_start,
                                               double loop_end) {
  if (!runtime) return KATA_E_NULL_POINTER;
  const kata::capi::ContextScope scope(runtime->context);
  kata::transport::PracticeSetting p;
  p.stream_id = stream_id;
  p.revision = revision;
  p.teacher_start = teacher_start;
  p.loop = loop != 0;
  p.loop_start = loop_start;
  p.loop_end = loop_end;
  return kata::capi::guarded_context([&] {
    std::string why;
    using kata::transport::TableVerdict;
    const TableVerdict v = runtime->runtime->set_practice(p, &why);
    if (v == TableVerdict::kAccepted) return KATA_OK;
    kata::capi::set_context_error(("kata_runtime_set_practice: stream " + std::to_string(stream_id) + ": " +
                                   (v == TableVerdict::kUnknownStream ? std::string("no such stream") : why))
                                      .c_str());
    switch (v) {
      case TableVerdict::kUnknownStream: return KATA_E_NOT_FOUND;
      case TableVerdict::kPracticeValues:
      case TableVerdict::kPracticeOutsideClip: return KATA_E_INVALID_ARGUMENT;
      case TableVerdict::kPracticeNoClip: return KATA_E_NO_CLIP_TEACHER;
      case TableVerdict::kPracticeQueueFull: return KATA_E_QUEUE_FULL;
      default: return KATA_E_STATE;
    }
  });
}

KATA_API kata_status kata_runtime_stop(kata_runtime runtime) {
  if (!runtime) return KATA_E_NULL_POINTER;
  const kata::capi::ContextScope scope(runtime->context);
  return kata::capi::guarded_context([&] {
    runtime->stop_sources();  // a source plugin pushes no frame after this
    runtime->runtime->stop();
    return KATA_OK;
  });
}

KATA_API kata_status kata_runtime_get_counters(kata_runtime runtime, kata_runtime_counters* out) {
  if (!runtime || !out) return KATA_E_NULL_POINTER;
  if (out->struct_size < kata::capi::kRuntimeCounters10) return KATA_E_INVALID_ARGUMENT;
  const kata::runtime::RuntimeCounters c = runtime->runtime->counters();
  kata_runtime_counters k{};
  k.struct_size = sizeof k;
  k.streams = static_cast<uint32_t>(c.streams);
  k.frames_in = c.total.frames_in;
  k.queue_full = c.total.queue_full;
  k.refused = c.total.refused;
  k.results = c.total.results;
  k.results_dropped = c.total.pipeline_dropped + c.total.result_queue_full;
  k.published = c.total.published;
  k.ingest_received = c.ingest.received;
  k.ingest_dropped = c.ingest.dropped_total();
  k.ingest_sequence_gaps = c.ingest.sequence_gaps;
  k.ingest_restarts = c.ingest.restarts;
  k.ingest_not_owner = c.ingest.not_owner;
  k.ingest_refused_limit = c.ingest.refused_limit;
  k.ingest_out_of_window = c.ingest.out_of_window;
  k.ingest_stale = c.ingest.stale;
  k.closed_streams = c.closed_streams;
  k.ingest_practices = c.ingest.practices;
  k.ingest_practice_bad_values = c.ingest.practice_bad_values;
  k.ingest_practice_outside_clip = c.ingest.practice_outside_clip;
  k.ingest_practice_no_clip = c.ingest.practice_no_clip;
  k.ingest_practice_queue_full = c.ingest.practice_queue_full;
  k.streams_refused_by_app = runtime->refused_by_app->load(std::memory_order_relaxed);
  const kata::transport::IngestCounters& in = c.ingest;
  k.ingest_frames = in.frames;
  k.ingest_skeletons = in.skeletons;
  k.ingest_repeated_skeletons = in.repeated_skeletons;
  k.ingest_closes = in.closes;
  k.ingest_repeated_practices = in.repeated_practices;
  k.ingest_other_shard = in.other_shard;
  k.ingest_batches = in.batches;
  k.ingest_batch_frames = in.batch_frames;
  k.ingest_malformed = in.malformed_total();
  k.ingest_refused_skeletons = in.refused_skeletons;
  k.ingest_unknown_stream = in.unknown_stream;
  k.ingest_wrong_joint_count = in.wrong_joint_count;
  k.ingest_out_of_order = in.out_of_order;
  k.ingest_other_kind = in.other_kind;
  k.ingest_connections = in.connections;
  k.ingest_disconnections = in.disconnections;
  k.ingest_connections_refused = in.connections_refused;
  k.ingest_handshake_failures = in.handshake_failures;
  k.ingest_last_handshake_error = in.last_handshake_error;
  k.pipeline_dropped = c.total.pipeline_dropped;
  k.result_queue_full = c.total.result_queue_full;
  k.send_failed = c.total.send_failed;
  const kata::runtime::PeopleCounters p = runtime->runtime->people_counters();
  k.people_frames = p.frames;
  k.people_empty_frames = p.empty_frames;
  k.people_refused_frames = p.refused_frames;
  k.people_poses = p.poses;
  k.people_poses_tracked = p.assigned;
  k.people_refused_non_finite = p.refused_non_finite;
  k.people_refused_out_of_range = p.refused_out_of_range;
  k.people_refused_few_joints = p.refused_few_joints;
  k.people_refused_too_many_poses = p.refused_too_many_poses;
  k.people_refused_table_full = p.refused_table_full;
  k.people_streams_opened = p.streams_opened;
  k.people_streams_closed = p.streams_closed;
  k.people_streams_refused = p.streams_refused;
  k.people_poses_unopened = p.unopened;
  kata::capi::write_sized(k, kata::capi::kRuntimeCounters10, out);  // size checked above
  return KATA_OK;
}

KATA_API const char* kata_runtime_publish_endpoint(kata_runtime runtime) {
  return runtime ? runtime->runtime->publish_endpoint_cstr() : "";
}

KATA_API const char* kata_runtime_ingest_endpoint(kata_runtime runtime) {
  return runtime ? runtime->runtime->ingest_endpoint_cstr() : "";
}

KATA_API kata_status kata_runtime_offer(kata_runtime runtime, const void* message, size_t size) {
  if (!runtime || !message) return KATA_E_NULL_POINTER;
  if (!runtime->direct_ingest) return KATA_E_STATE;
  return runtime->runtime->offer(message, size) ? KATA_OK : KATA_E_QUEUE_FULL;
}

KATA_API double kata_runtime_latency_percentile(kata_runtime runtime, double q) {
  if (!runtime || !(q >= 0.0 && q <= 1.0)) return 0.0;
  const kata::runtime::RuntimeCounters c = runtime->runtime->counters();
  return kata::runtime::latency_percentile(c.latency_histogram, q);
}

KATA_API kata_status kata_runtime_get_histogram(kata_runtime runtime, kata_histogram_kind kind, uint64_t* buckets,
                                                uint32_t capacity) {
  if (!runtime || !buckets) return KATA_E_NULL_POINTER;
  if (kind != KATA_HISTOGRAM_LATENCY && kind != KATA_HISTOGRAM_SOURCE_AGE) return KATA_E_INVALID_ARGUMENT;
  if (capacity < KATA_LATENCY_BUCKETS) return KATA_E_BUFFER_TOO_SMALL;
  static_assert(KATA_LATENCY_BUCKETS == kata::runtime::kLatencyBuckets &&
                    KATA_LATENCY_BUCKETS == kata::transport::IngestCounters::kAgeBuckets,
                "one bucket scheme");
  const kata::runtime::RuntimeCounters c = runtime->runtime->counters();
  const uint64_t* from = kind == KATA_HISTOGRAM_LATENCY ? c.latency_histogram : c.ingest.age_histogram;
  std::memcpy(buckets, from, sizeof(uint64_t) * KATA_LATENCY_BUCKETS);
  return KATA_OK;
}

KATA_API double kata_histogram_percentile(const uint64_t* buckets, uint32_t count, double q) {
  if (!buckets || count != KATA_LATENCY_BUCKETS || !(q >= 0.0 && q <= 1.0)) return 0.0;
  return kata::runtime::latency_percentile(buckets, q);
}

KATA_API kata_status kata_runtime_get_stream_counters(kata_runtime runtime, kata_stream_counters* out,
                                                      uint32_t capacity, uint32_t* count) {
  if (!runtime || !count || (!out && capacity > 0)) return KATA_E_NULL_POINTER;
  const kata::capi::ContextScope scope(runtime->context);
  return kata::capi::guarded_context([&] {
    const auto all = runtime->runtime->all_stream_counters();
    *count = static_cast<uint32_t>(all.size());
    if (capacity < all.size()) return KATA_E_BUFFER_TOO_SMALL;
    if (all.empty()) return KATA_OK;
    // Each element is as large as the caller's struct (out[0].struct_size), so an array of a
    // newer kata.h's structs is walked with its own stride.
    const uint32_t stride = out->struct_size;
    if (stride < kata::capi::kStreamCounters11)
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_runtime_get_stream_counters: out->struct_size is below 1.1's kata_stream_counters");
    auto* base = reinterpret_cast<unsigned char*>(out);
    for (size_t i = 0; i < all.size(); ++i) {
      const kata::runtime::StreamCounters& c = all[i].second;
      kata_stream_counters k{};
      k.struct_size = sizeof k;
      k.stream_id = all[i].first;
      k.frames_in = c.frames_in;
      k.results = c.results;
      k.published = c.published;
      k.queue_full = c.queue_full;
      k.stopped = c.stopped;
      k.stale = c.stale;
      k.unauthorised = c.unauthorised;
      k.out_of_sequence = c.out_of_sequence;
      k.wrong_joints = c.wrong_joints;
      k.refused = c.refused;
      k.pipeline_dropped = c.pipeline_dropped;
      k.result_queue_full = c.result_queue_full;
      k.send_failed = c.send_failed;
      auto* element = reinterpret_cast<kata_stream_counters*>(base + i * stride);
      element->struct_size = stride;
      kata::capi::write_sized(k, kata::capi::kStreamCounters11, element);
    }
    return KATA_OK;
  });
}

KATA_API kata_status kata_message_read_result(const void* message, size_t size, kata_result_record* out) {
  if (!message || !out) return KATA_E_NULL_POINTER;
  if (out->struct_size < sizeof(uint32_t)) return KATA_E_INVALID_ARGUMENT;
  try {
    thread_local kata::transport::Decoder decoder(1 << 22, false);
    const kata::transport::MessageKind kind = decoder.decode(message, size);
    // Every verified kata message that is not a result (the runtime publishes stats on the results'
    // socket; practice and frames travel the other way) is "no result here", not corrupt.
    if (kind == kata::transport::MessageKind::kNone) return KATA_E_PARSE;
    if (kind != kata::transport::MessageKind::kResult) return KATA_NO_DATA;
    kata::pipeline::copy_record_out(decoder.result(), out->struct_size, out);
    return KATA_OK;
  } catch (const std::bad_alloc&) {
    return KATA_E_OUT_OF_MEMORY;
  }
}

KATA_API kata_status kata_message_read_repetition(const void* message, size_t size, kata_repetition* out) {
  if (!message || !out) return KATA_E_NULL_POINTER;
  if (out->struct_size < sizeof(uint32_t)) return KATA_E_INVALID_ARGUMENT;
  try {
    thread_local kata::transport::Decoder decoder(1 << 22, false);
    const kata::transport::MessageKind kind = decoder.decode(message, size);
    if (kind == kata::transport::MessageKind::kNone) return KATA_E_PARSE;
    if (kind != kata::transport::MessageKind::kRepetition) return KATA_NO_DATA;
    if (!kata::capi::write_sized(decoder.repetition(), sizeof(uint32_t), out)) return KATA_E_INVALID_ARGUMENT;
    return KATA_OK;
  } catch (const std::bad_alloc&) {
    return KATA_E_OUT_OF_MEMORY;
  }
}

KATA_API kata_status kata_message_read_refusal(const void* message, size_t size, uint64_t* stream_id, char* reason,
                                              size_t capacity) {
  if (!message || !stream_id || (!reason && capacity > 0)) return KATA_E_NULL_POINTER;
  try {
    thread_local kata::transport::Decoder decoder(1 << 22, false);
    const kata::transport::MessageKind kind = decoder.decode(message, size);
    if (kind == kata::transport::MessageKind::kNone) return KATA_E_PARSE;
    size_t length = 0;
    const char* text = kind == kata::transport::MessageKind::kSkeleton ? decoder.skeleton_refused(&length) : nullptr;
    if (!text) return KATA_NO_DATA;
    *stream_id = decoder.stream_id();
    if (capacity > 0) {
      const size_t n = std::min(length, capacity - 1);  // cut at capacity - 1 bytes, NUL-terminated
      std::memcpy(reason, text, n);
      reason[n] = '\0';
    }
    return KATA_OK;
  } catch (const std::bad_alloc&) {
    return KATA_E_OUT_OF_MEMORY;
  }
}

}  // extern "C"

KATA_API uint32_t kata_shard_of(uint64_t stream_id, uint32_t shard_count) {
  return kata::transport::shard_of(stream_id, shard_count);
}
