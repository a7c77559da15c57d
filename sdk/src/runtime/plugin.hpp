// Loading kata plugins (sdk/include/kata/kata_plugin.h): dlopen, the entry symbol, and every
// check the ABI promises, with messages naming the plugin file.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "kata/kata_plugin.h"

namespace kata::runtime {

class LoadedPlugin {
 public:
  // Loads one plugin. Throws kata::Error naming `path`: kNotFound (no such file), kIo (dlopen
  // failed), kInvalidArgument (no entry symbol, a NULL table, another major version, a table
  // larger than this host knows, no kind, a missing required function).
  static std::unique_ptr<LoadedPlugin> load(const std::string& path);
  // Every *.so of a directory, in name order (the first refusal throws).
  static std::vector<std::unique_ptr<LoadedPlugin>> load_directory(const std::string& directory);
  ~LoadedPlugin();
  LoadedPlugin(const LoadedPlugin&) = delete;
  LoadedPlugin& operator=(const LoadedPlugin&) = delete;

  // The table, copied into a host-sized struct (fields past the plugin's struct_size are NULL).
  const kata_plugin& table() const { return table_; }
  const std::string& path() const { return path_; }
  bool is_source() const { return (table_.kinds & KATA_PLUGIN_SOURCE) != 0; }
  bool is_sink() const { return (table_.kinds & KATA_PLUGIN_SINK) != 0; }

 private:
  LoadedPlugin() = default;
  void* handle_ = nullptr;
  kata_plugin table_{};
  std::string path_;
};

}  // namespace kata::runtime
