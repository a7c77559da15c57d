#include "train/clips.hpp"

#include <atomic>
#include <cmath>
#include <cstdio>
#include <thread>

#include <Eigen/Geometry>

#include "common/error.hpp"
#include "skeleton/skeleton.hpp"
#include "io/clip_features.hpp"

namespace kata::train {
namespace {

double parse_number(const std::string& s, const std::string& spec) {
  size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(s, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != s.size() || !std::isfinite(v) || v <= 0)
    throw Error(ErrorKind::kInvalidArgument, "clip spec '" + spec + "': bad scale factor '" + s + "'");
  return v;
}

// Leg length (hip -> knee -> foot) of a skeleton's rest pose under a map.
double leg_length(const Skeleton& s, const GpdMap& m) {
  const Eigen::MatrixX3d p = rest_positions(s);
  auto len = [&](int a, int b) { return (p.row(m.source[a]) - p.row(m.source[b])).norm(); };
  return 0.5 * (len(10, 11) + len(11, 12) + len(13, 14) + len(14, 15));
}

bool is_descendant(const Skeleton& s, int j, int ancestor) {
  for (int k = s.parents[j]; k >= 0; k = s.parents[k])
    if (k == ancestor) return true;
  return false;
}

}  // namespace

ClipSpec parse_clip_spec(const std::string& spec) {
  ClipSpec out;
  const size_t t = spec.find('~');
  out.file = spec.substr(0, t);
  if (out.file.empty()) throw Error(ErrorKind::kInvalidArgument, "clip spec '" + spec + "': no file");
  if (t == std::string::npos) return out;
  const std::string body = spec.substr(t + 1);
  if (body.size() > 1 && body[0] == 's' && body.find(':') != std::string::npos) {
    const size_t c1 = body.find(':'), c2 = body.find(':', c1 + 1);
    if (c2 == std::string::npos) throw Error(ErrorKind::kInvalidArgument, "clip spec '" + spec + "': expected s<arms>:<legs>:<torso>");
    out.scaled = true;
    out.scale.arms = parse_number(body.substr(1, c1 - 1), spec);
    out.scale.legs = parse_number(body.substr(c1 + 1, c2 - c1 - 1), spec);
    out.scale.torso = parse_number(body.substr(c2 + 1), spec);
  } else {
    out.body_file = body;
  }
  return out;
}

std::string format_clip_spec(const ClipSpec& s) {
  if (s.scaled) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "~s%.3f:%.3f:%.3f", s.scale.arms, s.scale.legs, s.scale.torso);
    return s.file + buf;
  }
  if (!s.body_file.empty()) return s.file + "~" + s.body_file;
  return s.file;
}

Eigen::Matrix3d joint_rotation(const BvhClip& clip, int frame, int joint) {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  const double* row = clip.frame(frame) + clip.channel_offset[joint];
  const auto& ch = clip.channels[joint];
  for (size_t k = 0; k < ch.size(); ++k) {
    const double a = row[k] * (3.14159265358979323846 / 180.0);
    switch (ch[k]) {
      case Channel::kXrot: r = r * Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix(); break;
      case Channel::kYrot: r = r * Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix(); break;
      case Channel::kZrot: r = r * Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix(); break;
      default: break;
    }
  }
  return r;
}

std::vector<int> posing_joints(const Skeleton& s, const std::string& preset) {
  const GpdMap m = make_gpd_map(s, preset_joint_names(preset));
  std::vector<char> moves(static_cast<size_t>(s.joint_count()), 0);
  for (int g = 0; g < kGpdJoints; ++g)
    for (int k = s.parents[m.source[g]]; k > 0; k = s.parents[k]) moves[static_cast<size_t>(k)] = 1;
  std::vector<int> out;
  for (int j = 1; j < s.joint_count(); ++j)
    if (moves[static_cast<size_t>(j)]) out.push_back(j);
  return out;
}

BvhClip make_body(const BvhClip& motion, const BvhClip* body, const BodyScale* scale, const std::string& preset) {
  BvhClip out = motion;
  const GpdMap m = make_gpd_map(motion.skeleton, preset_joint_names(preset));
  const double legs_before = leg_length(motion.skeleton, m);
  double root_scale = 1.0;
  if (body) {
    if (body->skeleton.names != motion.skeleton.names || body->skeleton.parents != motion.skeleton.parents ||
        body->end_site_parent != motion.end_site_parent)
      throw Error(ErrorKind::kInvalidArgument, "make_body: " + body->path + " and " + motion.path +
                                                   " have different hierarchies");
    out.skeleton.offsets = body->skeleton.offsets;
    out.end_site_offset = body->end_site_offset;
    root_scale = leg_length(out.skeleton, m) / legs_before;
  } else if (scale) {
    const Skeleton& s = motion.skeleton;
    auto factor = [&](int j) {
      for (int g : {10, 13})
        if (is_descendant(s, j, m.source[g])) return scale->legs;
      for (int g : {4, 7})
        if (is_descendant(s, j, m.source[g])) return scale->arms;
      return scale->torso;
    };
    for (int j = 1; j < s.joint_count(); ++j) out.skeleton.offsets[j] *= factor(j);
    for (size_t e = 0; e < out.end_site_offset.size(); ++e) {
      const int p = out.end_site_parent[e];
      // An end site's offset belongs to its parent's segment group (the parent itself included).
      double f = scale->torso;
      for (int g : {10, 13})
        if (p == m.source[g] || is_descendant(s, p, m.source[g])) f = scale->legs;
      for (int g : {4, 7})
        if (p == m.source[g] || is_descendant(s, p, m.source[g])) f = scale->arms;
      out.end_site_offset[e] *= f;
    }
    root_scale = leg_length(out.skeleton, m) / legs_before;
  }
  if (root_scale != 1.0) {
    // Root translation channels follow the legs (stride and hip height).
    for (size_t k = 0; k < out.channels[0].size(); ++k) {
      const Channel c = out.channels[0][k];
      if (c != Channel::kXpos && c != Channel::kYpos && c != Channel::kZpos) continue;
      const int col = out.channel_offset[0] + static_cast<int>(k);
      for (int f = 0; f < out.frame_count(); ++f) out.motion[static_cast<size_t>(f) * out.channel_count + col] *= root_scale;
    }
  }
  return out;
}

double ClipData::joint_distance(const float* fa, const float* fb) {
  double sum = 0.0;
  for (int j = 0; j < 15; ++j) {
    const double dx = fa[3 * j] - fb[3 * j], dy = fa[3 * j + 1] - fb[3 * j + 1], dz = fa[3 * j + 2] - fb[3 * j + 2];
    sum += std::sqrt(dx * dx + dy * dy + dz * dz);
  }
  return sum / 16.0;  // the hip (joint 0) is at the origin in both poses
}

std::vector<float> clip_feature_rows(const BvhClip& clip, const std::string& preset, gpd::Stencil stencil) {
  const GpdMap map = make_gpd_map(clip.skeleton, preset_joint_names(preset));
  // kata::clip_features streams frames 1..F-1 through a kata::Stream (the live path).
  const std::vector<float> rows = kata::clip_features(clip, map, stencil, 1);
  std::vector<float> out(static_cast<size_t>(gpd::kDims), 0.0f);  // row 0: the T-pose, unused
  out.insert(out.end(), rows.begin(), rows.end());
  if (out.size() != static_cast<size_t>(clip.frame_count()) * gpd::kDims)
    throw Error(ErrorKind::kInvalidArgument, clip.path + ": unexpected feature row count");
  return out;
}

ClipStore::ClipStore(std::string data_dir, std::string preset, gpd::Stencil stencil)
    : dir_(std::move(data_dir)), preset_(std::move(preset)), stencil_(stencil) {}

const BvhClip& ClipStore::bvh(const std::string& file) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = bvh_.find(file);
  if (it != bvh_.end()) return *it->second;
  auto clip = std::make_unique<BvhClip>(load_bvh(dir_.empty() ? file : dir_ + "/" + file));
  return *(bvh_[file] = std::move(clip));
}

std::unique_ptr<ClipData> ClipStore::compute(const std::string& spec) {
  const ClipSpec cs = parse_clip_spec(spec);
  const BvhClip& motion = bvh(cs.file);
  auto data = std::make_unique<ClipData>();
  data->spec = spec;
  data->frames = motion.frame_count();
  data->frame_time = motion.frame_time;
  if (cs.scaled || !cs.body_file.empty()) {
    const BvhClip* body = cs.body_file.empty() ? nullptr : &bvh(cs.body_file);
    const BvhClip moved = make_body(motion, body, cs.scaled ? &cs.scale : nullptr, preset_);
    data->features = clip_feature_rows(moved, preset_, stencil_);
  } else {
    data->features = clip_feature_rows(motion, preset_, stencil_);
  }
  return data;
}

void ClipStore::load(const std::vector<std::string>& specs, int threads) {
  std::vector<std::string> todo;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& s : specs)
      if (!clips_.count(s) && std::find(todo.begin(), todo.end(), s) == todo.end()) todo.push_back(s);
  }
  // BVH files first (serially; parsing is cheap next to the features).
  for (const auto& s : todo) {
    const ClipSpec cs = parse_clip_spec(s);
    bvh(cs.file);
    if (!cs.body_file.empty()) bvh(cs.body_file);
  }
  std::vector<std::unique_ptr<ClipData>> out(todo.size());
  std::atomic<size_t> next{0};
  std::vector<std::string> errors(todo.size());
  auto work = [&]() {
    for (size_t i; (i = next.fetch_add(1)) < todo.size();) {
      try {
        out[i] = compute(todo[i]);
      } catch (const std::exception& e) {
        errors[i] = e.what();
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, threads); ++t) pool.emplace_back(work);
  for (auto& th : pool) th.join();
  for (size_t i = 0; i < todo.size(); ++i)
    if (!errors[i].empty()) throw Error(ErrorKind::kInvalidArgument, todo[i] + ": " + errors[i]);
  std::lock_guard<std::mutex> lock(mutex_);
  for (size_t i = 0; i < todo.size(); ++i) clips_[todo[i]] = std::move(out[i]);
}

const ClipData& ClipStore::get(const std::string& spec) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = clips_.find(spec);
    if (it != clips_.end()) return *it->second;
  }
  load({spec}, 1);
  std::lock_guard<std::mutex> lock(mutex_);
  return *clips_.at(spec);
}

}  // namespace kata::train
