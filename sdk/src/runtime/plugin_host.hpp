// Active plugin instances bound to a runtime: the kata_plugin_host a plugin calls back into, a
// sink plugin as a runtime Sink, a source plugin's start / stop.
#pragma once

#include <memory>
#include <string>

#include "runtime/plugin.hpp"
#include "runtime/runtime.hpp"

namespace kata::runtime {

// The runtime a host's callbacks reach; set once the runtime exists (sinks are activated before
// it, since the runtime's config holds them).
struct PluginHostTarget {
  Runtime* runtime = nullptr;
};

class PluginInstance {
 public:
  // Activates the plugin with its "key=value;..." config. Throws kata::Error(kInvalidArgument)
  // naming the plugin file and the plugin's own message.
  PluginInstance(std::shared_ptr<LoadedPlugin> plugin, const std::string& config,
                 std::shared_ptr<PluginHostTarget> target);
  // Stops a started source and deactivates.
  ~PluginInstance();
  PluginInstance(const PluginInstance&) = delete;
  PluginInstance& operator=(const PluginInstance&) = delete;

  // The runtime Sink of a sink plugin (on_result hands the published kata_result_record over on the I/O thread).
  Sink sink();
  // The runtime RepetitionSink of a sink plugin with on_repetition (plugin ABI 2.1); empty (no
  // target) for one without.
  RepetitionSink repetition_sink();
  // Starts / stops a source plugin. Throws kata::Error naming the file when start fails.
  void start();
  void stop();
  const LoadedPlugin& plugin() const { return *plugin_; }

 private:
  std::shared_ptr<LoadedPlugin> plugin_;
  std::shared_ptr<PluginHostTarget> target_;
  kata_plugin_host host_{};
  void* instance_ = nullptr;
  bool started_ = false;
};

}  // namespace kata::runtime
