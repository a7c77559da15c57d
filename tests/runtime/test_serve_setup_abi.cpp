// kata serve sets up each stream its ingest opens with the private RuntimeConfig::configure_stream
// (a Teacher built once per teacher path from the clip's positions with the CMU preset; ghost
// when the definition has a rest pose; the config's practice section as the alignment's options).
// The C ABI's way to do the same (kata_teacher_create once, kata_runtime_desc.on_stream_open
// attaching it with kata_stream_attach_shared_teacher and kata_stream_set_practice_section) must
// give the same results bit for bit, or serve cannot move onto it without changing its output.
// This test builds both, exactly as each is written, feeds both the same offered messages and
// compares every published record and ghost (all but the clock times).
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "kata/kata.h"
#include "pipeline/pipeline.hpp"
#include "runtime/runtime.hpp"
#include "support/capi_fixture.hpp"

namespace {

struct Collected {
  std::mutex mutex;
  std::vector<kata_result_record> records;
  std::vector<float> ghosts;
  void add(const kata_result_record& r) {
    std::lock_guard<std::mutex> lock(mutex);
    records.push_back(r);
    records.back().ghost = nullptr;
    if (r.ghost) ghosts.insert(ghosts.end(), r.ghost, r.ghost + 3 * r.ghost_joint_count);
  }
};

struct Hook {
  kata_teacher teacher = nullptr;
  int32_t first = 0, last = 0;
};
kata_status on_open(void* user, const kata_stream_open_info* info, kata_stream stream) {
  const Hook* h = static_cast<const Hook*>(user);
  kata_teacher_desc options;
  kata_teacher_desc_init(&options);
  options.ghost = info->has_rest_pose ? 1 : 0;
  if (const kata_status s = kata_stream_attach_shared_teacher(stream, h->teacher, &options)) return s;
  return kata_stream_set_practice_section(stream, h->first, h->last, 1);
}
void on_result(void* user, const kata_result_record* r) { static_cast<Collected*>(user)->add(*r); }

TEST(serve_setup_abi, TheCAbisStreamSetupScoresAndGhostsBitIdenticallyToServesConfigureStream) {
  const std::string model_path = std::string(KATA_SOURCE_DIR) + "/models/default.kata";
  const std::string teacher_path = std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh";
  const std::string student_path = std::string(KATA_DATA_DIR) + "/cmu/07_01.bvh";
  const int first = 40, last = 200;

  // The messages both runtimes are offered: two streams of the student clip (rest pose sent).
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_clip student = nullptr, teacher_clip = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, student_path.c_str(), &student), KATA_OK);
  ASSERT_EQ(kata_clip_load_bvh(ctx, teacher_path.c_str(), &teacher_clip), KATA_OK);
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(student, &skel), KATA_OK);
  const uint32_t joints = kata_skeleton_joint_count(skel);
  std::vector<std::vector<unsigned char>> messages;
  std::vector<unsigned char> buffer(1 << 16);
  size_t size = 0;
  for (uint64_t id : {uint64_t{3}, uint64_t{4}}) {
    kata_skeleton_message sm;
    kata_skeleton_message_init(&sm);
    sm.stream_id = id;
    sm.skeleton = skel;
    sm.layout = "cmu";
    ASSERT_EQ(kata_message_write_skeleton(&sm, buffer.data(), buffer.size(), &size), KATA_OK);
    messages.emplace_back(buffer.begin(), buffer.begin() + static_cast<long>(size));
  }
  std::vector<float> p(3 * joints);
  const int frames = 240;
  for (int i = 0; i < frames; ++i) {
    ASSERT_EQ(kata_clip_positions(student, static_cast<uint32_t>(1 + i), p.data(), p.size()), KATA_OK);
    for (uint64_t id : {uint64_t{3}, uint64_t{4}}) {
      kata_frame_message fm;
      kata_frame_message_init(&fm);
      fm.stream_id = id;
      fm.sequence = static_cast<uint64_t>(i);
      fm.capture_time = 10.0 + i / 128.0;
      fm.positions = p.data();
      fm.joint_count = joints;
      ASSERT_EQ(kata_message_write_frame(&fm, buffer.data(), buffer.size(), &size), KATA_OK);
      messages.emplace_back(buffer.begin(), buffer.begin() + static_cast<long>(size));
    }
  }

  // Serve's way (sdk/tools/cmd_serve.cpp: load_teacher, alignment_for, configure_stream).
  Collected served;
  {
    auto metric = std::make_shared<const kata::metric::Metric>(kata::metric::load_model(model_path));
    const kata::BvhClip clip = kata::load_bvh(teacher_path);
    const auto positions = kata::clip_positions(clip, 1);
    const kata::GpdMap map = kata::make_gpd_map(clip.skeleton, kata::preset_joint_names("cmu"));
    std::shared_ptr<const kata::pipeline::Teacher> teacher = kata::pipeline::Teacher::from_positions(
        metric, clip.skeleton, kata::stream_config_for(clip.skeleton, map, metric->stencil()), positions.data(),
        clip.frame_count() - 1, clip.frame_time, -1, {});
    kata::runtime::RuntimeConfig config;
    config.workers = 1;
    config.ingest.kind = kata::transport::IngestKind::kDirect;
    config.ingest.limits.max_frame_age_ns = 0;
    config.configure_stream = [&](const kata::transport::SkeletonDefinition& d) {
      kata::runtime::StreamSetup s = kata::runtime::setup_from_definition(d);
      s.pipeline.stream.stencil = metric->stencil();
      s.teacher = teacher;
      s.teacher_options.ghost = d.skeleton.has_rest_pose;
      s.teacher_options.alignment.first_frame = first;
      s.teacher_options.alignment.last_frame = last;
      s.teacher_options.alignment.loop = true;
      return s;
    };
    config.sinks.push_back({[&](const kata::transport::ResultFields& f) { served.add(f); }, {}});
    kata::runtime::Runtime runtime(config);
    for (const auto& m : messages) ASSERT_TRUE(runtime.offer(m.data(), m.size()));
    runtime.stop();
  }

  // The C ABI's way.
  Collected through_abi;
  {
    kata_model model = nullptr;
    ASSERT_EQ(kata_model_load(ctx, model_path.c_str(), &model), KATA_OK);
    const kata_teacher_desc td = kata::test::clip_teacher_desc(model, teacher_clip);
    Hook hook;
    hook.first = first;
    hook.last = last;
    ASSERT_EQ(kata_teacher_create(ctx, &td, &hook.teacher), KATA_OK) << kata_context_last_error(ctx);
    const kata_runtime_desc rd = kata::test::hooked_direct_ingest_desc(model, on_open, &hook, on_result, &through_abi);
    kata_runtime runtime = nullptr;
    ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
    for (const auto& m : messages) ASSERT_EQ(kata_runtime_offer(runtime, m.data(), m.size()), KATA_OK);
    ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);
    kata_runtime_destroy(runtime);
    kata_teacher_destroy(hook.teacher);
    kata_model_destroy(model);
  }

  ASSERT_EQ(served.records.size(), static_cast<size_t>(2 * frames));
  ASSERT_EQ(through_abi.records.size(), served.records.size());
  int scored = 0;
  for (size_t i = 0; i < served.records.size(); ++i) {
    SCOPED_TRACE(i);
    kata_result_record a = served.records[i], b = through_abi.records[i];
    scored += a.scored;
    for (kata_result_record* r : {&a, &b}) r->arrival_ns = r->computed_ns = r->published_ns = 0;  // clocks
    EXPECT_EQ(std::memcmp(&a, &b, sizeof a), 0) << "stream " << a.stream_id << " result " << a.result_sequence;
  }
  EXPECT_GT(scored, 2 * frames - 80);
  ASSERT_GT(served.ghosts.size(), 0u);
  ASSERT_EQ(through_abi.ghosts.size(), served.ghosts.size());
  EXPECT_EQ(std::memcmp(through_abi.ghosts.data(), served.ghosts.data(), served.ghosts.size() * sizeof(float)), 0);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(teacher_clip);
  kata_clip_destroy(student);
  kata_context_destroy(ctx);
}

}  // namespace
