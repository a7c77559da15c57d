// The plugin ABI: refusals with their messages, and shipped plugins working through a runtime
// (bvh-replay as a source, csv-sink as a sink).
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "common/error.hpp"
#include "io/bvh.hpp"
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
  EXPECT_EQ(refusal(major), "plugin " + major + ": ABI major version 2, this host speaks 1");
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

}  // namespace
}  // namespace kata::runtime
