// Model files over time: the golden files of every released schema version still load to their
// known content, and every single-bit flip of a model file is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "golden_models.hpp"
#include "io/model_file.hpp"
#include "metric/model.hpp"

namespace kata {
namespace {

std::string golden_path(int kind) {
  return std::string(KATA_SOURCE_DIR) + "/tests/data/models/" + test::golden_model_file(kind);
}

std::vector<uint8_t> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(ModelFiles, GoldenSchemaV1FilesLoadToTheirKnownContent) {
  for (int kind = 0; kind < 2; ++kind) {
    SCOPED_TRACE(test::golden_model_file(kind));
    const metric::Model expected = test::golden_model(kind);
    const metric::Model m = metric::load_model(golden_path(kind));
    EXPECT_EQ(m.layout_id, "gpd-v1");
    EXPECT_EQ(m.stencil, expected.stencil);
    EXPECT_EQ(m.normalisation, expected.normalisation);
    EXPECT_EQ(m.rank, 1);
    EXPECT_EQ(m.min, expected.min);
    EXPECT_EQ(m.max, expected.max);
    EXPECT_EQ(m.shift, expected.shift);
    EXPECT_EQ(m.scale, expected.scale);
    EXPECT_EQ(m.w, expected.w);
    EXPECT_EQ(m.delta_star, 0.375);
    EXPECT_EQ(m.info.date, expected.info.date);
    EXPECT_EQ(m.info.data, expected.info.data);
    EXPECT_EQ(m.info.parameters, expected.info.parameters);
    EXPECT_EQ(m.info.evaluation, expected.info.evaluation);
  }
}

// The loader accepts a current-version file only in the writer's canonical layout, so the writer
// must still produce the golden bytes (else old files would be refused: bump the version).
TEST(ModelFiles, ThisBuildWritesTheGoldenBytes) {
  for (int kind = 0; kind < 2; ++kind) {
    SCOPED_TRACE(test::golden_model_file(kind));
    EXPECT_EQ(metric::serialize_model(test::golden_model(kind)), file_bytes(golden_path(kind)));
  }
}

// Every bit of the file matters: values through the checksum, everything else (padding, string
// terminators, vtables, defaulted fields) through the canonical layout.
TEST(ModelFiles, EverySingleBitFlipIsRefused) {
  std::vector<uint8_t> bytes = file_bytes(golden_path(0));
  ASSERT_GT(bytes.size(), 1000u);
  long accepted = 0;
  for (size_t i = 0; i < bytes.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      bytes[i] = static_cast<uint8_t>(bytes[i] ^ (1u << bit));
      try {
        metric::parse_model(bytes.data(), bytes.size());
        if (++accepted <= 10) ADD_FAILURE() << "a flip of byte " << i << " bit " << bit << " was accepted";
      } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::kModel);
      }
      bytes[i] = static_cast<uint8_t>(bytes[i] ^ (1u << bit));
    }
  }
  EXPECT_EQ(accepted, 0) << "of " << 8 * bytes.size() << " single-bit flips";
  EXPECT_NO_THROW(metric::parse_model(bytes.data(), bytes.size()));  // the unflipped file still loads
}

// Magnitudes that would let a finite feature vector overflow in scoring are refused by name.
TEST(ModelFiles, ImplausibleMagnitudesAreRefused) {
  auto refused = [](const metric::Model& m, const std::string& needle) {
    try {
      metric::serialize_model(m);
      ADD_FAILURE() << "accepted: " << needle;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::kModel);
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  metric::Model m = test::golden_model(0);
  m.w[5] = 2e6f;
  refused(m, "|W[5, 0]|");
  m = test::golden_model(0);
  m.min[7] = 1e-3f;
  m.max[7] = 1e-3f + 1e-10f;
  refused(m, "at dimension 7 is below");
  m = test::golden_model(0);
  m.min[3] = -1e20f;
  refused(m, "min/max at dimension 3");
  m = test::golden_model(1);
  m.scale[9] = 1e10f;
  refused(m, "shift/scale at dimension 9");
  m = test::golden_model(0);
  m.max[7] = m.min[7];  // a constant dimension is fine (gain 0)
  EXPECT_NO_THROW(metric::serialize_model(m));
}

}  // namespace
}  // namespace kata
