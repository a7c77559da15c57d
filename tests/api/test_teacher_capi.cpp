// The teacher as kata.h's one way to say what a stream is compared with (1.0): a teacher given as
// GPD features or as the 16 GPD joints, the newest result as a convenience over the ring, detach
// and restart. Through the shipped libkata only. The expected values are known without kata: a
// stream compared with its own features or its own held pose is at distance 0 (d = |W^T (x - x)|)
// on every frame, matched frame for frame; the newest result is the last one a drain returns.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <string>
#include <vector>

#include "kata/kata.h"

namespace {

struct TeacherCapi : ::testing::Test {
  void SetUp() override {
    ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
    ASSERT_EQ(kata_model_load(ctx, KATA_SOURCE_DIR "/models/default.kata", &model), KATA_OK)
        << kata_context_last_error(ctx);
    ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/02_01.bvh", &clip), KATA_OK);
    ASSERT_EQ(kata_clip_skeleton(clip, &skel), KATA_OK);
    joints = kata_skeleton_joint_count(skel);
  }
  void TearDown() override {
    kata_skeleton_destroy(skel);
    kata_clip_destroy(clip);
    kata_model_destroy(model);
    kata_context_destroy(ctx);
  }
  kata_stream open(kata_skeleton on, const char* preset, double body_height = 0.0) {
    kata_stream_desc d;
    kata_stream_desc_init(&d);
    d.layout = preset;
    d.stencil = kata_model_stencil(model);
    d.body_height = body_height;
    d.result_capacity = 256;
    kata_stream s = nullptr;
    EXPECT_EQ(kata_stream_open(ctx, on, &d, &s), KATA_OK) << kata_context_last_error(ctx);
    return s;
  }
  std::vector<float> frame(uint32_t f) {
    std::vector<float> p(3 * static_cast<size_t>(joints));
    EXPECT_EQ(kata_clip_positions(clip, f, p.data(), p.size()), KATA_OK);
    return p;
  }
  kata_teacher_desc desc() {
    kata_teacher_desc t;
    kata_teacher_desc_init(&t);
    t.model = model;
    return t;
  }
  // Drains every unread result of s.
  static std::vector<kata_result_record> drain(kata_stream s, std::vector<kata_result_record>* scores) {
    std::vector<kata_result_record> r(kata_stream_results_pending(s) + 1);
    r[0].struct_size = sizeof r[0];
    uint32_t n = 0;
    EXPECT_EQ(kata_stream_read_results(s, r.data(), nullptr, 0, nullptr, 0,
                                       static_cast<uint32_t>(r.size()), &n),
              KATA_OK);
    r.resize(n);
    *scores = r;  // each record carries its score
    return r;
  }
  kata_context ctx = nullptr;
  kata_model model = nullptr;
  kata_clip clip = nullptr;
  kata_skeleton skel = nullptr;
  uint32_t joints = 0;
};

constexpr uint32_t kFirst = 1, kFrames = 90;  // frames 1..90 of CMU 02_01 (frame 0: the T-pose)

TEST_F(TeacherCapi, AStreamComparedWithItsOwnFeaturesIsAtDistanceZeroFrameForFrame) {
  // The teacher's features: every vector a stream of the clip emits, as kata_stream_features gives it.
  kata_stream t = open(skel, "cmu");
  std::vector<float> features;
  std::vector<float> f(KATA_GPD_DIMS);
  int64_t seen = 0;
  for (uint32_t i = 0; i < kFrames; ++i) {
    ASSERT_EQ(kata_stream_push(t, i * kata_clip_frame_time(clip), frame(kFirst + i).data(), joints), KATA_OK);
    if (kata_stream_feature_count(t) == seen) continue;
    seen = kata_stream_feature_count(t);
    ASSERT_EQ(kata_stream_features(t, f.data(), f.size(), nullptr, nullptr), KATA_OK);
    features.insert(features.end(), f.begin(), f.end());
  }
  kata_stream_destroy(t);
  const uint32_t vectors = static_cast<uint32_t>(features.size() / KATA_GPD_DIMS);
  ASSERT_GT(vectors, kFrames - 4);

  kata_stream s = open(skel, "cmu");
  kata_teacher_desc d = desc();
  d.features = features.data();
  d.frames = vectors;
  d.frame_time = kata_clip_frame_time(clip);
  EXPECT_EQ(kata_stream_attach_teacher(s, &d), KATA_E_INVALID_ARGUMENT) << "ghost = 1 with features is refused";
  EXPECT_NE(std::strstr(kata_stream_last_error(s), "ghost"), nullptr) << kata_stream_last_error(s);
  d.ghost = 0;
  ASSERT_EQ(kata_stream_attach_teacher(s, &d), KATA_OK) << kata_stream_last_error(s);
  EXPECT_EQ(kata_stream_ghost_joint_count(s), 0u);
  for (uint32_t i = 0; i < kFrames; ++i)
    ASSERT_EQ(kata_stream_push(s, i * kata_clip_frame_time(clip), frame(kFirst + i).data(), joints), KATA_OK);
  std::vector<kata_result_record> sc;
  const std::vector<kata_result_record> r = drain(s, &sc);
  ASSERT_EQ(r.size(), vectors);
  for (size_t k = 0; k < r.size(); ++k) {
    EXPECT_TRUE(r[k].scored) << k;
    EXPECT_EQ(r[k].ghost_joint_count, 0u) << k;
    EXPECT_EQ(r[k].result_sequence, k);
    EXPECT_EQ(r[k].matched_teacher_frame, static_cast<int32_t>(k)) << "frame for frame";
    EXPECT_EQ(sc[k].matched_teacher_frame, static_cast<int32_t>(k));
    EXPECT_LT(sc[k].distance, 1e-4f) << k;
    if (sc[k].state == KATA_SCORE_SCORING) {
      EXPECT_GT(sc[k].score, 99.99f) << k;
    }
  }
  EXPECT_EQ(sc.back().state, KATA_SCORE_SCORING);

  // One of those vectors as a single-pose teacher (pose_frame): the matching frame is at 0, the
  // others farther; a pose always "matches" frame 0.
  const uint32_t pose = 40;
  d.pose_frame = static_cast<int32_t>(pose);
  ASSERT_EQ(kata_stream_attach_teacher(s, &d), KATA_OK) << kata_stream_last_error(s);
  kata_stream_reset(s);
  for (uint32_t i = 0; i < kFrames; ++i)
    ASSERT_EQ(kata_stream_push(s, 10.0 + i * kata_clip_frame_time(clip), frame(kFirst + i).data(), joints), KATA_OK);
  const std::vector<kata_result_record> p = drain(s, &sc);
  ASSERT_EQ(p.size(), vectors);
  float farthest = 0.0f;
  for (size_t k = 0; k < p.size(); ++k) {
    EXPECT_EQ(sc[k].matched_teacher_frame, 0) << k;
    if (k == pose) {
      EXPECT_LT(sc[k].distance, 1e-4f);
    }
    if (k + 10 < pose || k > pose + 10) {
      EXPECT_GT(sc[k].distance, 1e-3f) << k;
    }
    farthest = std::fmax(farthest, sc[k].distance);
  }
  EXPECT_GT(farthest, 0.01f);
  kata_stream_destroy(s);
}

TEST_F(TeacherCapi, AHeldPoseGivenAsTheSixteenGpdJointsMatchesAStudentHoldingIt) {
  // The 16 GPD joints of clip frame 30 (the "cmu" preset's joints, in GPD order), and a student
  // that sends exactly those 16 joints, held still ("gpd" layout, the same body height).
  static const char* const kCmuGpd[KATA_GPD_JOINTS] = {
      "Hips", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm", "LeftHand", "RightArm",
      "RightForeArm", "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot"};
  const std::vector<float> all = frame(30);
  std::vector<float> pose(3 * KATA_GPD_JOINTS);
  for (int g = 0; g < KATA_GPD_JOINTS; ++g) {
    uint32_t j = 0;
    while (j < joints && std::strcmp(kata_skeleton_joint_name(skel, j), kCmuGpd[g]) != 0) ++j;
    ASSERT_LT(j, joints) << kCmuGpd[g];
    for (int k = 0; k < 3; ++k) pose[3 * g + k] = all[3 * j + k];
  }
  const double body_height = 30.0;  // any value, the same for both: features are in body heights

  kata_skeleton gpd = nullptr;
  ASSERT_EQ(kata_skeleton_create_layout(ctx, "gpd", &gpd), KATA_OK);
  kata_stream s = open(gpd, "gpd", body_height);
  kata_skeleton_destroy(gpd);
  kata_teacher_desc d = desc();
  d.joints = pose.data();
  d.body_height = body_height;
  d.ghost = 0;
  ASSERT_EQ(kata_stream_attach_teacher(s, &d), KATA_OK) << kata_stream_last_error(s);
  // A moving teacher of GPD joints is positions, not joints: refused with the way to say it.
  kata_teacher_desc moving = d;
  moving.frames = 2;
  EXPECT_EQ(kata_stream_attach_teacher(s, &moving), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::strstr(kata_stream_last_error(s), "positions"), nullptr) << kata_stream_last_error(s);

  for (int i = 0; i < 20; ++i) ASSERT_EQ(kata_stream_push(s, i / 30.0, pose.data(), KATA_GPD_JOINTS), KATA_OK);
  kata_result_record r;
  r.struct_size = sizeof r;
  kata_result_record& sc = r;
  ASSERT_EQ(kata_stream_read_newest(s, &r, nullptr, 0, nullptr, 0), KATA_OK);
  EXPECT_TRUE(r.scored);
  EXPECT_LT(sc.distance, 1e-4f) << "held still: kinetics zero on both sides, the same static features";
  EXPECT_EQ(sc.state, KATA_SCORE_SCORING);
  EXPECT_GT(sc.score, 99.99f);
  // Another pose (frame 90) held by the student is farther.
  const std::vector<float> other_all = frame(90);
  std::vector<float> other(pose);
  for (int g = 0; g < KATA_GPD_JOINTS; ++g) {
    uint32_t j = 0;
    while (std::strcmp(kata_skeleton_joint_name(skel, j), kCmuGpd[g]) != 0) ++j;
    for (int k = 0; k < 3; ++k) other[3 * g + k] = other_all[3 * j + k];
  }
  for (int i = 20; i < 40; ++i) ASSERT_EQ(kata_stream_push(s, i / 30.0, other.data(), KATA_GPD_JOINTS), KATA_OK);
  ASSERT_EQ(kata_stream_read_newest(s, &r, nullptr, 0, nullptr, 0), KATA_OK);
  EXPECT_GT(sc.distance, 1e-2f);
  kata_stream_destroy(s);
}

TEST_F(TeacherCapi, TheNewestResultIsTheLastEntryOfADrain) {
  kata_skeleton student = nullptr;
  kata_clip sclip = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &sclip), KATA_OK);
  ASSERT_EQ(kata_clip_skeleton(sclip, &student), KATA_OK);
  const uint32_t sj = kata_skeleton_joint_count(student);
  kata_stream a = open(student, "cmu"), b = open(student, "cmu");
  kata_teacher_desc d = desc();
  d.clip = clip;
  d.first_frame = kFirst;
  ASSERT_EQ(kata_stream_attach_teacher(a, &d), KATA_OK) << kata_stream_last_error(a);
  ASSERT_EQ(kata_stream_attach_teacher(b, &d), KATA_OK) << kata_stream_last_error(b);
  const uint32_t g = kata_stream_ghost_joint_count(b);
  ASSERT_GT(g, 0u);

  kata_result_record r;
  r.struct_size = sizeof r;
  kata_result_record& sc = r;
  std::vector<float> ghost(3 * g);
  EXPECT_EQ(kata_stream_read_newest(b, &r, ghost.data(), ghost.size(), nullptr, 0), KATA_NO_DATA);
  EXPECT_EQ(kata_stream_read_newest(b, &r, ghost.data(), ghost.size() - 1, nullptr, 0), KATA_E_BUFFER_TOO_SMALL);

  std::vector<float> p(3 * static_cast<size_t>(sj));
  for (uint32_t round = 0; round < 3; ++round) {
    for (uint32_t i = 0; i < 12; ++i) {
      const uint32_t f = 1 + round * 12 + i;
      ASSERT_EQ(kata_clip_positions(sclip, f, p.data(), p.size()), KATA_OK);
      ASSERT_EQ(kata_stream_push(a, f / 120.0, p.data(), sj), KATA_OK);
      ASSERT_EQ(kata_stream_push(b, f / 120.0, p.data(), sj), KATA_OK);
    }
    // a: every result; b: the newest only.
    std::vector<kata_result_record> all(64);
    
    std::vector<float> all_ghosts(64 * 3 * static_cast<size_t>(g));
    all[0].struct_size = sizeof all[0];
    uint32_t n = 0;
    ASSERT_EQ(kata_stream_read_results(a, all.data(), all_ghosts.data(), all_ghosts.size(), nullptr, 0,
                                       64, &n),
              KATA_OK);
    ASSERT_GT(n, 1u);
    ASSERT_EQ(kata_stream_read_newest(b, &r, ghost.data(), ghost.size(), nullptr, 0), KATA_OK);
    const kata_result_record& last = all[n - 1];
    EXPECT_EQ(r.result_sequence, last.result_sequence);
    EXPECT_EQ(r.frame_index, last.frame_index);
    EXPECT_EQ(r.capture_time, last.capture_time);
    EXPECT_EQ(r.scored, last.scored);
    EXPECT_EQ(r.matched_teacher_frame, last.matched_teacher_frame);
    EXPECT_EQ(r.ghost_joint_count, g);
    EXPECT_EQ(sc.distance, all[n - 1].distance);
    EXPECT_EQ(sc.score, all[n - 1].score);
    for (size_t k = 0; k < ghost.size(); ++k) ASSERT_EQ(ghost[k], all_ghosts[(n - 1) * ghost.size() + k]) << k;
    // The older ones were passed over, not dropped; nothing new: no data.
    EXPECT_EQ(kata_stream_results_pending(b), 0u);
    EXPECT_EQ(kata_stream_results_dropped(b), 0u);
    EXPECT_EQ(kata_stream_read_newest(b, &r, nullptr, 0, nullptr, 0), KATA_NO_DATA);
  }
  kata_stream_destroy(a);
  kata_stream_destroy(b);
  kata_skeleton_destroy(student);
  kata_clip_destroy(sclip);
}

TEST_F(TeacherCapi, RestartMatchesFromTheStartAndDetachStopsScoring) {
  kata_stream s = open(skel, "cmu");
  EXPECT_EQ(kata_stream_restart_teacher(s), KATA_E_STATE);
  kata_teacher_desc d = desc();
  d.clip = clip;
  d.first_frame = kFirst;
  ASSERT_EQ(kata_stream_attach_teacher(s, &d), KATA_OK) << kata_stream_last_error(s);
  const double dt = kata_clip_frame_time(clip);
  kata_result_record r;
  r.struct_size = sizeof r;
  kata_result_record& sc = r;
  // The teacher's own frames 1..60: the match follows, frame for frame.
  for (uint32_t i = 0; i < 60; ++i) ASSERT_EQ(kata_stream_push(s, i * dt, frame(kFirst + i).data(), joints), KATA_OK);
  ASSERT_EQ(kata_stream_read_newest(s, &r, nullptr, 0, nullptr, 0), KATA_OK);
  EXPECT_GE(r.matched_teacher_frame, 50);
  // From the clip's start again: without a restart the monotone match cannot go back ...
  kata_stream_reset(s);
  ASSERT_EQ(kata_stream_push(s, 60 * dt, frame(kFirst).data(), joints), KATA_OK);
  ASSERT_EQ(kata_stream_push(s, 61 * dt, frame(kFirst + 1).data(), joints), KATA_OK);
  ASSERT_EQ(kata_stream_read_newest(s, &r, nullptr, 0, nullptr, 0), KATA_OK);
  EXPECT_GE(r.matched_teacher_frame, 50);
  // ... with one it does, and calibrates again.
  ASSERT_EQ(kata_stream_restart_teacher(s), KATA_OK);
  kata_stream_reset(s);
  for (uint32_t i = 0; i < 3; ++i) ASSERT_EQ(kata_stream_push(s, (70 + i) * dt, frame(kFirst + i).data(), joints), KATA_OK);
  ASSERT_EQ(kata_stream_read_newest(s, &r, nullptr, 0, nullptr, 0), KATA_OK);
  EXPECT_LE(r.matched_teacher_frame, 3);
  EXPECT_EQ(sc.state, KATA_SCORE_CALIBRATING);

  ASSERT_EQ(kata_stream_detach_teacher(s), KATA_OK);
  EXPECT_EQ(kata_stream_ghost_joint_count(s), 0u);
  ASSERT_EQ(kata_stream_push(s, 80 * dt, frame(kFirst + 3).data(), joints), KATA_OK);
  ASSERT_EQ(kata_stream_read_newest(s, &r, nullptr, 0, nullptr, 0), KATA_OK);
  EXPECT_EQ(r.scored, 0);
  EXPECT_EQ(r.ghost_joint_count, 0u);
  EXPECT_EQ(r.matched_teacher_frame, -1);
  EXPECT_EQ(sc.distance, 0.0f);
  EXPECT_EQ(kata_stream_restart_teacher(s), KATA_E_STATE);
  EXPECT_EQ(kata_stream_detach_teacher(s), KATA_OK) << "without a teacher too";
  kata_stream_destroy(s);
}

TEST_F(TeacherCapi, DescSizesMotionsAndNullsAreChecked) {
  kata_stream s = open(skel, "cmu");
  kata_teacher_desc d = desc();
  d.clip = clip;
  d.first_frame = kFirst;
  ASSERT_EQ(kata_stream_attach_teacher(s, &d), KATA_OK) << kata_stream_last_error(s);
  EXPECT_GT(kata_stream_ghost_joint_count(s), 0u);
  // Below 1.0's struct (0.2's: every field before features) is refused.
  for (uint32_t size : {0u, 4u, static_cast<uint32_t>(offsetof(kata_teacher_desc, features)),
                        static_cast<uint32_t>(offsetof(kata_teacher_desc, body_height))}) {
    d.struct_size = size;
    EXPECT_EQ(kata_stream_attach_teacher(s, &d), KATA_E_INVALID_ARGUMENT) << size;
  }
  d.struct_size = sizeof d;
  std::vector<float> f(KATA_GPD_DIMS, 0.1f);
  d.features = f.data();
  d.frames = 1;
  EXPECT_EQ(kata_stream_attach_teacher(s, &d), KATA_E_INVALID_ARGUMENT) << "a clip and features";
  EXPECT_NE(std::strstr(kata_stream_last_error(s), "one teacher motion"), nullptr) << kata_stream_last_error(s);
  d.clip = nullptr;
  d.first_frame = 0;
  d.ghost = 0;
  d.frames = 0;
  EXPECT_EQ(kata_stream_attach_teacher(s, &d), KATA_E_INVALID_ARGUMENT) << "features without frames";
  d.frames = 1;
  f[7] = NAN;
  EXPECT_EQ(kata_stream_attach_teacher(s, &d), KATA_E_INVALID_ARGUMENT) << "non-finite features";
  EXPECT_GT(kata_stream_ghost_joint_count(s), 0u) << "a refused call leaves the old teacher";
  EXPECT_EQ(kata_stream_read_newest(nullptr, nullptr, nullptr, 0, nullptr, 0), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_read_newest(s, nullptr, nullptr, 0, nullptr, 0), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_detach_teacher(nullptr), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_stream_restart_teacher(nullptr), KATA_E_NULL_POINTER);
  kata_stream_destroy(s);
}

// The ghost across layouts (1.1, kata_teacher_desc.ghost_across): the pipeline's ghost equals what
// kata_retargeter_create_across + solve + place make of the same teacher frames in the same order
// (the warm start included), independently of the pipeline: the matched frames are the ones the
// results name, the student frames the ones the results' frame_index name. Student CMU 07_01 on
// its own skeleton (other bone lengths), teacher 02_01.
TEST_F(TeacherCapi, TheGhostAcrossLayoutsIsTheAcrossRetargetersOfTheMatchedFrames) {
  kata_clip student_clip = nullptr;
  kata_skeleton student = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &student_clip), KATA_OK);
  ASSERT_EQ(kata_clip_skeleton(student_clip, &student), KATA_OK);
  const uint32_t sj = kata_skeleton_joint_count(student);
  kata_stream s = open(student, "cmu");
  kata_teacher_desc d = desc();
  d.clip = clip;
  d.first_frame = kFirst;
  d.ghost_across = 1;
  ASSERT_EQ(kata_stream_attach_teacher(s, &d), KATA_OK) << kata_stream_last_error(s);
  ASSERT_EQ(kata_stream_ghost_joint_count(s), static_cast<uint32_t>(KATA_GPD_JOINTS));
  std::vector<float> student_frames;
  for (uint32_t f = kFirst; f < kFirst + kFrames; ++f) {
    std::vector<float> p(3 * static_cast<size_t>(sj));
    ASSERT_EQ(kata_clip_positions(student_clip, f, p.data(), p.size()), KATA_OK);
    student_frames.insert(student_frames.end(), p.begin(), p.end());
    ASSERT_EQ(kata_stream_push(s, (f - kFirst) / 120.0, p.data(), sj), KATA_OK) << kata_stream_last_error(s);
  }
  const uint32_t pending = kata_stream_results_pending(s);
  ASSERT_GT(pending, 10u);
  std::vector<kata_result_record> r(pending);
  r[0].struct_size = sizeof r[0];
  std::vector<float> ghosts(static_cast<size_t>(pending) * 3 * KATA_GPD_JOINTS);
  uint32_t n = 0;
  ASSERT_EQ(kata_stream_read_results(s, r.data(), ghosts.data(), ghosts.size(), nullptr, 0, pending, &n), KATA_OK);
  ASSERT_EQ(n, pending);

  kata_retargeter rt = nullptr;
  ASSERT_EQ(kata_retargeter_create_across(ctx, s, skel, "cmu", KATA_UP_Y, nullptr, &rt), KATA_OK)
      << kata_context_last_error(ctx);
  ASSERT_EQ(kata_retargeter_joint_count(rt), static_cast<uint32_t>(KATA_GPD_JOINTS));
  for (uint32_t g = 0; g < KATA_GPD_JOINTS; ++g)
    EXPECT_EQ(kata_stream_ghost_joint_source(s, g), kata_retargeter_joint_source(rt, g)) << g;
  double largest = 0.0;
  for (uint32_t i = 0; i < n; ++i) {
    ASSERT_EQ(r[i].ghost_joint_count, static_cast<uint32_t>(KATA_GPD_JOINTS)) << i;
    ASSERT_GE(r[i].matched_teacher_frame, 0) << i;
    float expected[3 * KATA_GPD_JOINTS];
    const std::vector<float> t = frame(kFirst + static_cast<uint32_t>(r[i].matched_teacher_frame));
    ASSERT_EQ(kata_retargeter_solve(rt, t.data(), joints, expected, 3 * KATA_GPD_JOINTS, nullptr), KATA_OK);
    ASSERT_EQ(kata_retargeter_place(rt, student_frames.data() + static_cast<size_t>(r[i].frame_index) * 3 * sj, sj,
                                    expected, 3 * KATA_GPD_JOINTS),
              KATA_OK);
    for (int k = 0; k < 3 * KATA_GPD_JOINTS; ++k) {
      const float got = ghosts[static_cast<size_t>(i) * 3 * KATA_GPD_JOINTS + static_cast<size_t>(k)];
      largest = std::max(largest, static_cast<double>(std::fabs(got - expected[k])));
    }
  }
  EXPECT_LT(largest, 1e-4) << "the pipeline's ghost differs from the across retargeter's";
  // ghost_across needs ghost = 1; values other than 0 and 1 are refused.
  d.ghost = 0;
  EXPECT_EQ(kata_stream_attach_teacher(s, &d), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::strstr(kata_stream_last_error(s), "ghost_across"), nullptr) << kata_stream_last_error(s);
  d.ghost = 1;
  d.ghost_across = 2;
  EXPECT_EQ(kata_stream_attach_teacher(s, &d), KATA_E_INVALID_ARGUMENT);
  kata_retargeter_destroy(rt);
  kata_stream_destroy(s);
  kata_skeleton_destroy(student);
  kata_clip_destroy(student_clip);
}

// 1.1's additions for an app that draws and coaches (kata coach): which student joint each GPD
// joint reads, each GPD joint's body part, the parts' and cue joints' names. The expected values
// are the documented ones (kata/stream.h "Layouts", kata/result.h's kata_body_part, the cmu
// layout's joint names read back from the skeleton by name).
TEST_F(TeacherCapi, GpdJointSourcesPartsAndNamesAreTheDocumentedOnes) {
  static const char* const kCmu[KATA_GPD_JOINTS] = {"Hips", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm",
                                                    "LeftHand", "RightArm", "RightForeArm", "RightHand",
                                                    "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg",
                                                    "RightFoot"};
  kata_stream s = open(skel, "cmu");
  for (uint32_t g = 0; g < KATA_GPD_JOINTS; ++g) {
    const int32_t j = kata_stream_gpd_joint_source(s, g);
    ASSERT_GE(j, 0) << g;
    EXPECT_STREQ(kata_skeleton_joint_name(skel, static_cast<uint32_t>(j)), kCmu[g]) << g;
  }
  EXPECT_EQ(kata_stream_gpd_joint_source(s, KATA_GPD_JOINTS), -1);
  EXPECT_EQ(kata_stream_gpd_joint_source(nullptr, 0), -1);
  kata_stream_destroy(s);
  // MediaPipe: the landmarks in its documented order; the four synthesised joints have none.
  kata_skeleton mp = nullptr;
  ASSERT_EQ(kata_skeleton_create_layout(ctx, "mediapipe", &mp), KATA_OK);
  kata_stream m = open(mp, "mediapipe", 1.7);
  const int32_t kMediapipe[KATA_GPD_JOINTS] = {-1, -1, -1, -1, 11, 13, 15, 12, 14, 16, 23, 25, 27, 24, 26, 28};
  for (uint32_t g = 0; g < KATA_GPD_JOINTS; ++g) EXPECT_EQ(kata_stream_gpd_joint_source(m, g), kMediapipe[g]) << g;
  kata_stream_destroy(m);
  kata_skeleton_destroy(mp);
  // Parts: torso and head, then each limb's three joints in GPD order.
  const int32_t kPart[KATA_GPD_JOINTS] = {0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4};
  for (int32_t g = 0; g < KATA_GPD_JOINTS; ++g) EXPECT_EQ(kata_gpd_joint_part(g), kPart[g]) << g;
  EXPECT_EQ(kata_gpd_joint_part(-1), -1);
  EXPECT_EQ(kata_gpd_joint_part(KATA_GPD_JOINTS), -1);
  const char* const kParts[KATA_PART_COUNT] = {"torso_head", "left_arm", "right_arm", "left_leg", "right_leg"};
  for (int32_t p = 0; p < KATA_PART_COUNT; ++p) EXPECT_STREQ(kata_body_part_name(p), kParts[p]) << p;
  EXPECT_EQ(kata_body_part_name(-1), nullptr);
  EXPECT_EQ(kata_body_part_name(KATA_PART_COUNT), nullptr);
  // A cue joint's words are how kata_cue_text's phrase starts; the end joints have none.
  for (int32_t g = 0; g < KATA_GPD_JOINTS; ++g) {
    kata_result_record r;
    std::memset(&r, 0, sizeof r);
    r.struct_size = sizeof r;
    r.part_to_fix = kPart[g];
    r.cue_joint = g;
    r.cue_degrees = 30.0f;
    r.cue_action = KATA_CUE_RAISE;
    char text[64];
    kata_cue_text(&r, text, sizeof text);
    const char* words = kata_gpd_joint_words(g);
    ASSERT_NE(words, nullptr) << g;
    const bool end_joint = g == 3 || g == 6 || g == 9 || g == 12 || g == 15;
    EXPECT_EQ(words[0] == '\0', end_joint) << g;
    if (!end_joint) {
      EXPECT_EQ(std::string(text), std::string(words) + ": raise 30 deg") << g;
    }
  }
  EXPECT_STREQ(kata_gpd_joint_words(11), "left knee");
  EXPECT_EQ(kata_gpd_joint_words(-1), nullptr);
  EXPECT_EQ(kata_gpd_joint_words(KATA_GPD_JOINTS), nullptr);
}

// kata_teacher_desc.alignment_window (1.1): 0.5 teacher seconds by default, and for a caller's
// 1.0-sized struct; another window follows the student differently; out of range is refused.
// on_progress: called as the teacher's frames are done, ending at the clip's frames from first_frame.
struct Progress {
  std::vector<uint32_t> done;
  uint32_t frames = 0;
};
void on_progress(void* user, uint32_t done, uint32_t frames) {
  auto* p = static_cast<Progress*>(user);
  p->done.push_back(done);
  p->frames = frames;
}

TEST_F(TeacherCapi, AlignmentWindowAndLoadingProgress) {
  kata_clip other = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/02_02.bvh", &other), KATA_OK);
  kata_skeleton other_skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(other, &other_skel), KATA_OK);
  const uint32_t other_joints = kata_skeleton_joint_count(other_skel);
  // The matched teacher frames of 02_02's first 200 frames against 02_01 under a desc.
  auto matches = [&](const kata_teacher_desc& t) {
    kata_stream s = open(other_skel, "cmu");
    EXPECT_EQ(kata_stream_attach_teacher(s, &t), KATA_OK) << kata_stream_last_error(s);
    std::vector<float> p(3 * static_cast<size_t>(other_joints));
    for (uint32_t f = 1; f <= 200; ++f) {
      EXPECT_EQ(kata_clip_positions(other, f, p.data(), p.size()), KATA_OK);
      EXPECT_EQ(kata_stream_push(s, f / 120.0, p.data(), other_joints), KATA_OK);
    }
    std::vector<kata_result_record> r;
    drain(s, &r);
    kata_stream_destroy(s);
    std::vector<int32_t> m;
    for (const auto& x : r) m.push_back(x.matched_teacher_frame);
    return m;
  };
  kata_teacher_desc t = desc();
  EXPECT_EQ(t.alignment_window, 0.5);
  EXPECT_EQ(t.on_progress, nullptr);
  EXPECT_EQ(t.on_progress_user, nullptr);
  t.clip = clip;
  t.first_frame = kFirst;
  Progress progress;
  t.on_progress = on_progress;
  t.on_progress_user = &progress;
  const std::vector<int32_t> by_default = matches(t);
  ASSERT_GT(by_default.size(), 150u);
  ASSERT_FALSE(progress.done.empty());
  EXPECT_EQ(progress.frames, kata_clip_frame_count(clip) - kFirst);
  EXPECT_EQ(progress.done.back(), progress.frames);
  EXPECT_TRUE(std::is_sorted(progress.done.begin(), progress.done.end()));
  // A 1.0 caller's struct (up to body_height) gets the same window.
  kata_teacher_desc old;
  kata_teacher_desc_init_sized(&old, static_cast<uint32_t>(offsetof(kata_teacher_desc, body_height) + sizeof(double)));
  old.model = model;
  old.clip = clip;
  old.first_frame = kFirst;
  EXPECT_EQ(matches(old), by_default);
  t.on_progress = nullptr;
  t.alignment_window = 0.05;  // six teacher frames ahead at most without a re-localisation
  EXPECT_NE(matches(t), by_default);
  kata_stream s = open(other_skel, "cmu");
  for (double bad : {0.0, -0.5, 61.0, std::nan("")}) {
    t.alignment_window = bad;
    EXPECT_EQ(kata_stream_attach_teacher(s, &t), KATA_E_INVALID_ARGUMENT) << bad;
    EXPECT_NE(std::strstr(kata_stream_last_error(s), "alignment_window"), nullptr) << kata_stream_last_error(s);
  }
  kata_stream_destroy(s);
  kata_skeleton_destroy(other_skel);
  kata_clip_destroy(other);
}

// kata_teacher_desc.tolerance (1.1): NULL by default and for a 1.1 caller's struct (the normal
// map, the scores as before); "lenient" and a number of degrees give each part score the documented
// map 100 / (1 + (a / a50)^5) of the angle recovered here from the normal score (lenient 58, "33"
// 33), the matched frames unchanged; a shared teacher's streams take it from the teacher's desc or
// their own options; anything else is refused, naming the field.
TEST_F(TeacherCapi, ToleranceSetsThePartMap) {
  kata_clip other = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &other), KATA_OK);
  kata_skeleton other_skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(other, &other_skel), KATA_OK);
  const uint32_t other_joints = kata_skeleton_joint_count(other_skel);
  auto records = [&](const kata_teacher_desc* t, kata_teacher shared, const kata_teacher_desc* options) {
    kata_stream s = open(other_skel, "cmu");
    if (shared)
      EXPECT_EQ(kata_stream_attach_shared_teacher(s, shared, options), KATA_OK) << kata_stream_last_error(s);
    else
      EXPECT_EQ(kata_stream_attach_teacher(s, t), KATA_OK) << kata_stream_last_error(s);
    std::vector<float> p(3 * static_cast<size_t>(other_joints));
    for (uint32_t f = 1; f <= 150; ++f) {
      EXPECT_EQ(kata_clip_positions(other, f, p.data(), p.size()), KATA_OK);
      EXPECT_EQ(kata_stream_push(s, f / 120.0, p.data(), other_joints), KATA_OK);
    }
    std::vector<kata_result_record> r;
    drain(s, &r);
    kata_stream_destroy(s);
    return r;
  };
  kata_teacher_desc t = desc();
  EXPECT_EQ(t.tolerance, nullptr);
  t.clip = clip;
  t.first_frame = kFirst;
  t.ghost = 0;
  const std::vector<kata_result_record> normal = records(&t, nullptr, nullptr);
  ASSERT_GT(normal.size(), 100u);
  kata_teacher_desc old;  // a 1.1 caller's struct: up to on_progress_user
  kata_teacher_desc_init_sized(&old, static_cast<uint32_t>(offsetof(kata_teacher_desc, on_progress_user) + sizeof(void*)));
  old.model = model;
  old.clip = clip;
  old.first_frame = kFirst;
  old.ghost = 0;
  const std::vector<kata_result_record> as_11 = records(&old, nullptr, nullptr);
  ASSERT_EQ(as_11.size(), normal.size());
  for (size_t i = 0; i < normal.size(); ++i) EXPECT_EQ(as_11[i].score, normal[i].score);
  auto check = [&](const std::vector<kata_result_record>& got, double a50, const char* what) {
    ASSERT_EQ(got.size(), normal.size()) << what;
    int compared = 0;
    for (size_t i = 0; i < got.size(); ++i) {
      EXPECT_EQ(got[i].matched_teacher_frame, normal[i].matched_teacher_frame) << what;
      for (int q = 0; q < KATA_PART_COUNT; ++q) {
        const double n = normal[i].part_scores[q];
        if (!(n > 1e-3)) continue;  // no angle to recover from a score at float's floor
        const double angle = 40.0 * std::pow(std::max(0.0, 100.0 / n - 1.0), 0.2);
        EXPECT_NEAR(got[i].part_scores[q], 100.0 / (1.0 + std::pow(angle / a50, 5.0)), 0.05) << what << " " << i;
        ++compared;
      }
    }
    EXPECT_GT(compared, 500) << what;
  };
  t.tolerance = "lenient";
  check(records(&t, nullptr, nullptr), 58.0, "lenient");
  t.tolerance = "33";
  check(records(&t, nullptr, nullptr), 33.0, "33");
  // A shared teacher: the desc's tolerance is its streams' default; a stream's options replace it.
  t.tolerance = "lenient";
  kata_teacher shared = nullptr;
  ASSERT_EQ(kata_teacher_create(ctx, &t, &shared), KATA_OK) << kata_context_last_error(ctx);
  check(records(nullptr, shared, nullptr), 58.0, "shared lenient");
  kata_teacher_desc options;
  kata_teacher_desc_init(&options);
  options.ghost = 0;
  options.tolerance = "33";
  check(records(nullptr, shared, &options), 33.0, "shared, the stream's 33");
  kata_teacher_destroy(shared);
  kata_stream s = open(other_skel, "cmu");
  for (const char* bad : {"loose", "Lenient", "4", "121", "", "40 degrees"}) {
    t.tolerance = bad;
    EXPECT_EQ(kata_stream_attach_teacher(s, &t), KATA_E_INVALID_ARGUMENT) << bad;
    EXPECT_NE(std::strstr(kata_stream_last_error(s), "tolerance"), nullptr) << kata_stream_last_error(s);
  }
  kata_stream_destroy(s);
  kata_skeleton_destroy(other_skel);
  kata_clip_destroy(other);
}

}  // namespace
