// `kata coach` as CI runs it: headless at 8x real time on the default teacher, to the end, with a
// report (the student another dance of the teacher's subject, 05_03: its lesson names parts to
// fix, which the comparison needs; the default student's lesson names none, docs/model/scores.md); its per-frame states, scores, part scores, mean score and part-to-fix sequence equal a
// pipeline run here in the test process on the same frames (computed without any of the coach's
// or the runtime's code), and what it publishes over ZeroMQ (read here by a subscriber) too. A recorded
// lesson replays to the same results; a damaged recording is refused naming the file.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <zmq.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "metric/scorer.hpp"
#include "pipeline/pipeline.hpp"
#include "support/temp_paths.hpp"
#include "transport/wire.hpp"

namespace {

struct CliRun {
  int code;
  std::string output;
};

CliRun run_in_source_dir(const std::string& args, const kata::test::TempDir& dir) {
  const std::string log = dir.file("coach.log");
  // Bounded: a coach that hangs is killed (the lesson takes about a second at --speed 8).
  const std::string cmd = std::string("cd ") + KATA_SOURCE_DIR + " && timeout 120 " + KATA_CLI + " " + args + " >" + log + " 2>&1";
  const int status = std::system(cmd.c_str());
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str()};
}

struct Row {
  int state = -1;
  float score = 0.0f;
  float part_scores[kata::metric::kParts] = {};
  int part_to_fix = -2, matched = -2;
  double matched_time = -2.0;
  std::string cue_joint = "?", cue = "?";  // the correction cue's GPD joint name and phrase ("" for none)
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
    if (line.back() == ',') cells.emplace_back();  // getline drops an empty last cell
    if (cells.size() != 23) continue;
    Row r;
    r.state = std::stoi(cells[2]);
    r.score = std::stof(cells[3]);
    for (int p = 0; p < kata::metric::kParts; ++p) r.part_scores[p] = std::stof(cells[10 + static_cast<size_t>(p)]);
    r.part_to_fix = std::stoi(cells[15]);
    r.matched = std::stoi(cells[16]);
    r.matched_time = std::stod(cells[17]);
    r.cue_joint = cells[18], r.cue = cells[20];
    rows.push_back(r);
  }
  return rows;
}

// The lesson computed here: the default clips from frame 1, the shipped model (its calibrated
// score map), one pipeline with the whole teacher clip attached, frames pushed i / 120 s apart.
// state: the coach's numbering (0 calibrating, 1 tracking, 2 tracking lost, 3 teacher finished).
struct Expected {
  std::vector<int> state;
  std::vector<float> score;
  std::vector<std::array<float, kata::metric::kParts>> part_scores;
  std::vector<int> part_to_fix, matched, cue_joint;
  double mean = 0.0;  // over scored frames (tracking or teacher finished)
};

int coach_state(kata::metric::ScoreState s) {
  switch (s) {
    case kata::metric::ScoreState::kScoring: return 1;
    case kata::metric::ScoreState::kCalibrating: return 0;
    case kata::metric::ScoreState::kTrackingLost: return 2;
    case kata::metric::ScoreState::kTeacherFinished: return 3;
  }
  return -1;
}

// The lesson's student (the teacher is the coach's default, 05_18).
const std::string kStudent = "05_03.bvh";

Expected run_pipeline_here() {
  using namespace kata;
  const std::string data = KATA_DATA_DIR;
  const auto metric = std::make_shared<const metric::Metric>(metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata"));
  const BvhClip teacher = load_bvh(data + "/cmu/05_18.bvh");
  const BvhClip student = load_bvh(data + "/cmu/" + kStudent);
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
  e.state.assign(static_cast<size_t>(frames), -1);
  e.score.assign(static_cast<size_t>(frames), -1.0f);
  e.part_scores.assign(static_cast<size_t>(frames), {});
  e.part_to_fix.assign(static_cast<size_t>(frames), -2);
  e.matched.assign(static_cast<size_t>(frames), -2);
  e.cue_joint.assign(static_cast<size_t>(frames), -2);
  auto drain = [&] {
    pipeline::Result r;
    while (p.read(&r, nullptr, nullptr, 1) == 1) {
      const size_t f = static_cast<size_t>(r.frame_index);
      e.state[f] = coach_state(r.score.state);
      e.score[f] = r.score.score;
      for (int q = 0; q < metric::kParts; ++q) e.part_scores[f][static_cast<size_t>(q)] = r.score.part_scores[q];
      e.matched[f] = r.matched_frame;
      e.part_to_fix[f] = r.score.part_to_fix;
      e.cue_joint[f] = r.score.cue_joint;
    }
  };
  for (int i = 0; i < frames; ++i) {
    EXPECT_EQ(p.push(i * student.frame_time, sp.data() + static_cast<size_t>(i) * 3 * joints, joints), Status::kOk);
    drain();
  }
  p.flush();
  drain();
  int n = 0;
  for (size_t i = 0; i < e.score.size(); ++i)
    if (e.state[i] == 1 || e.state[i] == 3) e.mean += e.score[i], ++n;
  e.mean /= std::max(n, 1);
  return e;
}

double mean_in_summary(const std::string& output) {
  const size_t at = output.find("mean score ");
  return at == std::string::npos ? -1.0 : std::atof(output.c_str() + at + 11);
}

// What a subscriber to the coach's ZeroMQ publisher received of the student's stream.
struct Received {
  std::map<uint64_t, kata::transport::ResultFields> student;  // by frame sequence
  uint64_t teacher = 0, gaps = 0;
};

TEST(CliCoach, HeadlessLessonEqualsThePipelineRunInProcess) {
  kata::test::TempDir dir;
  const std::string csv = dir.file("lesson.csv"), report = dir.file("lesson.html"), rec = dir.file("lesson.npz");
  // Loopback only: an ipc socket in this test's own directory.
  const std::string endpoint = "ipc://" + dir.file("pub");

  // A subscriber connected before the coach binds (ZeroMQ retries the connect), reading while
  // the coach runs in another thread.
  void* context = zmq_ctx_new();
  void* sub = zmq_socket(context, ZMQ_SUB);
  zmq_setsockopt(sub, ZMQ_SUBSCRIBE, "", 0);
  const int reconnect_ms = 10;
  zmq_setsockopt(sub, ZMQ_RECONNECT_IVL, &reconnect_ms, sizeof reconnect_ms);
  ASSERT_EQ(zmq_connect(sub, endpoint.c_str()), 0);
  std::atomic<bool> coach_done{false};
  CliRun r;
  std::thread coach([&] {
    r = run_in_source_dir("coach --headless --speed 8 --student data/cmu/" + kStudent + " --publish " + endpoint +
                              " --csv " + csv + " --report " + report + " --record " + rec,
                          dir);
    coach_done = true;
  });
  Received got;
  kata::transport::Decoder decoder;
  std::vector<uint8_t> buffer(1 << 20);
  uint64_t last_sequence = 0;
  bool any = false;
  for (auto quiet_since = std::chrono::steady_clock::now();;) {
    zmq_pollitem_t item{sub, 0, ZMQ_POLLIN, 0};
    if (zmq_poll(&item, 1, 50) > 0) {
      const int n = zmq_recv(sub, buffer.data(), buffer.size(), ZMQ_DONTWAIT);
      if (n > 0 && decoder.decode(buffer.data(), static_cast<size_t>(n)) == kata::transport::MessageKind::kResult) {
        const auto& f = decoder.result();
        if (f.stream_id == 1) ++got.teacher;
        if (f.stream_id == 2) {
          if (any && f.result_sequence != last_sequence + 1) ++got.gaps;
          any = true, last_sequence = f.result_sequence;
          auto& kept = got.student[f.frame_sequence] = f;
          kept.ghost = nullptr, kept.features = nullptr;  // point into the decoder's buffer
        }
      }
      quiet_since = std::chrono::steady_clock::now();
    } else if (coach_done && std::chrono::steady_clock::now() - quiet_since > std::chrono::milliseconds(300)) {
      break;
    }
  }
  coach.join();
  zmq_close(sub);
  zmq_ctx_term(context);
  ASSERT_EQ(r.code, 0) << r.output;

  const Expected e = run_pipeline_here();
  const std::vector<Row> rows = read_csv(csv);
  ASSERT_EQ(rows.size(), e.score.size()) << "the lesson runs to the end";
  double mean = 0.0;
  int n = 0, named = 0, calibrating = 0;
  for (size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].state, e.state[i]) << "frame " << i;
    ASSERT_EQ(rows[i].score, e.score[i]) << "frame " << i;
    for (int q = 0; q < kata::metric::kParts; ++q)
      ASSERT_EQ(rows[i].part_scores[q], e.part_scores[i][static_cast<size_t>(q)]) << "frame " << i << " part " << q;
    ASSERT_EQ(rows[i].part_to_fix, e.part_to_fix[i]) << "frame " << i;
    // The correction cue: the pipeline's joint, by its GPD name, and a phrase exactly when named.
    ASSERT_EQ(rows[i].cue_joint, e.cue_joint[i] >= 0 ? kata::kGpdJointNames[static_cast<size_t>(e.cue_joint[i])] : "")
        << "frame " << i;
    ASSERT_EQ(rows[i].cue.empty(), e.cue_joint[i] < 0) << "frame " << i;
    ASSERT_EQ(rows[i].matched, e.matched[i]) << "frame " << i;
    if (rows[i].matched >= 0) {
      ASSERT_NEAR(rows[i].matched_time, rows[i].matched * 0.0083333, 1e-6) << "frame " << i;
    }
    if (rows[i].state == 1 || rows[i].state == 3) mean += rows[i].score, ++n;
    named += rows[i].part_to_fix >= 0;
    calibrating += rows[i].state == 0;
  }
  // The lesson exercises what the test compares: a calibrating start, scored frames, named parts.
  EXPECT_GT(calibrating, 0);
  EXPECT_GT(n, static_cast<int>(rows.size()) / 2);
  EXPECT_GT(named, 0);
  EXPECT_DOUBLE_EQ(mean / n, e.mean);
  EXPECT_NEAR(mean_in_summary(r.output), e.mean, 0.005) << r.output;

  // Published over ZeroMQ: both streams, the student's results equal to the pipeline's. A
  // subscriber may miss the first messages (it joins while the coach starts), never later ones.
  EXPECT_GT(got.student.size(), rows.size() * 9 / 10) << r.output;
  EXPECT_GT(got.teacher, 0u);
  EXPECT_EQ(got.gaps, 0u);
  for (const auto& [sequence, f] : got.student) {
    ASSERT_LT(sequence, e.score.size());
    ASSERT_EQ(f.score, e.score[sequence]) << "published frame " << sequence;
    ASSERT_EQ(f.part_to_fix, e.part_to_fix[sequence]) << "published frame " << sequence;
    ASSERT_EQ(f.cue_joint, e.cue_joint[sequence]) << "published frame " << sequence;
    ASSERT_EQ(f.part_scores[4], e.part_scores[sequence][4]) << "published frame " << sequence;
    ASSERT_EQ(f.matched_teacher_frame, e.matched[sequence]) << "published frame " << sequence;
    // Where the student is in the routine: the matched frame at the teacher's 120 fps (its BVH
    // frame time .0083333 s).
    if (f.scored) {
      ASSERT_NEAR(f.matched_teacher_time, e.matched[sequence] * 0.0083333, 1e-9) << sequence;
    }
  }

  // The report: one self-contained page (inline SVG drawings, uPlot and its data inline, nothing
  // fetched) naming the clips by file name only.
  std::ifstream in(report);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string html = ss.str();
  EXPECT_NE(html.find("<svg"), std::string::npos);
  EXPECT_NE(html.find("The three lowest moments"), std::string::npos);
  EXPECT_NE(html.find("Each body part over time"), std::string::npos);
  EXPECT_NE(html.find(kStudent), std::string::npos);
  EXPECT_NE(html.find("var uPlot="), std::string::npos) << "the chart library inlined";
  EXPECT_EQ(html.find("<script src"), std::string::npos);
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);
  EXPECT_EQ(html.find("href=\"http"), std::string::npos);
  EXPECT_EQ(html.find(KATA_SOURCE_DIR), std::string::npos) << "no absolute path of this machine";
  // The charts' data: every frame's time and score (null where the CSV has no score), each part's.
  const std::string open_tag = "<script type=\"application/json\" id=\"report-data\">";
  const size_t data_at = html.find(open_tag);
  ASSERT_NE(data_at, std::string::npos);
  const size_t data_end = html.find("</script>", data_at);
  const nlohmann::json chart = nlohmann::json::parse(html.substr(data_at + open_tag.size(), data_end - data_at - open_tag.size()));
  ASSERT_EQ(chart["time"].size(), rows.size());
  ASSERT_EQ(chart["parts"].size(), static_cast<size_t>(kata::metric::kParts));
  EXPECT_EQ(chart["marks"].size(), 3u);
  for (size_t i = 0; i < rows.size(); ++i) {
    if (rows[i].state == 1 || rows[i].state == 3) {
      ASSERT_NEAR(chart["total"][i].get<double>(), rows[i].score, 0.005) << "frame " << i;
      ASSERT_NEAR(chart["parts"][3]["values"][i].get<double>(), rows[i].part_scores[3], 0.005) << "frame " << i;
    } else {
      ASSERT_TRUE(chart["total"][i].is_null()) << "frame " << i;
    }
  }

  // The recording as NumPy reads it: the arrays, dtypes and shapes of recording.hpp.
  {
    const std::string check =
        "import numpy as np\n"
        "z = np.load(\"" + rec + "\")\n"
        "F, J, G = len(z[\"time\"]), len(z[\"joint_parents\"]), len(z[\"ghost_sources\"])\n"
        "want = dict(positions=(\"<f4\", (F, J, 3)), time=(\"<f8\", (F,)), state=(\"|u1\", (F,)), score=(\"<f4\", (F,)),\n"
        "  distance=(\"<f4\", (F,)), parts=(\"<f4\", (F, 5)), part_scores=(\"<f4\", (F, 5)), part_to_fix=(\"<i4\", (F,)),\n"
        "  matched=(\"<i4\", (F,)), latency_ns=(\"<i8\", (F,)), ghosts=(\"<f4\", (F, G, 3)), has_ghost=(\"|u1\", (F,)),\n"
        "  joint_parents=(\"<i4\", (J,)), joint_part=(\"<i4\", (J,)), ghost_sources=(\"<i4\", (G,)), hips=(\"<i4\", (2,)),\n"
        "  numbers=(\"<f8\", (9,)), text=(\"|u1\", (len(z[\"text\"]),)), matched_time=(\"<f8\", (F,)),\n"
        "  practice=(\"<i4\", (3,)), cue_joint=(\"<i4\", (F,)), cue_degrees=(\"<f4\", (F,)), cue_action=(\"<i4\", (F,)),\n"
        "  repetition=(\"<i4\", (F,)), repetition_progress=(\"<f4\", (F,)), repetitions=(\"<f8\", (len(z[\"repetitions\"]), 27)))\n"
        "got = {k: (z[k].dtype.str, z[k].shape) for k in z.files}\n"
        "assert got == want, (got, want)\n"
        "lines = bytes(z[\"text\"]).decode().split(\"\\n\")\n"
        "assert len(lines) == 4 + J + 1 and lines[-1] == \"\", lines\n"
        "print(F, J, G > 0, int(z[\"numbers\"][6]), lines[1].split(\"/\")[-1], sorted(set(z[\"state\"].tolist())))\n";
    std::FILE* p = popen(("/usr/bin/python3 -c '" + check + "' 2>&1").c_str(), "r");
    ASSERT_NE(p, nullptr);
    std::string out;
    char buf[4096];
    for (size_t read; (read = std::fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, read);
    ASSERT_EQ(pclose(p), 0) << out;
    // F frames (the CSV's rows), the student's 31 CMU joints, a ghost, the teacher's file, the
    // states the CSV has.
    std::set<int> states;
    for (const Row& row : rows) states.insert(row.state);
    std::string state_list;
    for (int st : states) state_list += (state_list.empty() ? "" : ", ") + std::to_string(st);
    EXPECT_EQ(out, std::to_string(rows.size()) + " 31 True " + std::to_string(rows.size()) + " 05_18.bvh [" + state_list + "]\n")
        << out;
  }

  // The recording replays to the same per-frame results.
  const std::string csv2 = dir.file("replay.csv");
  const CliRun replay = run_in_source_dir("coach --headless --speed 64 --replay " + rec + " --csv " + csv2 + " --report ''", dir);
  ASSERT_EQ(replay.code, 0) << replay.output;
  const std::vector<Row> again = read_csv(csv2);
  ASSERT_EQ(again.size(), rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(again[i].state, rows[i].state) << "frame " << i;
    ASSERT_EQ(again[i].score, rows[i].score) << "frame " << i;
    ASSERT_EQ(again[i].part_scores[2], rows[i].part_scores[2]) << "frame " << i;
    ASSERT_EQ(again[i].part_to_fix, rows[i].part_to_fix) << "frame " << i;
    ASSERT_EQ(again[i].cue_joint, rows[i].cue_joint) << "frame " << i;
    ASSERT_EQ(again[i].cue, rows[i].cue) << "frame " << i;
    // Where the student was in the routine is kept in the recording too (array matched_time).
    ASSERT_EQ(again[i].matched, rows[i].matched) << "frame " << i;
    ASSERT_EQ(again[i].matched_time, rows[i].matched_time) << "frame " << i;
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
