// Landmark files in the CLI: the 16 GPD joints of a CMU clip written as a "gpd"-layout
// .npy (frames, 16, 4 with confidence) and as a .csv score against the clip's own BVH with the
// default model as the exact joints do, and the two file forms give the same features.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>
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

// Across layouts from the CLI: a CMU BVH teacher onto a "gpd"-layout .npy student of another
// subject (no rest pose: its bone lengths come from its first 60 frames). The ghost's bones equal
// the student's (the median over those frames, computed here) and its Hip stands on the student's.
TEST(CliLandmarks, CrossLayoutGhostFromTheCli) {
  kata::test::TempDir dir;
  const std::string teacher = std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh";
  const kata::BvhClip clip = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/07_01.bvh");
  const kata::GpdMap map = kata::make_gpd_map(clip.skeleton, kata::preset_joint_names("cmu"));
  const std::vector<float> pos = kata::clip_positions(clip, 1);
  const int n = clip.skeleton.joint_count(), frames = clip.frame_count() - 1;
  std::vector<float> arr;
  for (int f = 0; f < frames; ++f)
    for (int g = 0; g < 16; ++g) {
      const float* p = pos.data() + (static_cast<size_t>(f) * n + map.source[static_cast<size_t>(g)]) * 3;
      arr.insert(arr.end(), {p[0], p[1], p[2]});
    }
  kata::write_npy(dir.file("student.npy"), arr.data(), {static_cast<size_t>(frames), 16, 3});
  const CliResult r = run_cli(dir, "retarget --teacher " + teacher + " --teacher-layout cmu --student " +
                                       dir.file("student.npy") + " --student-layout gpd --fps 120 --out " +
                                       dir.file("ghost.npy"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("estimated"), std::string::npos) << r.output;

  // The student's bones: per bone the median over its first 60 frames.
  const int parents[16] = {-1, 0, 1, 2, 2, 4, 5, 2, 7, 8, 0, 10, 11, 0, 13, 14};
  auto bone = [&](const float* joints, int g) {
    const float* a = joints + 3 * g;
    const float* b = joints + 3 * parents[g];
    return std::sqrt(double(a[0] - b[0]) * (a[0] - b[0]) + double(a[1] - b[1]) * (a[1] - b[1]) +
                     double(a[2] - b[2]) * (a[2] - b[2]));
  };
  double expected[16] = {0};
  for (int g = 1; g < 16; ++g) {
    std::vector<double> v;
    for (int f = 0; f < 60; ++f) v.push_back(bone(arr.data() + static_cast<size_t>(f) * 48, g));
    std::sort(v.begin(), v.end());
    expected[g] = 0.5 * (v[29] + v[30]);
  }
  std::vector<size_t> shape;
  const std::vector<double> ghost = kata::read_npy(dir.file("ghost.npy"), &shape);
  const kata::BvhClip teacher_clip = kata::load_bvh(teacher);
  ASSERT_EQ(shape, (std::vector<size_t>{static_cast<size_t>(teacher_clip.frame_count()), 16, 3}));
  double worst_bone = 0, worst_hip = 0;
  for (size_t f = 0; f < shape[0]; ++f) {
    std::vector<float> g(ghost.begin() + static_cast<std::ptrdiff_t>(f * 48), ghost.begin() + static_cast<std::ptrdiff_t>(f * 48 + 48));
    for (int j = 1; j < 16; ++j) worst_bone = std::max(worst_bone, std::fabs(bone(g.data(), j) / expected[j] - 1.0));
    const float* hip = arr.data() + std::min<size_t>(f, static_cast<size_t>(frames) - 1) * 48;
    for (int k = 0; k < 3; ++k) worst_hip = std::max(worst_hip, std::fabs(double(g[static_cast<size_t>(k)]) - hip[k]));
  }
  std::printf("[ figures ] kata retarget across layouts (CMU BVH -> gpd .npy): worst bone error %.3g%%, hip placement "
              "%.3g units\n",
              100 * worst_bone, worst_hip);
  EXPECT_LT(worst_bone, 0.005);
  EXPECT_LT(worst_hip, 1e-3);

  // BVH output is refused across layouts, naming the reason.
  const CliResult bad = run_cli(dir, "retarget --teacher " + teacher + " --student " + dir.file("student.npy") +
                                         " --student-layout gpd --fps 120 --out " + dir.file("ghost.bvh"));
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.output.find(".npy"), std::string::npos) << bad.output;
}

// Frames a landmark array lost (NaN joints: more than a quarter of the 16 missing) keep their CSV
// rows in kata score, with the state "tracking_lost" and no score; the others are scored at
// their own times.
TEST(CliLandmarks, LostFramesKeepTheirRowsAsTrackingLost) {
  kata::test::TempDir dir;
  const std::string bvh = std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh";
  const kata::BvhClip clip = kata::load_bvh(bvh);
  const kata::GpdMap map = kata::make_gpd_map(clip.skeleton, kata::preset_joint_names("cmu"));
  const std::vector<float> pos = kata::clip_positions(clip, 1);
  const int n = clip.skeleton.joint_count(), frames = clip.frame_count() - 1;
  std::vector<float> arr;
  for (int f = 0; f < frames; ++f)
    for (int g = 0; g < 16; ++g) {
      const float* p = pos.data() + (static_cast<size_t>(f) * n + map.source[static_cast<size_t>(g)]) * 3;
      const bool lost = f >= 100 && f < 140 && g >= 10;  // both legs gone for 40 frames
      arr.insert(arr.end(), {lost ? NAN : p[0], p[1], p[2]});
    }
  kata::write_npy(dir.file("lost.npy"), arr.data(), {static_cast<size_t>(frames), 16, 3});
  const std::string model = std::string(KATA_SOURCE_DIR) + "/models/default.kata";
  const CliResult r = run_cli(dir, "score --model " + model + " --teacher " + bvh + " --layout cmu --first-frame 1 " +
                                       "--student " + dir.file("lost.npy") + " --student-layout gpd --fps " +
                                       std::to_string(1.0 / clip.frame_time) + " --out " + dir.file("s.csv"));
  ASSERT_EQ(r.code, 0) << r.output;
  std::ifstream in(dir.file("s.csv"));
  std::string line;
  std::getline(in, line);
  // The state's column, by its name (columns are appended: the cue's after it).
  auto cells = [](const std::string& text) {
    std::vector<std::string> out;
    std::stringstream ss(text);
    for (std::string cell; std::getline(ss, cell, ',');) out.push_back(cell);
    if (!text.empty() && text.back() == ',') out.emplace_back();
    return out;
  };
  const std::vector<std::string> header = cells(line);
  const size_t state_column =
      static_cast<size_t>(std::find(header.begin(), header.end(), "state") - header.begin());
  ASSERT_LT(state_column, header.size()) << line;
  int rows = 0, lost_rows = 0, scored_rows = 0;
  while (std::getline(in, line)) {
    const std::vector<std::string> row = cells(line);
    ASSERT_EQ(row.size(), header.size()) << line;
    const std::string state = row[state_column];
    const int frame = std::stoi(line.substr(0, line.find(',')));
    // --first-frame 1 skips the array's first frame too: CSV frame = array index.
    EXPECT_EQ(frame, rows + 1) << "one row per source frame, numbered from --first-frame";
    if (frame >= 100 && frame < 140) {
      EXPECT_EQ(state, "tracking_lost") << line;
    } else {
      EXPECT_NE(state, "tracking_lost") << line;
    }
    lost_rows += state == "tracking_lost";
    scored_rows += state == "scoring";
    ++rows;
  }
  EXPECT_EQ(rows, frames - 1);
  EXPECT_EQ(lost_rows, 40);
  EXPECT_GT(scored_rows, frames - 40 - 80);  // calibrating after each restart: 0.25 s
}

// MediaPipe's shapes: timestamps in milliseconds (performance.now()-like, far from 0),
// with capture jitter, beside the .npy (X.times.npy) or as a CSV's first column, with five channels
// (x, y, z, visibility, presence). Read with --time-units ms they give the features of the same
// frames in seconds (to rounding), which differ from a uniform --fps run (the timestamps are used);
// the units are inferred when left out; steps that fit neither unit are refused naming the file
// unless a unit is stated, and a stated unit that fits only the other is refused naming it.
TEST(CliLandmarks, MillisecondTimestampsGiveTheFeaturesOfSeconds) {
  kata::test::TempDir dir;
  const kata::BvhClip clip = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh");
  const kata::GpdMap map = kata::make_gpd_map(clip.skeleton, kata::preset_joint_names("cmu"));
  const std::vector<float> pos = kata::clip_positions(clip, 1);
  const int n = clip.skeleton.joint_count(), frames = std::min(clip.frame_count() - 1, 240);
  std::vector<float> four, five;
  std::vector<double> seconds, ms, bad;
  std::ofstream csv(dir.file("ms.csv"));
  csv.precision(12);
  csv << "timestamp_ms,landmarks...\n";
  for (int f = 0; f < frames; ++f) {
    const double t = f * clip.frame_time + 0.002 * std::sin(0.7 * f);  // jitter, still increasing
    seconds.push_back(t);
    ms.push_back(5.0e6 + 1000.0 * t);
    bad.push_back(0.7 * f);  // 0.7 s or 0.7 ms a frame: neither is a camera
    csv << ms.back();
    for (int g = 0; g < 16; ++g) {
      const float* p = pos.data() + (static_cast<size_t>(f) * n + map.source[static_cast<size_t>(g)]) * 3;
      four.insert(four.end(), {p[0], p[1], p[2], 1.0f});
      five.insert(five.end(), {p[0], p[1], p[2], 1.0f, 1.0f});
      csv << "," << p[0] << "," << p[1] << "," << p[2] << ",1,1";
    }
    csv << "\n";
  }
  csv.close();
  const std::vector<size_t> shape4 = {static_cast<size_t>(frames), 16, 4}, shape5 = {static_cast<size_t>(frames), 16, 5};
  const std::vector<size_t> times_shape = {static_cast<size_t>(frames)};
  kata::write_npy(dir.file("s.npy"), four.data(), shape4);
  kata::write_npy(dir.file("s.times.npy"), seconds.data(), times_shape);
  kata::write_npy(dir.file("ms.npy"), five.data(), shape5);
  kata::write_npy(dir.file("ms.times.npy"), ms.data(), times_shape);
  kata::write_npy(dir.file("uniform.npy"), four.data(), shape4);
  kata::write_npy(dir.file("bad.npy"), four.data(), shape4);
  kata::write_npy(dir.file("bad.times.npy"), bad.data(), times_shape);

  auto features = [&](const std::string& in, const std::string& flags, const std::string& out) {
    const CliResult r = run_cli(dir, "features --student " + dir.file(in) + " --layout gpd " + flags + " --out " + dir.file(out));
    EXPECT_EQ(r.code, 0) << r.output;
    std::vector<size_t> shape;
    return kata::read_npy(dir.file(out), &shape);
  };
  const std::vector<double> in_s = features("s.npy", "--time-units s", "a.npy");
  const std::vector<double> in_ms = features("ms.npy", "--time-units ms", "b.npy");
  const std::vector<double> inferred = features("ms.npy", "", "c.npy");
  const std::vector<double> from_csv = features("ms.csv", "--time-units ms", "d.npy");
  const std::vector<double> uniform = features("uniform.npy", "--fps " + std::to_string(1.0 / clip.frame_time), "e.npy");
  ASSERT_EQ(in_s.size(), static_cast<size_t>(frames) * 1683);
  ASSERT_EQ(in_ms.size(), in_s.size());
  ASSERT_EQ(inferred.size(), in_s.size());
  ASSERT_EQ(from_csv.size(), in_s.size());
  ASSERT_EQ(uniform.size(), in_s.size());
  double worst = 0, worst_csv = 0, jitter = 0;
  for (size_t i = 0; i < in_s.size(); ++i) {
    const double scale = 1.0 + std::fabs(in_s[i]);
    worst = std::max({worst, std::fabs(in_ms[i] - in_s[i]) / scale, std::fabs(inferred[i] - in_s[i]) / scale});
    worst_csv = std::max(worst_csv, std::fabs(from_csv[i] - in_s[i]) / scale);
    jitter = std::max(jitter, std::fabs(uniform[i] - in_s[i]) / scale);
  }
  std::printf("[ figures ] ms vs s features: worst relative difference %.2g (csv %.2g); uniform --fps vs the "
              "jittered timestamps: %.2g\n", worst, worst_csv, jitter);
  EXPECT_LT(worst, 1e-5);
  EXPECT_LT(worst_csv, 2e-2);  // CSV text with 12 significant digits of position
  EXPECT_GT(jitter, 1e-2) << "the timestamps must reach the kinetics";

  CliResult r = run_cli(dir, "features --student " + dir.file("bad.npy") + " --layout gpd --out " + dir.file("f.npy"));
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find(dir.file("bad.npy")), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("ambiguous time units"), std::string::npos) << r.output;
  r = run_cli(dir, "score --model " + std::string(KATA_SOURCE_DIR) + "/models/default.kata --teacher " +
                       dir.file("bad.npy") + " --teacher-layout gpd --student " + dir.file("s.npy") +
                       " --student-layout gpd --out " + dir.file("g.csv"));
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find(dir.file("bad.npy")), std::string::npos) << r.output;
  r = run_cli(dir, "features --student " + dir.file("ms.npy") + " --layout gpd --time-units s --out " + dir.file("f.npy"));
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("fits milliseconds (--time-units ms)"), std::string::npos) << r.output;
  // Steps that fit neither unit, stated by the user: taken (a webcam page without a GPU runs at
  // about 1 Hz; the coach's --record-teacher / --record-student files are in seconds).
  r = run_cli(dir, "features --student " + dir.file("bad.npy") + " --layout gpd --time-units s --out " + dir.file("h.npy"));
  EXPECT_EQ(r.code, 0) << r.output;
  // 1.2 s a frame (such a page's, measured): auto reads 1.2 ms; stated seconds take it.
  std::vector<double> slow;
  for (int f = 0; f < frames; ++f) slow.push_back(1.2 * f);
  kata::write_npy(dir.file("slow.npy"), four.data(), shape4);
  kata::write_npy(dir.file("slow.times.npy"), slow.data(), times_shape);
  r = run_cli(dir, "features --student " + dir.file("slow.npy") + " --layout gpd --time-units s --out " + dir.file("i.npy"));
  EXPECT_EQ(r.code, 0) << r.output;
}

// Five channels: presence is read as confidence with visibility (the smaller of the two), so a
// joint MediaPipe calls visible but not present is missing: both legs absent for 40 frames are
// "tracking lost" frames, as a NaN would be; all 1 gives the 4-channel features.
TEST(CliLandmarks, PresenceGatesJointsLikeVisibility) {
  kata::test::TempDir dir;
  const kata::BvhClip clip = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh");
  const kata::GpdMap map = kata::make_gpd_map(clip.skeleton, kata::preset_joint_names("cmu"));
  const std::vector<float> pos = kata::clip_positions(clip, 1);
  const int n = clip.skeleton.joint_count(), frames = std::min(clip.frame_count() - 1, 200);
  std::vector<float> five;
  for (int f = 0; f < frames; ++f)
    for (int g = 0; g < 16; ++g) {
      const float* p = pos.data() + (static_cast<size_t>(f) * n + map.source[static_cast<size_t>(g)]) * 3;
      const float presence = f >= 100 && f < 140 && g >= 10 ? 0.1f : 0.9f;
      five.insert(five.end(), {p[0], p[1], p[2], 0.95f, presence});
    }
  kata::write_npy(dir.file("mp.npy"), five.data(), {static_cast<size_t>(frames), 16, 5});
  const CliResult r = run_cli(dir, "features --student " + dir.file("mp.npy") + " --layout gpd --fps 120 --out " + dir.file("a.npy"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("40 frames tracking lost"), std::string::npos) << r.output;
}

}  // namespace

namespace {

// kata score --tolerance: "40" is the normal map (a50 40, slope 5), CSV for CSV with the default;
// lenient scores another subject's walk higher; anything else is refused naming it, before a clip
// is read.
TEST(CliScore, ToleranceSetsThePartMap) {
  kata::test::TempDir dir;
  const std::string base = "score --model " + std::string(KATA_SOURCE_DIR) + "/models/default.kata --teacher " +
                           std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh --student " + std::string(KATA_DATA_DIR) +
                           "/cmu/07_01.bvh --preset cmu --first-frame 1 --out ";
  auto text = [](const std::string& path) {
    std::stringstream ss;
    ss << std::ifstream(path).rdbuf();
    return ss.str();
  };
  ASSERT_EQ(run_cli(dir, base + dir.file("default.csv")).code, 0);
  ASSERT_EQ(run_cli(dir, base + dir.file("forty.csv") + " --tolerance 40").code, 0);
  ASSERT_EQ(run_cli(dir, base + dir.file("normal.csv") + " --tolerance normal").code, 0);
  ASSERT_EQ(run_cli(dir, base + dir.file("lenient.csv") + " --tolerance lenient").code, 0);
  EXPECT_EQ(text(dir.file("forty.csv")), text(dir.file("default.csv")));
  EXPECT_EQ(text(dir.file("normal.csv")), text(dir.file("default.csv")));
  EXPECT_GT(mean_score(dir.file("lenient.csv")), mean_score(dir.file("default.csv")) + 5.0);
  const CliResult bad = run_cli(dir, base + dir.file("bad.csv") + " --tolerance loose");
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.output.find("tolerance \"loose\""), std::string::npos) << bad.output;
}

}  // namespace
