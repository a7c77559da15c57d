// Plugins hosted by a runtime through the C ABI (kata_runtime_desc.plugins, 1.1), with the
// shipped plugins and libkata only: bvh-replay plays a clip into the runtime as a source,
// csv-sink writes every result as a row. The expected counts come from the clip itself and from
// the records on_result receives; a refusal names the plugin's file and its own reason. csv-sink's
// repetitions (plugin ABI 2.1 on_repetition) against `kata score --reps` on the same clip.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "kata/kata.h"
#include "support/temp_paths.hpp"

namespace {

struct Seen {
  std::vector<uint64_t> frame_sequences;
};
void on_result(void* user, const kata_result_record* r) {
  static_cast<Seen*>(user)->frame_sequences.push_back(r->frame_sequence);
}

TEST(runtime_plugins_capi, ASourcePlaysAClipIntoTheRuntimeAndASinkWritesEveryResult) {
  kata::test::TempDir tmp;
  const std::string csv = tmp.file("scores.csv");
  const std::string clip_path = std::string(KATA_DATA_DIR) + "/cmu/07_01.bvh";
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_clip clip = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, clip_path.c_str(), &clip), KATA_OK);
  const uint64_t frames = kata_clip_frame_count(clip) - 1;  // bvh-replay skips the T-pose frame 0
  kata_clip_destroy(clip);

  const std::string sink_path = std::string(KATA_PLUGIN_DIR) + "/csv-sink.so";
  const std::string source_path = std::string(KATA_PLUGIN_DIR) + "/bvh-replay.so";
  const std::string sink_config = "path=" + csv;
  const std::string source_config = "path=" + clip_path + ";stream=5;speed=20";
  const kata_runtime_plugin plugins[] = {{sink_path.c_str(), sink_config.c_str()},
                                         {source_path.c_str(), source_config.c_str()}};
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  EXPECT_EQ(rd.plugins, nullptr);
  EXPECT_EQ(rd.plugin_count, 0u);
  rd.workers = 1;
  rd.plugins = plugins;
  rd.plugin_count = 2;
  Seen seen;
  rd.on_result = on_result;
  rd.on_result_user = &seen;
  kata_runtime runtime = nullptr;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  kata_runtime_counters c;
  c.struct_size = sizeof c;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  do {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    ASSERT_EQ(kata_runtime_get_counters(runtime, &c), KATA_OK);
  } while (c.results < frames && std::chrono::steady_clock::now() < deadline);
  ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);  // the source first, then every result to the sink
  ASSERT_EQ(kata_runtime_get_counters(runtime, &c), KATA_OK);
  kata_runtime_destroy(runtime);  // the sink is deactivated: its file closed
  EXPECT_EQ(c.frames_in, frames);
  EXPECT_EQ(c.results, frames);
  ASSERT_EQ(seen.frame_sequences.size(), frames);

  // One row per result, in order, for stream 5: what on_result saw.
  std::ifstream in(csv);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  EXPECT_EQ(line.rfind("stream_id,result_sequence,frame_sequence", 0), 0u) << line;
  uint64_t rows = 0;
  while (std::getline(in, line)) {
    ASSERT_LT(rows, frames);
    EXPECT_EQ(line.rfind("5," + std::to_string(rows) + "," + std::to_string(seen.frame_sequences[rows]) + ",", 0), 0u)
        << line;
    ++rows;
  }
  EXPECT_EQ(rows, frames);
  kata_context_destroy(ctx);
}

TEST(runtime_plugins_capi, RefusalsNameThePluginFileAndNoRuntimeIsCreated) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  const std::string sink_path = std::string(KATA_PLUGIN_DIR) + "/csv-sink.so";
  const std::string missing = std::string(KATA_PLUGIN_DIR) + "/no-such-plugin.so";
  struct Case {
    kata_runtime_plugin plugin;
    std::string says;
  };
  const Case cases[] = {
      {{sink_path.c_str(), nullptr}, "csv-sink.so: activate failed: csv-sink: config needs path=FILE"},
      {{missing.c_str(), ""}, "no-such-plugin.so"},
      {{"", ""}, "plugins[0].path is empty"},
  };
  for (const Case& k : cases) {
    SCOPED_TRACE(k.says);
    kata_runtime_desc rd;
    kata_runtime_desc_init(&rd);
    rd.plugins = &k.plugin;
    rd.plugin_count = 1;
    kata_runtime runtime = nullptr;
    EXPECT_NE(kata_runtime_create(ctx, &rd, &runtime), KATA_OK);
    EXPECT_EQ(runtime, nullptr);
    EXPECT_NE(std::string(kata_context_last_error(ctx)).find(k.says), std::string::npos) << kata_context_last_error(ctx);
  }
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.plugin_count = 1;  // without plugins
  kata_runtime runtime = nullptr;
  EXPECT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(kata_context_last_error(ctx)).find("plugin_count"), std::string::npos);
  kata_context_destroy(ctx);
}

std::vector<std::string> cells(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream in(line);
  std::string cell;
  while (std::getline(in, cell, ',')) out.push_back(cell);
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

std::vector<std::vector<std::string>> read_csv(const std::string& path) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) rows.push_back(cells(line));
  return rows;
}

void on_repetition(void* user, const kata_repetition* r) { static_cast<std::vector<kata_repetition>*>(user)->push_back(*r); }

// A walk (02_01 after its T-pose) played two and a half times on end (the second time with the
// left knee turned 45 degrees), against itself as the teacher, the whole clip one repetition, looped: through a runtime hosting csv-sink with
// repetitions=FILE, and through `kata score --reps` of the same clip. The sink writes the rows
// kata score writes (two complete repetitions, the third partial, ended by the end of the take),
// the same columns, and a stream_id after them; every repetition on_repetition saw, in order.
TEST(runtime_plugins_capi, ASinkWritesTheRepetitionsKataScoreWrites) {
  kata::test::TempDir tmp;
  const std::string teacher_path = std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh";
  // The student's file: the clip's hierarchy, its T-pose, then its frames 1..n, 2.5 times.
  std::ifstream bvh(teacher_path);
  std::string line, header, joint;
  std::vector<std::string> motion;
  double ft = 0.0;
  bool in_motion = false;
  int column = 0, knee = -1;  // the motion column of LeftLeg's Xrotation (the left knee)
  while (std::getline(bvh, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.rfind("MOTION", 0) == 0) in_motion = true;
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (!in_motion && (word == "ROOT" || word == "JOINT")) words >> joint;
    if (!in_motion && word == "CHANNELS") {
      int count = 0;
      words >> count;
      for (int c = 0; c < count && words >> word; ++c, ++column)
        if (joint == "LeftLeg" && word == "Xrotation") knee = column;
    }
    if (!in_motion) header += line + "\n";
    else if (line.rfind("Frame Time:", 0) == 0) ft = std::stod(line.substr(11));
    else if (line.find_first_not_of(" \t") != std::string::npos && line.rfind("Frames:", 0) != 0 && line != "MOTION")
      motion.push_back(line);
  }
  const size_t n = motion.size() - 1;
  ASSERT_GT(n, 100u);
  ASSERT_GE(knee, 0);
  ASSERT_GT(ft, 0.0);
  const size_t played = 5 * n / 2;
  const std::string student_path = tmp.file("student.bvh");
  {
    std::ofstream out(student_path);
    out << header << "MOTION\nFrames: " << played + 1 << "\nFrame Time: " << ft << "\n" << motion[0] << "\n";
    for (size_t k = 0; k < played; ++k) {
      if (k < n || k >= 2 * n) {
        out << motion[1 + k % n] << "\n";
        continue;
      }
      // The second play with the left knee turned 45 degrees: a part to fix and a cue.
      std::istringstream values(motion[1 + k % n]);
      double v = 0.0;
      for (int c = 0; values >> v; ++c) out << (c ? " " : "") << (c == knee ? v + 45.0 : v);
      out << "\n";
    }
  }

  // The runtime, csv-sink writing the repetitions.
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_model model = nullptr;
  ASSERT_EQ(kata_model_load(ctx, KATA_SOURCE_DIR "/models/default.kata", &model), KATA_OK);
  kata_clip teacher = nullptr, student = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, teacher_path.c_str(), &teacher), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_clip_load_bvh(ctx, student_path.c_str(), &student), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_clip_frame_count(student), played + 1);
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(student, &skel), KATA_OK);
  const uint32_t joints = kata_skeleton_joint_count(skel);
  kata_stream_desc sd;
  kata_stream_desc_init(&sd);
  sd.layout = "cmu";
  sd.stencil = kata_model_stencil(model);
  kata_stream stream = nullptr;
  ASSERT_EQ(kata_stream_open(ctx, skel, &sd, &stream), KATA_OK) << kata_context_last_error(ctx);
  kata_teacher_desc td;
  kata_teacher_desc_init(&td);
  td.model = model;
  td.clip = teacher;
  td.first_frame = 1;
  td.ghost = 0;
  ASSERT_EQ(kata_stream_attach_teacher(stream, &td), KATA_OK) << kata_stream_last_error(stream);
  ASSERT_EQ(kata_stream_set_practice_section(stream, 0, -1, 1), KATA_OK) << kata_stream_last_error(stream);
  const std::string sink_path = std::string(KATA_PLUGIN_DIR) + "/csv-sink.so";
  const std::string runtime_reps = tmp.file("runtime_reps.csv");
  const std::string sink_config = "path=" + tmp.file("results.csv") + ";repetitions=" + runtime_reps;
  const kata_runtime_plugin plugin = {sink_path.c_str(), sink_config.c_str()};
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.workers = 1;
  rd.plugins = &plugin;
  rd.plugin_count = 1;
  std::vector<kata_repetition> seen;
  rd.on_repetition = on_repetition;
  rd.on_result_user = &seen;
  kata_runtime runtime = nullptr;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_runtime_add_stream(runtime, 9, &stream, "cmu", 0), KATA_OK) << kata_context_last_error(ctx);
  std::vector<float> p(3 * static_cast<size_t>(joints));
  for (uint32_t f = 1; f <= played; ++f) {
    ASSERT_EQ(kata_clip_positions(student, f, p.data(), p.size()), KATA_OK);
    while (kata_runtime_push(runtime, 9, f - 1, (f - 1) * ft, p.data(), joints) == KATA_E_QUEUE_FULL)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);  // the take's end closes the third repetition
  kata_runtime_destroy(runtime);                   // the sink deactivated: its files closed
  kata_skeleton_destroy(skel);
  kata_clip_destroy(student);
  kata_clip_destroy(teacher);
  kata_model_destroy(model);
  kata_context_destroy(ctx);

  // kata score --reps on the same clips.
  const std::string score_reps = tmp.file("score_reps.csv");
  const std::string command = std::string(KATA_CLI) + " score --model " KATA_SOURCE_DIR "/models/default.kata --teacher " +
                              teacher_path + " --student " + student_path + " --layout cmu --first-frame 1 --out " +
                              tmp.file("frames.csv") + " --reps " + score_reps + " > " + tmp.file("score.log") + " 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;

  const auto ours = read_csv(runtime_reps);
  const auto theirs = read_csv(score_reps);
  ASSERT_GE(theirs.size(), 2u);
  ASSERT_EQ(ours.size(), theirs.size());
  // The header: kata score's columns, then stream_id.
  std::vector<std::string> columns = theirs[0];
  columns.push_back("stream_id");
  EXPECT_EQ(ours[0], columns);
  ASSERT_EQ(theirs.size(), 4u) << "kata score: not 2 complete + 1 partial";
  ASSERT_EQ(seen.size(), 3u);
  for (size_t i = 1; i < theirs.size(); ++i) {
    SCOPED_TRACE("repetition row " + std::to_string(i));
    const auto& a = ours[i];
    const auto& b = theirs[i];
    ASSERT_EQ(a.size(), b.size() + 1);
    EXPECT_EQ(a.back(), "9");
    std::printf("runtime: ");
    for (const auto& c : a) std::printf("%s,", c.c_str());
    std::printf("\nscore:   ");
    for (const auto& c : b) std::printf("%s,", c.c_str());
    std::printf("\n");
    EXPECT_EQ(a[0], b[0]);  // rep
    EXPECT_EQ(a[7], b[7]);  // partial
    EXPECT_EQ(a[0], std::to_string(seen[i - 1].index));
    EXPECT_EQ(a[7], seen[i - 1].partial ? "1" : "0");
    EXPECT_EQ(a[5], b[5]);  // part_to_fix
    EXPECT_EQ(a[6], b[6]);  // cue
    for (size_t c = 1; c < b.size(); ++c) {
      if (c == 5 || c == 6 || c == 7) continue;
      EXPECT_EQ(a[c], b[c]) << "column " << theirs[0][c];
    }
  }
  EXPECT_EQ(theirs[3][7], "1");  // the third, abandoned halfway: partial
  EXPECT_EQ(theirs[2][5], "left_leg");  // the second, the knee turned
  EXPECT_NE(theirs[2][6].find("left knee"), std::string::npos) << theirs[2][6];
}

}  // namespace
