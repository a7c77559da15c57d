// `kata coach` as CI runs it: headless at 8x real time on the default data, to the end, with a
// report; its per-frame scores, mean score and part-to-fix sequence equal a pipeline run here in
// the test process on the same frames (computed without any of the coach's code). A recorded
// lesson replays to the same results; a damaged recording is refused naming the file.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "metric/scorer.hpp"
#include "pipeline/pipeline.hpp"
#include "support/temp_paths.hpp"

namespace {

struct CliRun {
  int code;
  std::string output;
};

CliRun run_in_source_dir(const std::string& args, const kata::test::TempDir& dir) {
  const std::string log = dir.file("coach.log");
  const std::string cmd = std::string("cd ") + KATA_SOURCE_DIR + " && " + KATA_CLI + " " + args + " >" + log + " 2>&1";
  const int status = std::system(cmd.c_str());
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str()};
}

struct Row {
  int state = -1;
  float score = 0.0f;
  int part_to_fix = -2, matched = -2;
};

std::vector<Row> read_csv(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  std::vector<Row> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    if (cells.size() != 12) continue;
    Row r;
    r.state = std::stoi(cells[2]);
    r.score = std::stof(cells[3]);
    r.part_to_fix = std::stoi(cells[10]);
    r.matched = std::stoi(cells[11]);
    rows.push_back(r);
  }
  return rows;
}

// The lesson computed here: the default clips from frame 1, the shipped model, one pipeline with
// the whole teacher clip attached, frames pushed i / 120 s apart.
struct Expected {
  std::vector<float> score;
  std::vector<int> part_to_fix, matched;
  double mean = 0.0;
};

Expected run_pipeline_here() {
  using namespace kata;
  const std::string data = KATA_DATA_DIR;
  const auto metric = std::make_shared<const metric::Metric>(metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata"));
  const BvhClip teacher = load_bvh(data + "/cmu/05_18.bvh");
  const BvhClip student = load_bvh(data + "/cmu/05_19_on_02.bvh");
  const std::vector<float> tp = clip_positions(teacher, 1);
  const StreamConfig tc = stream_config_for(teacher.skeleton, make_gpd_map(teacher.skeleton, preset_joint_names("cmu")),
                                            metric->stencil());
  const auto t = pipeline::Teacher::from_positions(metric, teacher.skeleton, tc, tp.data(), teacher.frame_count() - 1,
                                                   teacher.frame_time);
  pipeline::PipelineConfig config;
  config.stream = stream_config_for(student.skeleton, make_gpd_map(student.skeleton, preset_joint_names("cmu")),
                                    metric->stencil());
  config.student = student.skeleton;
  pipeline::Pipeline p(config);
  p.set_teacher(t);
  const std::vector<float> sp = clip_positions(student, 1);
  const int frames = student.frame_count() - 1, joints = student.skeleton.joint_count();
  Expected e;
  e.score.assign(static_cast<size_t>(frames), -1.0f);
  e.part_to_fix.assign(static_cast<size_t>(frames), -2);
  e.matched.assign(static_cast<size_t>(frames), -2);
  auto drain = [&] {
    pipeline::Result r;
    while (p.read(&r, nullptr, nullptr, 1) == 1) {
      const size_t f = static_cast<size_t>(r.frame_index);
      e.score[f] = r.score.score;
      e.matched[f] = r.matched_frame;
      int worst = -1;
      float worst_value = 0.0f;
      for (int q = 0; q < metric::kParts; ++q)
        if (r.score.parts[q] > worst_value) worst = q, worst_value = r.score.parts[q];
      e.part_to_fix[f] = worst;
    }
  };
  for (int i = 0; i < frames; ++i) {
    EXPECT_EQ(p.push(i * student.frame_time, sp.data() + static_cast<size_t>(i) * 3 * joints, joints), Status::kOk);
    drain();
  }
  p.flush();
  drain();
  for (float s : e.score) e.mean += s;
  e.mean /= frames;
  return e;
}

double mean_in_summary(const std::string& output) {
  const size_t at = output.find("mean score ");
  return at == std::string::npos ? -1.0 : std::atof(output.c_str() + at + 11);
}

TEST(CliCoach, HeadlessLessonEqualsThePipelineRunInProcess) {
  kata::test::TempDir dir;
  const std::string csv = dir.file("lesson.csv"), report = dir.file("lesson.html"), rec = dir.file("lesson.npz");
  const CliRun r = run_in_source_dir("coach --headless --speed 8 --csv " + csv + " --report " + report + " --record " + rec, dir);
  ASSERT_EQ(r.code, 0) << r.output;
  const Expected e = run_pipeline_here();
  const std::vector<Row> rows = read_csv(csv);
  ASSERT_EQ(rows.size(), e.score.size()) << "the lesson runs to the end";
  double mean = 0.0;
  for (size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].state, 1) << "frame " << i << " scored and tracking";
    ASSERT_EQ(rows[i].score, e.score[i]) << "frame " << i;
    ASSERT_EQ(rows[i].part_to_fix, e.part_to_fix[i]) << "frame " << i;
    ASSERT_EQ(rows[i].matched, e.matched[i]) << "frame " << i;
    mean += rows[i].score;
  }
  EXPECT_DOUBLE_EQ(mean / rows.size(), e.mean);
  EXPECT_NEAR(mean_in_summary(r.output), e.mean, 0.005) << r.output;

  // The report: one self-contained page (inline SVG, no script, nothing fetched) naming the clips
  // by file name only.
  std::ifstream in(report);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string html = ss.str();
  EXPECT_NE(html.find("<svg"), std::string::npos);
  EXPECT_NE(html.find("The three lowest moments"), std::string::npos);
  EXPECT_NE(html.find("05_19_on_02.bvh"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);
  EXPECT_EQ(html.find(KATA_SOURCE_DIR), std::string::npos) << "no absolute path of this machine";

  // The recording replays to the same per-frame results.
  const std::string csv2 = dir.file("replay.csv");
  const CliRun replay = run_in_source_dir("coach --headless --speed 64 --replay " + rec + " --csv " + csv2 + " --report ''", dir);
  ASSERT_EQ(replay.code, 0) << replay.output;
  const std::vector<Row> again = read_csv(csv2);
  ASSERT_EQ(again.size(), rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(again[i].score, rows[i].score) << "frame " << i;
    ASSERT_EQ(again[i].part_to_fix, rows[i].part_to_fix) << "frame " << i;
  }
}

TEST(CliCoach, DamagedRecordingIsRefusedNamingTheFile) {
  kata::test::TempDir dir;
  const std::string bad = dir.file("bad.npz");
  std::ofstream(bad) << "PK\x03\x04 not really a zip";
  const CliRun r = run_in_source_dir("coach --headless --replay " + bad, dir);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find(bad), std::string::npos) << r.output;
}

}  // namespace
