// Labeled pose pairs: the file format and the two proxy-label protocols of `kata pairs`.
//
// File format (CSV, UTF-8): lines starting with '#' are comments (the generating command and its
// parameters are recorded there); the first other line is the header
//   clip_a,frame_a,clip_b,frame_b,label
// then one pair per line: two clip specs (see clips.hpp), their BVH frame indices (>= 1; frame 0
// is the T-pose) and the label, 1 = similar (positive), 0 = dissimilar (negative).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "train/clips.hpp"

namespace kata::train {

struct PairRecord {
  std::string clip_a;
  int frame_a = 0;
  std::string clip_b;
  int frame_b = 0;
  int label = 0;
};

struct PairFile {
  std::vector<std::string> comments;  // without the leading '#'
  std::vector<PairRecord> pairs;
};

PairFile read_pairs(const std::string& path);
void write_pairs(const std::string& path, const PairFile& file);

// "Future agreement" (transitions): candidates (i in clip A, j in clip B, A != B) with eq. 35
// mean joint distance < tau; positive when the next `window` seconds of both clips, each from its
// pose, stay within tau_f on average, negative when above 2 tau_f, discarded otherwise.
struct TransitionOptions {
  double tau = 0.06;      // body heights
  double tau_f = -1.0;    // <= 0: = tau
  double window = 1.0;    // seconds
  int per_class = 500;
  uint64_t seed = 1;
  int max_attempts = 200000;
};

// Cross-body (coaching): positive = the same frame of a clip on two different bodies (another
// subject's skeleton among the given clips, or the clip's own skeleton rescaled: arms, legs,
// torso x U(scale_min, scale_max)); negative = the same two bodies at frames at least `min_gap`
// seconds apart with eq. 35 distance < tau and some posing joint rotated more than
// `min_angle` degrees apart.
struct CrossBodyOptions {
  double tau = 0.06;
  double min_gap = 0.25;     // seconds
  double min_angle = 25.0;   // degrees
  int per_class = 500;
  int scaled_bodies = 2;     // rescaled bodies per clip
  double scale_min = 0.75, scale_max = 1.3;
  uint64_t seed = 1;
  int max_attempts = 200000;
};

// "Uniform transition" (the independent protocol of docs/model/transition.md): two different clips a, b drawn
// uniformly, then frames i in a and j in b each uniformly from 2 <= i < length - future_frames,
// where length and i count the clip without frame 0 (BVH frame = i + 1); kept only when
// MJD(L_a[i], L_b[j]) < tau (MJD = the eq. 35 mean joint distance). Label from the future:
// f = mean over k = 1..future_frames of MJD(L_a[i+k], L_b[j+k]); positive if f < pos_below,
// negative if f > neg_above, discarded otherwise. Unlike `transition`, the pair (i, j) is drawn
// uniformly and then filtered (poses that match often weigh more), j is not picked among i's
// matches, and the future starts at k = 1 in frames, not seconds.
struct UniformTransitionOptions {
  double tau = 0.06;         // current MJD below this (body heights)
  double pos_below = 0.06;   // future mean MJD below this: positive
  double neg_above = 0.12;   // future mean MJD above this: negative
  int future_frames = 120;   // 1 s at 120 Hz
  int per_class = 500;
  uint64_t seed = 1;
  long long max_attempts = 50000000;  // uniform draws (most fail the tau filter; each costs one MJD)
};

using PairLog = std::function<void(const std::string&)>;

// `clips` are BVH file names relative to the store's data folder. Balanced: per_class of each
// label (fewer of both, equal, if the attempts run out; the log says so).
std::vector<PairRecord> transition_pairs(ClipStore& store, const std::vector<std::string>& clips,
                                         const TransitionOptions& options, int threads, const PairLog& log = {});
std::vector<PairRecord> uniform_transition_pairs(ClipStore& store, const std::vector<std::string>& clips,
                                                 const UniformTransitionOptions& options, int threads,
                                                 const PairLog& log = {});
std::vector<PairRecord> cross_body_pairs(ClipStore& store, const std::vector<std::string>& clips,
                                         const CrossBodyOptions& options, int threads, const PairLog& log = {});

// Every clip spec a pair list refers to (sorted, unique).
std::vector<std::string> pair_clips(const std::vector<PairRecord>& pairs);

}  // namespace kata::train
