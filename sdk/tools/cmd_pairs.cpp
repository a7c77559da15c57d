// kata pairs: labeled pose pairs by a reproducible proxy protocol (train/pairs.hpp).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "data_files.hpp"
#include "command.hpp"
#include "common/error.hpp"
#include "io/clip_features.hpp"
#include "train/pipeline.hpp"

namespace {

struct PairsArgs {
  std::string data, protocol = "transition", out, split_part = "all", stencil = "backward", preset = "cmu";
  std::vector<std::string> clips;
  std::vector<int> subjects;
  int split_every = 0, threads = 2;
  kata::train::TransitionOptions tr;
  kata::train::UniformTransitionOptions ut;
  kata::train::CrossBodyOptions cb;
  int per_class = 500;
  uint64_t seed = 1;
  double tau = 0.06;
};

template <typename T>
std::string join(const std::vector<T>& v, const char* sep) {
  std::ostringstream s;
  for (size_t i = 0; i < v.size(); ++i) s << (i ? sep : "") << v[i];
  return s.str();
}

void run_pairs(PairsArgs a) {
  using namespace kata::train;
  std::vector<std::string> clips = a.clips;
  if (clips.empty()) clips = list_clips(a.data, a.subjects);
  clips = split_clips(clips, a.split_every, a.split_part);
  if (clips.empty()) throw kata::Error(kata::ErrorKind::kInvalidArgument, "pairs: no clips selected");
  ClipStore store(a.data, a.preset, kata::parse_stencil(a.stencil));
  auto log = [](const std::string& s) { std::printf("%s\n", s.c_str()); std::fflush(stdout); };
  PairFile f;
  std::ostringstream cmd;
  // The data folder by name only (shipped pair files carry no path of this machine).
  std::filesystem::path folder = std::filesystem::path(a.data).lexically_normal();
  if (folder.filename().empty()) folder = folder.parent_path();
  cmd << "kata pairs --protocol " << a.protocol << " --data <" << folder.filename().string() << " folder> --per-class " << a.per_class
      << " --seed " << a.seed << " --tau " << a.tau << " --stencil " << a.stencil << " --preset " << a.preset;
  if (!a.subjects.empty()) cmd << " --subjects " << join(a.subjects, ",");
  if (a.split_every > 1) cmd << " --split-every " << a.split_every << " --split-part " << a.split_part;
  std::vector<PairRecord> pairs;
  if (a.protocol == "transition") {
    a.tr.tau = a.tau;
    a.tr.per_class = a.per_class;
    a.tr.seed = a.seed;
    cmd << " --tau-f " << (a.tr.tau_f > 0 ? a.tr.tau_f : a.tau) << " --window " << a.tr.window << " --max-attempts "
        << a.tr.max_attempts;
    pairs = transition_pairs(store, clips, a.tr, a.threads, log);
  } else if (a.protocol == "transition-uniform") {
    a.ut.tau = a.tau;
    a.ut.per_class = a.per_class;
    a.ut.seed = a.seed;
    cmd << " --pos-below " << a.ut.pos_below << " --neg-above " << a.ut.neg_above << " --future-frames "
        << a.ut.future_frames << " --max-draws " << a.ut.max_attempts;
    pairs = uniform_transition_pairs(store, clips, a.ut, a.threads, log);
  } else {
    a.cb.tau = a.tau;
    a.cb.per_class = a.per_class;
    a.cb.seed = a.seed;
    cmd << " --min-gap " << a.cb.min_gap << " --min-angle " << a.cb.min_angle << " --scaled-bodies "
        << a.cb.scaled_bodies << " --scale-min " << a.cb.scale_min << " --scale-max " << a.cb.scale_max
        << " --max-attempts " << a.cb.max_attempts;
    pairs = cross_body_pairs(store, clips, a.cb, a.threads, log);
  }
  f.comments.push_back(cmd.str() + " --out " + a.out);
  f.comments.push_back("clips: " + join(clips, " "));
  f.comments.push_back("frames are BVH frame indices (frame 0, the T-pose, is never used); label 1 = similar");
  f.pairs = pairs;
  write_pairs(a.out, f);
  int pos = 0;
  for (const auto& p : pairs) pos += p.label;
  std::printf("%zu pairs (%d positive, %zu negative) from %zu clips -> %s\n", pairs.size(), pos, pairs.size() - pos,
              clips.size(), a.out.c_str());
}

void setup(CLI::App& app) {
  auto a = std::make_shared<PairsArgs>();
  CLI::App* cmd = app.add_subcommand(
      "pairs", "labeled pose pairs (CSV clip_a,frame_a,clip_b,frame_b,label) by a reproducible proxy protocol: "
               "'transition' (future agreement, j among i's matches), 'transition-uniform' (future agreement, i and j "
               "drawn uniformly then filtered: the uniform protocol of " + kata::cli::doc_file("model/transition.md") +
                   ") or 'cross-body' (same frame on two "
               "bodies vs. close-but-rotated poses)");
  cmd->add_option("clips", a->clips, "BVH files relative to --data (default: every clip of --subjects)");
  cmd->add_option("--data", a->data, "folder of BVH clips")->required();
  cmd->add_option("--subjects", a->subjects, "CMU subject numbers (files NN_*.bvh)")->delimiter(',');
  cmd->add_option("--protocol", a->protocol, "transition | transition-uniform | cross-body")
      ->check(CLI::IsMember({"transition", "transition-uniform", "cross-body"}));
  cmd->add_option("--out", a->out, "output CSV")->required();
  cmd->add_option("--per-class", a->per_class, "pairs per label (balanced)");
  cmd->add_option("--seed", a->seed, "random seed");
  cmd->add_option("--tau", a->tau, "eq. 35 filter: mean joint distance below tau (body heights)");
  cmd->add_option("--tau-f", a->tr.tau_f, "transition: future threshold (default tau)");
  cmd->add_option("--window", a->tr.window, "transition: future window (s)");
  cmd->add_option("--pos-below", a->ut.pos_below, "transition-uniform: positive when the future mean MJD is below this");
  cmd->add_option("--neg-above", a->ut.neg_above, "transition-uniform: negative when the future mean MJD is above this");
  cmd->add_option("--future-frames", a->ut.future_frames, "transition-uniform: future frames k = 1..N (120 = 1 s at 120 Hz)");
  cmd->add_option("--max-draws", a->ut.max_attempts, "transition-uniform: uniform (i, j) draws before giving up");
  cmd->add_option("--min-gap", a->cb.min_gap, "cross-body negatives: min frame distance (s)");
  cmd->add_option("--min-angle", a->cb.min_angle, "cross-body negatives: some joint rotated more than this (deg)");
  cmd->add_option("--scaled-bodies", a->cb.scaled_bodies, "cross-body: rescaled bodies per clip");
  cmd->add_option("--scale-min", a->cb.scale_min, "cross-body: smallest segment scale");
  cmd->add_option("--scale-max", a->cb.scale_max, "cross-body: largest segment scale");
  cmd->add_option("--max-attempts", a->tr.max_attempts, "candidate draws before giving up")
      ->each([a](const std::string& s) { a->cb.max_attempts = std::stoi(s); });
  cmd->add_option("--split-every", a->split_every, "clip split: every N-th clip (sorted) is 'val'");
  cmd->add_option("--split-part", a->split_part, "train | val | all")->check(CLI::IsMember({"train", "val", "all"}));
  cmd->add_option("--stencil", a->stencil, "backward | central")->check(CLI::IsMember({"backward", "central"}));
  cmd->add_option("--layout,--preset", a->preset, "layout of the clips (default cmu; --preset: its name before 1.0)");
  cmd->add_option("--threads", a->threads, "threads for feature computation");
  cmd->callback([a] { run_pairs(*a); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
