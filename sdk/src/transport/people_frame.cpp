#include "transport/people_frame.hpp"

#include <cstring>

#include <flatbuffers/flatbuffers.h>

#include "kata_schemas/people_frame_generated.h"

namespace kata::transport {
namespace {
constexpr uint16_t kPeopleFrameVersion = 1;
}  // namespace

bool is_people_frame(const void* data, size_t size) {
  if (size < kTopicBytes + 8) return false;
  // The identifier sits at bytes 4..7 of the FlatBuffer; alignment does not matter for a compare.
  return std::memcmp(static_cast<const uint8_t*>(data) + kTopicBytes + 4, fb::PeopleFrameIdentifier(), 4) == 0;
}

PeopleFrameDecoder::PeopleFrameDecoder(size_t max_message_bytes, bool require_checksum)
    : max_bytes_(max_message_bytes), require_checksum_(require_checksum) {}

DecodeError PeopleFrameDecoder::decode(const void* data, size_t size, PeopleFrameView* out) {
  if (size < kTopicBytes + 8) return DecodeError::kTooShort;
  if (size > max_bytes_) return DecodeError::kOversized;
  const auto* bytes = static_cast<const uint8_t*>(data);
  uint64_t topic = 0;
  if (!parse_topic(bytes, &topic)) return DecodeError::kBadTopic;
  const size_t payload_size = size - kTopicBytes;
  const uint8_t* payload = bytes + kTopicBytes;
  if (reinterpret_cast<uintptr_t>(payload) % 8 != 0) {
    // Sized at the limit by the first misaligned people frame (a runtime without people frames
    // never pays for it), then reused.
    if (scratch_.empty()) scratch_.resize(max_bytes_ / 8 + 1);
    std::memcpy(scratch_.data(), payload, payload_size);
    payload = reinterpret_cast<const uint8_t*>(scratch_.data());
  }
  flatbuffers::Verifier::Options options;
  options.max_depth = 8;
  options.max_tables = 8;
  flatbuffers::Verifier verifier(payload, payload_size, options);
  if (!fb::VerifyPeopleFrameBuffer(verifier)) return DecodeError::kVerifier;
  const fb::PeopleFrame* f = fb::GetPeopleFrame(payload);
  if (f->schema_version() != kPeopleFrameVersion) return DecodeError::kVersion;
  if (f->stream_id() != topic) return DecodeError::kTopicMismatch;
  if (!f->capture_time()) return DecodeError::kMissingField;
  const uint32_t joints = f->joint_count(), poses = f->pose_count();
  if (joints == 0 || joints > (1u << 20) || poses > static_cast<uint32_t>(kMaxPeoplePoses))
    return DecodeError::kMissingField;
  const size_t total = static_cast<size_t>(joints) * poses;
  const auto* positions = f->positions();
  if ((positions ? positions->size() : 0u) != total) return DecodeError::kMissingField;
  const auto* confidence = f->confidence();
  if (confidence && confidence->size() != total) return DecodeError::kMissingField;
  out->stream_id = f->stream_id();
  out->sequence = f->sequence();
  out->capture_ns = f->capture_time()->nanoseconds();
  out->joints = static_cast<int>(joints);
  out->poses = static_cast<int>(poses);
  out->xyz = positions && total ? reinterpret_cast<const float*>(positions->Data()) : nullptr;
  out->confidence = confidence && total ? confidence->data() : nullptr;
  if (require_checksum_ || flatbuffers::IsFieldPresent(f, fb::PeopleFrame::VT_CHECKSUM)) {
    if (!flatbuffers::IsFieldPresent(f, fb::PeopleFrame::VT_CHECKSUM)) return DecodeError::kMissingField;
    static const float kNone = 0.0f;
    if (f->checksum() != frame_checksum(out->stream_id, out->sequence, out->capture_ns, out->xyz ? out->xyz : &kNone,
                                        static_cast<int>(total), out->confidence))
      return DecodeError::kChecksum;
  }
  return DecodeError::kNone;
}

void encode_people_frame(uint64_t stream_id, uint64_t sequence, int64_t capture_ns, int joints, int poses,
                         const float* xyz, const float* confidence, std::vector<uint8_t>* out) {
  thread_local flatbuffers::FlatBufferBuilder builder(1024);
  builder.Clear();
  const size_t total = static_cast<size_t>(joints) * static_cast<size_t>(poses);
  flatbuffers::Offset<flatbuffers::Vector<const fb::Vec3*>> positions = 0;
  flatbuffers::Offset<flatbuffers::Vector<float>> conf = 0;
  if (total > 0) {
    positions = builder.CreateVectorOfStructs(reinterpret_cast<const fb::Vec3*>(xyz), total);
    if (confidence) conf = builder.CreateVector(confidence, total);
  }
  static const float kNone = 0.0f;
  const uint32_t checksum =
      frame_checksum(stream_id, sequence, capture_ns, total ? xyz : &kNone, static_cast<int>(total), total ? confidence : nullptr);
  const fb::Time time(capture_ns);
  fb::PeopleFrameBuilder f(builder);
  f.add_schema_version(kPeopleFrameVersion);
  f.add_stream_id(stream_id);
  f.add_sequence(sequence);
  f.add_capture_time(&time);
  f.add_joint_count(static_cast<uint32_t>(joints));
  f.add_pose_count(static_cast<uint32_t>(poses));
  if (total > 0) f.add_positions(positions);
  if (!conf.IsNull()) f.add_confidence(conf);
  f.add_checksum(checksum);
  builder.Finish(f.Finish(), fb::PeopleFrameIdentifier());
  out->resize(kTopicBytes + builder.GetSize());
  char topic[kTopicBytes];
  write_topic(stream_id, topic);
  std::memcpy(out->data(), topic, kTopicBytes);
  std::memcpy(out->data() + kTopicBytes, builder.GetBufferPointer(), builder.GetSize());
}

uint64_t person_stream_id(uint64_t group, uint32_t person) {
  uint64_t h = 14695981039346656037ull;
  const auto mix = [&h](uint64_t v) {
    for (int i = 0; i < 8; ++i) {
      h ^= (v >> (8 * i)) & 0xff;
      h *= 1099511628211ull;
    }
  };
  mix(group);
  mix(person);
  return h >= ~0ULL - 1 ? h - 2 : h;
}

}  // namespace kata::transport
