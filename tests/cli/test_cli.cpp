// The CLI as a user runs it: `kata features` writes every frame of a clip as (frames, 1683)
// float32 rows equal to the live stream's vectors; bad input exits non-zero with a clear message.
#include <gtest/gtest.h>

#include "support/temp_paths.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "io/bvh.hpp"
#include "io/npy.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"

namespace {

struct CliRun {
  int code;
  std::string output;
};

CliRun run(const std::string& args) {
  const std::string log = kata::test::temp_path("kata_cli_test.log");
  const std::string cmd = std::string(KATA_CLI) + " " + args + " >" + log + " 2>&1";
  const int status = std::system(cmd.c_str());
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str()};
}

TEST(CliFeatures, WritesEveryFrameAsTheStreamComputesIt) {
  const std::string clip_path = std::string(KATA_DATA_DIR) + "/cmu/09_01.bvh";
  const kata::BvhClip clip = kata::load_bvh(clip_path);
  const kata::GpdMap map = kata::make_gpd_map(clip.skeleton, kata::preset_joint_names("cmu"));
  for (const char* stencil : {"backward", "central"}) {
    const std::string out = kata::test::temp_path("kata_cli_features.npy");
    const CliRun r = run("features --bvh " + clip_path + " --preset cmu --stencil " + stencil + " --out " + out);
    ASSERT_EQ(r.code, 0) << r.output;
    // The header says float32, C order, (frames, 1683).
    std::ifstream f(out, std::ios::binary);
    std::string header(128, '\0');
    f.read(&header[0], 128);
    EXPECT_NE(header.find("'descr': '<f4'"), std::string::npos) << header;
    EXPECT_NE(header.find("(149, 1683)"), std::string::npos) << header;
    std::vector<size_t> shape;
    const std::vector<double> got = kata::read_npy(out, &shape);
    ASSERT_EQ(shape, (std::vector<size_t>{149, 1683}));
    const std::vector<float> want = kata::clip_features(clip, map, kata::parse_stencil(stencil));
    ASSERT_EQ(got.size(), want.size());
    for (size_t i = 0; i < want.size(); ++i) ASSERT_EQ(static_cast<float>(got[i]), want[i]) << "element " << i;
    std::remove(out.c_str());
  }
}

TEST(CliFeatures, BadInputExitsWithAClearMessage) {
  const std::string bad = kata::test::temp_path("kata_cli_bad.bvh");
  {
    std::ofstream b(bad);
    b << "HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 zero\n}\n";
  }
  CliRun r = run("features --bvh " + bad + " --preset cmu --out " + kata::test::temp_path("x.npy"));
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find(bad + ":4"), std::string::npos) << "names file and line: " << r.output;
  r = run("features --bvh " + std::string(KATA_DATA_DIR) + "/cmu/09_01.bvh --preset nope --out x.npy");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("nope"), std::string::npos) << r.output;
  r = run("features --bvh " + std::string(KATA_DATA_DIR) + "/cmu/09_01.bvh --preset cmu --stencil sideways --out x.npy");
  EXPECT_NE(r.code, 0);
  std::remove(bad.c_str());
}

TEST(CliFeatures, ALandmarkArrayGivenAsBvhAndAFirstFrameOutOfRangeSayWhatToDo) {
  const std::string npy = kata::test::temp_path("kata_cli_landmarks.npy");
  std::ofstream(npy) << "not read";
  CliRun r = run("features --bvh " + npy + " --preset cmu --out " + kata::test::temp_path("x.npy"));
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find(npy + ": --bvh takes a BVH clip; a landmark array (.npy) goes in with --student"),
            std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("HIERARCHY"), std::string::npos) << r.output;
  std::remove(npy.c_str());
  const std::string clip = std::string(KATA_DATA_DIR) + "/cmu/09_01.bvh";  // 149 frames
  r = run("features --bvh " + clip + " --preset cmu --first-frame 500 --out " + kata::test::temp_path("x.npy"));
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find(clip + ": first frame 500 out of range (the clip has 149 frames; --first-frame takes 0..149)"),
            std::string::npos) << r.output;
}

TEST(CliScore, AJointThePresetNeedsIsMissingNamesTheFileTheCorrectionAndTheJoints) {
  // 09_01 with its RightFoot renamed, as a typo in an exporter would: the message names the clip,
  // the preset, the GPD joint, the closest name the skeleton has, and lists its joints.
  std::ifstream in(std::string(KATA_DATA_DIR) + "/cmu/09_01.bvh");
  std::stringstream text;
  text << in.rdbuf();
  std::string bvh = text.str();
  for (size_t at = bvh.find("JOINT RightFoot"); at != std::string::npos; at = bvh.find("JOINT RightFoot", at))
    bvh.replace(at, 15, "JOINT RightFot");
  const std::string typo = kata::test::temp_path("kata_cli_typo.bvh");
  std::ofstream(typo) << bvh;
  const CliRun r = run("score --model " + std::string(KATA_SOURCE_DIR) + "/models/default.kata --teacher " +
                       std::string(KATA_DATA_DIR) + "/cmu/09_01.bvh --student " + typo + " --preset cmu --out " +
                       kata::test::temp_path("kata_cli_typo.csv"));
  EXPECT_NE(r.code, 0);
  for (const char* part : {"kata_cli_typo.bvh: layout 'cmu': skeleton has no joint 'RightFoot' (GPD RFoot)",
                           "did you mean 'RightFot'?", "joints are: Hips, "})
    EXPECT_NE(r.output.find(part), std::string::npos) << "'" << part << "' not in: " << r.output;
  std::remove(typo.c_str());
}

}  // namespace

// Issue 27's tool path as a user runs it: pairs by the independent protocol, `kata eval` with
// the figures stored in a copy of a model under a name that says the protocol, `model-info`
// listing them, and `kata score` warning that a model evaluated on a transition protocol is not
// a coaching model.
TEST(CliTransition, ProtocolPairsEvalStoresNamedFiguresScoreNotes) {
  const std::string data = std::string(KATA_DATA_DIR) + "/cmu";
  const std::string pairs = kata::test::temp_path("kata_cli_uniform_pairs.csv");
  CliRun r = run("pairs --data " + data + " 02_01.bvh 02_02.bvh 07_01.bvh --protocol transition-uniform --per-class 6 "
                 "--seed 3 --max-draws 2000000 --out " + pairs);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("12 pairs (6 positive, 6 negative)"), std::string::npos) << r.output;
  const std::string model = kata::test::temp_path("kata_cli_transition.kata");
  r = run("eval --data " + data + " --pairs " + pairs + " --model " + std::string(KATA_SOURCE_DIR) +
          "/models/default.kata --label m --store-in " + model + " --figure-prefix 'test, protocol transition-uniform'");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("JCD (issue 27)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("weighs GPD+RDSR"), std::string::npos) << r.output;
  r = run("model-info " + model);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("test, protocol transition-uniform: GPD+RDSR"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("test, protocol transition-uniform: JCD (issue 27)"), std::string::npos) << r.output;
  const std::string csv = kata::test::temp_path("kata_cli_transition_scores.csv");
  r = run("score --model " + model + " --teacher " + data + "/02_01.bvh --student " + data +
          "/02_02.bvh --preset cmu --out " + csv);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("is a transition model"), std::string::npos) << r.output;
  // kata train --blocks 9: W trained on these pairs is zero outside the kinetics block (dims
  // 1591..1682 of gpd.hpp) and not inside it, the parameters say so, and a block outside 1..9 is
  // refused with the reason.
  const std::string kin = kata::test::temp_path("kata_cli_blocks.kata");
  r = run("train --data " + data + " 02_01.bvh 07_01.bvh --pairs " + pairs + " --unlabeled 300 --rank 5 --blocks 9 "
          "--negative-weight 1 --out " + kin);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("W restricted to 92 of 1683 dimensions"), std::string::npos) << r.output;
  const kata::metric::Model m = kata::metric::load_model(kin);
  ASSERT_EQ(m.rank, 5);
  double outside = 0.0, inside = 0.0;
  for (int c = 0; c < m.rank; ++c)
    for (int k = 0; k < 1683; ++k) (k >= 1591 ? inside : outside) += std::abs(m.w[static_cast<size_t>(c) * 1683 + k]);
  EXPECT_EQ(outside, 0.0);
  EXPECT_GT(inside, 1.0);
  EXPECT_NE(m.info.parameters.find("\"blocks\":[9]"), std::string::npos) << m.info.parameters;
  r = run("train --data " + data + " 02_01.bvh --pairs " + pairs + " --unlabeled 100 --rank 5 --blocks 10 --out " + kin);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("GPD block 10 is not in 1..9"), std::string::npos) << r.output;
  std::remove(kin.c_str());
  for (const std::string& f : {pairs, model, csv}) std::remove(f.c_str());
}
