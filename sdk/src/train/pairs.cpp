#include "train/pairs.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>

#include "common/error.hpp"

namespace kata::train {
namespace {

// Portable draws (std::uniform_*_distribution differ between standard libraries).
struct Rng {
  std::mt19937_64 g;
  explicit Rng(uint64_t seed) : g(seed) {}
  int below(int n) { return static_cast<int>(g() % static_cast<uint64_t>(n)); }
  double unit() { return static_cast<double>(g() >> 11) * (1.0 / 9007199254740992.0); }
};

std::string trim(const std::string& s) {
  size_t a = 0, b = s.size();
  while (a < b && (s[a] == ' ' || s[a] == '\t' || s[a] == '\r')) ++a;
  while (b > a && (s[b - 1] == ' ' || s[b - 1] == '\t' || s[b - 1] == '\r')) --b;
  return s.substr(a, b - a);
}

int parse_int(const std::string& s, const std::string& where) {
  size_t used = 0;
  int v = 0;
  try {
    v = std::stoi(s, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != s.size() || s.empty()) throw Error(ErrorKind::kParse, where + ": not an integer: '" + s + "'");
  return v;
}

// Balanced, shuffled output.
std::vector<PairRecord> finish(std::vector<PairRecord> pos, std::vector<PairRecord> neg, Rng& rng, const PairLog& log,
                               int per_class) {
  const size_t n = std::min(pos.size(), neg.size());
  if (n < static_cast<size_t>(per_class) && log)
    log("warning: only " + std::to_string(n) + " pairs per class found (asked for " + std::to_string(per_class) + ")");
  pos.resize(n);
  neg.resize(n);
  std::vector<PairRecord> out;
  out.insert(out.end(), pos.begin(), pos.end());
  out.insert(out.end(), neg.begin(), neg.end());
  for (size_t i = out.size(); i > 1; --i) std::swap(out[i - 1], out[static_cast<size_t>(rng.below(static_cast<int>(i)))]);
  return out;
}

double rotation_angle_deg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const double c = std::clamp(((a.transpose() * b).trace() - 1.0) * 0.5, -1.0, 1.0);
  return std::acos(c) * (180.0 / 3.14159265358979323846);
}

}  // namespace

PairFile read_pairs(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(ErrorKind::kIo, path + ": cannot open");
  PairFile f;
  std::string line;
  int n = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++n;
    const std::string where = path + ":" + std::to_string(n);
    const std::string t = trim(line);
    if (t.empty()) continue;
    if (t[0] == '#') {
      f.comments.push_back(trim(t.substr(1)));
      continue;
    }
    std::vector<std::string> cols;
    std::stringstream ss(t);
    std::string c;
    while (std::getline(ss, c, ',')) cols.push_back(trim(c));
    if (cols.size() != 5) throw Error(ErrorKind::kParse, where + ": expected 5 columns, got " + std::to_string(cols.size()));
    if (!header) {
      if (cols[0] != "clip_a") throw Error(ErrorKind::kParse, where + ": expected the header clip_a,frame_a,clip_b,frame_b,label");
      header = true;
      continue;
    }
    PairRecord r;
    r.clip_a = cols[0];
    r.frame_a = parse_int(cols[1], where);
    r.clip_b = cols[2];
    r.frame_b = parse_int(cols[3], where);
    r.label = parse_int(cols[4], where);
    if (r.label != 0 && r.label != 1) throw Error(ErrorKind::kParse, where + ": label must be 0 or 1");
    if (r.frame_a < 1 || r.frame_b < 1) throw Error(ErrorKind::kParse, where + ": frame 0 (the T-pose) is not a pose");
    f.pairs.push_back(r);
  }
  if (!header) throw Error(ErrorKind::kParse, path + ": no header line");
  return f;
}

void write_pairs(const std::string& path, const PairFile& f) {
  std::ofstream out(path);
  if (!out) throw Error(ErrorKind::kIo, path + ": cannot write");
  for (const auto& c : f.comments) out << "# " << c << "\n";
  out << "clip_a,frame_a,clip_b,frame_b,label\n";
  for (const auto& p : f.pairs)
    out << p.clip_a << "," << p.frame_a << "," << p.clip_b << "," << p.frame_b << "," << p.label << "\n";
  if (!out) throw Error(ErrorKind::kIo, path + ": write failed");
}

std::vector<std::string> pair_clips(const std::vector<PairRecord>& pairs) {
  std::set<std::string> s;
  for (const auto& p : pairs) {
    s.insert(p.clip_a);
    s.insert(p.clip_b);
  }
  return {s.begin(), s.end()};
}

std::vector<PairRecord> transition_pairs(ClipStore& store, const std::vector<std::string>& clips,
                                         const TransitionOptions& o, int threads, const PairLog& log) {
  if (clips.size() < 2) throw Error(ErrorKind::kInvalidArgument, "pairs: the transition protocol needs >= 2 clips");
  store.load(clips, threads);
  std::vector<const ClipData*> data;
  for (const auto& c : clips) data.push_back(&store.get(c));
  const double tau_f = o.tau_f > 0 ? o.tau_f : o.tau;
  Rng rng(o.seed);
  std::vector<PairRecord> pos, neg;
  std::vector<int> cand;
  int attempts = 0;
  const int first = 3;  // the first frames of a stream have start-of-segment kinetics
  for (; attempts < o.max_attempts; ++attempts) {
    if (static_cast<int>(pos.size()) >= o.per_class && static_cast<int>(neg.size()) >= o.per_class) break;
    const int ca = rng.below(static_cast<int>(clips.size()));
    int cb = rng.below(static_cast<int>(clips.size()) - 1);
    if (cb >= ca) ++cb;
    const ClipData& a = *data[static_cast<size_t>(ca)];
    const ClipData& b = *data[static_cast<size_t>(cb)];
    const int wa = static_cast<int>(std::lround(o.window / a.frame_time));
    const int wb = static_cast<int>(std::lround(o.window / b.frame_time));
    const int la = a.frames - wa - first, lb = b.frames - wb - first;
    if (la <= 0 || lb <= 0) continue;
    const int i = first + rng.below(la);
    cand.clear();
    for (int j = first; j < first + lb; ++j)
      if (ClipData::joint_distance(a.row(i), b.row(j)) < o.tau) cand.push_back(j);
    if (cand.empty()) continue;
    const int j = cand[static_cast<size_t>(rng.below(static_cast<int>(cand.size())))];
    // Future agreement over the window, time-aligned (frame times may differ between clips).
    const int steps = std::max(wa, 1);
    double sum = 0.0;
    for (int s = 0; s <= steps; ++s) {
      const double t = o.window * s / steps;
      const int fa = i + static_cast<int>(std::lround(t / a.frame_time));
      const int fb = j + static_cast<int>(std::lround(t / b.frame_time));
      sum += ClipData::joint_distance(a.row(std::min(fa, a.frames - 1)), b.row(std::min(fb, b.frames - 1)));
    }
    const double future = sum / (steps + 1);
    PairRecord r{clips[static_cast<size_t>(ca)], i, clips[static_cast<size_t>(cb)], j, 0};
    if (future < tau_f && static_cast<int>(pos.size()) < o.per_class) {
      r.label = 1;
      pos.push_back(r);
    } else if (future > 2 * tau_f && static_cast<int>(neg.size()) < o.per_class) {
      neg.push_back(r);
    }
  }
  if (log)
    log("transition pairs: " + std::to_string(pos.size()) + " positive, " + std::to_string(neg.size()) +
        " negative after " + std::to_string(attempts) + " attempts");
  return finish(std::move(pos), std::move(neg), rng, log, o.per_class);
}

std::vector<PairRecord> uniform_transition_pairs(ClipStore& store, const std::vector<std::string>& clips,
                                                 const UniformTransitionOptions& o, int threads, const PairLog& log) {
  if (clips.size() < 2) throw Error(ErrorKind::kInvalidArgument, "pairs: the transition protocol needs >= 2 clips");
  if (o.future_frames < 1) throw Error(ErrorKind::kInvalidArgument, "pairs: future frames must be >= 1");
  store.load(clips, threads);
  std::vector<const ClipData*> data;
  for (const auto& c : clips) data.push_back(&store.get(c));
  Rng rng(o.seed);
  std::vector<PairRecord> pos, neg;
  long long attempts = 0, close = 0;
  // Frame 0 (the T-pose) dropped: a clip of F BVH frames has length F - 1 and its index i is
  // BVH frame i + 1, so 2 <= i < length - future_frames is BVH frame 3 .. F - future_frames - 1
  // (a count of F - future_frames - 3 frames); the last future frame is then F - 1.
  constexpr int kFirstFrame = 3;
  auto frame_count = [&](const ClipData& c) { return c.frames - o.future_frames - kFirstFrame; };
  for (; attempts < o.max_attempts; ++attempts) {
    if (static_cast<int>(pos.size()) >= o.per_class && static_cast<int>(neg.size()) >= o.per_class) break;
    const int ca = rng.below(static_cast<int>(clips.size()));
    int cb = rng.below(static_cast<int>(clips.size()) - 1);
    if (cb >= ca) ++cb;
    const ClipData& a = *data[static_cast<size_t>(ca)];
    const ClipData& b = *data[static_cast<size_t>(cb)];
    const int na = frame_count(a), nb = frame_count(b);
    if (na <= 0 || nb <= 0) continue;
    const int i = kFirstFrame + rng.below(na);
    const int j = kFirstFrame + rng.below(nb);
    if (ClipData::joint_distance(a.row(i), b.row(j)) >= o.tau) continue;
    ++close;
    double sum = 0.0;
    for (int k = 1; k <= o.future_frames; ++k) sum += ClipData::joint_distance(a.row(i + k), b.row(j + k));
    const double future = sum / o.future_frames;
    PairRecord r{clips[static_cast<size_t>(ca)], i, clips[static_cast<size_t>(cb)], j, 0};
    if (future < o.pos_below) {
      if (static_cast<int>(pos.size()) < o.per_class) {
        r.label = 1;
        pos.push_back(r);
      }
    } else if (future > o.neg_above && static_cast<int>(neg.size()) < o.per_class) {
      neg.push_back(r);
    }
  }
  if (log)
    log("uniform transition pairs: " + std::to_string(pos.size()) + " positive, " + std::to_string(neg.size()) +
        " negative after " + std::to_string(attempts) + " draws (" + std::to_string(close) + " within tau)");
  return finish(std::move(pos), std::move(neg), rng, log, o.per_class);
}

std::vector<PairRecord> cross_body_pairs(ClipStore& store, const std::vector<std::string>& clips,
                                         const CrossBodyOptions& o, int threads, const PairLog& log) {
  if (clips.empty()) throw Error(ErrorKind::kInvalidArgument, "pairs: no clips");
  Rng rng(o.seed);
  // Distinct skeletons among the clips (one representative file each).
  std::vector<std::string> skeleton_files;
  for (const auto& c : clips) {
    const BvhClip& b = store.bvh(c);
    bool seen = false;
    for (const auto& s : skeleton_files) {
      const BvhClip& k = store.bvh(s);
      if (k.skeleton.names == b.skeleton.names && k.skeleton.offsets == b.skeleton.offsets) seen = true;
    }
    if (!seen) skeleton_files.push_back(c);
  }
  // Bodies of each clip: its own, every other skeleton, and `scaled_bodies` rescaled ones.
  std::vector<std::vector<std::string>> bodies(clips.size());
  std::vector<std::string> all;
  for (size_t c = 0; c < clips.size(); ++c) {
    const BvhClip& b = store.bvh(clips[c]);
    bodies[c].push_back(clips[c]);
    for (const auto& s : skeleton_files) {
      const BvhClip& k = store.bvh(s);
      if (k.skeleton.offsets != b.skeleton.offsets && k.skeleton.names == b.skeleton.names)
        bodies[c].push_back(clips[c] + "~" + s);
    }
    for (int k = 0; k < o.scaled_bodies; ++k) {
      ClipSpec cs;
      cs.file = clips[c];
      cs.scaled = true;
      auto draw = [&]() { return o.scale_min + (o.scale_max - o.scale_min) * rng.unit(); };
      cs.scale.arms = draw();
      cs.scale.legs = draw();
      cs.scale.torso = draw();
      bodies[c].push_back(format_clip_spec(cs));
    }
    all.insert(all.end(), bodies[c].begin(), bodies[c].end());
  }
  if (log) log("cross-body: " + std::to_string(all.size()) + " clip bodies from " + std::to_string(clips.size()) + " clips");
  store.load(all, threads);
  std::vector<std::vector<int>> posing(clips.size());
  for (size_t c = 0; c < clips.size(); ++c) posing[c] = posing_joints(store.bvh(clips[c]).skeleton, store.preset());

  std::vector<PairRecord> pos, neg;
  std::vector<int> cand;
  const int first = 3;
  int attempts = 0;
  for (; attempts < o.max_attempts; ++attempts) {
    const bool want_pos = static_cast<int>(pos.size()) < o.per_class;
    const bool want_neg = static_cast<int>(neg.size()) < o.per_class;
    if (!want_pos && !want_neg) break;
    const size_t c = static_cast<size_t>(rng.below(static_cast<int>(clips.size())));
    const auto& bs = bodies[c];
    if (bs.size() < 2) continue;
    const int b1 = rng.below(static_cast<int>(bs.size()));
    int b2 = rng.below(static_cast<int>(bs.size()) - 1);
    if (b2 >= b1) ++b2;
    const ClipData& d1 = store.get(bs[static_cast<size_t>(b1)]);
    const ClipData& d2 = store.get(bs[static_cast<size_t>(b2)]);
    if (d1.frames <= first + 1) continue;
    const int i = first + rng.below(d1.frames - first);
    // Alternate the two kinds so both fill at the same pace.
    const bool make_pos = want_pos && (!want_neg || (attempts % 2 == 0));
    if (make_pos) {
      pos.push_back({bs[static_cast<size_t>(b1)], i, bs[static_cast<size_t>(b2)], i, 1});
      continue;
    }
    const int gap = static_cast<int>(std::lround(o.min_gap / d1.frame_time));
    const BvhClip& motion = store.bvh(clips[c]);
    cand.clear();
    for (int j = first; j < d2.frames; ++j) {
      if (std::abs(j - i) < gap) continue;
      if (ClipData::joint_distance(d1.row(i), d2.row(j)) >= o.tau) continue;
      double worst = 0.0;
      for (int k : posing[c]) {
        worst = std::max(worst, rotation_angle_deg(joint_rotation(motion, i, k), joint_rotation(motion, j, k)));
        if (worst > o.min_angle) break;
      }
      if (worst > o.min_angle) cand.push_back(j);
    }
    if (cand.empty()) continue;
    const int j = cand[static_cast<size_t>(rng.below(static_cast<int>(cand.size())))];
    neg.push_back({bs[static_cast<size_t>(b1)], i, bs[static_cast<size_t>(b2)], j, 0});
  }
  if (log)
    log("cross-body pairs: " + std::to_string(pos.size()) + " positive, " + std::to_string(neg.size()) +
        " negative after " + std::to_string(attempts) + " attempts");
  return finish(std::move(pos), std::move(neg), rng, log, o.per_class);
}

}  // namespace kata::train
