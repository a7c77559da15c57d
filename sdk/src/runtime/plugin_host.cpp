// Plugin instances over a runtime (see plugin_host.hpp).
#include "runtime/plugin_host.hpp"

#include <cstdio>
#include <cstring>

#include "common/error.hpp"

namespace kata::runtime {

namespace {

int32_t host_open_stream(void* data, uint64_t stream_id, uint32_t joint_count, const char* const* names,
                         const int32_t* parents, const float* rest_offsets, const char* layout) {
  auto* target = static_cast<PluginHostTarget*>(data);
  if (!target->runtime) return static_cast<int32_t>(Status::kState);
  if (!names || !parents || joint_count == 0) return static_cast<int32_t>(Status::kNullPointer);
  try {
    transport::SkeletonDefinition d;
    d.stream_id = stream_id;
    d.revision = 1;
    for (uint32_t i = 0; i < joint_count; ++i) {
      if (!names[i]) return static_cast<int32_t>(Status::kNullPointer);
      d.skeleton.names.emplace_back(names[i]);
      d.skeleton.parents.push_back(parents[i]);
      d.skeleton.offsets.emplace_back(rest_offsets ? Eigen::Vector3d(rest_offsets[3 * i], rest_offsets[3 * i + 1],
                                                                     rest_offsets[3 * i + 2])
                                                   : Eigen::Vector3d::Zero());
    }
    d.skeleton.has_rest_pose = rest_offsets != nullptr;
    d.skeleton.validate();
    d.layout = layout && layout[0] ? layout : "cmu";
    target->runtime->open_announced(d);
    return 0;
  } catch (const Error&) {
    return static_cast<int32_t>(Status::kInvalidArgument);
  } catch (...) {
    return static_cast<int32_t>(Status::kInternal);
  }
}

int32_t host_push_frame(void* data, uint64_t stream_id, uint64_t sequence, double capture_time, const float* xyz,
                        uint32_t joints) {
  auto* target = static_cast<PluginHostTarget*>(data);
  if (!target->runtime) return static_cast<int32_t>(Status::kState);
  return static_cast<int32_t>(target->runtime->push(stream_id, sequence, capture_time, xyz, static_cast<int>(joints)));
}

void host_log(void*, const char* message) {
  if (message) std::fprintf(stderr, "%s\n", message);
}

}  // namespace

PluginInstance::PluginInstance(std::shared_ptr<LoadedPlugin> plugin, const std::string& config,
                               std::shared_ptr<PluginHostTarget> target)
    : plugin_(std::move(plugin)), target_(std::move(target)) {
  host_.struct_size = sizeof host_;
  host_.host_data = target_.get();
  host_.open_stream = host_open_stream;
  host_.push_frame = host_push_frame;
  host_.log = host_log;
  char error[512] = {0};
  instance_ = plugin_->table().activate(&host_, config.c_str(), error, sizeof error);
  if (!instance_)
    throw Error(ErrorKind::kInvalidArgument, "plugin " + plugin_->path() + ": activate failed: " +
                                                 (error[0] ? std::string(error, strnlen(error, sizeof error)) : "no reason given"));
}

PluginInstance::~PluginInstance() {
  stop();
  plugin_->table().deactivate(instance_);
}

Sink PluginInstance::sink() {
  if (!plugin_->is_sink()) throw Error(ErrorKind::kInvalidArgument, "plugin " + plugin_->path() + " is not a sink");
  const kata_plugin* table = &plugin_->table();
  void* instance = instance_;
  Sink s;
  // The record as published (its struct_size is this host's sizeof(kata_result_record)).
  s.on_result = [table, instance](const transport::ResultFields& f) { table->on_result(instance, &f); };
  if (table->flush) s.flush = [table, instance] { table->flush(instance); };
  return s;
}

RepetitionSink PluginInstance::repetition_sink() {
  const kata_plugin* table = &plugin_->table();
  if (!plugin_->is_sink() || !table->on_repetition) return {};
  void* instance = instance_;
  return [table, instance](const kata_repetition& r) { table->on_repetition(instance, &r); };
}

void PluginInstance::start() {
  if (!plugin_->is_source() || started_) return;
  if (plugin_->table().start(instance_) != 0)
    throw Error(ErrorKind::kInvalidArgument, "plugin " + plugin_->path() + ": start failed");
  started_ = true;
}

void PluginInstance::stop() {
  if (!started_) return;
  plugin_->table().stop(instance_);
  started_ = false;
}

}  // namespace kata::runtime
