// The plugin ABI: refusals with their messages, and shipped plugins working through a runtime
// (bvh-replay as a source, csv-sink as a sink).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "common/error.hpp"
#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "pipeline/pipeline.hpp"
#include "runtime/plugin.hpp"
#include "runtime/plugin_host.hpp"
#include "runtime/runtime.hpp"
#include "support/accounting.hpp"
#include "support/temp_paths.hpp"

namespace kata::runtime {
namespace {

std::string refusal(const std::string& path) {
  try {
    LoadedPlugin::load(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(runtime_plugin, RefusalsNameTheFileAndTheReason) {
  const std::string dir = KATA_TEST_PLUGIN_DIR;
  const std::string major = dir + "/broken_major.so";
  EXPECT_EQ(refusal(major), "plugin " + major + ": ABI major version 1, this host speaks 2");
  const std::string size = dir + "/broken_size.so";
  EXPECT_NE(refusal(size).find("plugin " + size + ": its table is"), std::string::npos) << refusal(size);
  EXPECT_NE(refusal(size).find("larger than this host knows"), std::string::npos);
  const std::string missing = dir + "/broken_missing.so";
  EXPECT_EQ(refusal(missing), "plugin " + missing + ": missing required function on_result (a sink)");
  const std::string no_entry = dir + "/broken_no_entry.so";
  EXPECT_EQ(refusal(no_entry), "plugin " + no_entry + ": no entry symbol kata_plugin_entry");
  const std::string absent = dir + "/no_such_plugin.so";
  EXPECT_EQ(refusal(absent), "plugin " + absent + ": no such file");
  // A file that is not a shared library: dlopen's reason, with the file.
  kata::test::TempDir tmp;
  const std::string text = (tmp.path() / "not_a_library.so").string();
  std::ofstream(text) << "hello";
  EXPECT_NE(refusal(text).find("plugin " + text + ": cannot load: "), std::string::npos) << refusal(text);
}

// A sink built against plugin ABI 2.0 (its table ends before on_repetition) still loads, and the
// host hands it no repetition (no RepetitionSink), while the shipped csv-sink (2.1) takes them.
TEST(runtime_plugin, ASinkOfAbi20LoadsWithoutRepetitions) {
  const std::string old = std::string(KATA_TEST_PLUGIN_DIR) + "/broken_old_minor.so";
  EXPECT_EQ(refusal(old), "");
  std::shared_ptr<LoadedPlugin> plugin = LoadedPlugin::load(old);
  EXPECT_TRUE(plugin->is_sink());
  EXPECT_EQ(plugin->table().struct_size, offsetof(kata_plugin, on_repetition));
  EXPECT_EQ(plugin->table().on_repetition, nullptr);
  PluginInstance instance(plugin, "", std::make_shared<PluginHostTarget>());
  EXPECT_FALSE(static_cast<bool>(instance.repetition_sink()));
  EXPECT_TRUE(static_cast<bool>(instance.sink().on_result));
  std::shared_ptr<LoadedPlugin> csv = LoadedPlugin::load(std::string(KATA_PLUGIN_DIR) + "/csv-sink.so");
  EXPECT_EQ(csv->table().struct_size, sizeof(kata_plugin));
  EXPECT_NE(csv->table().on_repetition, nullptr);
  // Without repetitions=FILE it takes them and writes nothing (no file to write).
  kata::test::TempDir tmp;
  PluginInstance sink(csv, "path=" + tmp.file("results.csv"), std::make_shared<PluginHostTarget>());
  kata_repetition r{};
  r.struct_size = sizeof r;
  r.index = 1;
  sink.repetition_sink()(r);
}

TEST(runtime_plugin, ShippedPluginsLoadFromTheirDirectory) {
  const auto plugins = LoadedPlugin::load_directory(KATA_PLUGIN_DIR);
  ASSERT_GE(plugins.size(), 2u);
  bool csv = false, replay = false;
  for (const auto& p : plugins) {
    csv = csv || (std::string(p->table().name) == "csv-sink" && p->is_sink());
    replay = replay || (std::string(p->table().name) == "bvh-replay" && p->is_source());
  }
  EXPECT_TRUE(csv && replay);
}

TEST(runtime_plugin, BvhReplaySourceIntoCsvSinkThroughTheRuntime) {
  kata::test::TempDir tmp;
  const std::string csv_path = (tmp.path() / "scores.csv").string();
  const std::string clip = std::string(KATA_DATA_DIR) + "/cmu/07_01.bvh";
  const int frames = load_bvh(clip).frame_count() - 1;

  auto target = std::make_shared<PluginHostTarget>();
  std::shared_ptr<LoadedPlugin> sink_plugin = LoadedPlugin::load(std::string(KATA_PLUGIN_DIR) + "/csv-sink.so");
  std::shared_ptr<LoadedPlugin> source_plugin = LoadedPlugin::load(std::string(KATA_PLUGIN_DIR) + "/bvh-replay.so");
  // A sink's own refusal comes back with the file.
  try {
    PluginInstance bad(sink_plugin, "", target);
    FAIL() << "activate without path must fail";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("csv-sink.so: activate failed: csv-sink: config needs path=FILE"),
              std::string::npos)
        << e.what();
  }
  StreamCounters counted;  // stream 5's, after the stop
  {
    PluginInstance sink(sink_plugin, "path=" + csv_path, target);
    RuntimeConfig config;
    config.sinks.push_back(sink.sink());
    Runtime runtime(config);
    target->runtime = &runtime;
    PluginInstance source(source_plugin, "path=" + clip + ";stream=5;speed=20", target);
    source.start();
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (runtime.counters().total.results < static_cast<uint64_t>(frames) && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    source.stop();
    runtime.stop();  // flushes the sink on the I/O thread
    target->runtime = nullptr;
    const RuntimeCounters c = runtime.counters();
    EXPECT_EQ(c.total.frames_in, static_cast<uint64_t>(frames));
    EXPECT_EQ(c.total.results, static_cast<uint64_t>(frames));
    counted = runtime.stream_counters(5).value();
  }
  std::ifstream in(csv_path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line.rfind("stream_id,result_sequence,frame_sequence", 0), 0u);
  int rows = 0;
  while (std::getline(in, line)) {
    std::stringstream row(line);
    std::string stream, result_sequence, frame_sequence;
    std::getline(row, stream, ',');
    std::getline(row, result_sequence, ',');
    std::getline(row, frame_sequence, ',');
    EXPECT_EQ(stream, "5");
    EXPECT_EQ(result_sequence, std::to_string(rows));
    EXPECT_EQ(frame_sequence, std::to_string(rows));
    ++rows;
  }
  EXPECT_EQ(rows, frames);
  // Every frame the source plugin played is a row of the sink's file.
  EXPECT_EQ(kata::test::unaccounted(5, {static_cast<uint64_t>(frames), static_cast<uint64_t>(rows)}, counted,
                                    kata::test::Delivery::kSinks),
            "");
}

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream row(line);
  std::string cell;
  while (std::getline(row, cell, ',')) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

// Each header cell's column index.
std::map<std::string, size_t> columns_of(const std::vector<std::string>& header) {
  std::map<std::string, size_t> column;
  for (size_t i = 0; i < header.size(); ++i) column[header[i]] = i;
  return column;
}

// The correction cue reaches a sink plugin in the record (kata/result.h): csv-sink's cue cells
// from a record carrying one (the GPD joint's name, the degrees, the action's word) and empty
// cells from a record without one.
TEST(runtime_plugin, CsvSinkWritesTheCue) {
  kata::test::TempDir tmp;
  const std::string csv_path = (tmp.path() / "cue.csv").string();
  std::shared_ptr<LoadedPlugin> sink_plugin = LoadedPlugin::load(std::string(KATA_PLUGIN_DIR) + "/csv-sink.so");
  {
    PluginInstance sink(sink_plugin, "path=" + csv_path, std::make_shared<PluginHostTarget>());
    transport::ResultFields f;
    f.scored = 1;
    f.part_to_fix = 2;
    f.cue_joint = 8;  // RElbow
    f.cue_degrees = 31.5f;
    f.cue_action = 1;  // straighten
    sink.sink().on_result(f);
    transport::ResultFields none;
    none.result_sequence = 1;
    sink.sink().on_result(none);
  }
  std::ifstream in(csv_path);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  const std::vector<std::string> header = split_csv(line);
  std::map<std::string, size_t> column = columns_of(header);
  for (const char* name : {"cue_joint", "cue_degrees", "cue_action"}) ASSERT_TRUE(column.count(name)) << name;
  ASSERT_TRUE(std::getline(in, line));
  std::vector<std::string> cell = split_csv(line);
  ASSERT_EQ(cell.size(), header.size()) << line;
  EXPECT_EQ(cell[column["cue_joint"]], "RElbow") << line;
  EXPECT_EQ(std::stof(cell[column["cue_degrees"]]), 31.5f) << line;
  EXPECT_EQ(cell[column["cue_action"]], "straighten") << line;
  ASSERT_TRUE(std::getline(in, line));
  cell = split_csv(line);
  ASSERT_EQ(cell.size(), header.size()) << line;
  EXPECT_EQ(cell[column["cue_joint"]], "") << line;
  EXPECT_EQ(cell[column["cue_degrees"]], "") << line;
  EXPECT_EQ(cell[column["cue_action"]], "") << line;
}

// What a coaching app shows, through a sink plugin: each part's score, the part to fix, the
// scorer's state, where the student is in the routine and the practice section (plugin ABI minor
// 1). The student is the teacher's own clip (05_18 from frame 1, teacher row i = frame i); every
// CSV cell is checked against the result the runtime handed its in-process sinks.
TEST(runtime_plugin, CsvSinkRowsCarryThePartScoresTheCueAndTheState) {
  kata::test::TempDir tmp;
  const std::string csv_path = (tmp.path() / "coach.csv").string();
  const std::string clip_path = std::string(KATA_DATA_DIR) + "/cmu/05_18.bvh";
  const BvhClip clip = load_bvh(clip_path);
  const int frames = clip.frame_count() - 1;
  const std::vector<float> positions = clip_positions(clip, 1);
  const auto metric =
      std::make_shared<const metric::Metric>(metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata"));
  const GpdMap map = make_gpd_map(clip.skeleton, preset_joint_names("cmu"));
  const std::shared_ptr<const pipeline::Teacher> teacher = pipeline::Teacher::from_positions(
      metric, clip.skeleton, stream_config_for(clip.skeleton, map, metric->stencil()), positions.data(), frames,
      clip.frame_time);

  std::mutex mutex;
  std::map<uint64_t, transport::ResultFields> published;  // by result_sequence (the I/O thread's copy)
  auto target = std::make_shared<PluginHostTarget>();
  std::shared_ptr<LoadedPlugin> sink_plugin = LoadedPlugin::load(std::string(KATA_PLUGIN_DIR) + "/csv-sink.so");
  std::shared_ptr<LoadedPlugin> source_plugin = LoadedPlugin::load(std::string(KATA_PLUGIN_DIR) + "/bvh-replay.so");
  {
    PluginInstance sink(sink_plugin, "path=" + csv_path, target);
    RuntimeConfig config;
    config.sinks.push_back(sink.sink());
    config.sinks.push_back({[&](const transport::ResultFields& f) {
                              transport::ResultFields copy = f;
                              copy.ghost = nullptr, copy.features = nullptr;
                              std::lock_guard<std::mutex> lock(mutex);
                              published[f.result_sequence] = copy;
                            },
                            nullptr});
    config.configure_stream = [&](const transport::SkeletonDefinition& d) {
      StreamSetup s = setup_from_definition(d);
      s.pipeline.stream.stencil = metric->stencil();
      s.teacher = teacher;
      s.teacher_options.ghost = false;
      return s;
    };
    Runtime runtime(config);
    target->runtime = &runtime;
    PluginInstance source(source_plugin, "path=" + clip_path + ";stream=3;speed=20", target);
    source.start();
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (runtime.counters().total.results < static_cast<uint64_t>(frames) && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    source.stop();
    runtime.stop();
    target->runtime = nullptr;
  }
  std::ifstream in(csv_path);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  const std::vector<std::string> header = split_csv(line);
  std::map<std::string, size_t> column = columns_of(header);
  for (const char* name : {"torso_head_score", "left_arm_score", "right_arm_score", "left_leg_score", "right_leg_score",
                           "part_to_fix", "state", "matched_teacher_time", "practice_start_time", "practice_end_time",
                           "practice_loop", "practice_revision", "cue_joint", "cue_degrees", "cue_action",
                           "repetition", "repetition_progress"})
    ASSERT_TRUE(column.count(name)) << name << " missing from " << line;
  static const char* const kParts[] = {"torso_head", "left_arm", "right_arm", "left_leg", "right_leg"};
  static const char* const kStates[] = {"scoring", "calibrating", "tracking_lost", "teacher_finished"};
  int rows = 0, scoring = 0, calibrating = 0;
  double score_sum = 0.0;
  while (std::getline(in, line)) {
    const std::vector<std::string> cell = split_csv(line);
    ASSERT_EQ(cell.size(), header.size()) << line;
    const uint64_t sequence = std::stoull(cell[1]);
    ASSERT_TRUE(published.count(sequence)) << line;
    const transport::ResultFields& f = published.at(sequence);
    for (int q = 0; q < 5; ++q)
      EXPECT_FLOAT_EQ(std::stof(cell[column[std::string(kParts[q]) + "_score"]]), f.part_scores[q]) << line;
    EXPECT_EQ(cell[column["part_to_fix"]], f.part_to_fix >= 0 ? kParts[f.part_to_fix] : "") << line;
    EXPECT_EQ(cell[column["state"]], kStates[f.state]) << line;
    // The cue as the record carries it (present iff part_to_fix is).
    EXPECT_EQ(f.cue_joint >= 0, f.part_to_fix >= 0) << line;
    EXPECT_EQ(cell[column["cue_joint"]], f.cue_joint >= 0 ? kGpdJointNames[static_cast<size_t>(f.cue_joint)] : "") << line;
    if (f.cue_joint >= 0) {
      EXPECT_FLOAT_EQ(std::stof(cell[column["cue_degrees"]]), f.cue_degrees) << line;
      static const char* const kActions[] = {"bend", "straighten", "raise", "lower", "turn"};
      ASSERT_TRUE(f.cue_action >= 0 && f.cue_action < 5) << line;
      EXPECT_EQ(cell[column["cue_action"]], kActions[f.cue_action]) << line;
    } else {
      EXPECT_EQ(cell[column["cue_degrees"]], "") << line;
    }
    EXPECT_DOUBLE_EQ(std::stod(cell[column["matched_teacher_time"]]), f.matched_teacher_time) << line;
    // The whole clip is the section, from the stream's configuration (revision 0).
    ASSERT_TRUE(f.has_practice) << line;
    EXPECT_DOUBLE_EQ(std::stod(cell[column["practice_start_time"]]), 0.0) << line;
    EXPECT_NEAR(std::stod(cell[column["practice_end_time"]]), (frames - 1) * clip.frame_time, 1e-6) << line;
    EXPECT_EQ(cell[column["practice_loop"]], "0") << line;
    EXPECT_EQ(cell[column["practice_revision"]], "0") << line;
    // The repetition in progress and the progress through the section, as the record has them:
    // one pass of the clip is the first repetition, the progress where the student is in it.
    EXPECT_EQ(cell[column["repetition"]], std::to_string(f.repetition)) << line;
    EXPECT_FLOAT_EQ(std::stof(cell[column["repetition_progress"]]), f.repetition_progress) << line;
    EXPECT_EQ(f.repetition, 1) << line;
    if (f.state == 0) {
      EXPECT_NEAR(f.repetition_progress, static_cast<double>(f.frame_index) / (frames - 1), 5.0 / (frames - 1)) << line;
      ++scoring;
      score_sum += std::stod(cell[column["torso_head_score"]]);
      // The student is the teacher: matched at its own time, within a few frames.
      EXPECT_NEAR(f.matched_teacher_time, static_cast<double>(f.frame_index) * clip.frame_time, 5 * clip.frame_time)
          << line;
    }
    calibrating += f.state == 1;
    ++rows;
  }
  EXPECT_EQ(rows, frames);
  EXPECT_GT(calibrating, 0);           // the first 0.25 s
  EXPECT_GT(scoring, frames * 8 / 10);
  EXPECT_GT(score_sum / scoring, 95.0);  // its own pose scores near 100 in every part
}

}  // namespace
}  // namespace kata::runtime
