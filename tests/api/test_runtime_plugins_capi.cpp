// Plugins hosted by a runtime through the C ABI (kata_runtime_desc.plugins, 1.1), with the
// shipped plugins and libkata only: bvh-replay plays a clip into the runtime as a source,
// csv-sink writes every result as a row. The expected counts come from the clip itself and from
// the records on_result receives; a refusal names the plugin's file and its own reason.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
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

}  // namespace
