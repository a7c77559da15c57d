// The retargeting section of the C ABI, through libkata and kata/kata.h only: a CMU teacher
// clip on another subject's bones (exact student bone lengths), the same subject (the teacher
// itself comes back), placement, argument errors, and no allocation per frame.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "support/alloc_counter.hpp"
#include "kata/kata.h"

namespace {

std::string clip_path(const char* name) { return std::string(KATA_DATA_DIR) + "/cmu/" + name; }

// A clip's frames as float positions, and its skeleton's parents.
struct Clip {
  kata_clip clip = nullptr;
  kata_skeleton skeleton = nullptr;
  uint32_t joints = 0;
  std::vector<int> parents;
  ~Clip() {
    kata_skeleton_destroy(skeleton);
    kata_clip_destroy(clip);
  }
  std::vector<float> frame(uint32_t f) const {
    std::vector<float> x(3 * joints);
    EXPECT_EQ(kata_clip_positions(clip, f, x.data(), x.size()), KATA_OK);
    return x;
  }
};

void load(kata_context ctx, const char* name, Clip* c) {
  ASSERT_EQ(kata_clip_load_bvh(ctx, clip_path(name).c_str(), &c->clip), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_clip_skeleton(c->clip, &c->skeleton), KATA_OK);
  c->joints = kata_skeleton_joint_count(c->skeleton);
  for (uint32_t j = 0; j < c->joints; ++j) c->parents.push_back(kata_skeleton_joint_parent(c->skeleton, j));
}

float dist(const float* a, const float* b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

class RetargetCapi : public testing::Test {
 protected:
  void SetUp() override { ASSERT_EQ(kata_context_create(&ctx_), KATA_OK); }
  void TearDown() override { kata_context_destroy(ctx_); }
  kata_context ctx_ = nullptr;
};

TEST_F(RetargetCapi, GhostHasTheStudentsBonesAndNoAllocationPerFrame) {
  Clip teacher, student;
  load(ctx_, "05_02.bvh", &teacher);
  load(ctx_, "02_01.bvh", &student);
  kata_retargeter rt = nullptr;
  ASSERT_EQ(kata_retargeter_create(ctx_, student.skeleton, nullptr, &rt), KATA_OK) << kata_context_last_error(ctx_);
  const uint32_t n = kata_retargeter_joint_count(rt);
  ASSERT_EQ(n, 21u);
  // Output joint -> skeleton joint, and the output tree: the nearest selected ancestor.
  std::vector<int> source(n), out_of(student.joints, -1), parent(n, -1);
  for (uint32_t k = 0; k < n; ++k) {
    source[k] = kata_retargeter_joint_source(rt, k);
    out_of[static_cast<size_t>(source[k])] = static_cast<int>(k);
  }
  for (uint32_t k = 1; k < n; ++k) {
    int a = student.parents[static_cast<size_t>(source[k])];
    while (out_of[static_cast<size_t>(a)] < 0) a = student.parents[static_cast<size_t>(a)];
    parent[k] = out_of[static_cast<size_t>(a)];
  }
  // Student bone lengths, measured on one of its own frames (bones are rigid).
  const std::vector<float> s = student.frame(10);
  std::vector<float> ghost(3 * n);
  kata_retarget_info info;
  info.struct_size = sizeof info;
  std::vector<std::vector<float>> frames;
  for (uint32_t f = 1; f < 240; ++f) frames.push_back(teacher.frame(f));
  ASSERT_EQ(kata_retargeter_solve(rt, frames[0].data(), teacher.joints, ghost.data(), ghost.size(), &info), KATA_OK);
  EXPECT_EQ(info.warm, 0);
  const long before = kata::test::allocations();
  float worst = 0.0f;
  for (const auto& t : frames) {
    ASSERT_EQ(kata_retargeter_solve(rt, t.data(), teacher.joints, ghost.data(), ghost.size(), &info), KATA_OK)
        << kata_retargeter_last_error(rt);
    for (uint32_t k = 1; k < n; ++k) {
      const float want = dist(&s[3 * static_cast<size_t>(source[k])], &s[3 * static_cast<size_t>(source[static_cast<size_t>(parent[k])])]);
      worst = std::max(worst, std::fabs(dist(&ghost[3 * k], &ghost[3 * static_cast<size_t>(parent[k])]) - want) / want);
    }
    // Root on the teacher's root.
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(ghost[static_cast<size_t>(c)], t[static_cast<size_t>(c)], 1e-4f);
  }
  ASSERT_EQ(kata_retargeter_place(rt, s.data(), student.joints, ghost.data(), ghost.size()), KATA_OK);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(ghost[static_cast<size_t>(c)], s[static_cast<size_t>(c)], 1e-4f);
  ASSERT_EQ(kata_retargeter_reset(rt), KATA_OK);
  ASSERT_EQ(kata_retargeter_solve(rt, frames[5].data(), teacher.joints, ghost.data(), ghost.size(), &info), KATA_OK);
  EXPECT_EQ(info.warm, 0);
  const long allocated = kata::test::allocations() - before;
  if (kata::test::kAllocCounting) {
    EXPECT_EQ(allocated, 0);  // (counting is off under AddressSanitizer)
  }
  EXPECT_LT(worst, 1e-5f);                   // float output of exact bones
  EXPECT_GT(info.max_bone_error_solved, 0.0);  // the optimum alone does not keep them
  EXPECT_LT(info.max_bone_error, 1e-9);
  kata_retargeter_destroy(rt);
}

TEST_F(RetargetCapi, SameSubjectGivesTheTeacherBack) {
  Clip teacher;
  load(ctx_, "02_02.bvh", &teacher);
  Clip student;
  load(ctx_, "02_01.bvh", &student);  // the same subject: identical bones
  // (The "cmu" preset: its bones are rigid in both clips. The GPD tree's are not - e.g. Neck to
  // shoulder moves with the neck - so there even the same subject gives a non-zero stress.)
  kata_retarget_desc desc;
  kata_retarget_desc_init(&desc);
  desc.gradient_tolerance = 1e-9;
  desc.max_iterations = 10000;
  kata_retargeter rt = nullptr;
  ASSERT_EQ(kata_retargeter_create(ctx_, student.skeleton, &desc, &rt), KATA_OK) << kata_context_last_error(ctx_);
  const uint32_t n = kata_retargeter_joint_count(rt);
  ASSERT_EQ(n, 21u);
  std::vector<float> ghost(3 * n);
  kata_retarget_info info;
  info.struct_size = sizeof info;
  for (uint32_t f = 1; f < 100; f += 7) {
    const std::vector<float> t = teacher.frame(f);
    ASSERT_EQ(kata_retargeter_solve(rt, t.data(), teacher.joints, ghost.data(), ghost.size(), &info), KATA_OK);
    EXPECT_LT(info.stress, 1e-8);
    for (uint32_t k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(ghost[3 * k + static_cast<uint32_t>(c)],
                    t[3 * static_cast<size_t>(kata_retargeter_joint_source(rt, k)) + static_cast<size_t>(c)], 1e-3f);
  }
  kata_retargeter_destroy(rt);
}

TEST_F(RetargetCapi, GpdPresetGivesSixteenJointsWithTheStudentsLengths) {
  Clip teacher, student;
  load(ctx_, "09_01.bvh", &teacher);
  load(ctx_, "07_01.bvh", &student);
  kata_retarget_desc desc;
  kata_retarget_desc_init(&desc);
  desc.joint_set = "gpd";
  kata_retargeter rt = nullptr;
  ASSERT_EQ(kata_retargeter_create_for_stream(ctx_, nullptr, &desc, &rt), KATA_E_NULL_POINTER);
  ASSERT_EQ(kata_retargeter_create(ctx_, student.skeleton, &desc, &rt), KATA_OK) << kata_context_last_error(ctx_);
  ASSERT_EQ(kata_retargeter_joint_count(rt), 16u);
  std::vector<float> ghost(48);
  kata_retarget_info info;
  info.struct_size = sizeof info;
  for (uint32_t f = 1; f < 100; f += 9) {
    const std::vector<float> t = teacher.frame(f);
    ASSERT_EQ(kata_retargeter_solve(rt, t.data(), teacher.joints, ghost.data(), ghost.size(), &info), KATA_OK);
    EXPECT_LT(info.max_bone_error, 1e-9);
    for (float g : ghost) EXPECT_TRUE(std::isfinite(g));
  }
  kata_retargeter_destroy(rt);
}

TEST_F(RetargetCapi, ErrorsAreStatusesWithMessages) {
  Clip student;
  load(ctx_, "07_01.bvh", &student);
  kata_retargeter rt = nullptr;
  kata_retarget_desc desc;
  kata_retarget_desc_init(&desc);
  desc.joint_set = "nope";
  EXPECT_EQ(kata_retargeter_create(ctx_, student.skeleton, &desc, &rt), KATA_E_NOT_FOUND);
  EXPECT_NE(std::string(kata_context_last_error(ctx_)).find("nope"), std::string::npos);
  EXPECT_EQ(rt, nullptr);
  EXPECT_EQ(kata_retargeter_create(ctx_, nullptr, nullptr, &rt), KATA_E_NULL_POINTER);
  // A bare skeleton without rest offsets has no bone lengths.
  const char* names[] = {"a", "b"};
  const int32_t parents[] = {-1, 0};
  kata_skeleton bare = nullptr;
  ASSERT_EQ(kata_skeleton_create(ctx_, 2, names, parents, nullptr, &bare), KATA_OK);
  EXPECT_EQ(kata_retargeter_create(ctx_, bare, nullptr, &rt), KATA_E_INVALID_ARGUMENT);
  kata_skeleton_destroy(bare);

  ASSERT_EQ(kata_retargeter_create(ctx_, student.skeleton, nullptr, &rt), KATA_OK);
  std::vector<float> t = student.frame(3), ghost(3 * kata_retargeter_joint_count(rt));
  EXPECT_EQ(kata_retargeter_solve(rt, t.data(), 30, ghost.data(), ghost.size(), nullptr), KATA_E_WRONG_JOINT_COUNT);
  EXPECT_EQ(kata_retargeter_solve(rt, t.data(), student.joints, ghost.data(), 10, nullptr), KATA_E_BUFFER_TOO_SMALL);
  EXPECT_NE(std::string(kata_retargeter_last_error(rt)), "");
  t[7] = NAN;
  EXPECT_EQ(kata_retargeter_solve(rt, t.data(), student.joints, ghost.data(), ghost.size(), nullptr), KATA_E_NON_FINITE);
  t = student.frame(3);
  EXPECT_EQ(kata_retargeter_solve(rt, t.data(), student.joints, ghost.data(), ghost.size(), nullptr), KATA_OK);
  EXPECT_STREQ(kata_retargeter_last_error(rt), "");
  EXPECT_EQ(kata_retargeter_solve(nullptr, t.data(), student.joints, ghost.data(), ghost.size(), nullptr),
            KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_retargeter_joint_count(nullptr), 0u);
  EXPECT_EQ(kata_retargeter_joint_source(rt, 999), -1);
  kata_retargeter_destroy(rt);
  kata_retargeter_destroy(nullptr);
}

}  // namespace
