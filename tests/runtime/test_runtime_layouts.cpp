// Streams announced to the runtime (ingest, kata serve) by a built-in layout name: a
// MediaPipe source's definition sets up its synthesised joints, its camera axes and smoothing, and
// its frames give the same features as a stream opened by hand with that layout.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "runtime/runtime.hpp"
#include "skeleton/skeleton.hpp"
#include "stream/stream.hpp"

namespace {

TEST(runtime_layouts, MediaPipeDefinitionUsesTheLayoutsAxesSmoothingAndSynthesis) {
  kata::transport::SkeletonDefinition d;
  d.stream_id = 3;
  d.skeleton = kata::layout_skeleton("mediapipe");
  d.layout = "mediapipe";
  d.up_axis = kata::UpAxis::kY;  // what the wire says; the layout fixes the camera axes
  const kata::runtime::StreamSetup setup = kata::runtime::setup_from_definition(d);
  const kata::StreamConfig& c = setup.pipeline.stream;
  EXPECT_EQ(c.up_axis, kata::UpAxis::kYDown);
  EXPECT_TRUE(c.smoothing);
  const kata::Layout layout = kata::resolve_layout(d.skeleton, "mediapipe");
  for (int g = 0; g < kata::kGpdJoints; ++g) {
    EXPECT_EQ(c.map.source[static_cast<size_t>(g)], layout.map.source[static_cast<size_t>(g)]) << g;
    EXPECT_EQ(c.map.blend[static_cast<size_t>(g)].count, layout.map.blend[static_cast<size_t>(g)].count) << g;
  }
  EXPECT_EQ(c.map.floor_count, layout.map.floor_count);

  // Same frames through both streams: same features.
  kata::StreamConfig by_hand;
  by_hand.map = layout.map;
  by_hand.input_joints = d.skeleton.joint_count();
  by_hand.up_axis = layout.axes;
  by_hand.smoothing = layout.smooth;
  kata::Stream a(c), b(by_hand);
  std::vector<float> frame(3 * 33);
  for (int f = 0; f < 20; ++f) {
    for (int i = 0; i < 33; ++i) {
      frame[3 * i] = 0.01f * static_cast<float>(i % 7) + 0.002f * static_cast<float>(f);
      frame[3 * i + 1] = -0.9f + 0.05f * static_cast<float>(i);  // y down: the feet (high ids) lowest
      frame[3 * i + 2] = 0.003f * static_cast<float>(i);
    }
    ASSERT_EQ(a.push(f / 30.0, frame.data(), 33), kata::Status::kOk) << a.last_error();
    ASSERT_EQ(b.push(f / 30.0, frame.data(), 33), kata::Status::kOk) << b.last_error();
  }
  ASSERT_EQ(a.emitted_count(), b.emitted_count());
  ASSERT_GT(a.emitted_count(), 0);
  for (int k = 0; k < kata::gpd::kDims; ++k) EXPECT_EQ(a.features()[k], b.features()[k]) << k;

  // A preset that names joints only keeps the wire's axes and no smoothing.
  kata::transport::SkeletonDefinition named = d;
  named.skeleton = kata::layout_skeleton("gpd");
  named.layout = "gpd";
  named.up_axis = kata::UpAxis::kZ;
  const kata::runtime::StreamSetup plain = kata::runtime::setup_from_definition(named);
  EXPECT_EQ(plain.pipeline.stream.up_axis, kata::UpAxis::kZ);
  EXPECT_FALSE(plain.pipeline.stream.smoothing);
}

}  // namespace
