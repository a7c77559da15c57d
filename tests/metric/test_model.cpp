// .kata model files: round trip, and every malformed case refused with a message naming it.
#include <gtest/gtest.h>

#include "support/temp_paths.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

#include "common/error.hpp"
#include "fixtures.hpp"
#include "kata_schemas/model_generated.h"
#include "io/model_file.hpp"
#include "metric/model.hpp"

namespace kata {
namespace {

using metric::Model;

bool same(const Model& a, const Model& b) {
  return a.layout_id == b.layout_id && a.stencil == b.stencil && a.normalisation == b.normalisation &&
         a.min == b.min && a.max == b.max && a.shift == b.shift && a.scale == b.scale && a.rank == b.rank &&
         a.w == b.w && a.delta_star == b.delta_star && a.info.date == b.info.date && a.info.data == b.info.data &&
         a.info.parameters == b.info.parameters && a.info.evaluation == b.info.evaluation;
}

Model small_model() {
  Model m = test::test_model(2, 11);
  m.info.evaluation = {{"precision", 0.75}, {"auc", 0.9}};
  return m;
}

// Expects parse_model to throw kata::Error(kModel) whose message contains `needle`.
void expect_refused(const std::vector<uint8_t>& buf, const std::string& needle) {
  try {
    metric::parse_model(buf.data(), buf.size());
    ADD_FAILURE() << "accepted a model that should be refused for: " << needle;
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kModel);
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << "message: " << e.what() << "\nexpected: " << needle;
  }
}

// A raw .kata buffer written with the generated API, bypassing serialize_model's checks, so the
// test can produce content the writer refuses. The checksum is whatever the caller passes.
struct Raw {
  Model m;
  uint16_t version = 1;
  uint32_t dims = gpd::kDims;
  int64_t rank = -1;  // -1: m.rank
  uint64_t checksum = 0;
};
std::vector<uint8_t> raw_buffer(const Raw& r) {
  flatbuffers::FlatBufferBuilder b;
  auto info = fb::CreateTrainingInfo(b, 1, b.CreateString(r.m.info.date), b.CreateString(r.m.info.data),
                                     b.CreateString(r.m.info.parameters));
  auto layout = b.CreateString(r.m.layout_id);
  auto mn = b.CreateVector(r.m.min);
  auto mx = b.CreateVector(r.m.max);
  flatbuffers::Offset<flatbuffers::Vector<float>> shift, scale;
  if (!r.m.shift.empty()) shift = b.CreateVector(r.m.shift);
  if (!r.m.scale.empty()) scale = b.CreateVector(r.m.scale);
  auto w = b.CreateVector(r.m.w);
  auto root = fb::CreateModel(b, r.version, layout, static_cast<fb::Stencil>(r.m.stencil),
                              static_cast<fb::Normalisation>(r.m.normalisation), r.dims,
                              static_cast<uint32_t>(r.rank >= 0 ? r.rank : r.m.rank), mn, mx, shift, scale, w,
                              r.m.delta_star, info, r.checksum);
  fb::FinishSizePrefixedModelBuffer(b, root);
  return {b.GetBufferPointer(), b.GetBufferPointer() + b.GetSize()};
}

TEST(Model, RoundTripThroughBufferAndFile) {
  const Model m = small_model();
  const std::vector<uint8_t> buf = metric::serialize_model(m);
  ASSERT_TRUE(fb::SizePrefixedModelBufferHasIdentifier(buf.data()));
  EXPECT_TRUE(same(metric::parse_model(buf.data(), buf.size()), m));

  const std::string path = kata::test::temp_path("roundtrip.kata");
  metric::save_model(path, m);
  EXPECT_TRUE(same(metric::load_model(path), m));
  std::remove(path.c_str());
}

TEST(Model, BlockBalancedRoundTrip) {
  Model m = small_model();
  m.normalisation = metric::Normalisation::kBlockBalanced;
  m.shift.assign(gpd::kDims, 0.25f);
  m.scale.assign(gpd::kDims, 2.0f);
  const std::vector<uint8_t> buf = metric::serialize_model(m);
  EXPECT_TRUE(same(metric::parse_model(buf.data(), buf.size()), m));
}

TEST(Model, UnalignedBufferIsRead) {
  const std::vector<uint8_t> buf = metric::serialize_model(small_model());
  std::vector<uint8_t> shifted(buf.size() + 1);
  std::copy(buf.begin(), buf.end(), shifted.begin() + 1);
  EXPECT_TRUE(same(metric::parse_model(shifted.data() + 1, buf.size()), small_model()));
}

TEST(Model, MissingFileIsAnIoError) {
  try {
    metric::load_model("/nonexistent/model.kata");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kIo);
  }
}

TEST(Model, TruncatedBuffersAreRefused) {
  const std::vector<uint8_t> buf = metric::serialize_model(small_model());
  for (size_t n : {size_t{0}, size_t{4}, size_t{7}, size_t{8}, size_t{64}, buf.size() / 2, buf.size() - 64, buf.size() - 1}) {
    const std::vector<uint8_t> cut(buf.begin(), buf.begin() + static_cast<long>(n));
    try {
      metric::parse_model(cut.data(), cut.size());
      ADD_FAILURE() << "accepted a buffer truncated to " << n << " of " << buf.size() << " bytes";
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_TRUE(msg.find("too small") != std::string::npos || msg.find("empty") != std::string::npos ||
                  msg.find("truncated: the size prefix says " + std::to_string(buf.size()) + " bytes, the buffer has " +
                           std::to_string(n)) != std::string::npos)
          << n << ": " << msg;
    }
  }
}

TEST(Model, TrailingBytesAreRefused) {
  std::vector<uint8_t> buf = metric::serialize_model(small_model());
  buf.push_back(0);
  expect_refused(buf, "trailing bytes");
}

TEST(Model, CorruptOffsetIsCaughtByTheVerifier) {
  std::vector<uint8_t> buf = metric::serialize_model(small_model());
  // The root offset (bytes 4..7) pointed far outside the buffer.
  buf[7] = 0x7f;
  expect_refused(buf, "verifier");
}

TEST(Model, TruncatedFileIsRefusedWithItsPath) {
  const std::vector<uint8_t> buf = metric::serialize_model(small_model());
  const std::string path = kata::test::temp_path("truncated.kata");
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(buf.data()), static_cast<std::streamsize>(buf.size() / 3));
  }
  try {
    metric::load_model(path);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kModel);
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}

// Every byte of the buffer gets one bit flipped in turn: each result is refused, or (a flip in
// padding) parses to exactly the original model. Nothing else is ever returned.
TEST(Model, EveryBitFlipIsRefusedOrHarmless) {
  const Model m = small_model();
  const std::vector<uint8_t> buf = metric::serialize_model(m);
  size_t refused = 0, harmless = 0;
  for (size_t i = 0; i < buf.size(); ++i) {
    std::vector<uint8_t> bad = buf;
    bad[i] = static_cast<uint8_t>(bad[i] ^ (1u << (i % 8)));
    try {
      const Model got = metric::parse_model(bad.data(), bad.size());
      ASSERT_TRUE(same(got, m)) << "byte " << i << ": a flipped bit changed the model and was accepted";
      ++harmless;
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::kModel);
      ++refused;
    }
  }
  EXPECT_GT(refused, buf.size() * 9 / 10) << "harmless flips: " << harmless;
}

TEST(Model, BitFlipInsideWIsCaughtByTheChecksum) {
  const std::vector<uint8_t> buf = metric::serialize_model(small_model());
  const fb::Model* root = fb::GetSizePrefixedModel(buf.data());
  const size_t at = static_cast<size_t>(reinterpret_cast<const uint8_t*>(root->w()->data()) - buf.data()) + 4 * 1000;
  std::vector<uint8_t> bad = buf;
  bad[at] ^= 0x01;  // lowest mantissa bit of W[1000, 0]: still a finite float
  expect_refused(bad, "checksum mismatch");
}

TEST(Model, WrongIdentifierIsRefused) {
  std::vector<uint8_t> buf = metric::serialize_model(small_model());
  buf[8] = 'N';
  buf[9] = 'O';
  buf[10] = 'P';
  buf[11] = 'E';
  expect_refused(buf, "file identifier \"NOPE\" is not \"KATA\"");
  const std::string text = "this is a text file, not a model";
  expect_refused(std::vector<uint8_t>(text.begin(), text.end()), "is not \"KATA\"");
}

TEST(Model, WellFormedRawBufferIsOnlyRefusedForItsChecksum) {
  // Guards the raw writer used below: with a zero checksum, only the checksum is wrong.
  Raw r{small_model()};
  expect_refused(raw_buffer(r), "checksum mismatch");
}

TEST(Model, WrongLayoutIdIsRefused) {
  Raw r{small_model()};
  r.m.layout_id = "gpd-v2";
  expect_refused(raw_buffer(r), "layout id \"gpd-v2\" is not \"gpd-v1\"");
}

TEST(Model, WrongDimensionsAreRefused) {
  {
    Raw r{small_model()};
    r.dims = 1700;
    expect_refused(raw_buffer(r), "dims = 1700, expected 1683");
  }
  {
    Raw r{small_model()};
    r.m.w.pop_back();
    expect_refused(raw_buffer(r), "W has 3365 values, expected 1683 x r = 1683 x 2 = 3366");
  }
  {
    Raw r{small_model()};
    r.rank = 3;  // W holds 2 columns
    expect_refused(raw_buffer(r), "W has 3366 values, expected 1683 x r = 1683 x 3 = 5049");
  }
  {
    Raw r{small_model()};
    r.m.min.resize(1682);
    expect_refused(raw_buffer(r), "min has 1682 values, expected 1683");
  }
  {
    Raw r{small_model()};
    r.m.max.resize(1684, 1.0f);
    expect_refused(raw_buffer(r), "max has 1684 values, expected 1683");
  }
  {
    Raw r{small_model()};
    r.m.normalisation = metric::Normalisation::kBlockBalanced;  // needs shift and scale
    expect_refused(raw_buffer(r), "shift has 0 values, expected 1683");
  }
}

TEST(Model, NonFiniteValuesAreRefused) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  {
    Raw r{small_model()};
    r.m.w[1683 + 5] = nan;
    expect_refused(raw_buffer(r), "NaN/Inf in W[5, 1]");
  }
  {
    Raw r{small_model()};
    r.m.min[17] = -inf;
    expect_refused(raw_buffer(r), "NaN/Inf in min[17]");
  }
  {
    Raw r{small_model()};
    r.m.max[1682] = inf;
    expect_refused(raw_buffer(r), "NaN/Inf in max[1682]");
  }
  {
    Raw r{small_model()};
    r.m.delta_star = std::numeric_limits<double>::quiet_NaN();
    expect_refused(raw_buffer(r), "delta* = nan");
  }
}

TEST(Model, MaxBelowMinIsRefused) {
  Raw r{small_model()};
  r.m.max[300] = r.m.min[300] - 0.5f;
  expect_refused(raw_buffer(r), "max < min at dimension 300");
}

TEST(Model, RankZeroIsRefused) {
  Raw r{small_model()};
  r.m.w.clear();
  r.rank = 0;
  expect_refused(raw_buffer(r), "rank r = 0");
}

TEST(Model, NonPositiveThresholdIsRefused) {
  Raw r{small_model()};
  r.m.delta_star = 0.0;
  expect_refused(raw_buffer(r), "delta* = 0");
}

TEST(Model, NewerSchemaIsRefused) {
  Raw r{small_model()};
  r.version = 2;
  expect_refused(raw_buffer(r), "schema version 2");
}

TEST(Model, WriterRefusesInvalidModels) {
  Model m = small_model();
  m.rank = 0;
  m.w.clear();
  EXPECT_THROW(metric::serialize_model(m), Error);
  m = small_model();
  m.max[0] = m.min[0] - 1.0f;
  EXPECT_THROW(metric::serialize_model(m), Error);
}

}  // namespace
}  // namespace kata
