// Landmark files in the CLI (issue 11): the 16 GPD joints of a CMU clip written as a "gpd"-layout
// .npy (frames, 16, 4 with confidence) and as a .csv score against the clip's own BVH with the
// default model as the exact joints do, and the two file forms give the same features.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/npy.hpp"
#include "support/temp_paths.hpp"

namespace {

struct CliResult {
  int code;
  std::string output;
};

CliResult run_cli(const kata::test::TempDir& dir, const std::string& args) {
  const std::string log = dir.file("cli.log");
  const int status = std::system((std::string(KATA_CLI) + " " + args + " >" + log + " 2>&1").c_str());
  std::stringstream ss;
  ss << std::ifstream(log).rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str()};
}

double mean_score(const std::string& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // header
  double sum = 0;
  int n = 0;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string field;
    for (int k = 0; k < 4 && std::getline(ss, field, ','); ++k) {
      if (k == 3) sum += std::stod(field);
    }
    ++n;
  }
  return n ? sum / n : 0.0;
}

TEST(CliLandmarks, GpdLayoutArraysScoreLikeTheBvhAndNpyEqualsCsv) {
  kata::test::TempDir dir;
  const std::string bvh = std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh";
  const kata::BvhClip clip = kata::load_bvh(bvh);
  const kata::GpdMap map = kata::make_gpd_map(clip.skeleton, kata::preset_joint_names("cmu"));
  const std::vector<float> pos = kata::clip_positions(clip, 1);
  const int n = clip.skeleton.joint_count(), frames = clip.frame_count() - 1;
  std::vector<float> arr;
  std::ofstream csv(dir.file("gpd.csv"));
  csv.precision(9);
  csv << "# x,y,z,confidence per GPD joint\n";
  for (int f = 0; f < frames; ++f) {
    for (int g = 0; g < 16; ++g) {
      const float* p = pos.data() + (static_cast<size_t>(f) * n + map.source[static_cast<size_t>(g)]) * 3;
      arr.insert(arr.end(), {p[0], p[1], p[2], 1.0f});
      csv << (g ? "," : "") << p[0] << "," << p[1] << "," << p[2] << ",1";
    }
    csv << "\n";
  }
  csv.close();
  kata::write_npy(dir.file("gpd.npy"), arr.data(), {static_cast<size_t>(frames), 16, 4});
  const double fps = 1.0 / clip.frame_time;
  const std::string model = std::string(KATA_SOURCE_DIR) + "/models/default.kata";

  CliResult r = run_cli(dir, "score --model " + model + " --teacher " + bvh + " --layout cmu --first-frame 1 --student " +
                           dir.file("gpd.npy") + " --student-layout gpd --fps " + std::to_string(fps) + " --out " +
                           dir.file("s.csv"));
  ASSERT_EQ(r.code, 0) << r.output;
  const double npy_score = mean_score(dir.file("s.csv"));
  std::printf("[ figures ] gpd-layout .npy student vs its own BVH teacher: mean score %.2f\n", npy_score);
  EXPECT_GE(npy_score, 95.0);

  r = run_cli(dir, "features --student " + dir.file("gpd.npy") + " --layout gpd --fps " + std::to_string(fps) +
                       " --out " + dir.file("a.npy"));
  ASSERT_EQ(r.code, 0) << r.output;
  r = run_cli(dir, "features --student " + dir.file("gpd.csv") + " --layout gpd --fps " + std::to_string(fps) +
                       " --out " + dir.file("b.npy"));
  ASSERT_EQ(r.code, 0) << r.output;
  std::vector<size_t> sa, sb;
  const std::vector<double> a = kata::read_npy(dir.file("a.npy"), &sa), b = kata::read_npy(dir.file("b.npy"), &sb);
  ASSERT_EQ(sa, sb);
  EXPECT_EQ(sa[0], static_cast<size_t>(frames));
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::fabs(a[i] - b[i]));
  EXPECT_LT(worst, 2e-2);  // CSV text written with 9 significant digits

  // Errors name the file: wrong joint count for the layout, a missing --fps.
  r = run_cli(dir, "features --student " + dir.file("gpd.npy") + " --layout mediapipe --fps 30 --out " + dir.file("c.npy"));
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("gpd.npy"), std::string::npos) << r.output;
  r = run_cli(dir, "features --student " + dir.file("gpd.csv") + " --layout gpd --out " + dir.file("c.npy"));
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("--fps"), std::string::npos) << r.output;
}

}  // namespace
