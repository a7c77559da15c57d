// The CLI as a user runs it: `kata features` writes every frame of a clip as (frames, 1683)
// float32 rows equal to the live stream's vectors; bad input exits non-zero with a clear message.
#include <gtest/gtest.h>

#include "support/temp_paths.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

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

// A name map with a typo in a skeleton joint's name: the message names the map's file and the
// line of the entry to fix (text and JSON maps), the closest joint and the skeleton's joints.
TEST(CliFeatures, ANameMapTypoNamesTheMapsFileAndLine) {
  const std::string clip = std::string(KATA_DATA_DIR) + "/cmu/09_01.bvh";
  const char* gpd[] = {"Hip", "Chest", "Neck", "Head", "LShoulder", "LElbow", "LHand", "RShoulder",
                       "RElbow", "RHand", "LHip", "LKnee", "LFoot", "RHip", "RKnee", "RFoot"};
  const auto cmu = kata::preset_joint_names("cmu");
  std::string text = "# the cmu preset by hand\n\n", json = "{\n";
  for (int g = 0; g < 16; ++g) {
    // RElbow (text line 11, JSON line 10) misspelt.
    const std::string name = g == 8 ? std::string("RightForeArn") : cmu[static_cast<size_t>(g)];
    text += std::string(gpd[g]) + " = " + name + "\n";
    json += std::string("  \"") + gpd[g] + "\": \"" + name + "\"" + (g < 15 ? ",\n" : "\n");
  }
  json += "}\n";
  const std::string text_map = kata::test::temp_path("kata_cli_typo.map"), json_map = kata::test::temp_path("kata_cli_typo.json");
  std::ofstream(text_map) << text;
  std::ofstream(json_map) << json;
  for (const auto& [map, line] : {std::pair<std::string, int>{text_map, 11}, {json_map, 10}}) {
    const CliRun r = run("features --bvh " + clip + " --name-map " + map + " --out " + kata::test::temp_path("x.npy"));
    EXPECT_NE(r.code, 0);
    for (const std::string& part : {map + ":" + std::to_string(line) + ": skeleton has no joint 'RightForeArn' (GPD RElbow)",
                                   std::string("did you mean 'RightForeArm'?"), std::string("its 31 joints are: Hips, ")})
      EXPECT_NE(r.output.find(part), std::string::npos) << "'" << part << "' not in: " << r.output;
  }
  std::remove(text_map.c_str());
  std::remove(json_map.c_str());
}

// A landmark array of the wrong shape: the message shows the shape it got, the one expected, and
// what the shape looks like instead (too few joints for the layout, a feature array).
TEST(CliFeatures, ALandmarkArrayOfTheWrongShapeShowsTheShapeItGot) {
  const std::string npy = kata::test::temp_path("kata_cli_shape.npy");
  const std::vector<float> zeros(10 * 1683, 0.5f);
  struct Case {
    std::vector<size_t> shape;
    std::string says;
  };
  for (const Case& c : {Case{{10, 20, 3}, "shape (10, 20, 3) is not a landmark array: expected (frames <= 16777216, 33, "
                                          "3, 4 or 5) for layout mediapipe; it has 20 joints per frame, layout mediapipe has 33"},
                        Case{{10, 33, 7}, "shape (10, 33, 7) is not a landmark array"},
                        Case{{10, 1683}, "shape (10, 1683) is not a landmark array: expected (frames <= 16777216, 33, 3, "
                                         "4 or 5) for layout mediapipe; (frames, 1683) is a GPD feature array"}}) {
    kata::write_npy(npy, zeros.data(), c.shape);
    const CliRun r = run("features --student " + npy + " --layout mediapipe --fps 30 --out " + kata::test::temp_path("x.npy"));
    EXPECT_NE(r.code, 0);
    EXPECT_NE(r.output.find(npy + ": " + c.says), std::string::npos) << r.output;
  }
  // A first frame past the array's end names the option and the range it takes.
  kata::write_npy(npy, zeros.data(), {10, 33, 3});
  const CliRun r = run("features --student " + npy + " --layout mediapipe --fps 30 --first-frame 40 --out " +
                       kata::test::temp_path("x.npy"));
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find(npy + ": first frame 40 out of range (the array has 10 frames; --first-frame takes 0..10)"),
            std::string::npos) << r.output;
  std::remove(npy.c_str());
}

// A student clip too short to score (2 frames: both within the first 0.25 s, calibrating): no
// "mean score 0.0 ... most to fix: torso_head", but what happened to every frame, and a failure.
TEST(CliScore, AClipWithNothingScoredSaysWhyInsteadOfAMeanOfZero) {
  std::ifstream in(std::string(KATA_DATA_DIR) + "/cmu/09_01.bvh");
  std::string bvh, line;
  int frames_line = -1, n = 0;
  while (std::getline(in, line)) {
    if (line.rfind("Frames:", 0) == 0) {
      line = "Frames: 2";
      frames_line = n;
    }
    if (frames_line >= 0 && n > frames_line + 3) break;  // Frames, Frame Time, two frames
    bvh += line + "\n";
    ++n;
  }
  const std::string student = kata::test::temp_path("kata_cli_two_frames.bvh");
  const std::string csv = kata::test::temp_path("kata_cli_two_frames.csv");
  std::ofstream(student) << bvh;
  const CliRun r = run("score --model " + std::string(KATA_SOURCE_DIR) + "/models/default.kata --teacher " +
                       std::string(KATA_DATA_DIR) + "/cmu/09_01.bvh --student " + student + " --preset cmu --out " + csv);
  EXPECT_NE(r.code, 0) << r.output;
  EXPECT_NE(r.output.find(student + ": nothing scored: of its 2 frame(s), 2 calibrating (the first 0.25 s"),
            std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("mean score 0"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("most to fix:"), std::string::npos) << r.output;
  std::ifstream rows(csv);
  int count = 0;
  for (std::string row; std::getline(rows, row);) ++count;
  EXPECT_EQ(count, 3) << "the CSV still has each frame";
  std::remove(student.c_str());
  std::remove(csv.c_str());
}

// The correction cue in `kata score`'s CSV: a copy of 02_01 with the left knee
// (BVH LeftLeg, X rotation) turned by 30 degrees on every frame, scored against the original by
// the online alignment, names LKnee in cue_joint on >= 70 % of the scoring rows, with a median
// cue_degrees of 30 +- 8 and the phrase "left knee: ..."; the columns are named exactly so, and
// empty exactly when part_to_fix is.
TEST(CliScore, ABentKneeCopyNamesTheLeftKneeInTheCueColumns) {
  kata::BvhClip clip = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh");
  const int j = clip.skeleton.find("LeftLeg");
  ASSERT_GE(j, 0);
  const auto& ch = clip.channels[static_cast<size_t>(j)];
  int c = -1;
  for (size_t k = 0; k < ch.size(); ++k)
    if (ch[k] == kata::Channel::kXrot) c = static_cast<int>(k);
  ASSERT_GE(c, 0);
  for (int f = 1; f < clip.frame_count(); ++f)
    clip.motion[static_cast<size_t>(f) * clip.channel_count + static_cast<size_t>(clip.channel_offset[static_cast<size_t>(j)] + c)] += 30.0;
  const std::string student = kata::test::temp_path("kata_cli_bent_knee.bvh");
  const std::string csv = kata::test::temp_path("kata_cli_bent_knee.csv");
  kata::write_bvh(student, clip);
  const CliRun r = run("score --model " + std::string(KATA_SOURCE_DIR) + "/models/default.kata --teacher " +
                       std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh --student " + student +
                       " --preset cmu --first-frame 1 --out " + csv);
  ASSERT_EQ(r.code, 0) << r.output;
  std::ifstream in(csv);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  auto split = [](const std::string& text) {
    std::vector<std::string> cells;
    std::stringstream ss(text);
    for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
    if (!text.empty() && text.back() == ',') cells.emplace_back();
    return cells;
  };
  const std::vector<std::string> header = split(line);
  auto column = [&](const std::string& name) {
    for (size_t i = 0; i < header.size(); ++i)
      if (header[i] == name) return i;
    ADD_FAILURE() << name << " missing from " << line;
    return size_t{0};
  };
  const size_t joint = column("cue_joint"), degrees = column("cue_degrees"), cue = column("cue");
  const size_t state = column("state"), part = column("part_to_fix");
  int scoring = 0, knee = 0;
  std::vector<double> knee_degrees;
  while (std::getline(in, line)) {
    const std::vector<std::string> cell = split(line);
    ASSERT_EQ(cell.size(), header.size()) << line;
    EXPECT_EQ(cell[joint].empty(), cell[part].empty()) << line;
    EXPECT_EQ(cell[degrees].empty(), cell[joint].empty()) << line;
    EXPECT_EQ(cell[cue].empty(), cell[joint].empty()) << line;
    if (cell[state] != "scoring") continue;
    ++scoring;
    if (cell[joint] != "LKnee") continue;
    ++knee;
    knee_degrees.push_back(std::stod(cell[degrees]));
    EXPECT_EQ(cell[part], "left_leg") << line;
    EXPECT_EQ(cell[cue].rfind("left knee: ", 0), 0u) << line;
  }
  ASSERT_GT(scoring, 100);
  std::sort(knee_degrees.begin(), knee_degrees.end());
  const double median = knee_degrees.empty() ? 0.0 : knee_degrees[knee_degrees.size() / 2];
  std::printf("bent knee copy: cue LKnee on %d of %d scoring rows, median %.1f deg\n", knee, scoring, median);
  EXPECT_GE(knee, scoring * 7 / 10);
  EXPECT_NEAR(median, 30.0, 8.0);
  std::remove(student.c_str());
  std::remove(csv.c_str());
}

}  // namespace

// The transition protocol's tool path as a user runs it: pairs by the independent protocol, `kata eval` with
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
  EXPECT_NE(r.output.find("JCD (local)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("weighs GPD+RDSR"), std::string::npos) << r.output;
  r = run("model-info " + model);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("test, protocol transition-uniform: GPD+RDSR"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("test, protocol transition-uniform: JCD (local)"), std::string::npos) << r.output;
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
  // kata train --method joint-form: the model file says what it is, W reads only the joints'
  // coordinates and kinetics (45 + 90 dimensions, 3 columns per joint and axis), and kata eval
  // scores it on the same pairs.
  const std::string form = kata::test::temp_path("kata_cli_joint_form.kata");
  r = run("train --data " + data + " 02_01.bvh 07_01.bvh --pairs " + pairs + " --method joint-form --out " + form);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("training-pair precision"), std::string::npos) << r.output;
  const kata::metric::Model fm = kata::metric::load_model(form);
  ASSERT_EQ(fm.rank, 135);
  EXPECT_NE(fm.info.parameters.find("\"method\":\"joint-form\""), std::string::npos) << fm.info.parameters;
  double static_w = 0.0;
  for (int c = 0; c < fm.rank; ++c)
    for (int k = 45; k < 1591; ++k) static_w += std::abs(fm.w[static_cast<size_t>(c) * 1683 + k]);
  EXPECT_EQ(static_w, 0.0);
  const std::string form_eval = kata::test::temp_path("kata_cli_joint_form_eval");
  r = run("eval --data " + data + " --pairs " + pairs + " --model " + form + " --label form --no-plot --out-dir " +
          form_eval);
  ASSERT_EQ(r.code, 0) << r.output;
  // Its rows are named by its own method, not as an RDSR model's.
  EXPECT_NE(r.output.find("joint form             form"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("joint form @delta*     form"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("GPD+RDSR               form"), std::string::npos) << r.output;
  std::ifstream form_csv(form_eval + "/eval.csv");
  const std::string form_rows((std::istreambuf_iterator<char>(form_csv)), std::istreambuf_iterator<char>());
  EXPECT_NE(form_rows.find("\njoint form,form,"), std::string::npos) << form_rows;
  EXPECT_EQ(form_rows.find("GPD+RDSR,form,"), std::string::npos) << form_rows;
  std::remove(form.c_str());
  std::filesystem::remove_all(form_eval);
  for (const std::string& f : {pairs, model, csv}) std::remove(f.c_str());
}
