// A live pose stream: frames in (timestamp + world joint positions of the input skeleton),
// GPD v1 feature vectors out (spec gpd-v1.md). All memory is sized when the stream is opened;
// push() and the readers never allocate. One stream is used by one thread at a time; streams
// share nothing, so many run in parallel.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "common/status.hpp"
#include "gpd/gpd.hpp"
#include "skeleton/skeleton.hpp"

namespace kata {

// The plausibility range of a stream's input (kata.h documents the same figures). Inside it
// every feature is finite by construction: local coordinates stay below 2 kMaxCoordinate /
// kMinBodyHeight = 2e15 body heights and the difference weights below 2 / kMinTimeStep^2.
constexpr double kMinTimeStep = 1e-5;      // seconds between two accepted frames (100 kHz)
// The largest step between two accepted frames, seconds (11.6 days): no live source pauses that
// long; a later frame is a clock in other units or a restarted source, and its step would reach
// the alignment as millions of teacher frames.
constexpr double kMaxTimeStep = 1e6;
constexpr double kMaxCoordinate = 1e9;     // |x|, |y|, |z| of a mapped joint, input units
constexpr double kMinBodyHeight = 1e-6;    // input units
constexpr double kMaxReach = 100.0;        // a mapped joint's distance from the hip, body heights
constexpr int kMaxHistory = 1 << 16;       // ring-buffer frames (64 Ki x 6.7 KB = 440 MB at most)

struct StreamConfig {
  GpdMap map;                 // input joint -> GPD joint
  int input_joints = 0;       // joints per pushed frame
  gpd::Stencil stencil = gpd::Stencil::kBackward;
  double max_gap = 0.25;      // seconds; a larger gap between frames starts a new segment
  int history = 16;           // frames kept in the ring buffer (>= 3; >= calibration_frames)
  // Body height H in input units (spec section 2, step 4). > 0: use it (e.g. from the
  // skeleton's rest pose; kMinBodyHeight..kMaxCoordinate). 0: estimate it as the median of the
  // per-frame bone lengths over the first `calibration_frames` frames (1..history - 1); those
  // frames are held until then. Negative or NaN: refused.
  double body_height = 0.0;
  int calibration_frames = 8;
  UpAxis up_axis = UpAxis::kY;  // input axes, turned into Y-up (skeleton.hpp, UpAxis)

  // Per-joint confidence (push with confidences). A GPD joint's confidence is the smallest of
  // the input joints it reads; below the threshold, NaN, or with a non-finite coordinate the joint
  // is missing and held at its last good position for at most max_hold seconds. A frame with a
  // joint missing for longer, or with more than max_missing_share of the 16 joints missing, is
  // "tracking lost": accepted (its timestamp counts), no features, the segment ends; the stream
  // recovers by itself at the next frame that passes.
  float confidence_threshold = 0.5f;  // MediaPipe's visibility is a probability in [0, 1]
  double max_hold = 0.5;              // seconds
  double max_missing_share = 0.25;    // of the 16 GPD joints (so more than 4 missing = lost)

  // One-Euro filter (Casiez, Roussel, Vogel, CHI 2012) on the 16 mapped joints, per coordinate,
  // before features: cutoff = min_cutoff + beta |velocity|. Off by default (mocap is clean); the
  // MediaPipe layout turns it on. It restarts at every segment start. Kinetics see the filtered
  // positions.
  bool smoothing = false;
  // Defaults from a sweep on CMU 02_01 as MediaPipe landmarks + 1 cm noise at 120 Hz (min cutoff
  // 1/2/4 Hz x beta 1/5/20): 2 Hz, 1.0 scored best (tests/api/test_anybody.cpp figures).
  double smoothing_min_cutoff = 2.0;  // Hz
  double smoothing_beta = 1.0;        // per (input unit / s): 1.0 suits metres
  double smoothing_d_cutoff = 1.0;    // Hz, cutoff of the velocity estimate

  // Bone lengths of the GPD tree from live frames: over the first bone_window frames whose 16
  // joints are all good (unfiltered positions), the root mean square length less the lengthening
  // by the joints' noise (estimated from the bone vectors' second differences; stream.cpp,
  // collect_bones), with a robust spread (1.4826 x the median absolute deviation of the lengths).
  // 0 turns the estimate off.
  int bone_window = 60;
};

// A stream's config for a skeleton with a rest pose (e.g. a BVH clip's): H from the rest pose.
StreamConfig stream_config_for(const Skeleton& skeleton, const GpdMap& map, gpd::Stencil stencil);
// The body height a stream on `skeleton` uses: `given` when it is not 0 (a bad value is passed
// through for the Stream to refuse), else the rest pose's H when the skeleton has one of at least
// kMinBodyHeight, else 0 (estimated from the first frames).
double stream_body_height(double given, const Skeleton& skeleton, const GpdMap& map);

// GPD v1 features of `frames` recorded frames (positions: frames x config.input_joints x 3 floats,
// row-major, input units), `frame_time` seconds apart, pushed one by one through a Stream with
// `config` (the live code path) and flushed after the last: frames x gpd::kDims floats. Throws
// kata::Error(kInvalidArgument) naming the frame a stream refuses. Allocates (offline use).
std::vector<float> features_of_frames(const StreamConfig& config, const float* positions, int frames,
                                      double frame_time);

// The same features delivered in chunks instead of one matrix, so a long clip's features (6.7 KB
// a frame) need never be held whole (a 20-minute teacher's would be 1.3 GB).
// `positions(i, xyz)` writes frame i's config.input_joints x 3 floats to xyz; `sink(features, n)`
// receives the next n frames' features (n x gpd::kDims, in frame order, n <= chunk_frames; the
// buffer is reused after it returns). Same values as features_of_frames, same errors.
using FramePositions = std::function<void(int frame, float* xyz)>;
using FeatureSink = std::function<void(const float* features, int count)>;
void features_in_chunks(const StreamConfig& config, const FramePositions& positions, int frames, double frame_time,
                        int chunk_frames, const FeatureSink& sink);

// The check a Stream applies to each vector before it publishes it: the index of the vector's
// first non-finite feature, or -1 when every feature is finite. `largest_bits` is the GPD
// kernels' report of the largest magnitude they wrote (the maximum of what gpd::static_features
// and gpd::kinetics* return): below Inf (0x7f800000) the vector is finite and is not read again.
int first_non_finite_feature(const float* vector, uint32_t largest_bits);

class Stream {
 public:
  // Allocates every buffer. Throws kata::Error(kInvalidArgument) on a bad config (a value out
  // of the ranges above, a map outside the input joints).
  explicit Stream(const StreamConfig& config);

  // Adds a frame: t in seconds, xyz = input_joints x 3 floats (x, y, z interleaved, input
  // units). A refused frame changes nothing and its reason is in last_error(): null
  // (kNullPointer), wrong count (kWrongJointCount), NaN/Inf (kNonFinite), t not at least
  // kMinTimeStep after the previous frame (kTimestampNotIncreasing), a mapped joint beyond
  // kMaxCoordinate or, once H is known, farther than kMaxReach x H from the hip
  // (kInvalidArgument, naming the joint). May emit one feature vector (the frame itself with the
  // backward stencil, the previous frame with the central one; several after calibration).
  // Every emitted vector is checked finite; a violation (a bug) is not published and returns
  // kInternal with a message.
  Status push(double t, const float* xyz, int joint_count) { return push(t, xyz, nullptr, joint_count); }
  // The same with a confidence per input joint (joint_count floats; null = all confident): missing
  // joints are held, and a frame may return Status::kTrackingLost (see StreamConfig). Here a
  // non-finite coordinate marks its joint missing instead of refusing the frame.
  Status push(double t, const float* xyz, const float* confidence, int joint_count);
  // Ends the current segment: with the central stencil the held frame is emitted with the
  // backward formulas (spec: end of a stream). The next frame starts a new segment. kInternal
  // as for push.
  Status flush();
  // The next frame starts a new segment (its kinetics restart); nothing is emitted.
  void reset();

  // The newest emitted feature vector (gpd::kDims floats), its timestamp and its frame index
  // (0-based count of accepted frames). Valid until the next push/flush. Null before the first.
  const float* features() const {
    return emitted_ ? vectors_.data() + static_cast<size_t>(out_slot_) * gpd::kDims : nullptr;
  }
  double feature_time() const { return out_time_; }
  int64_t feature_frame() const { return out_frame_; }
  // Number of vectors emitted so far; a caller that sees it grow by one knows it has them all.
  int64_t emitted_count() const { return emitted_; }
  // Emitted vectors are consecutive frames: the vector of frame f (emitted, and among the last
  // `history` accepted frames) and that frame's timestamp. One push may emit several (the
  // frames held while calibrating); a pipeline reads each right after the push.
  const float* vector_of(int64_t frame) const {
    return vectors_.data() + static_cast<size_t>(slot_at(frame)) * gpd::kDims;
  }
  double time_of(int64_t frame) const { return time_[static_cast<size_t>(slot_at(frame))]; }
  // The mapped GPD joints of accepted frame f (16 x 3, Y up, input units), among the last
  // `history` accepted frames.
  const float* joints_of(int64_t frame) const {
    return joints_.data() + static_cast<size_t>(slot_at(frame)) * 3 * gpd::kJoints;
  }
  // The newest accepted frame's mapped GPD joints (16 x 3, Y up, input units), or null.
  const float* last_joints() const;
  // Number of frames accepted so far (the next frame's index).
  int64_t accepted_count() const { return accepted_; }
  // H in input units; 0 while still calibrating.
  double body_height() const { return height_; }
  const StreamConfig& config() const { return config_; }
  // Change the confidence gate / smoothing of StreamConfig from the next push (no allocation).
  // Throw kata::Error(kInvalidArgument) on bad values, changing nothing.
  void set_confidence_gate(float threshold, double max_hold, double max_missing_share);
  void set_smoothing(bool enabled, double min_cutoff, double beta, double d_cutoff);
  // Bone lengths of the GPD tree (entry g = |joint g - parent g|, entry 0 = 0, input units) and
  // their spread, once bone_window good frames were seen; false before (nothing written).
  bool bone_lengths(double* lengths, double* spread) const;
  int bone_frames() const { return bone_count_; }  // good frames collected so far
  // Frames reported "tracking lost" so far, and GPD joints missing in the newest frame.
  int64_t lost_frames() const { return lost_frames_; }
  int missing_joints() const { return missing_joints_; }
  const char* last_error() const { return error_; }

 private:
  // Frame `frame` lives in ring slot `slot` (slot_at(frame), passed on so the per-frame path
  // divides nothing).
  void process(int64_t frame, int slot);
  // push's stages before anything changes: the frame's shape, times and values (*input_bits: the
  // largest |input coordinate|'s bits when every one was read, else infinity's), then the mapped
  // joints against the plausibility range and the body's reach. kOk, or the refusal's status.
  Status check_input(double t, const float* xyz, const float* confidence, int joint_count, uint32_t* input_bits);
  Status check_plausible(const float* mapped, uint32_t input_bits);
  // An accepted frame's mapped joints (smoothed here) into the ring, then its features, or its
  // bone lengths while the body height is calibrated; `gap` starts a new segment.
  Status store(double t, bool gap, float* mapped);
  // Completes frame `frame`'s vector (in `slot`) with block 9: kinetics by the backward rules
  // (central == false) or the central stencil (needs frame + 1).
  void emit(int64_t frame, int slot, bool central);
  void finish_calibration();
  // kOk, or kInternal with the message when emit() withheld a non-finite vector.
  Status emitted_status();
  // Confidence gate into `mapped` (48 floats, Y-up, before the floor) and good[16] (false: held
  // at its last good position): returns the number of missing joints, or -1 when a joint is held
  // past max_hold. Changes nothing: push commits after its plausibility checks.
  int gate(double t, const float* xyz, const float* confidence, float* mapped, bool* good) const;
  void smooth(double t, bool restart, float* mapped);
  // Layouts without a floor (GpdMap::floor_count): Y is measured from the lowest good foot joint.
  // *floor is left alone when no foot joint is good; false when it is beyond kMaxCoordinate.
  bool find_floor(const float* xyz, const float* confidence, float* floor) const;
  void collect_bones(const float* mapped);
  void end_segment();
  Status refuse(Status status, const char* fmt, ...);
  int slot_at(int64_t frame) const { return static_cast<int>(frame % config_.history); }
  int slot_before(int slot) const { return slot == 0 ? config_.history - 1 : slot - 1; }
  int slot_after(int slot) const { return slot + 1 == config_.history ? 0 : slot + 1; }

  StreamConfig config_;
  double height_ = 0.0;
  gpd::GeometryState geometry_;
  // Ring buffer, struct of arrays: per slot timestamp, mapped world joints, and the whole feature
  // vector (blocks 1..8 written when the frame arrives, block 9 when it is emitted), so reading
  // features copies nothing.
  std::vector<double> time_;
  std::vector<int> segment_pos_;   // position of the frame in its segment (0, 1, 2...)
  std::vector<char> starts_segment_;  // set at push time: gap, reset or first frame
  std::vector<double> calibration_;   // 7 x calibration_frames bone lengths, for the median H
  std::vector<float> joints_;      // history x 48
  std::vector<float> vectors_;     // history x kDims (block 1 = first kJcDims)
  // Per slot, what gpd::static_features reported of the static blocks (their largest magnitude as
  // bits): emit() checks the vector finite from it and the kinetics' report.
  std::vector<uint32_t> static_bits_;
  // The map reads each GPD joint from one input joint (no blends): mapping is a gather with the
  // axes turned, and a frame whose input coordinates are all within kMaxCoordinate has its mapped
  // joints within it too.
  bool direct_map_ = false;
  int next_slot_ = 0;              // slot_at(accepted_)
  int64_t accepted_ = 0;           // frames accepted so far
  int64_t processed_ = 0;          // frames turned into static features (< accepted_ while calibrating)
  bool pending_ = false;           // central: the newest processed frame awaits its successor
  bool new_segment_ = true;        // the next processed frame starts a segment
  double last_time_ = 0.0;
  int64_t emitted_ = 0;
  double out_time_ = 0.0;
  int64_t out_frame_ = -1;
  int out_slot_ = 0;               // slot_at(out_frame_)
  int withheld_dim_ = -1;          // set by emit() when a vector had a non-finite value (a bug)
  int64_t withheld_frame_ = -1;
  char error_[256] = {0};
  // Confidence gate, smoothing and bone estimate state (sized in the constructor).
  float last_good_[3 * kGpdJoints] = {0};
  double last_good_time_[kGpdJoints];
  bool seen_time_ = false;           // a frame (accepted or lost) has set last_time_
  int64_t lost_frames_ = 0;
  int missing_joints_ = 0;
  float filter_x_[3 * kGpdJoints] = {0}, filter_dx_[3 * kGpdJoints] = {0};
  double filter_time_ = 0.0;
  bool filter_ready_ = false;
  float floor_ = 0.0f;
  std::vector<float> bone_samples_;  // bone_window x 16 x 3 bone vectors (entry 0 unused)
  std::vector<float> bone_scratch_;  // bone_window
  int bone_count_ = 0;
  double bone_length_[kGpdJoints] = {0}, bone_spread_[kGpdJoints] = {0};
};

}  // namespace kata
