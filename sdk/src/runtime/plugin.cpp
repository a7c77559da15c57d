// Plugin loading and its refusals (see plugin.hpp).
#include "runtime/plugin.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cstring>
#include <filesystem>

#include "common/error.hpp"

namespace kata::runtime {

std::unique_ptr<LoadedPlugin> LoadedPlugin::load(const std::string& path) {
  auto refuse = [&](ErrorKind kind, const std::string& why) -> Error { return Error(kind, "plugin " + path + ": " + why); };
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw refuse(ErrorKind::kNotFound, "no such file");
  std::unique_ptr<LoadedPlugin> p(new LoadedPlugin());
  p->path_ = path;
  // RTLD_LOCAL: a plugin's symbols never satisfy another's; RTLD_NOW: missing symbols fail here.
  p->handle_ = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!p->handle_) {
    const char* why = dlerror();
    throw refuse(ErrorKind::kIo, std::string("cannot load: ") + (why ? why : "unknown reason"));
  }
  void* symbol = dlsym(p->handle_, KATA_PLUGIN_ENTRY);
  if (!symbol) throw refuse(ErrorKind::kInvalidArgument, "no entry symbol " KATA_PLUGIN_ENTRY);
  kata_plugin_entry_fn entry;
  static_assert(sizeof entry == sizeof symbol, "function and object pointers differ in size");
  std::memcpy(&entry, &symbol, sizeof entry);
  const kata_plugin* t = entry();
  if (!t) throw refuse(ErrorKind::kInvalidArgument, "the entry returned no table");
  const uint32_t major = t->abi_version >> 16;
  if (major != KATA_PLUGIN_ABI_MAJOR)
    throw refuse(ErrorKind::kInvalidArgument, "ABI major version " + std::to_string(major) + ", this host speaks " +
                                                  std::to_string(KATA_PLUGIN_ABI_MAJOR));
  if (t->struct_size > sizeof(kata_plugin))
    throw refuse(ErrorKind::kInvalidArgument, "its table is " + std::to_string(t->struct_size) +
                                                  " bytes, larger than this host knows (" +
                                                  std::to_string(sizeof(kata_plugin)) + "): a newer plugin ABI");
  if (t->struct_size < offsetof(kata_plugin, deactivate) + sizeof t->deactivate)
    throw refuse(ErrorKind::kInvalidArgument, "its table is too small (" + std::to_string(t->struct_size) + " bytes)");
  std::memcpy(&p->table_, t, t->struct_size);  // fields the plugin does not know stay NULL
  const kata_plugin& k = p->table_;
  auto require = [&](bool present, const char* function) {
    if (!present) throw refuse(ErrorKind::kInvalidArgument, std::string("missing required function ") + function);
  };
  if (!(k.kinds & (KATA_PLUGIN_SOURCE | KATA_PLUGIN_SINK)))
    throw refuse(ErrorKind::kInvalidArgument, "neither a source nor a sink (kinds = 0)");
  require(k.activate != nullptr, "activate");
  require(k.deactivate != nullptr, "deactivate");
  if (k.kinds & KATA_PLUGIN_SOURCE) {
    require(k.start != nullptr, "start (a source)");
    require(k.stop != nullptr, "stop (a source)");
  }
  if (k.kinds & KATA_PLUGIN_SINK) require(k.on_result != nullptr, "on_result (a sink)");
  if (!k.name || !k.name[0]) throw refuse(ErrorKind::kInvalidArgument, "no name");
  return p;
}

std::vector<std::unique_ptr<LoadedPlugin>> LoadedPlugin::load_directory(const std::string& directory) {
  std::error_code ec;
  if (!std::filesystem::is_directory(directory, ec))
    throw Error(ErrorKind::kNotFound, "plugin directory " + directory + ": not a directory");
  std::vector<std::string> paths;
  for (const auto& e : std::filesystem::directory_iterator(directory))
    if (e.path().extension() == ".so") paths.push_back(e.path().string());
  std::sort(paths.begin(), paths.end());
  std::vector<std::unique_ptr<LoadedPlugin>> out;
  for (const auto& p : paths) out.push_back(load(p));
  return out;
}

LoadedPlugin::~LoadedPlugin() {
  if (handle_) dlclose(handle_);
}

}  // namespace kata::runtime
