// Identity for unlabeled detections: each frame brings the poses a detector found (any layout,
// in no particular order, with per-joint confidences); the tracker says which stream each belongs
// to, opens a stream for a new person and closes one that stayed away longer than a set time.
//
// Per frame:
//   1. every pose is checked (a confident joint that is not finite or beyond KATA_MAX_COORDINATE,
//      a confidence that is NaN, fewer than kMinJoints confident joints, a pose of no extent:
//      refused and counted by cause); of the valid ones, at most max_poses are taken, the most
//      confident first (the rest refused and counted);
//   2. each pose is summarised as its centroid c (the confidence-weighted mean of its confident
//      joints), its size s (the weighted RMS distance of those joints from c) and its shape (the
//      joints relative to c);
//   3. each open stream predicts where its person is: c + v * min(unseen, coast_seconds) (a
//      constant velocity, smoothed over the frames seen; a hidden person keeps moving for
//      coast_seconds, then is expected where the motion stopped);
//   4. a cost per (stream, pose), in body sizes (the stream's s):
//        |c_pose - c_predicted| / s + shape_weight * mean_j |shape_pose,j - shape_stream,j| / s
//      (the shape term over joints confident in both) and the gate: a pose may only take a stream
//      when its centroid lies within gate + gate_growth * unseen body sizes of the prediction
//      and its size is within size_gate times the stream's (either way). Outside every gate a
//      pose is a stranger: it opens a new stream, it never inherits one;
//   5. the assignment of least total cost (the Hungarian method, hungarian.hpp) over the matrix
//      [cost | miss] / [open | 0]: a stream may stay unmatched at cost `miss` and a pose may open
//      a stream at cost `miss`, with 2 miss above any gated cost, so that as many gated pairs as
//      possible are matched and among those the cheapest;
//   6. matched streams take the pose (centroid, velocity, size, shape); poses left open new
//      streams (ids count up from 1 and are never reused) while the table has room (refused and
//      counted when it is full); streams unseen for more than forget_seconds close.
// Everything is sized at construction: track() allocates nothing. One thread at a time.
#pragma once

#include <cstdint>
#include <vector>

#include "people/hungarian.hpp"

namespace kata::people {

// A pose needs this many confident joints to be tracked.
inline constexpr int kMinJoints = 3;
// The largest max_people and max_poses.
inline constexpr int kMaxPeople = 64;

struct TrackerConfig {
  int joints = 0;                // joints per pose (any layout), 1..4096
  int max_people = 8;            // streams open at once
  int max_poses = 16;            // poses per frame taken (the most confident)
  double forget_seconds = 3.0;   // a stream unseen for longer closes
  double coast_seconds = 1.0;    // how long a hidden person's predicted motion continues
  double gate = 1.0;             // body sizes from the prediction a pose may be, seen last frame
  double gate_growth = 2.0;      // body sizes per second unseen the gate widens by
  double size_gate = 1.5;        // a pose's size within [1/size_gate, size_gate] x the stream's
  double shape_weight = 1.0;     // weight of the shape term in the cost
  double min_confidence = 0.3;   // joints below are ignored (their coordinates may be anything)
};

// Why poses were refused, and what happened, since construction.
struct TrackerCounters {
  uint64_t frames = 0;            // track() calls that were accepted
  uint64_t empty_frames = 0;      // accepted frames with no pose
  uint64_t refused_frames = 0;    // track() calls refused (time not finite or not increasing)
  uint64_t poses = 0;             // poses given in accepted frames
  uint64_t assigned = 0;          // poses given a stream (matched or opened)
  uint64_t opened = 0;            // streams opened
  uint64_t closed = 0;            // streams closed (unseen for longer than forget_seconds)
  uint64_t refused_non_finite = 0;      // a confident joint (or a confidence) NaN or infinite
  uint64_t refused_out_of_range = 0;    // a confident joint beyond KATA_MAX_COORDINATE
  uint64_t refused_few_joints = 0;      // fewer than kMinJoints confident joints, or no extent
  uint64_t refused_too_many_poses = 0;  // beyond max_poses in a frame (the least confident)
  uint64_t refused_table_full = 0;      // a new person while max_people streams were open
};

// What track() made of a frame.
enum class Frame { kTaken, kTimeNotFinite, kTimeNotIncreasing };

// The tracker of one camera (or any one source of multi-person frames).
class Tracker {
 public:
  // Throws kata::Error (kInvalidArgument) on a config out of range.
  explicit Tracker(const TrackerConfig& config);

  // One frame at `time` (seconds, finite, increasing): pose_count poses of joints() x 3 floats
  // each, back to back; confidence: pose_count x joints() values in [0, 1] or null (all 1).
  // ids[i] receives pose i's stream id (0: refused). A time not finite or not after the previous
  // frame's refuses the frame (nothing changed but the count). Allocates nothing.
  Frame track(double time, const float* xyz, const float* confidence, int pose_count, uint32_t* ids);

  // The streams the last accepted frame opened and closed, and the streams open now.
  int opened_count() const { return opened_count_; }
  const uint32_t* opened() const { return opened_.data(); }
  int closed_count() const { return closed_count_; }
  const uint32_t* closed() const { return closed_.data(); }
  // Copies the ids of the open streams (seen or hidden) into out (up to capacity); returns how many are open.
  int open_streams(uint32_t* out, int capacity) const;
  // Where an open stream's person is predicted at `time` (its centroid, 3 values); false for an unknown id.
  bool predicted(uint32_t id, double time, double* centroid) const;

  const TrackerConfig& config() const { return config_; }
  const TrackerCounters& counters() const { return counters_; }
  int joints() const { return config_.joints; }

 private:
  struct Track {
    uint32_t id = 0;          // 0: free slot
    double last_seen = 0.0;   // time of the last pose taken
    double c[3] = {0, 0, 0};  // centroid then
    double v[3] = {0, 0, 0};  // smoothed velocity, units per second
    double size = 0.0;        // smoothed size (units)
    int frames_seen = 0;
  };
  struct Pose {
    int index = 0;            // in the caller's frame
    double c[3] = {0, 0, 0};
    double size = 0.0;
    double confidence = 0.0;  // mean over joints (the ranking when a frame has too many)
  };

  // Checks pose i; false (counted) when refused, else fills *out.
  bool summarise(const float* xyz, const float* confidence, int i, Pose* out);
  double cost(const Track& t, int slot, const Pose& p, const float* xyz, const float* confidence, double now,
              bool* gated_in) const;
  void take(Track& t, int slot, const Pose& p, const float* xyz, const float* confidence, double now);
  void predict(const Track& t, double time, double* out) const;

  TrackerConfig config_;
  TrackerCounters counters_;
  std::vector<Track> tracks_;          // max_people slots
  std::vector<float> shape_;           // per slot: joints x 3, relative to its centroid
  std::vector<float> shape_weight_;    // per slot: joints (1 confident, 0 not)
  std::vector<Pose> poses_;            // this frame's taken poses (max_poses)
  std::vector<int> slot_of_row_;       // the cost matrix's track rows -> slots
  std::vector<double> matrix_;         // (max_people + max_poses)^2
  std::vector<int> assignment_;
  std::vector<uint32_t> opened_, closed_;
  int opened_count_ = 0, closed_count_ = 0;
  Hungarian hungarian_;
  uint32_t next_id_ = 1;
  bool has_time_ = false;
  double last_time_ = 0.0;
};

}  // namespace kata::people
