// Public C ABI tests (link only libkata): streams from user skeletons and name maps, Z-up input,
// error reporting per handle, and no allocation per frame through the ABI.
#include <gtest/gtest.h>

#include "support/temp_paths.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "kata/kata.h"
#include "support/alloc_counter.hpp"

namespace {

struct Clip {
  kata_context ctx = nullptr;
  kata_clip clip = nullptr;
  kata_skeleton skel = nullptr;
  std::vector<std::vector<float>> frames;
  Clip() {
    EXPECT_EQ(kata_context_create(&ctx), KATA_OK);
    EXPECT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &clip), KATA_OK) << kata_context_last_error(ctx);
    EXPECT_EQ(kata_clip_skeleton(clip, &skel), KATA_OK);
    const uint32_t n = kata_skeleton_joint_count(skel);
    for (uint32_t i = 1; i < kata_clip_frame_count(clip); ++i) {
      std::vector<float> p(3 * n);
      EXPECT_EQ(kata_clip_positions(clip, i, p.data(), p.size()), KATA_OK);
      frames.push_back(p);
    }
  }
  ~Clip() {
    kata_skeleton_destroy(skel);
    kata_clip_destroy(clip);
    kata_context_destroy(ctx);
  }
  uint32_t joints() const { return kata_skeleton_joint_count(skel); }
};

std::vector<std::vector<float>> run(kata_stream s, const std::vector<std::vector<float>>& frames, uint32_t joints) {
  std::vector<std::vector<float>> out;
  std::vector<float> f(KATA_GPD_DIMS);
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(kata_stream_push(s, static_cast<double>(i) / 120.0, frames[i].data(), joints), KATA_OK)
        << kata_stream_last_error(s);
    if (kata_stream_features(s, f.data(), f.size(), nullptr, nullptr) == KATA_OK) out.push_back(f);
  }
  return out;
}

TEST(CApi, NoAllocationPerFrame) {
  if (!kata::test::kAllocCounting) GTEST_SKIP() << "allocation counting is off under AddressSanitizer";
  Clip c;
  for (kata_stencil stencil : {KATA_STENCIL_BACKWARD, KATA_STENCIL_CENTRAL}) {
    kata_stream_desc desc;
    kata_stream_desc_init(&desc);
    desc.layout = "cmu";
    desc.stencil = stencil;
    kata_stream s = nullptr;
    ASSERT_EQ(kata_stream_open(c.ctx, c.skel, &desc, &s), KATA_OK);
    std::vector<float> f(KATA_GPD_DIMS);
    double t = 0;
    int64_t idx = 0;
    const long before = kata::test::allocations();
    for (size_t i = 0; i < c.frames.size(); ++i) {
      kata_stream_push(s, static_cast<double>(i) / 120.0, c.frames[i].data(), c.joints());
      kata_stream_push(s, 0.0, c.frames[i].data(), c.joints());  // refused: timestamp goes back
      kata_stream_features(s, f.data(), f.size(), &t, &idx);
    }
    kata_stream_flush(s);
    kata_stream_features(s, f.data(), f.size(), &t, &idx);
    EXPECT_EQ(kata::test::allocations() - before, 0);
    EXPECT_EQ(idx, static_cast<int64_t>(c.frames.size()) - 1);
    kata_stream_destroy(s);
  }
}

TEST(CApi, ZUpInputGivesTheSameFeatures) {
  Clip c;
  kata_stream_desc desc;
  kata_stream_desc_init(&desc);
  desc.layout = "cmu";
  kata_stream y = nullptr, z = nullptr;
  ASSERT_EQ(kata_stream_open(c.ctx, c.skel, &desc, &y), KATA_OK);
  desc.up_axis = KATA_UP_Z;
  ASSERT_EQ(kata_stream_open(c.ctx, c.skel, &desc, &z), KATA_OK);
  auto zup = c.frames;
  for (auto& f : zup)
    for (size_t j = 0; j < f.size(); j += 3) {
      const float yv = f[j + 1], zv = f[j + 2];
      f[j + 1] = -zv;  // Z-up world: (x, y, z)_Yup = (x, z, -y)_Zup  =>  y_Zup = -z_Yup, z_Zup = y_Yup
      f[j + 2] = yv;
    }
  const auto a = run(y, c.frames, c.joints());
  const auto b = run(z, zup, c.joints());
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i)
    for (int d = 0; d < KATA_GPD_DIMS; ++d) ASSERT_EQ(a[i][d], b[i][d]) << "frame " << i << " dim " << d;
  kata_stream_destroy(y);
  kata_stream_destroy(z);
}

TEST(CApi, UserSkeletonWithNameMapAndNoRestPoseCalibratesHeight) {
  Clip c;
  // The same skeleton given as bare arrays (no rest offsets) and mapped by a user JSON file.
  const uint32_t n = c.joints();
  std::vector<const char*> names(n);
  std::vector<int32_t> parents(n);
  for (uint32_t i = 0; i < n; ++i) {
    names[i] = kata_skeleton_joint_name(c.skel, i);
    parents[i] = kata_skeleton_joint_parent(c.skel, i);
  }
  kata_skeleton bare = nullptr;
  ASSERT_EQ(kata_skeleton_create(c.ctx, n, names.data(), parents.data(), nullptr, &bare), KATA_OK);
  const std::string map_path = kata::test::temp_path("kata_cmu_map.json");
  {
    std::ofstream m(map_path);
    m << R"({"Hip": "Hips", "Chest": "Spine1", "Neck": "Neck1", "Head": "Head",
             "LShoulder": "LeftArm", "LElbow": "LeftForeArm", "LHand": "LeftHand",
             "RShoulder": "RightArm", "RElbow": "RightForeArm", "RHand": "RightHand",
             "LHip": "LeftUpLeg", "LKnee": "LeftLeg", "LFoot": "LeftFoot",
             "RHip": "RightUpLeg", "RKnee": "RightLeg", "RFoot": "RightFoot"})";
  }
  kata_stream_desc desc;
  kata_stream_desc_init(&desc);
  desc.name_map_path = map_path.c_str();
  desc.calibration_frames = 9;
  kata_stream s = nullptr;
  ASSERT_EQ(kata_stream_open(c.ctx, bare, &desc, &s), KATA_OK) << kata_context_last_error(c.ctx);
  std::vector<float> f(KATA_GPD_DIMS);
  for (int i = 0; i < 8; ++i) {
    ASSERT_EQ(kata_stream_push(s, i / 120.0, c.frames[i].data(), n), KATA_OK);
    EXPECT_EQ(kata_stream_features(s, f.data(), f.size(), nullptr, nullptr), KATA_NO_DATA);
  }
  ASSERT_EQ(kata_stream_push(s, 8 / 120.0, c.frames[8].data(), n), KATA_OK);
  int64_t idx = -1;
  EXPECT_EQ(kata_stream_features(s, f.data(), f.size(), nullptr, &idx), KATA_OK);
  EXPECT_EQ(idx, 8);
  // Bones are rigid in mocap: the median lengths give (nearly) the rest-pose height.
  kata_stream_desc rest_desc;
  kata_stream_desc_init(&rest_desc);
  rest_desc.layout = "cmu";
  kata_stream r = nullptr;
  ASSERT_EQ(kata_stream_open(c.ctx, c.skel, &rest_desc, &r), KATA_OK);
  EXPECT_NEAR(kata_stream_body_height(s), kata_stream_body_height(r), 1e-3 * kata_stream_body_height(r));
  kata_stream_destroy(r);
  kata_stream_destroy(s);

  // A map naming a joint the skeleton lacks is refused with its name.
  {
    std::ofstream m(map_path);
    m << R"({"Hip": "Pelvis", "Chest": "Spine1", "Neck": "Neck1", "Head": "Head",
             "LShoulder": "LeftArm", "LElbow": "LeftForeArm", "LHand": "LeftHand",
             "RShoulder": "RightArm", "RElbow": "RightForeArm", "RHand": "RightHand",
             "LHip": "LeftUpLeg", "LKnee": "LeftLeg", "LFoot": "LeftFoot",
             "RHip": "RightUpLeg", "RKnee": "RightLeg", "RFoot": "RightFoot"})";
  }
  EXPECT_EQ(kata_stream_open(c.ctx, bare, &desc, &s), KATA_E_NOT_FOUND);
  EXPECT_NE(std::string(kata_context_last_error(c.ctx)).find("Pelvis"), std::string::npos)
      << kata_context_last_error(c.ctx);
  kata_skeleton_destroy(bare);
  std::remove(map_path.c_str());
}

TEST(CApi, BadSkeletonsAndArgumentsAreRefused) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  const char* names[] = {"a", "b", "c"};
  const int32_t bad_parents[] = {-1, 2, 0};  // parent after child
  kata_skeleton s = nullptr;
  EXPECT_EQ(kata_skeleton_create(ctx, 3, names, bad_parents, nullptr, &s), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(s, nullptr);
  EXPECT_GT(std::string(kata_context_last_error(ctx)).size(), 0u);
  const char* dup[] = {"a", "b", "a"};
  const int32_t parents[] = {-1, 0, 1};
  EXPECT_EQ(kata_skeleton_create(ctx, 3, dup, parents, nullptr, &s), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(kata_skeleton_create(ctx, 3, names, nullptr, nullptr, &s), KATA_E_NULL_POINTER);
  ASSERT_EQ(kata_skeleton_create(ctx, 3, names, parents, nullptr, &s), KATA_OK);
  kata_stream_desc desc;
  kata_stream_desc_init(&desc);
  desc.layout = "cmu";
  kata_stream st = nullptr;
  EXPECT_EQ(kata_stream_open(ctx, s, &desc, &st), KATA_E_NOT_FOUND) << "the cmu joints are missing";
  desc.struct_size = 4;
  EXPECT_EQ(kata_stream_open(ctx, s, &desc, &st), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(kata_layout_name(0), nullptr);
  EXPECT_EQ(std::string(kata_layout_name(0)), "cmu");
  kata_skeleton_destroy(s);
  kata_context_destroy(ctx);
}

}  // namespace
