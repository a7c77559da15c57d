#include "support/clips.hpp"

#include <map>
#include <mutex>

#include "io/clip_features.hpp"

namespace kata::test {
namespace {
std::mutex g_mutex;  // tests may load from several threads
}

std::string clip_path(const std::string& name) { return std::string(KATA_DATA_DIR) + "/cmu/" + name + ".bvh"; }

const BvhClip& clip(const std::string& name) {
  static std::map<std::string, BvhClip> cache;
  std::lock_guard<std::mutex> lock(g_mutex);
  auto it = cache.find(name);
  if (it == cache.end()) it = cache.emplace(name, load_bvh(clip_path(name))).first;
  return it->second;
}

const std::vector<float>& clip_features(const std::string& name, gpd::Stencil stencil, int first) {
  static std::map<std::string, std::vector<float>> cache;
  const BvhClip& c = clip(name);
  std::lock_guard<std::mutex> lock(g_mutex);
  const std::string key = name + "/" + std::to_string(static_cast<int>(stencil)) + "/" + std::to_string(first);
  auto it = cache.find(key);
  if (it == cache.end())
    it = cache.emplace(key, kata::clip_features(c, make_gpd_map(c.skeleton, preset_joint_names("cmu")), stencil, first))
             .first;
  return it->second;
}

const std::vector<float>& clip_positions(const std::string& name, int first) {
  static std::map<std::string, std::vector<float>> cache;
  const BvhClip& c = clip(name);
  std::lock_guard<std::mutex> lock(g_mutex);
  const std::string key = name + "/" + std::to_string(first);
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, kata::clip_positions(c, first)).first;
  return it->second;
}

}  // namespace kata::test
