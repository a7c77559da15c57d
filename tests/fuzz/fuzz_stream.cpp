// libFuzzer target: a live stream through the C ABI, driven by fuzzed descriptors, skeletons
// and frames, scored against the golden model. Asserts what kata.h promises for any input:
// no KATA_E_INTERNAL, every feature vector and score finite, refused frames change nothing.
//
// Input layout (all little-endian; bytes past the end read as zero):
//   u8 mode (bit 0: rest offsets follow, bit 1: score against the model)
//   i32 stencil, i32 up_axis, f64 max_gap, u32 history_capacity, f64 body_height, u32 calibration_frames
//   [16 x 3 f64 rest offsets]
//   frames until the input ends: f64 timestamp, 16 x 3 f32 positions
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "kata/kata.h"

namespace {

// The CMU joint names the "cmu" preset maps, in a tree (parents before children).
const char* const kNames[16] = {"Hips",     "Spine1",      "Neck1",     "Head",      "LeftArm",    "LeftForeArm",
                                "LeftHand", "RightArm",    "RightForeArm", "RightHand", "LeftUpLeg", "LeftLeg",
                                "LeftFoot", "RightUpLeg",  "RightLeg",  "RightFoot"};
const int32_t kParents[16] = {-1, 0, 1, 2, 2, 4, 5, 2, 7, 8, 0, 10, 11, 0, 13, 14};

class Reader {
 public:
  Reader(const uint8_t* d, size_t n) : d_(d), n_(n) {}
  template <class T>
  T get() {
    T v;
    uint8_t b[sizeof(T)] = {};
    for (size_t i = 0; i < sizeof(T); ++i) b[i] = pos_ + i < n_ ? d_[pos_ + i] : 0;
    pos_ += sizeof(T);
    std::memcpy(&v, b, sizeof v);
    return v;
  }
  bool more() const { return pos_ < n_; }

 private:
  const uint8_t* d_;
  size_t n_;
  size_t pos_ = 0;
};

void check(bool ok) {
  if (!ok) std::abort();
}

struct Shared {
  kata_context ctx = nullptr;
  kata_model model = nullptr;
  Shared() {
    check(kata_context_create(&ctx) == KATA_OK);
    check(kata_model_load(ctx, KATA_SOURCE_DIR "/tests/data/models/v1-minmax-backward.kata", &model) == KATA_OK);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Shared shared;
  Reader in(data, size);
  const uint8_t mode = in.get<uint8_t>();
  kata_stream_desc desc;
  kata_stream_desc_init(&desc);
  desc.layout = "cmu";
  const int32_t stencil = in.get<int32_t>(), up = in.get<int32_t>();
  std::memcpy(&desc.stencil, &stencil, sizeof stencil);  // any integer, as a C caller may pass
  std::memcpy(&desc.up_axis, &up, sizeof up);
  desc.max_gap = in.get<double>();
  // Bounded so a run spends its time on frames, not on allocating rings (the C ABI tests cover
  // capacities up to UINT32_MAX).
  desc.history_capacity = in.get<uint32_t>() % 256;
  desc.body_height = in.get<double>();
  desc.calibration_frames = in.get<uint32_t>();
  double offsets[16 * 3];
  const bool rest = mode & 1;
  if (rest)
    for (double& o : offsets) o = in.get<double>();
  kata_skeleton skel = nullptr;
  const kata_status made = kata_skeleton_create(shared.ctx, 16, kNames, kParents, rest ? offsets : nullptr, &skel);
  check(made != KATA_E_INTERNAL);
  if (made != KATA_OK) return 0;
  kata_stream s = nullptr;
  const kata_status opened = kata_stream_open(shared.ctx, skel, &desc, &s);
  kata_skeleton_destroy(skel);
  check(opened != KATA_E_INTERNAL && opened != KATA_E_OUT_OF_MEMORY);
  if (opened != KATA_OK) return 0;

  const bool score = (mode & 2) && kata_model_stencil(shared.model) == desc.stencil;
  float features[KATA_GPD_DIMS];
  bool reference = false;
  while (in.more()) {
    const double t = in.get<double>();
    float xyz[16 * 3];
    for (float& v : xyz) v = in.get<float>();
    const int64_t before = kata_stream_feature_count(s);
    const kata_status pushed = kata_stream_push(s, t, xyz, 16);
    check(pushed != KATA_E_INTERNAL);
    if (pushed != KATA_OK) check(kata_stream_feature_count(s) == before);  // a refusal changes nothing
    if (kata_stream_features(s, features, KATA_GPD_DIMS, nullptr, nullptr) != KATA_OK) continue;
    for (float f : features) check(std::isfinite(f));
    if (!score) continue;
    if (!reference) {
      kata_teacher_desc teacher;
      kata_teacher_desc_init(&teacher);
      teacher.model = shared.model;
      teacher.features = features;
      teacher.frames = 1;
      teacher.pose_frame = 0;
      teacher.ghost = 0;
      const kata_status set = kata_stream_attach_teacher(s, &teacher);
      check(set != KATA_E_INTERNAL);
      reference = set == KATA_OK;
      continue;
    }
    kata_result_record r;
    r.struct_size = sizeof r;
    const kata_status scored = kata_stream_read_newest(s, &r, nullptr, 0, nullptr, 0);
    check(scored != KATA_E_INTERNAL);
    if (scored == KATA_OK && r.scored) {
      check(std::isfinite(r.distance) && std::isfinite(r.score) && r.score >= 0.0f && r.score <= 100.0f);
      for (float p : r.parts) check(std::isfinite(p));
    }
  }
  check(kata_stream_flush(s) != KATA_E_INTERNAL);
  if (kata_stream_features(s, features, KATA_GPD_DIMS, nullptr, nullptr) == KATA_OK)
    for (float f : features) check(std::isfinite(f));
  kata_stream_destroy(s);
  return 0;
}
