// C ABI misuse and hostile input: every reproducer of a non-finite output, an
// INTERNAL status or an unbounded read is a test here, through libkata only.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <climits>
#include <cstddef>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "kata/kata.h"
#include "support/capi_teacher.hpp"
#include "support/temp_paths.hpp"

namespace {

namespace fs = std::filesystem;

using kata::test::TempDir;

// A sparse file of `bytes` (no data blocks written).
void make_sparse(const std::string& path, off_t bytes, const std::string& head = "") {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ASSERT_GE(fd, 0);
  if (!head.empty()) {
    ASSERT_EQ(::write(fd, head.data(), head.size()), static_cast<ssize_t>(head.size()));
  }
  ASSERT_EQ(::ftruncate(fd, bytes), 0);
  ::close(fd);
}

// Bytes this process has read through read() so far (/proc/self/io "rchar").
long long bytes_read() {
  std::ifstream io("/proc/self/io");
  std::string key;
  long long value = 0;
  while (io >> key >> value)
    if (key == "rchar:") return value;
  return -1;
}

bool contains(const char* text, const std::string& needle) { return std::string(text).find(needle) != std::string::npos; }

// A CMU clip, its frames as world positions, and the index of one named joint.
struct Fixture {
  kata_context ctx = nullptr;
  kata_clip clip = nullptr;
  kata_skeleton skel = nullptr;
  uint32_t joints = 0;
  std::vector<std::vector<float>> frames;
  Fixture() {
    EXPECT_EQ(kata_context_create(&ctx), KATA_OK);
    EXPECT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &clip), KATA_OK) << kata_context_last_error(ctx);
    EXPECT_EQ(kata_clip_skeleton(clip, &skel), KATA_OK);
    joints = kata_skeleton_joint_count(skel);
    for (uint32_t i = 1; i < 40; ++i) {
      std::vector<float> p(3 * joints);
      EXPECT_EQ(kata_clip_positions(clip, i, p.data(), p.size()), KATA_OK);
      frames.push_back(p);
    }
  }
  ~Fixture() {
    kata_skeleton_destroy(skel);
    kata_clip_destroy(clip);
    kata_context_destroy(ctx);
  }
  uint32_t joint(const char* name) const {
    for (uint32_t i = 0; i < joints; ++i)
      if (std::strcmp(kata_skeleton_joint_name(skel, i), name) == 0) return i;
    ADD_FAILURE() << "no joint " << name;
    return 0;
  }
  kata_stream open(double body_height = 0.0, kata_skeleton on = nullptr) const {
    kata_stream_desc d;
    kata_stream_desc_init(&d);
    d.layout = "cmu";
    d.body_height = body_height;
    kata_stream s = nullptr;
    EXPECT_EQ(kata_stream_open(ctx, on ? on : skel, &d, &s), KATA_OK) << kata_context_last_error(ctx);
    return s;
  }
};

// The newest feature vector, if any, has only finite values.
void expect_finite_features(kata_stream s) {
  std::vector<float> f(KATA_GPD_DIMS);
  if (kata_stream_features(s, f.data(), f.size(), nullptr, nullptr) != KATA_OK) return;
  for (int i = 0; i < KATA_GPD_DIMS; ++i) ASSERT_TRUE(std::isfinite(f[static_cast<size_t>(i)])) << "feature " << i;
}

// ---- finite outputs --------------------------------------------------------------------------

TEST(Misuse, GlitchedCoordinateIsRefusedNamingTheJointAndLaterFramesStayFinite) {
  Fixture c;
  const uint32_t hand = c.joint("LeftHand");
  for (const float glitch : {1e37f, 1e10f, 5000.0f}) {  // 5000 units = ~170 body heights from the hip
    SCOPED_TRACE(glitch);
    kata_stream s = c.open();
    for (size_t i = 0; i < c.frames.size(); ++i) {
      std::vector<float> p = c.frames[i];
      if (i == 5) p[3 * hand + 1] = glitch;
      const kata_status st = kata_stream_push(s, static_cast<double>(i) / 30.0, p.data(), c.joints);
      if (i == 5) {
        EXPECT_EQ(st, KATA_E_INVALID_ARGUMENT);
        EXPECT_TRUE(contains(kata_stream_last_error(s), "LHand")) << kata_stream_last_error(s);
      } else {
        EXPECT_EQ(st, KATA_OK) << kata_stream_last_error(s);
      }
      expect_finite_features(s);
    }
    EXPECT_EQ(kata_stream_feature_count(s), static_cast<int64_t>(c.frames.size()) - 1);
    kata_stream_destroy(s);
  }
}

TEST(Misuse, GlitchWhileCalibratingIsRefused) {
  Fixture c;
  // The same skeleton without a rest pose: H is estimated from the first frames.
  std::vector<const char*> names(c.joints);
  std::vector<int32_t> parents(c.joints);
  for (uint32_t i = 0; i < c.joints; ++i) {
    names[i] = kata_skeleton_joint_name(c.skel, i);
    parents[i] = kata_skeleton_joint_parent(c.skel, i);
  }
  kata_skeleton bare = nullptr;
  ASSERT_EQ(kata_skeleton_create(c.ctx, c.joints, names.data(), parents.data(), nullptr, &bare), KATA_OK);
  kata_stream s = c.open(0.0, bare);
  std::vector<float> p = c.frames[0];
  p[3 * c.joint("Head")] = 1e37f;
  EXPECT_EQ(kata_stream_push(s, 0.0, p.data(), c.joints), KATA_E_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(kata_stream_last_error(s), "Head")) << kata_stream_last_error(s);
  for (size_t i = 0; i < c.frames.size(); ++i) {
    ASSERT_EQ(kata_stream_push(s, static_cast<double>(i) / 30.0, c.frames[i].data(), c.joints), KATA_OK);
    expect_finite_features(s);
  }
  EXPECT_GT(kata_stream_body_height(s), 0.0);
  kata_stream_destroy(s);
  kata_skeleton_destroy(bare);
}

TEST(Misuse, TimeStepBelowTheMinimumIsRefused) {
  Fixture c;
  kata_stream s = c.open();
  ASSERT_EQ(kata_stream_push(s, 0.0, c.frames[0].data(), c.joints), KATA_OK);
  for (const double t : {1.35e-312, 1e-20, 0.5 * KATA_MIN_TIME_STEP}) {
    EXPECT_EQ(kata_stream_push(s, t, c.frames[1].data(), c.joints), KATA_E_TIMESTAMP_NOT_INCREASING) << t;
    EXPECT_TRUE(contains(kata_stream_last_error(s), "minimum step")) << kata_stream_last_error(s);
  }
  EXPECT_EQ(kata_stream_push(s, KATA_MIN_TIME_STEP, c.frames[1].data(), c.joints), KATA_OK);
  expect_finite_features(s);
  for (size_t i = 2; i < c.frames.size(); ++i) {
    ASSERT_EQ(kata_stream_push(s, KATA_MIN_TIME_STEP * static_cast<double>(i), c.frames[i].data(), c.joints), KATA_OK);
    expect_finite_features(s);
  }
  kata_stream_destroy(s);
}

TEST(Misuse, BodyHeightOutsideItsRangeIsRefused) {
  Fixture c;
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  d.layout = "cmu";
  kata_stream s = nullptr;
  for (const double h : {1.4e-315, 1e-300, 0.5 * KATA_MIN_BODY_HEIGHT, -1.0, -0.0 - 1e-9, std::nan(""),
                         HUGE_VAL, 2 * KATA_MAX_COORDINATE}) {
    d.body_height = h;
    EXPECT_EQ(kata_stream_open(c.ctx, c.skel, &d, &s), KATA_E_INVALID_ARGUMENT) << h;
    EXPECT_EQ(s, nullptr);
    EXPECT_TRUE(contains(kata_context_last_error(c.ctx), "body height")) << kata_context_last_error(c.ctx);
  }
  // The smallest accepted H: CMU joints (tens of units from the hip) are then implausible.
  d.body_height = KATA_MIN_BODY_HEIGHT;
  ASSERT_EQ(kata_stream_open(c.ctx, c.skel, &d, &s), KATA_OK);
  EXPECT_EQ(kata_stream_push(s, 0.0, c.frames[0].data(), c.joints), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(kata_stream_feature_count(s), 0);
  kata_stream_destroy(s);
}

TEST(Misuse, CountsBeyondTheirRangeAreRefusedWithoutOverflow) {
  Fixture c;
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  d.layout = "cmu";
  kata_skeleton bare = nullptr;
  const char* names[] = {"a"};
  const int32_t parents[] = {-1};
  ASSERT_EQ(kata_skeleton_create(c.ctx, 1, names, parents, nullptr, &bare), KATA_OK);
  kata_stream s = nullptr;
  // Calibration counts only matter without a rest pose: use the CMU skeleton's own names.
  std::vector<const char*> cmu_names(c.joints);
  std::vector<int32_t> cmu_parents(c.joints);
  for (uint32_t i = 0; i < c.joints; ++i) {
    cmu_names[i] = kata_skeleton_joint_name(c.skel, i);
    cmu_parents[i] = kata_skeleton_joint_parent(c.skel, i);
  }
  kata_skeleton no_rest = nullptr;
  ASSERT_EQ(kata_skeleton_create(c.ctx, c.joints, cmu_names.data(), cmu_parents.data(), nullptr, &no_rest), KATA_OK);
  for (const uint32_t frames : {static_cast<uint32_t>(INT_MAX), UINT32_MAX, 0u, d.history_capacity}) {
    d.calibration_frames = frames;
    EXPECT_EQ(kata_stream_open(c.ctx, no_rest, &d, &s), KATA_E_INVALID_ARGUMENT) << frames;
    EXPECT_TRUE(contains(kata_context_last_error(c.ctx), "calibration_frames")) << kata_context_last_error(c.ctx);
  }
  kata_stream_desc_init(&d);
  d.layout = "cmu";
  for (const uint32_t history : {3u, static_cast<uint32_t>(KATA_MAX_HISTORY) + 1, static_cast<uint32_t>(INT_MAX), UINT32_MAX}) {
    d.history_capacity = history;
    EXPECT_EQ(kata_stream_open(c.ctx, c.skel, &d, &s), KATA_E_INVALID_ARGUMENT) << history;
    EXPECT_TRUE(contains(kata_context_last_error(c.ctx), "history")) << kata_context_last_error(c.ctx);
  }
  kata_skeleton_destroy(no_rest);
  kata_skeleton_destroy(bare);
}

// ---- files -----------------------------------------------------------------------------------

TEST(Misuse, DirectoriesAndSpecialFilesAreIoErrorsNamingThePath) {
  Fixture c;
  TempDir dir;
  const std::string fifo = dir.file("fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& path : {dir.path().string(), fifo, std::string("/dev/null")}) {
    SCOPED_TRACE(path);
    kata_clip clip = nullptr;
    EXPECT_EQ(kata_clip_load_bvh(c.ctx, path.c_str(), &clip), KATA_E_IO);
    EXPECT_TRUE(contains(kata_context_last_error(c.ctx), path)) << kata_context_last_error(c.ctx);
    kata_skeleton skel = nullptr;
    EXPECT_EQ(kata_skeleton_load_bvh(c.ctx, path.c_str(), &skel), KATA_E_IO);
    EXPECT_TRUE(contains(kata_context_last_error(c.ctx), path)) << kata_context_last_error(c.ctx);
    kata_model model = nullptr;
    EXPECT_EQ(kata_model_load(c.ctx, path.c_str(), &model), KATA_E_IO);
    EXPECT_TRUE(contains(kata_context_last_error(c.ctx), path)) << kata_context_last_error(c.ctx);
    kata_stream_desc d;
    kata_stream_desc_init(&d);
    d.name_map_path = path.c_str();
    kata_stream s = nullptr;
    EXPECT_EQ(kata_stream_open(c.ctx, c.skel, &d, &s), KATA_E_IO);
    EXPECT_TRUE(contains(kata_context_last_error(c.ctx), path)) << kata_context_last_error(c.ctx);
  }
}

TEST(Misuse, OversizedSparseFilesAreRefusedWithoutReadingThem) {
  Fixture c;
  TempDir dir;
  const std::string bvh = dir.file("huge.bvh"), model = dir.file("huge.kata"), map = dir.file("huge.map");
  make_sparse(bvh, static_cast<off_t>(KATA_MAX_BVH_BYTES) + 4096, "HIERARCHY\n");
  make_sparse(model, static_cast<off_t>(KATA_MAX_MODEL_BYTES) + 1);
  make_sparse(map, static_cast<off_t>(KATA_MAX_NAME_MAP_BYTES) + 1);
  const long long before = bytes_read();
  kata_clip clip = nullptr;
  EXPECT_EQ(kata_clip_load_bvh(c.ctx, bvh.c_str(), &clip), KATA_E_IO);
  EXPECT_TRUE(contains(kata_context_last_error(c.ctx), "exceeds")) << kata_context_last_error(c.ctx);
  kata_model m = nullptr;
  EXPECT_EQ(kata_model_load(c.ctx, model.c_str(), &m), KATA_E_IO);
  EXPECT_TRUE(contains(kata_context_last_error(c.ctx), "exceeds")) << kata_context_last_error(c.ctx);
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  d.name_map_path = map.c_str();
  kata_stream s = nullptr;
  EXPECT_EQ(kata_stream_open(c.ctx, c.skel, &d, &s), KATA_E_IO);
  EXPECT_TRUE(contains(kata_context_last_error(c.ctx), "exceeds")) << kata_context_last_error(c.ctx);
  // Only /proc/self/io itself was read in between, not gigabytes.
  EXPECT_LT(bytes_read() - before, 64 * 1024);
}

TEST(Misuse, ModelHeaderIsCheckedBeforeTheRestIsRead) {
  Fixture c;
  TempDir dir;
  const std::string path = dir.file("foreign.kata");
  make_sparse(path, 32 << 20, std::string("\x10\x00\x00\x00\x08\x00\x00\x00NOPE", 12));  // 32 MiB, not a model
  const long long before = bytes_read();
  kata_model m = nullptr;
  EXPECT_EQ(kata_model_load(c.ctx, path.c_str(), &m), KATA_E_MODEL);
  EXPECT_TRUE(contains(kata_context_last_error(c.ctx), "NOPE")) << kata_context_last_error(c.ctx);
  EXPECT_LT(bytes_read() - before, 64 * 1024);
}

// ---- descriptors and arguments ---------------------------------------------------------------

TEST(Misuse, PresetAndNameMapTogetherAreRefused) {
  Fixture c;
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  d.layout = "cmu";
  d.name_map_path = "/nonexistent/map.json";
  kata_stream s = nullptr;
  EXPECT_EQ(kata_stream_open(c.ctx, c.skel, &d, &s), KATA_E_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(kata_context_last_error(c.ctx), "not both")) << kata_context_last_error(c.ctx);
}

// Every descriptor follows one rule (sdk/src/capi/struct_size.hpp): a struct_size below 1.0's
// struct is refused (an uninitialised desc: no released kata.h has such a struct); 1.0's size and
// anything larger (a caller built against a newer kata.h) are read up to this library's struct,
// a newer caller's extra fields ignored.
TEST(Misuse, DescriptorStructSizeFromTheReleasedSizeUp) {
  Fixture c;
  // A newer caller's struct below: this library's, then 64 bytes of fields it does not know.
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  d.layout = "cmu";
  kata_stream s = nullptr;
  // 1.0's struct ends with keep_features (a caller's sizeof adds tail padding).
  for (const uint32_t size : {0u, 4u, static_cast<uint32_t>(offsetof(kata_stream_desc, keep_features) + 3)}) {
    d.struct_size = size;
    EXPECT_EQ(kata_stream_open(c.ctx, c.skel, &d, &s), KATA_E_INVALID_ARGUMENT) << size;
    EXPECT_EQ(s, nullptr);
    EXPECT_TRUE(contains(kata_context_last_error(c.ctx), "below 1.0's kata_stream_desc")) << kata_context_last_error(c.ctx);
  }
  {
    std::vector<unsigned char> newer(sizeof(kata_stream_desc) + 64, 0xA5);
    std::memcpy(newer.data(), &d, sizeof d);
    auto* nd = reinterpret_cast<kata_stream_desc*>(newer.data());
    for (const uint32_t size : {static_cast<uint32_t>(sizeof d), static_cast<uint32_t>(sizeof d) + 64}) {
      nd->struct_size = size;
      ASSERT_EQ(kata_stream_open(c.ctx, c.skel, nd, &s), KATA_OK) << size << kata_context_last_error(c.ctx);
      kata_stream_destroy(s);
    }
  }
  kata_model model = nullptr;
  ASSERT_EQ(kata_model_load(c.ctx, KATA_SOURCE_DIR "/tests/data/models/v1-minmax-backward.kata", &model), KATA_OK);
  kata_stream live = c.open();
  kata_teacher_desc t;
  kata_teacher_desc_init(&t);
  t.model = model;
  t.clip = c.clip;
  for (const uint32_t size : {0u, 4u, 12u, static_cast<uint32_t>(offsetof(kata_teacher_desc, body_height))}) {
    t.struct_size = size;
    EXPECT_EQ(kata_stream_attach_teacher(live, &t), KATA_E_INVALID_ARGUMENT) << size;
  }
  {
    std::vector<unsigned char> newer(sizeof(kata_teacher_desc) + 64, 0xA5);
    std::memcpy(newer.data(), &t, sizeof t);
    auto* nt = reinterpret_cast<kata_teacher_desc*>(newer.data());
    nt->struct_size = static_cast<uint32_t>(newer.size());
    EXPECT_EQ(kata_stream_attach_teacher(live, nt), KATA_OK) << kata_stream_last_error(live);
  }
  t.struct_size = sizeof t;
  EXPECT_EQ(kata_stream_attach_teacher(live, &t), KATA_OK) << kata_stream_last_error(live);
  kata_stream_destroy(live);
  kata_model_destroy(model);
  kata_retarget_desc r;
  kata_retarget_desc_init(&r);
  kata_retargeter rt = nullptr;
  for (const uint32_t size : {0u, 12u, static_cast<uint32_t>(offsetof(kata_retarget_desc, restore_bone_lengths) + 1)}) {
    r.struct_size = size;
    EXPECT_EQ(kata_retargeter_create(c.ctx, c.skel, &r, &rt), KATA_E_INVALID_ARGUMENT) << size;
    EXPECT_EQ(rt, nullptr);
  }
  {
    std::vector<unsigned char> newer(sizeof(kata_retarget_desc) + 64, 0xA5);
    kata_retarget_desc_init(&r);
    std::memcpy(newer.data(), &r, sizeof r);
    auto* nr = reinterpret_cast<kata_retarget_desc*>(newer.data());
    nr->struct_size = static_cast<uint32_t>(newer.size());
    ASSERT_EQ(kata_retargeter_create(c.ctx, c.skel, nr, &rt), KATA_OK) << kata_context_last_error(c.ctx);
    kata_retargeter_destroy(rt);
  }
  // Runtime desc: below 1.0 refused; a newer caller's larger struct read up to ours.
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.publish_endpoints = "inproc://kata-misuse-sizes";
  kata_runtime runtime = nullptr;
  rd.struct_size = 64;  // 0.2's
  EXPECT_EQ(kata_runtime_create(c.ctx, &rd, &runtime), KATA_E_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(kata_context_last_error(c.ctx), "below 1.0's kata_runtime_desc")) << kata_context_last_error(c.ctx);
  std::vector<unsigned char> newer(sizeof(kata_runtime_desc) + 64, 0xA5);
  rd.struct_size = static_cast<uint32_t>(newer.size());
  std::memcpy(newer.data(), &rd, sizeof rd);
  ASSERT_EQ(kata_runtime_create(c.ctx, reinterpret_cast<kata_runtime_desc*>(newer.data()), &runtime), KATA_OK)
      << kata_context_last_error(c.ctx);
  // Writers: a 1.0-sized counters struct or a newer one (its unknown fields zeroed); less refused.
  std::vector<unsigned char> counters(sizeof(kata_runtime_counters) + 16, 0xA5);
  auto* kc = reinterpret_cast<kata_runtime_counters*>(counters.data());
  kc->struct_size = static_cast<uint32_t>(counters.size());
  ASSERT_EQ(kata_runtime_get_counters(runtime, kc), KATA_OK);
  EXPECT_EQ(kc->struct_size, counters.size());
  EXPECT_EQ(kc->streams, 0u);
  for (size_t i = sizeof(kata_runtime_counters); i < counters.size(); ++i) EXPECT_EQ(counters[i], 0) << i;
  kc->struct_size = 8;
  EXPECT_EQ(kata_runtime_get_counters(runtime, kc), KATA_E_INVALID_ARGUMENT);
  kata_runtime_destroy(runtime);
}

// A caller with a smaller struct (0.2's kata_runtime_desc of 64 bytes, kata_teacher_desc of 88):
// the sized init writes its struct and not one byte past it (guard bytes after the struct stay as
// they were); the readers then refuse it, being below 1.0's size. A size past this library's
// struct (a newer kata.h) is cut to this one's, which struct_size then reports.
TEST(Misuse, DescInitWritesOnlyTheCallersStruct) {
  constexpr uint32_t kRuntime02 = 64, kTeacher02 = 88, kGuard = 64;
  constexpr unsigned char kPattern = 0xA5;
  auto guarded = [&](uint32_t size) { return std::vector<unsigned char>(size + kGuard, kPattern); };
  auto guard_intact = [&](const std::vector<unsigned char>& b, uint32_t size) {
    for (size_t i = size; i < b.size(); ++i)
      if (b[i] != kPattern) return false;
    return true;
  };
  std::vector<unsigned char> old_runtime = guarded(kRuntime02);
  auto* rd = reinterpret_cast<kata_runtime_desc*>(old_runtime.data());
  kata_runtime_desc_init_sized(rd, kRuntime02);
  EXPECT_TRUE(guard_intact(old_runtime, kRuntime02)) << "kata_runtime_desc_init_sized wrote past a 0.2 struct";
  EXPECT_EQ(rd->struct_size, kRuntime02);
  EXPECT_EQ(rd->workers, 2u);
  EXPECT_EQ(rd->skeleton_resend_seconds, 1.0);  // 0.2's last field
  rd->workers = 1;
  rd->publish_endpoints = "inproc://kata-misuse-old-desc";
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_runtime runtime = nullptr;
  // 1.0 reads no 0.x struct (libkata.so.1 is loaded by no 0.x binary): refused, not half-read.
  EXPECT_EQ(kata_runtime_create(ctx, rd, &runtime), KATA_E_INVALID_ARGUMENT);
  kata_context_destroy(ctx);

  std::vector<unsigned char> old_teacher = guarded(kTeacher02);
  auto* td = reinterpret_cast<kata_teacher_desc*>(old_teacher.data());
  kata_teacher_desc_init_sized(td, kTeacher02);
  EXPECT_TRUE(guard_intact(old_teacher, kTeacher02)) << "kata_teacher_desc_init_sized wrote past a 0.2 struct";
  EXPECT_EQ(td->struct_size, kTeacher02);
  EXPECT_EQ(td->pose_frame, -1);
  EXPECT_EQ(td->ghost, 1);

  // Every desc: the macro passes the caller's sizeof; a newer caller's bigger struct is cut to ours.
  kata_runtime_desc full;
  std::memset(&full, 0xA5, sizeof full);
  kata_runtime_desc_init(&full);
  EXPECT_EQ(full.struct_size, sizeof full);
  EXPECT_EQ(full.idle_stream_seconds, 300.0);
  auto check_newer = [&](auto init, uint32_t ours, const char* what) {
    std::vector<unsigned char> newer = guarded(ours + 32);
    init(newer.data(), ours + 32);
    uint32_t reported = 0;
    std::memcpy(&reported, newer.data(), sizeof reported);
    EXPECT_EQ(reported, ours) << what;
    EXPECT_TRUE(guard_intact(newer, ours)) << what << " wrote past this library's struct";
    std::vector<unsigned char> tiny = guarded(0);
    init(tiny.data(), 3);
    EXPECT_TRUE(guard_intact(tiny, 0)) << what << ": struct_size 3 writes nothing";
  };
  check_newer([](void* p, uint32_t n) { kata_runtime_desc_init_sized(static_cast<kata_runtime_desc*>(p), n); },
              sizeof(kata_runtime_desc), "runtime");
  check_newer([](void* p, uint32_t n) { kata_teacher_desc_init_sized(static_cast<kata_teacher_desc*>(p), n); },
              sizeof(kata_teacher_desc), "teacher");
  check_newer([](void* p, uint32_t n) { kata_stream_desc_init_sized(static_cast<kata_stream_desc*>(p), n); },
              sizeof(kata_stream_desc), "stream");
  check_newer([](void* p, uint32_t n) { kata_retarget_desc_init_sized(static_cast<kata_retarget_desc*>(p), n); },
              sizeof(kata_retarget_desc), "retarget");
  // The macro kata_runtime_desc_init passes the caller's own sizeof, and nothing past it is written.
  std::vector<unsigned char> v10 = guarded(sizeof(kata_runtime_desc));
  kata_runtime_desc_init(reinterpret_cast<kata_runtime_desc*>(v10.data()));
  EXPECT_TRUE(guard_intact(v10, sizeof(kata_runtime_desc)));
  kata_runtime_desc_init_sized(nullptr, 64);  // NULL: nothing
}

// kata_stream_push_many pushes what kata_stream_push would frame by frame: the same results; a
// refused frame stops it with its index (the frames before it pushed, the stream still usable).
TEST(Misuse, PushManyStopsAtTheFirstRefusedFrameWithItsIndex) {
  Fixture c;
  const uint32_t n = static_cast<uint32_t>(c.frames.size());
  std::vector<float> all;
  std::vector<double> times;
  for (uint32_t i = 0; i < n; ++i) {
    all.insert(all.end(), c.frames[i].begin(), c.frames[i].end());
    times.push_back(i / 120.0);
  }
  all[3 * c.joints * 20 + 1] = std::nanf("");  // frame 20 has a NaN
  kata_stream one = c.open(), many = c.open();
  uint32_t pushed = 99, lost = 99;
  const kata_status got = kata_stream_push_many(many, times.data(), all.data(), nullptr, c.joints, n, &pushed, &lost);
  EXPECT_EQ(pushed, 20u);
  EXPECT_EQ(lost, 0u);
  EXPECT_NE(std::string(kata_stream_last_error(many)).find("not finite"), std::string::npos) << kata_stream_last_error(many);
  for (uint32_t i = 0; i < 20; ++i) ASSERT_EQ(kata_stream_push(one, times[i], c.frames[i].data(), c.joints), KATA_OK);
  EXPECT_EQ(got, kata_stream_push(one, times[20], all.data() + 3 * c.joints * 20, c.joints));  // the same refusal
  EXPECT_NE(got, KATA_OK);
  // The rest after the bad frame, as one more chunk: accepted.
  EXPECT_EQ(kata_stream_push_many(many, times.data() + 21, all.data() + 3 * c.joints * 21, nullptr, c.joints, n - 21,
                                  &pushed, &lost),
            KATA_OK);
  EXPECT_EQ(pushed, n - 21);
  for (uint32_t i = 21; i < n; ++i) ASSERT_EQ(kata_stream_push(one, times[i], c.frames[i].data(), c.joints), KATA_OK);
  EXPECT_EQ(kata_stream_results_pending(one), kata_stream_results_pending(many));
  EXPECT_EQ(kata_stream_push_many(many, nullptr, nullptr, nullptr, c.joints, 0, &pushed, nullptr), KATA_OK);
  kata_stream_destroy(one);
  kata_stream_destroy(many);
}

TEST(Misuse, EnumFieldsOutsideTheirValuesAreRefused) {
  Fixture c;
  kata_stream s = nullptr;
  for (const int32_t raw : {3, 7, -1, INT32_MIN}) {  // 2 is KATA_UP_Y_DOWN
    for (int field = 0; field < 2; ++field) {
      kata_stream_desc d;
      kata_stream_desc_init(&d);
      d.layout = "cmu";
      // Written as the integer a C caller (or a corrupt struct) may hold.
      std::memcpy(field == 0 ? static_cast<void*>(&d.stencil) : static_cast<void*>(&d.up_axis), &raw, sizeof raw);
      EXPECT_EQ(kata_stream_open(c.ctx, c.skel, &d, &s), KATA_E_INVALID_ARGUMENT) << field << " " << raw;
    }
  }
  kata_status unknown;
  const int32_t raw = 999;
  std::memcpy(&unknown, &raw, sizeof raw);
  EXPECT_STREQ(kata_status_string(unknown), "KATA_E_UNKNOWN_STATUS");
}

TEST(Misuse, StringsAreBoundedInAndOut) {
  Fixture c;
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  kata_stream s = nullptr;
  const std::string long_name(1 << 20, 'x');
  d.layout = long_name.c_str();
  EXPECT_EQ(kata_stream_open(c.ctx, c.skel, &d, &s), KATA_E_INVALID_ARGUMENT)
      << "no terminator within KATA_MAX_STRING_BYTES";
  const std::string long_but_bounded(KATA_MAX_STRING_BYTES - 1, 'y');
  d.layout = long_but_bounded.c_str();
  EXPECT_EQ(kata_stream_open(c.ctx, c.skel, &d, &s), KATA_E_NOT_FOUND);
  EXPECT_LT(std::strlen(kata_context_last_error(c.ctx)), 600u) << "the message quotes the name cut short";
  // A path of 1 MB in a message is cut too.
  const std::string long_path = "/nonexistent/" + long_name;
  kata_clip clip = nullptr;
  EXPECT_EQ(kata_clip_load_bvh(c.ctx, long_path.c_str(), &clip), KATA_E_IO);
  EXPECT_LT(std::strlen(kata_context_last_error(c.ctx)), 600u);
}

TEST(Misuse, PoseFrameBelowMinusOneIsRefused) {
  Fixture c;
  kata_model model = nullptr;
  ASSERT_EQ(kata_model_load(c.ctx, KATA_SOURCE_DIR "/tests/data/models/v1-minmax-backward.kata", &model), KATA_OK)
      << kata_context_last_error(c.ctx);
  kata_stream s = c.open();
  for (const int32_t frame : {-2, -100, INT32_MIN}) {
    EXPECT_EQ(kata::test::attach_clip(s, model, c.clip, 1, frame), KATA_E_INVALID_ARGUMENT) << frame;
    EXPECT_TRUE(contains(kata_stream_last_error(s), "below -1")) << kata_stream_last_error(s);
  }
  EXPECT_EQ(kata::test::attach_clip(s, model, c.clip, 1), KATA_OK) << kata_stream_last_error(s);
  // Scores stay finite through a glitch.
  for (size_t i = 0; i < c.frames.size(); ++i) {
    std::vector<float> p = c.frames[i];
    if (i == 3) p[0] = 1e30f;
    kata_stream_push(s, static_cast<double>(i) / 30.0, p.data(), c.joints);
    kata_result_record r;
    r.struct_size = sizeof r;
    if (kata::test::read_newest(s, &r) == KATA_OK) {
      EXPECT_TRUE(std::isfinite(r.distance) && std::isfinite(r.score));
      for (float part : r.parts) EXPECT_TRUE(std::isfinite(part));
    }
  }
  kata_result_record r;
  r.struct_size = 0;
  EXPECT_EQ(kata::test::read_newest(s, &r), KATA_E_INVALID_ARGUMENT);
  kata_stream_destroy(s);
  kata_model_destroy(model);
}

TEST(Misuse, NullHandlesAndPointersAreRefused) {
  Fixture c;
  float buf[3 * 64] = {};
  EXPECT_EQ(kata_context_create(nullptr), KATA_E_NULL_POINTER);
  kata_clip clip = nullptr;
  kata_skeleton skel = nullptr;
  kata_model model = nullptr;
  kata_stream s = nullptr;
  kata_retargeter rt = nullptr;
  EXPECT_EQ(kata_clip_load_bvh(nullptr, KATA_DATA_DIR "/cmu/07_01.bvh", &clip), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_clip_load_bvh(c.ctx, nullptr, &clip), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_clip_load_bvh(c.ctx, KATA_DATA_DIR "/cmu/07_01.bvh", nullptr), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_skeleton_load_bvh(c.ctx, nullptr, &skel), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_model_load(c.ctx, nullptr, &model), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_model_load(nullptr, "x.kata", &model), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_model_load_memory(c.ctx, nullptr, 10, &model), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_open(c.ctx, nullptr, nullptr, &s), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_open(c.ctx, c.skel, nullptr, &s), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_push(nullptr, 0.0, buf, 1), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_flush(nullptr), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_reset(nullptr), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_features(nullptr, buf, KATA_GPD_DIMS, nullptr, nullptr), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_read_newest(nullptr, nullptr, nullptr, 0, nullptr, 0), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_attach_teacher(nullptr, nullptr), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata::test::attach_clip(nullptr, nullptr, nullptr, 0), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_clip_positions(nullptr, 0, buf, 3), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_clip_skeleton(nullptr, &skel), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_retargeter_create(c.ctx, nullptr, nullptr, &rt), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_retargeter_solve(nullptr, buf, 1, buf, 3, nullptr), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_retargeter_reset(nullptr), KATA_E_NULL_POINTER);
  // Queries on NULL answer their documented neutral values; destroys ignore NULL.
  EXPECT_EQ(kata_skeleton_joint_count(nullptr), 0u);
  EXPECT_EQ(kata_skeleton_joint_name(nullptr, 0), nullptr);
  EXPECT_EQ(kata_skeleton_joint_parent(nullptr, 0), -2);
  EXPECT_EQ(kata_clip_frame_count(nullptr), 0u);
  EXPECT_EQ(kata_clip_frame_time(nullptr), 0.0);
  EXPECT_EQ(kata_stream_feature_count(nullptr), 0);
  EXPECT_EQ(kata_stream_body_height(nullptr), 0.0);
  EXPECT_STREQ(kata_stream_last_error(nullptr), "");
  EXPECT_EQ(kata_model_rank(nullptr), 0u);
  EXPECT_EQ(kata_model_metadata(nullptr, "date"), nullptr);
  EXPECT_EQ(kata_retargeter_joint_count(nullptr), 0u);
  kata_stream_destroy(nullptr);
  kata_clip_destroy(nullptr);
  kata_skeleton_destroy(nullptr);
  kata_model_destroy(nullptr);
  kata_retargeter_destroy(nullptr);
  kata_context_destroy(nullptr);
  // Pointer arguments of a live stream.
  kata_stream live = c.open();
  EXPECT_EQ(kata_stream_push(live, 0.0, nullptr, c.joints), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_features(live, nullptr, KATA_GPD_DIMS, nullptr, nullptr), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_read_newest(live, nullptr, nullptr, 0, nullptr, 0), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_attach_teacher(live, nullptr), KATA_E_NULL_POINTER);
  kata_stream_destroy(live);
}

TEST(Misuse, ShortBuffersAndWrongJointCountsChangeNothing) {
  Fixture c;
  kata_stream s = c.open();
  std::vector<float> p = c.frames[0];
  for (const uint32_t n : {0u, c.joints - 1, c.joints + 1, 1000001u, UINT32_MAX}) {
    EXPECT_EQ(kata_stream_push(s, 0.0, p.data(), n), KATA_E_WRONG_JOINT_COUNT) << n;
  }
  EXPECT_EQ(kata_stream_feature_count(s), 0);
  ASSERT_EQ(kata_stream_push(s, 0.0, p.data(), c.joints), KATA_OK);
  std::vector<float> f(KATA_GPD_DIMS, -7.0f);
  EXPECT_EQ(kata_stream_features(s, f.data(), KATA_GPD_DIMS - 1, nullptr, nullptr), KATA_E_BUFFER_TOO_SMALL);
  EXPECT_EQ(f[0], -7.0f);
  EXPECT_EQ(kata_stream_features(s, f.data(), 0, nullptr, nullptr), KATA_E_BUFFER_TOO_SMALL);
  std::vector<float> pos(3 * c.joints);
  EXPECT_EQ(kata_clip_positions(c.clip, 0, pos.data(), pos.size() - 1), KATA_E_BUFFER_TOO_SMALL);
  EXPECT_EQ(kata_clip_positions(c.clip, UINT32_MAX, pos.data(), pos.size()), KATA_E_INVALID_ARGUMENT);

  kata_retargeter rt = nullptr;
  ASSERT_EQ(kata_retargeter_create(c.ctx, c.skel, nullptr, &rt), KATA_OK) << kata_context_last_error(c.ctx);
  std::vector<float> ghost(3 * kata_retargeter_joint_count(rt));
  EXPECT_EQ(kata_retargeter_solve(rt, p.data(), c.joints, ghost.data(), ghost.size() - 1, nullptr),
            KATA_E_BUFFER_TOO_SMALL);
  EXPECT_EQ(kata_retargeter_solve(rt, p.data(), c.joints - 1, ghost.data(), ghost.size(), nullptr),
            KATA_E_WRONG_JOINT_COUNT);
  EXPECT_EQ(kata_retargeter_solve(rt, p.data(), c.joints, ghost.data(), ghost.size(), nullptr), KATA_OK)
      << kata_retargeter_last_error(rt);
  kata_retargeter_destroy(rt);
  kata_stream_destroy(s);
}

}  // namespace

namespace {

// kata.h: "the message of the last failed call made on this context from the calling thread".
// Two contexts on one thread keep their own; a runtime reports on the context it was made on; a
// context-less failure shows on any context while it is the thread's newest.
TEST(Misuse, EachContextKeepsItsOwnLastError) {
  kata_context a = nullptr, b = nullptr;
  ASSERT_EQ(kata_context_create(&a), KATA_OK);
  ASSERT_EQ(kata_context_create(&b), KATA_OK);
  EXPECT_STREQ(kata_context_last_error(a), "");
  kata_clip clip = nullptr;
  EXPECT_NE(kata_clip_load_bvh(a, "/nonexistent/first.bvh", &clip), KATA_OK);
  kata_skeleton skel = nullptr;
  EXPECT_NE(kata_skeleton_create_layout(b, "no-such-layout", &skel), KATA_OK);
  const std::string on_a = kata_context_last_error(a), on_b = kata_context_last_error(b);
  EXPECT_NE(on_a.find("first.bvh"), std::string::npos) << on_a;
  EXPECT_NE(on_b.find("no-such-layout"), std::string::npos) << on_b;
  EXPECT_EQ(on_a.find("no-such-layout"), std::string::npos) << on_a;

  // Another thread's failure on a does not replace this thread's message.
  std::thread([a] {
    kata_clip c = nullptr;
    EXPECT_NE(kata_clip_load_bvh(a, "/nonexistent/other-thread.bvh", &c), KATA_OK);
    EXPECT_NE(std::string(kata_context_last_error(a)).find("other-thread.bvh"), std::string::npos);
  }).join();
  EXPECT_EQ(kata_context_last_error(a), on_a);

  // A runtime's refusal goes to its own context.
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.workers = 0;
  kata_runtime rt = nullptr;
  EXPECT_EQ(kata_runtime_create(b, &rd, &rt), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(kata_context_last_error(b)).find("workers 1..256"), std::string::npos);
  EXPECT_EQ(kata_context_last_error(a), on_a);

  // A call without a context reports on the thread: newest, so shown on both.
  const double steps[3] = {0.0, 0.7, 1.4};  // 0.7 s or 0.7 ms a frame: neither plausible
  kata_time_units units = KATA_TIME_SECONDS;
  EXPECT_EQ(kata_time_units_detect(steps, 3, &units), KATA_E_INVALID_ARGUMENT);
  const std::string loose = kata_context_last_error(nullptr);
  EXPECT_FALSE(loose.empty());
  EXPECT_EQ(kata_context_last_error(a), loose);
  EXPECT_EQ(kata_context_last_error(b), loose);
  // ... until a context's own failure is newer again.
  EXPECT_NE(kata_clip_load_bvh(a, "/nonexistent/third.bvh", &clip), KATA_OK);
  EXPECT_NE(std::string(kata_context_last_error(a)).find("third.bvh"), std::string::npos);
  EXPECT_EQ(kata_context_last_error(b), loose);
  kata_context_destroy(a);
  kata_context_destroy(b);
}

}  // namespace
