// The ingest message writers of the C ABI (kata/runtime.h, kata_message_write_*, since 1.1): the
// bytes they write are the runtime's own wire codec's (transport::Encoder) for the same values,
// and the runtime's Decoder reads them back to those values; a too-small buffer says the size it
// needs and writes nothing; a frame with a NaN or infinite coordinate is refused; the message
// structs follow the one struct-size rule (kata/core.h "Versions").
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "io/bvh.hpp"
#include "kata/kata.h"
#include "transport/wire.hpp"

namespace {

using kata::transport::Bytes;
using kata::transport::Decoder;
using kata::transport::Encoder;
using kata::transport::MessageKind;

const std::string kClip = std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh";

std::vector<uint8_t> bytes_of(Bytes m) { return std::vector<uint8_t>(m.data, m.data + m.size); }

// Writes through a C writer into a vector of exactly the size it asks for.
template <typename Message, typename Write>
std::vector<uint8_t> written(Write write, const Message& message) {
  size_t size = 1234;
  EXPECT_EQ(write(&message, nullptr, 0, &size), KATA_E_BUFFER_TOO_SMALL);
  std::vector<uint8_t> out(size);
  size_t wrote = 0;
  EXPECT_EQ(write(&message, out.data(), out.size(), &wrote), KATA_OK) << kata_context_last_error(nullptr);
  EXPECT_EQ(wrote, size);
  return out;
}

// A clip's skeleton, as the C ABI and the core each hold it.
struct Clip {
  kata_context context = nullptr;
  kata_clip clip = nullptr;
  kata_skeleton skeleton = nullptr;
  kata::BvhClip core = kata::load_bvh(kClip);
  Clip() {
    EXPECT_EQ(kata_context_create(&context), KATA_OK);
    EXPECT_EQ(kata_clip_load_bvh(context, kClip.c_str(), &clip), KATA_OK);
    EXPECT_EQ(kata_clip_skeleton(clip, &skeleton), KATA_OK);
  }
  ~Clip() {
    kata_skeleton_destroy(skeleton);
    kata_clip_destroy(clip);
    kata_context_destroy(context);
  }
  Clip(const Clip&) = delete;
  Clip& operator=(const Clip&) = delete;
};

TEST(runtime_message_writer, SkeletonIsTheEncodersBytesAndDecodesToItsValues) {
  Clip c;
  kata_skeleton_message m;
  kata_skeleton_message_init(&m);
  EXPECT_EQ(m.struct_size, sizeof m);
  EXPECT_EQ(m.revision, 1u);
  EXPECT_EQ(m.up_axis, KATA_UP_Y);
  m.stream_id = 0x42;
  m.revision = 3;
  m.skeleton = c.skeleton;
  m.layout = "cmu";
  m.frame_rate = 120.0f;
  m.metres_per_unit = 0.056444f;
  const std::vector<uint8_t> out = written(kata_message_write_skeleton, m);

  kata::transport::SkeletonDefinition d;
  d.stream_id = 0x42;
  d.revision = 3;
  d.skeleton = c.core.skeleton;
  d.layout = "cmu";
  d.frame_rate = 120.0f;
  d.metres_per_unit = 0.056444f;
  Encoder encoder;
  EXPECT_EQ(out, bytes_of(encoder.skeleton(d)));

  Decoder decoder;
  ASSERT_EQ(decoder.decode(out.data(), out.size()), MessageKind::kSkeleton);
  const kata::transport::SkeletonDefinition back = decoder.skeleton();
  EXPECT_EQ(back.stream_id, 0x42u);
  EXPECT_EQ(back.revision, 3u);
  EXPECT_EQ(back.skeleton.names, c.core.skeleton.names);
  EXPECT_EQ(back.skeleton.parents, c.core.skeleton.parents);
  ASSERT_TRUE(back.skeleton.has_rest_pose);
  for (size_t j = 0; j < back.skeleton.offsets.size(); ++j)
    EXPECT_TRUE(back.skeleton.offsets[j].isApprox(c.core.skeleton.offsets[j].cast<float>().cast<double>(), 0.0)) << j;
  EXPECT_EQ(back.layout, "cmu");
  EXPECT_TRUE(back.name_map.empty());
  EXPECT_EQ(back.up_axis, kata::UpAxis::kY);
  EXPECT_EQ(back.frame_rate, 120.0f);
  EXPECT_EQ(back.metres_per_unit, 0.056444f);
  EXPECT_FALSE(back.closed);

  // A name map instead of a layout, Z up, closing the stream.
  const char* names[KATA_GPD_JOINTS] = {"Hips",     "Spine1",   "Neck1",   "Head",      "LeftArm",  "LeftForeArm",
                                        "LeftHand", "RightArm", "RightForeArm", "RightHand", "LeftUpLeg", "LeftLeg",
                                        "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot"};
  m.layout = nullptr;
  m.name_map = names;
  m.up_axis = KATA_UP_Z;
  m.closed = 1;
  const std::vector<uint8_t> mapped = written(kata_message_write_skeleton, m);
  d.layout.clear();
  d.name_map.assign(names, names + KATA_GPD_JOINTS);
  d.up_axis = kata::UpAxis::kZ;
  d.closed = true;
  EXPECT_EQ(mapped, bytes_of(encoder.skeleton(d)));
  ASSERT_EQ(decoder.decode(mapped.data(), mapped.size()), MessageKind::kSkeleton);
  const kata::transport::SkeletonDefinition back2 = decoder.skeleton();
  EXPECT_EQ(back2.name_map, d.name_map);
  EXPECT_EQ(back2.up_axis, kata::UpAxis::kZ);
  EXPECT_TRUE(back2.closed);

  // A skeleton without rest pose (a bare live source) goes without offsets.
  kata_skeleton bare = nullptr;
  ASSERT_EQ(kata_skeleton_create_layout(c.context, "mediapipe", &bare), KATA_OK);
  kata_skeleton_message b;
  kata_skeleton_message_init(&b);
  b.stream_id = 7;
  b.skeleton = bare;
  b.layout = "mediapipe";
  const std::vector<uint8_t> landmarks = written(kata_message_write_skeleton, b);
  ASSERT_EQ(decoder.decode(landmarks.data(), landmarks.size()), MessageKind::kSkeleton);
  EXPECT_FALSE(decoder.skeleton().skeleton.has_rest_pose);
  EXPECT_EQ(decoder.skeleton_joints(), 33);
  kata_skeleton_destroy(bare);

  // The result reader takes it for what it is: a valid kata message that is no result.
  kata_result_record r;
  r.struct_size = sizeof r;
  EXPECT_EQ(kata_message_read_result(out.data(), out.size(), &r), KATA_NO_DATA);
}

TEST(runtime_message_writer, SkeletonRefusals) {
  Clip c;
  std::vector<uint8_t> buffer(1 << 16, 0xcd);
  size_t size = 99;
  kata_skeleton_message m;
  kata_skeleton_message_init(&m);
  m.skeleton = c.skeleton;
  // Neither a layout nor a name map; then both.
  EXPECT_EQ(kata_message_write_skeleton(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(size, 0u);
  EXPECT_NE(std::string(kata_context_last_error(c.context)).find("layout"), std::string::npos);
  const char* names[KATA_GPD_JOINTS] = {};
  m.layout = "cmu";
  m.name_map = names;
  EXPECT_EQ(kata_message_write_skeleton(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  m.layout = nullptr;  // a name map with NULL entries
  EXPECT_EQ(kata_message_write_skeleton(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  m.name_map = nullptr;
  m.layout = "cmu";
  m.up_axis = KATA_UP_Y_DOWN;  // the message carries Y or Z up only
  EXPECT_EQ(kata_message_write_skeleton(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  m.up_axis = KATA_UP_Y;
  m.frame_rate = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(kata_message_write_skeleton(&m, buffer.data(), buffer.size(), &size), KATA_E_NON_FINITE);
  m.frame_rate = -1.0f;
  EXPECT_EQ(kata_message_write_skeleton(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  m.frame_rate = 0.0f;
  m.closed = 2;
  EXPECT_EQ(kata_message_write_skeleton(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  m.closed = 0;
  m.skeleton = nullptr;
  EXPECT_EQ(kata_message_write_skeleton(&m, buffer.data(), buffer.size(), &size), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_message_write_skeleton(nullptr, buffer.data(), buffer.size(), &size), KATA_E_NULL_POINTER);
  m.skeleton = c.skeleton;
  EXPECT_EQ(kata_message_write_skeleton(&m, buffer.data(), buffer.size(), nullptr), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_message_write_skeleton(&m, nullptr, 16, &size), KATA_E_NULL_POINTER);
  for (uint8_t b : buffer) ASSERT_EQ(b, 0xcd);  // nothing written by any refusal
  EXPECT_EQ(kata_message_write_skeleton(&m, buffer.data(), buffer.size(), &size), KATA_OK);
}

TEST(runtime_message_writer, FrameIsTheEncodersBytesAndDecodesToItsValues) {
  const int joints = 31;
  std::vector<float> xyz(3 * joints), confidence(joints);
  for (int i = 0; i < 3 * joints; ++i) xyz[static_cast<size_t>(i)] = 0.25f * static_cast<float>(i) - 7.0f;
  for (int j = 0; j < joints; ++j) confidence[static_cast<size_t>(j)] = static_cast<float>(j) / joints;
  confidence[4] = std::numeric_limits<float>::quiet_NaN();  // a missing joint is sent as such

  kata_frame_message m;
  kata_frame_message_init(&m);
  EXPECT_EQ(m.struct_size, sizeof m);
  EXPECT_EQ(m.confidences, nullptr);
  m.stream_id = 0xfeedu;
  m.sequence = 1234567;
  m.capture_time = 1712345678.123456789;  // an epoch-scale clock: kept to the ns, rounded
  m.positions = xyz.data();
  m.joint_count = joints;
  const std::vector<uint8_t> plain = written(kata_message_write_frame, m);
  m.confidences = confidence.data();
  const std::vector<uint8_t> confident = written(kata_message_write_frame, m);
  // With presences (1.1): the encoder's bytes with both channels; the decoder's confidence is the
  // smaller of the two per joint (schemas/frame.fbs), checked against values computed here.
  std::vector<float> presence(joints);
  for (int j = 0; j < joints; ++j) presence[static_cast<size_t>(j)] = 1.0f - static_cast<float>(j) / (2 * joints);
  EXPECT_EQ(m.presences, nullptr);
  m.presences = presence.data();
  const std::vector<uint8_t> present = written(kata_message_write_frame, m);
  m.presences = nullptr;

  const int64_t capture_ns = static_cast<int64_t>(std::round(m.capture_time * 1e9));
  Encoder encoder;
  EXPECT_EQ(plain, bytes_of(encoder.frame(0xfeedu, 1234567, capture_ns, xyz.data(), joints)));
  EXPECT_EQ(confident, bytes_of(encoder.frame(0xfeedu, 1234567, capture_ns, xyz.data(), joints, confidence.data())));

  Decoder decoder(1 << 20, true);  // the ingest's: checksum required
  ASSERT_EQ(decoder.decode(confident.data(), confident.size()), MessageKind::kFrame)
      << kata::transport::decode_error_name(decoder.error());
  const kata::transport::FrameView& f = decoder.frame();
  EXPECT_EQ(f.stream_id, 0xfeedu);
  EXPECT_EQ(f.sequence, 1234567u);
  EXPECT_EQ(f.capture_ns, capture_ns);
  EXPECT_NEAR(static_cast<double>(f.capture_ns) * 1e-9, 1712345678.123456789, 1e-6);
  ASSERT_EQ(f.joints, joints);
  for (int i = 0; i < 3 * joints; ++i) EXPECT_EQ(f.xyz[i], xyz[static_cast<size_t>(i)]) << i;
  ASSERT_NE(f.confidence, nullptr);
  for (int j = 0; j < joints; ++j)
    if (j == 4) EXPECT_TRUE(std::isnan(f.confidence[j]));
    else EXPECT_EQ(f.confidence[j], confidence[static_cast<size_t>(j)]) << j;
  ASSERT_EQ(decoder.decode(plain.data(), plain.size()), MessageKind::kFrame);
  EXPECT_EQ(decoder.frame().confidence, nullptr);
  {
    const int64_t ns = static_cast<int64_t>(std::round(m.capture_time * 1e9));
    EXPECT_EQ(present, bytes_of(Encoder().frame(0xfeedu, 1234567, ns, xyz.data(), joints, confidence.data(), presence.data())));
    ASSERT_EQ(decoder.decode(present.data(), present.size()), MessageKind::kFrame)
        << kata::transport::decode_error_name(decoder.error());
    ASSERT_NE(decoder.frame().confidence, nullptr);
    for (int j = 0; j < joints; ++j) {
      const float c = confidence[static_cast<size_t>(j)], p = presence[static_cast<size_t>(j)];
      if (j == 4) EXPECT_TRUE(std::isnan(decoder.frame().confidence[j]));
      else EXPECT_EQ(decoder.frame().confidence[j], std::min(c, p)) << j;
    }
    EXPECT_NE(present, confident) << "the presence channel is on the wire";
  }

  kata_result_record r;
  r.struct_size = sizeof r;
  EXPECT_EQ(kata_message_read_result(plain.data(), plain.size(), &r), KATA_NO_DATA);
}

TEST(runtime_message_writer, TooSmallABufferSaysTheSizeAndWritesNothing) {
  const float xyz[6] = {1, 2, 3, 4, 5, 6};
  kata_frame_message m;
  kata_frame_message_init(&m);
  m.stream_id = 5;
  m.positions = xyz;
  m.joint_count = 2;
  size_t needed = 0;
  ASSERT_EQ(kata_message_write_frame(&m, nullptr, 0, &needed), KATA_E_BUFFER_TOO_SMALL);
  Encoder encoder;
  EXPECT_EQ(needed, encoder.frame(5, 0, 0, xyz, 2).size);
  std::vector<uint8_t> buffer(needed + 8, 0xcd);
  size_t size = 0;
  EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), needed - 1, &size), KATA_E_BUFFER_TOO_SMALL);
  EXPECT_EQ(size, needed);
  for (uint8_t b : buffer) ASSERT_EQ(b, 0xcd);
  EXPECT_NE(std::string(kata_context_last_error(nullptr)).find(std::to_string(needed) + " bytes"), std::string::npos)
      << kata_context_last_error(nullptr);
  EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), needed, &size), KATA_OK);
  EXPECT_EQ(size, needed);
  EXPECT_EQ(buffer[needed], 0xcd);  // not one byte past the message

  kata_practice_message p;
  kata_practice_message_init(&p);
  p.stream_id = 5;
  ASSERT_EQ(kata_message_write_practice(&p, nullptr, 0, &needed), KATA_E_BUFFER_TOO_SMALL);
  EXPECT_GT(needed, 16u);
  EXPECT_EQ(kata_message_write_practice(&p, buffer.data(), needed - 1, &size), KATA_E_BUFFER_TOO_SMALL);
  EXPECT_EQ(size, needed);
}

TEST(runtime_message_writer, NonFiniteFramesAreRefused) {
  kata_context context = nullptr;
  ASSERT_EQ(kata_context_create(&context), KATA_OK);
  float xyz[9] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  kata_frame_message m;
  kata_frame_message_init(&m);
  m.positions = xyz;
  m.joint_count = 3;
  std::vector<uint8_t> buffer(4096, 0xcd);
  size_t size = 7;
  for (const float bad : {nan, inf, -inf}) {
    xyz[7] = bad;  // joint 2
    EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), buffer.size(), &size), KATA_E_NON_FINITE);
    EXPECT_EQ(size, 0u);
    EXPECT_NE(std::string(kata_context_last_error(context)).find("joint 2"), std::string::npos)
        << kata_context_last_error(context);
  }
  xyz[7] = 8;
  m.capture_time = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), buffer.size(), &size), KATA_E_NON_FINITE);
  m.capture_time = std::numeric_limits<double>::infinity();
  EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), buffer.size(), &size), KATA_E_NON_FINITE);
  m.capture_time = 1e10;  // beyond the wire's int64 nanoseconds
  EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  m.capture_time = 0.5;
  const float confidence[3] = {1, inf, 1};
  m.confidences = confidence;
  EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), buffer.size(), &size), KATA_E_NON_FINITE);
  m.confidences = nullptr;
  m.presences = confidence;  // an infinite presence: refused as a confidence is
  EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), buffer.size(), &size), KATA_E_NON_FINITE);
  EXPECT_NE(std::string(kata_context_last_error(context)).find("infinite presence"), std::string::npos)
      << kata_context_last_error(context);
  m.presences = nullptr;
  m.joint_count = 0;
  EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), buffer.size(), &size), KATA_E_WRONG_JOINT_COUNT);
  m.joint_count = 3;
  m.positions = nullptr;
  EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), buffer.size(), &size), KATA_E_NULL_POINTER);
  for (uint8_t b : buffer) ASSERT_EQ(b, 0xcd);
  m.positions = xyz;
  EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), buffer.size(), &size), KATA_OK);
  kata_context_destroy(context);
}

// A frame batch (schemas/frame_batch.fbs): the encoder's bytes for the same frames, read back by
// the ingest's decoder frame by frame; the size query; refusals naming the frame, nothing written.
TEST(runtime_message_writer, FrameBatchIsTheEncodersBytesAndItsRefusals) {
  constexpr int kFrames = 5, kJoints = 31;
  std::vector<std::vector<float>> xyz(kFrames, std::vector<float>(3 * kJoints)), confidence(kFrames);
  std::vector<kata_frame_message> frames(kFrames);
  std::vector<const kata_frame_message*> pointers;
  Encoder reference;
  std::vector<Encoder::BatchFrame> expected;
  for (int i = 0; i < kFrames; ++i) {
    for (int k = 0; k < 3 * kJoints; ++k) xyz[i][static_cast<size_t>(k)] = 0.5f * static_cast<float>(k) - static_cast<float>(i);
    kata_frame_message_init(&frames[i]);
    frames[i].stream_id = 100 + static_cast<uint64_t>(i % 3);  // stream 100 three times: frames in a row
    frames[i].sequence = static_cast<uint64_t>(i);
    frames[i].capture_time = 1712345678.123456789 + 0.01 * i;
    frames[i].positions = xyz[i].data();
    frames[i].joint_count = kJoints;
    if (i == 1) {  // one frame with confidences: each frame keeps its own channels
      confidence[i].assign(kJoints, 0.75f);
      frames[i].confidences = confidence[i].data();
    }
    pointers.push_back(&frames[i]);
    expected.push_back({frames[i].stream_id, frames[i].sequence,
                        static_cast<int64_t>(std::round(frames[i].capture_time * 1e9)), xyz[i].data(), kJoints,
                        frames[i].confidences, nullptr});
  }
  size_t needed = 0;
  ASSERT_EQ(kata_message_write_frame_batch(pointers.data(), kFrames, nullptr, 0, &needed), KATA_E_BUFFER_TOO_SMALL);
  std::vector<uint8_t> out(needed + 8, 0xcd);
  size_t size = 0;
  EXPECT_EQ(kata_message_write_frame_batch(pointers.data(), kFrames, out.data(), needed - 1, &size),
            KATA_E_BUFFER_TOO_SMALL);
  EXPECT_EQ(size, needed);
  for (uint8_t b : out) ASSERT_EQ(b, 0xcd);
  ASSERT_EQ(kata_message_write_frame_batch(pointers.data(), kFrames, out.data(), out.size(), &size), KATA_OK)
      << kata_context_last_error(nullptr);
  ASSERT_EQ(size, needed);
  EXPECT_EQ(out[needed], 0xcd);
  out.resize(size);
  EXPECT_EQ(out, bytes_of(reference.frame_batch(expected.data(), expected.size())));
  Decoder decoder(1 << 20, true);
  ASSERT_EQ(decoder.decode(out.data(), out.size()), MessageKind::kFrameBatch)
      << kata::transport::decode_error_name(decoder.error());
  ASSERT_EQ(decoder.batch_size(), static_cast<size_t>(kFrames));
  for (int i = 0; i < kFrames; ++i) {
    ASSERT_EQ(decoder.batch_frame(static_cast<size_t>(i)), kata::transport::DecodeError::kNone) << i;
    const kata::transport::FrameView& f = decoder.frame();
    EXPECT_EQ(f.stream_id, frames[i].stream_id);
    EXPECT_EQ(f.sequence, frames[i].sequence);
    EXPECT_EQ(f.capture_ns, expected[static_cast<size_t>(i)].capture_ns);
    ASSERT_EQ(f.joints, kJoints);
    EXPECT_EQ(std::memcmp(f.xyz, xyz[i].data(), sizeof(float) * 3 * kJoints), 0) << i;
    EXPECT_EQ(f.confidence != nullptr, i == 1);
  }
  kata_result_record r;
  r.struct_size = sizeof r;
  EXPECT_EQ(kata_message_read_result(out.data(), out.size(), &r), KATA_NO_DATA);

  // Refusals: nothing written, *size 0, the reason names the frame.
  std::vector<uint8_t> buffer(1 << 16, 0xcd);
  size = 7;
  xyz[3][10] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(kata_message_write_frame_batch(pointers.data(), kFrames, buffer.data(), buffer.size(), &size),
            KATA_E_NON_FINITE);
  EXPECT_EQ(size, 0u);
  EXPECT_NE(std::string(kata_context_last_error(nullptr)).find("frame 3: joint 3"), std::string::npos)
      << kata_context_last_error(nullptr);
  xyz[3][10] = 0.5f * 10 - 3.0f;  // its value again
  pointers[2] = nullptr;
  EXPECT_EQ(kata_message_write_frame_batch(pointers.data(), kFrames, buffer.data(), buffer.size(), &size),
            KATA_E_NULL_POINTER);
  EXPECT_NE(std::string(kata_context_last_error(nullptr)).find("frame 2"), std::string::npos);
  pointers[2] = &frames[2];
  frames[4].struct_size = 8;  // below the struct's first size
  EXPECT_EQ(kata_message_write_frame_batch(pointers.data(), kFrames, buffer.data(), buffer.size(), &size),
            KATA_E_INVALID_ARGUMENT);
  frames[4].struct_size = sizeof frames[4];
  frames[0].joint_count = 0;
  EXPECT_EQ(kata_message_write_frame_batch(pointers.data(), kFrames, buffer.data(), buffer.size(), &size),
            KATA_E_WRONG_JOINT_COUNT);
  frames[0].joint_count = kJoints;
  EXPECT_EQ(kata_message_write_frame_batch(pointers.data(), 0, buffer.data(), buffer.size(), &size),
            KATA_E_INVALID_ARGUMENT);
  std::vector<const kata_frame_message*> too_many(4097, &frames[0]);
  EXPECT_EQ(kata_message_write_frame_batch(too_many.data(), too_many.size(), buffer.data(), buffer.size(), &size),
            KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(kata_message_write_frame_batch(nullptr, 1, buffer.data(), buffer.size(), &size), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_message_write_frame_batch(pointers.data(), kFrames, nullptr, 16, &size), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_message_write_frame_batch(pointers.data(), kFrames, buffer.data(), buffer.size(), nullptr),
            KATA_E_NULL_POINTER);
  EXPECT_EQ(size, 0u);
  for (uint8_t b : buffer) ASSERT_EQ(b, 0xcd);
  // After the refusals the same call writes the same bytes again.
  EXPECT_EQ(kata_message_write_frame_batch(pointers.data(), kFrames, buffer.data(), buffer.size(), &size), KATA_OK);
  EXPECT_EQ(std::vector<uint8_t>(buffer.begin(), buffer.begin() + static_cast<long>(size)), out);
}

TEST(runtime_message_writer, PracticeIsTheEncodersBytesAndItsRefusals) {
  kata_practice_message m;
  kata_practice_message_init(&m);
  EXPECT_EQ(m.revision, 1u);
  m.stream_id = 9;
  m.revision = 4;
  m.loop = 1;
  m.loop_start = 1.5;
  m.loop_end = 3.25;
  const std::vector<uint8_t> out = written(kata_message_write_practice, m);
  kata::transport::PracticeSetting p;
  p.stream_id = 9;
  p.revision = 4;
  p.loop = true;
  p.loop_start = 1.5;
  p.loop_end = 3.25;
  Encoder encoder;
  EXPECT_EQ(out, bytes_of(encoder.practice(p)));
  Decoder decoder;
  ASSERT_EQ(decoder.decode(out.data(), out.size()), MessageKind::kPractice);
  const kata::transport::PracticeSetting back = decoder.practice();
  EXPECT_EQ(back.stream_id, 9u);
  EXPECT_EQ(back.revision, 4u);
  EXPECT_TRUE(back.loop);
  EXPECT_EQ(back.loop_start, 1.5);
  EXPECT_EQ(back.loop_end, 3.25);
  EXPECT_EQ(back.teacher_start, 0.0);

  std::vector<uint8_t> buffer(1024);
  size_t size = 0;
  m.loop_end = 1.0;  // not after loop_start
  EXPECT_EQ(kata_message_write_practice(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(kata_context_last_error(nullptr)).find("loop_end"), std::string::npos);
  m.loop_end = 3.25;
  m.teacher_start = 2.0;  // a start and a loop
  EXPECT_EQ(kata_message_write_practice(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  m.loop = 0;
  m.teacher_start = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(kata_message_write_practice(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  m.teacher_start = -1.0;
  EXPECT_EQ(kata_message_write_practice(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  m.teacher_start = 2.0;
  EXPECT_EQ(kata_message_write_practice(&m, buffer.data(), buffer.size(), &size), KATA_OK);
}

// The struct-size rule on the writers' structs: their first (1.1) size is the end of their last
// field; a caller built against a later kata.h (a larger struct, fields this library does not know
// left at zero) is served; a smaller size is refused; the sized init writes nothing past the
// caller's struct.
TEST(runtime_message_writer, StructSizes) {
  const float xyz[3] = {1, 2, 3};
  std::vector<uint8_t> buffer(4096);
  size_t size = 0;

  // A 1.1 caller: struct_size is the end of confidences (its sizeof on every ABI kata builds for).
  const uint32_t first = static_cast<uint32_t>(offsetof(kata_frame_message, confidences) + sizeof(const float*));
  kata_frame_message m;
  kata_frame_message_init_sized(&m, first);
  EXPECT_EQ(m.struct_size, first);
  m.positions = xyz;
  m.joint_count = 1;
  m.stream_id = 3;
  ASSERT_EQ(kata_message_write_frame(&m, buffer.data(), buffer.size(), &size), KATA_OK);
  const std::vector<uint8_t> v11(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(size));

  // A caller of a later kata.h: a larger struct, its new fields zero (their defaults).
  struct Later {
    kata_frame_message m;
    uint64_t added[4];
  } later;
  std::memset(&later, 0xee, sizeof later);
  kata_frame_message_init_sized(&later.m, sizeof later);
  EXPECT_EQ(later.m.struct_size, sizeof(kata_frame_message));  // what this library wrote
  EXPECT_EQ(later.added[0], 0xeeeeeeeeeeeeeeeeull);             // and nothing past it
  later.m.struct_size = sizeof later;
  std::memset(later.added, 0, sizeof later.added);
  later.m.positions = xyz;
  later.m.joint_count = 1;
  later.m.stream_id = 3;
  ASSERT_EQ(kata_message_write_frame(&later.m, buffer.data(), buffer.size(), &size), KATA_OK);
  EXPECT_EQ(std::vector<uint8_t>(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(size)), v11);

  // Below the first size (an uninitialised struct): refused, nothing read past it.
  m.struct_size = first - 1;
  EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  m.struct_size = 0;
  EXPECT_EQ(kata_message_write_frame(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);

  kata_practice_message p;
  kata_practice_message_init(&p);
  p.struct_size = static_cast<uint32_t>(offsetof(kata_practice_message, loop_end));
  EXPECT_EQ(kata_message_write_practice(&p, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  p.struct_size = static_cast<uint32_t>(offsetof(kata_practice_message, loop_end) + sizeof(double));
  EXPECT_EQ(kata_message_write_practice(&p, buffer.data(), buffer.size(), &size), KATA_OK);

  kata_skeleton_message s;
  kata_skeleton_message_init(&s);
  s.struct_size = static_cast<uint32_t>(offsetof(kata_skeleton_message, closed));
  EXPECT_EQ(kata_message_write_skeleton(&s, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);

  // The sized init below 4 bytes writes nothing.
  kata_practice_message untouched;
  std::memset(&untouched, 0x5a, sizeof untouched);
  kata_practice_message_init_sized(&untouched, 3);
  EXPECT_EQ(untouched.struct_size, 0x5a5a5a5au);
}

}  // namespace
