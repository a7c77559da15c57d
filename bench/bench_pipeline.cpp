// The per-stream pipeline's push (features + score + ghost) against the sum of its three stages
// run alone on the same frames, side by side in one run (the pipeline may add <= 5%).
//
// Student 07_01 (CMU, 31 joints, ghost on the 21 joints that carry a bone) against teacher 02_01
// with the shipped model. Each benchmark iteration runs one block of 120 frames through
//   (a) the Pipeline (push: stream -> scorer -> retargeter -> placement -> result ring), and
//   (b) a Stream, a Scorer and a Retargeter + place_over_student driven by hand, in the same order,
// alternating which goes first; counters report the per-frame thread CPU time of each and their
// ratio.
// BM_Pipeline* alone gives the plain per-frame figure. The *Lesson variants run the same push on
// the default lesson's pair (kata coach: teacher 05_18, 1,829 frames; student 05_19 on subject 2's
// body), where the alignment's section is five times longer (cold4).
//
// BM_PipelinePushPaced: the same push when the caches are cold, as they are in a live stream at
// 120 Hz whose thread sleeps between frames while other work runs. Each push is timed
// alone on the wall clock (steady_clock: a thread-CPU-clock read is a system call under KVM, a
// few microseconds of its own) and the median is reported (counter p50_us: robust to the
// preemptions of a loaded machine; the benchmark's own time is the mean); between pushes the thread either sleeps one 120 Hz period
// (sleep: what the machine's other load leaves in the caches), or writes a buffer (evict: L1
// and L2 cold; evict_all: every cache level cold for data), or spins (see between_pushes). hot runs the same timing with nothing
// in between, the reference the other two are read against.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <malloc.h>
#include <thread>
#include <memory>
#include <string>
#include <vector>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <benchmark/benchmark.h>

#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "pipeline/pipeline.hpp"
#include "support/clips.hpp"

namespace {

// Thread CPU time: the machines are shared, and wall time would charge other processes' load to
// whichever side happened to run during it.
double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double median_us(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return 1e6 * v[v.size() / 2];
}

struct Setup {
  std::shared_ptr<const kata::pipeline::Teacher> teacher;
  kata::pipeline::PipelineConfig config;
  std::vector<float> frames;  // student frames x joints x 3
  int frame_count = 0, joints = 0;
  double frame_time = 0.0;

  // lesson: the default lesson's pair instead of 02_01 <- 07_01.
  static const Setup& get(bool lesson = false) {
    static const Setup walk = make("02_01", "07_01"), dance = make("05_18", "05_19_on_02");
    return lesson ? dance : walk;
  }
  static Setup make(const char* teacher_name, const char* student_name) {
    Setup s;
    const kata::BvhClip& t = kata::test::clip(teacher_name);
    const kata::BvhClip& st = kata::test::clip(student_name);
    auto metric = std::make_shared<const kata::metric::Metric>(
        kata::metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata"));
    const auto tmap = kata::make_gpd_map(t.skeleton, kata::preset_joint_names("cmu"));
    const std::vector<float>& tp = kata::test::clip_positions(teacher_name, 1);
    s.teacher = kata::pipeline::Teacher::from_positions(
        metric, t.skeleton, kata::stream_config_for(t.skeleton, tmap, metric->stencil()), tp.data(),
        t.frame_count() - 1, t.frame_time);
    const auto smap = kata::make_gpd_map(st.skeleton, kata::preset_joint_names("cmu"));
    s.config.stream = kata::stream_config_for(st.skeleton, smap, metric->stencil());
    s.config.student = st.skeleton;
    s.config.result_capacity = 256;
    s.frames = kata::test::clip_positions(student_name, 1);
    s.frame_count = st.frame_count() - 1;
    s.joints = st.skeleton.joint_count();
    s.frame_time = st.frame_time;
    return s;
  }
  const float* frame(int i) const { return frames.data() + static_cast<size_t>(i % frame_count) * 3 * joints; }
};

// The three stages by hand, with the state a pipeline holds.
struct Stages {
  explicit Stages(const Setup& s)
      : stream(s.config.stream),
        scorer(s.teacher->reference),
        selection(kata::retarget::select_joints(s.teacher->skeleton, s.config.student, "cmu")),
        retargeter(selection.parents, kata::retarget::selected_rest_lengths(s.config.student, selection), {},
                   kata::retarget::selected_rest_directions(s.config.student, selection)),
        teacher(3 * selection.source.size()),
        student(3 * selection.source.size()),
        ghost(3 * selection.source.size()),
        teacher_(s.teacher.get()) {}

  void push(double t, const float* xyz, int joints) {
    stream.push(t, xyz, joints);
    const kata::metric::ScoreRecord& r = scorer.score(stream.features(), stream.feature_time());
    ghost_of(r.matched, xyz);
  }

  void ghost_of(int matched, const float* xyz) {
    const float* tf = teacher_->frame_positions(matched);
    for (size_t j = 0; j < selection.source.size(); ++j)
      for (int c = 0; c < 3; ++c) {
        teacher[3 * j + c] = tf[3 * static_cast<size_t>(selection.source[j]) + c];
        student[3 * j + c] = xyz[3 * static_cast<size_t>(selection.source[j]) + c];
      }
    retargeter.retarget(teacher.data(), ghost.data());
    kata::retarget::place_over_student(static_cast<int>(selection.source.size()), student.data(), ghost.data());
    benchmark::DoNotOptimize(ghost.data());
  }

  kata::Stream stream;
  kata::metric::Scorer scorer;
  kata::retarget::JointSelection selection;
  kata::retarget::Retargeter retargeter;
  std::vector<double> teacher, student, ghost;
  const kata::pipeline::Teacher* teacher_;
};

constexpr int kBlock = 120;

// whole_section: the aligner's whole-section pass every frame (AlignmentOptions::windowed = false,
// the aligner before cold4), to compare with the window on the same binary.
kata::pipeline::TeacherOptions teacher_options(bool whole_section) {
  kata::pipeline::TeacherOptions o;
  o.alignment.windowed = !whole_section;
  return o;
}

void run_push(benchmark::State& state, bool lesson, bool whole_section = false) {
  const Setup& s = Setup::get(lesson);
  kata::pipeline::Pipeline p(s.config);
  p.set_teacher(s.teacher, teacher_options(whole_section));
  std::vector<kata::pipeline::Result> out(256);
  int64_t i = 0;
  for (auto _ : state) {
    p.push(static_cast<double>(i) * s.frame_time, s.frame(static_cast<int>(i)), s.joints);
    if (p.pending() >= 128) p.read(out.data(), nullptr, nullptr, out.size());
    ++i;
  }
  state.SetItemsProcessed(state.iterations());
}
void BM_PipelinePush(benchmark::State& state) { run_push(state, false); }
BENCHMARK(BM_PipelinePush);
void BM_PipelinePushLesson(benchmark::State& state) { run_push(state, true, state.range(0) == 1); }
BENCHMARK(BM_PipelinePushLesson)->ArgName("whole_section")->DenseRange(0, 1);

enum class Pacing : int { kHot = 0, kSleep = 1, kEvict = 2, kEvictAll = 3, kSpin = 4, kFlushData = 5, kFlushCode = 6 };

// The process's mappings that hold its code (executable) or its data (writable), from
// /proc/self/maps, for the flush pacings: read once, when first needed (the data set is the
// benchmark's heap, its clips included, so it is taken after the setup allocated them).
struct Range {
  const char* begin;
  const char* end;
};
std::vector<Range> mappings(bool code) {
  std::vector<Range> out;
  FILE* f = std::fopen("/proc/self/maps", "r");
  if (!f) return out;
  char line[512];
  while (std::fgets(line, sizeof line, f)) {
    unsigned long long a = 0, b = 0;
    char perms[8] = {0};
    if (std::sscanf(line, "%llx-%llx %7s", &a, &b, perms) != 3) continue;
    if (perms[0] != 'r' || std::strstr(line, "[vvar]") || std::strstr(line, "[vsyscall]")) continue;
    const bool exec = perms[2] == 'x', write = perms[1] == 'w';
    if (code ? exec : (write && !exec))
      out.push_back({reinterpret_cast<const char*>(a), reinterpret_cast<const char*>(b)});
  }
  std::fclose(f);
  return out;
}

// Every line of the ranges out of every cache level (clflush: the data stays where it is, only
// its cached copies go; translations stay in the TLB).
void flush(const std::vector<Range>& ranges) {
#if defined(__x86_64__)
  for (const Range& r : ranges)
    for (const char* p = r.begin; p < r.end; p += 64) _mm_clflush(p);
  _mm_mfence();
#else
  (void)ranges;
#endif
}

// Between two pushes: what the pacing leaves of the caches. evict: a buffer of twice the L2
// written; evict_all: one of twice the L3 (every data line cold; on AMD's inclusive L2 the code's
// lines go with it); spin: 8.3 ms of busy waiting that touches nothing (the core stays awake:
// against sleep, what the sleep itself costs); flush_data / flush_code: every line of the
// process's writable / executable mappings flushed (clflush), to tell what a cold frame pays for
// its data from what it pays for its code.
char between_pushes(Pacing pacing, std::vector<char>& l2, std::vector<char>& l3) {
  if (pacing == Pacing::kSleep) std::this_thread::sleep_for(std::chrono::microseconds(8333));
  if (pacing == Pacing::kSpin) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::microseconds(8333);
    while (std::chrono::steady_clock::now() < until) {
    }
  }
  if (pacing == Pacing::kFlushData || pacing == Pacing::kFlushCode) {
    static const std::vector<Range> data = mappings(false), code = mappings(true);
    flush(pacing == Pacing::kFlushData ? data : code);
    return 0;
  }
  std::vector<char>* buffer = pacing == Pacing::kEvict ? &l2 : pacing == Pacing::kEvictAll ? &l3 : nullptr;
  if (!buffer) return 0;
  if (buffer->empty()) buffer->assign(buffer == &l2 ? (4u << 20) : (64u << 20), 1);
  for (size_t k = 0; k < buffer->size(); k += 64) (*buffer)[k] = static_cast<char>((*buffer)[k] + 1);
  return (*buffer)[buffer->size() / 2];
}

void run_push_paced(benchmark::State& state, bool lesson, bool whole_section = false) {
  const Setup& s = Setup::get(lesson);
  const auto pacing = static_cast<Pacing>(state.range(0));
  kata::pipeline::Pipeline p(s.config);
  p.set_teacher(s.teacher, teacher_options(whole_section));
  std::vector<kata::pipeline::Result> out(256);
  std::vector<char> l2, l3;
  int64_t i = 0;
  for (; i < 120; ++i) p.push(static_cast<double>(i) * s.frame_time, s.frame(static_cast<int>(i)), s.joints);
  p.read(out.data(), nullptr, nullptr, out.size());
  char sink = 0;
  std::vector<double> took;
  took.reserve(static_cast<size_t>(state.max_iterations));
  for (auto _ : state) {
    sink = static_cast<char>(sink + between_pushes(pacing, l2, l3));
    const double t0 = wall_seconds();
    p.push(static_cast<double>(i) * s.frame_time, s.frame(static_cast<int>(i)), s.joints);
    const double dt = wall_seconds() - t0;
    state.SetIterationTime(dt);
    took.push_back(dt);
    if (p.pending() >= 128) p.read(out.data(), nullptr, nullptr, out.size());
    ++i;
  }
  benchmark::DoNotOptimize(sink);
  state.counters["p50_us"] = median_us(took);
  state.SetItemsProcessed(state.iterations());
}
void BM_PipelinePushPaced(benchmark::State& state) { run_push_paced(state, false); }
void BM_PipelinePushPacedLesson(benchmark::State& state) { run_push_paced(state, true, state.range(1) == 1); }
// The three stages of BM_PipelinePushPaced timed apart (counters stream_us, score_us, ghost_us:
// medians per frame, wall clock), to see which working set a cold frame pays for.
void BM_StagesPaced(benchmark::State& state) {
  const Setup& s = Setup::get();
  const auto pacing = static_cast<Pacing>(state.range(0));
  Stages st(s);
  std::vector<char> l2, l3;
  int64_t i = 0;
  for (; i < 120; ++i) st.push(static_cast<double>(i) * s.frame_time, s.frame(static_cast<int>(i)), s.joints);
  std::vector<double> stream_s, score_s, ghost_s, total_s;
  for (auto* v : {&stream_s, &score_s, &ghost_s, &total_s}) v->reserve(static_cast<size_t>(state.max_iterations));
  char sink = 0;
  for (auto _ : state) {
    sink = static_cast<char>(sink + between_pushes(pacing, l2, l3));
    const double t0 = wall_seconds();
    const float* xyz = s.frame(static_cast<int>(i));
    st.stream.push(static_cast<double>(i) * s.frame_time, xyz, s.joints);
    const double t1 = wall_seconds();
    const kata::metric::ScoreRecord& r = st.scorer.score(st.stream.features(), st.stream.feature_time());
    const double t2 = wall_seconds();
    st.ghost_of(r.matched, xyz);
    const double t3 = wall_seconds();
    stream_s.push_back(t1 - t0);
    score_s.push_back(t2 - t1);
    ghost_s.push_back(t3 - t2);
    total_s.push_back(t3 - t0);
    state.SetIterationTime(t3 - t0);
    ++i;
  }
  benchmark::DoNotOptimize(sink);
  state.counters["stream_us"] = median_us(stream_s);
  state.counters["score_us"] = median_us(score_s);
  state.counters["ghost_us"] = median_us(ghost_s);
  state.counters["p50_us"] = median_us(total_s);
}
BENCHMARK(BM_StagesPaced)
    ->ArgName("hot0_sleep1_evict2_evictall3_spin4_flushdata5_flushcode6")
    ->DenseRange(0, 6)
    ->UseManualTime()
    ->Iterations(240)
    ->Unit(benchmark::kMicrosecond);

// 240 pushes per repetition: two seconds of a 120 Hz stream in the sleep case.
BENCHMARK(BM_PipelinePushPaced)
    ->ArgName("hot0_sleep1_evict2_evictall3_spin4")
    ->DenseRange(0, 4)
    ->UseManualTime()
    ->Iterations(240)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PipelinePushPacedLesson)
    ->ArgNames({"hot0_sleep1_evict2_evictall3_spin4", "whole_section"})
    ->ArgsProduct({{0, 1, 2, 3, 4}, {0, 1}})
    ->UseManualTime()
    ->Iterations(240)
    ->Unit(benchmark::kMicrosecond);

// KB of the process's pages referenced since the accessed bits were last cleared (clear: clear them
// now and return what the reads themselves referenced); -1 where /proc does not allow it.
double referenced_kb(bool clear) {
  if (clear) {
    FILE* c = std::fopen("/proc/self/clear_refs", "w");
    if (!c) return -1.0;
    std::fputs("1", c);
    std::fclose(c);
  }
  FILE* f = std::fopen("/proc/self/smaps_rollup", "r");
  if (!f) return -1.0;
  char line[256];
  double kb = -1.0;
  while (std::fgets(line, sizeof line, f))
    if (std::sscanf(line, "Referenced: %lf kB", &kb) == 1) break;
  std::fclose(f);
  return kb;
}

// A burst over K streams, as the live runtime's worker sees it: K pipelines of the same
// teacher, each fed its own place in the student clip, pushed one frame each in turn, hot (no
// sleep). Against K = 1 this is what a stream's own state costs when K-1 other streams ran since
// its last frame: the per-stream working set (stream history, aligner, scorer, ghost, result ring)
// that no longer fits the caches. Counters: us_per_frame (thread CPU), heap_kb_per_stream (what one
// pipeline holds on the heap once warmed up, from mallinfo2: the most a frame could touch).
// scratch 0: each pipeline's own per-frame work (the scorer's and the ghost's workspaces, a set
// per stream); 1: one pipeline::Scratch for all K, as a runtime worker pushes them.
void BM_PipelinePushStreams(benchmark::State& state) {
  const Setup& s = Setup::get(false);
  const int k = static_cast<int>(state.range(0));
  kata::pipeline::Scratch shared;
  kata::pipeline::Scratch* const scratch = state.range(1) == 1 ? &shared : nullptr;
  const size_t heap_before = mallinfo2().uordblks;
  std::vector<std::unique_ptr<kata::pipeline::Pipeline>> streams;
  std::vector<kata::pipeline::Result> out(256);
  for (int j = 0; j < k; ++j) {
    streams.push_back(std::make_unique<kata::pipeline::Pipeline>(s.config));
    streams.back()->set_teacher(s.teacher, teacher_options(false));
  }
  const int stride = std::max(1, s.frame_count / k);
  int64_t i = 0;
  for (; i < 120; ++i)
    for (int j = 0; j < k; ++j) {
      streams[static_cast<size_t>(j)]->push(static_cast<double>(i) * s.frame_time, s.frame(static_cast<int>(i) + j * stride),
                                            nullptr, s.joints, 0, scratch);
      if (streams[static_cast<size_t>(j)]->pending() >= 128) streams[static_cast<size_t>(j)]->read(out.data(), nullptr, nullptr, out.size());
    }
  const double heap_per_stream = static_cast<double>(mallinfo2().uordblks - heap_before) / k;
  // What one round (a frame of each stream) touches: the pages referenced between two reads of
  // the kernel's accessed bits (/proc/self/clear_refs, smaps_rollup's Referenced; 4 KB pages, so
  // an upper bound), the process's code and the teacher included. Against K: the slope is what
  // one more stream's frame touches of its own.
  const double touched_before = referenced_kb(true);
  for (int j = 0; j < k; ++j)
    streams[static_cast<size_t>(j)]->push(static_cast<double>(i) * s.frame_time, s.frame(static_cast<int>(i) + j * stride),
                                          nullptr, s.joints, 0, scratch);
  const double touched_round = referenced_kb(false) - touched_before;
  ++i;
  const double t0 = thread_cpu_seconds();
  int64_t frames = 0;
  for (auto _ : state) {
    for (int j = 0; j < k; ++j) {
      kata::pipeline::Pipeline& p = *streams[static_cast<size_t>(j)];
      p.push(static_cast<double>(i) * s.frame_time, s.frame(static_cast<int>(i) + j * stride), nullptr, s.joints, 0,
             scratch);
      if (p.pending() >= 128) p.read(out.data(), nullptr, nullptr, out.size());
    }
    frames += k;
    ++i;
  }
  state.counters["us_per_frame"] = 1e6 * (thread_cpu_seconds() - t0) / static_cast<double>(std::max<int64_t>(frames, 1));
  state.counters["heap_kb_per_stream"] = heap_per_stream / 1024.0;
  state.counters["touched_kb_round"] = touched_round;
  state.SetItemsProcessed(frames);
}
BENCHMARK(BM_PipelinePushStreams)
    ->ArgNames({"streams", "scratch"})
    ->ArgsProduct({{1, 4, 16, 64, 256}, {0, 1}})
    ->Unit(benchmark::kMillisecond);

// A burst: one frame of each of K streams (K pipelines of the same teacher, each at its own place
// in the student clip) drained together, as a live worker finds them after a 120 Hz tick, with the
// caches taken between bursts as BM_PipelinePushPaced takes them between frames (pacing: hot0,
// evict2, evictall3). path 0 pushes the K frames one after the other (push(), the per-frame path),
// path 1 as one Pipeline::push_burst (stage by stage: features of all, the scores of all with one
// pass over W per 8 frames, then ghosts and results). Each burst is timed alone on the wall clock;
// counter us_per_frame is the median burst's time / K (the benchmark's own time is the mean burst),
// cpu_us_per_frame the same on the thread's CPU clock. scratch 1: one pipeline::Scratch for the K
// streams (a runtime worker's), 0: each pipeline's own.
void BM_PipelinePushBurst(benchmark::State& state) {
  const Setup& s = Setup::get(false);
  const int k = static_cast<int>(state.range(0));
  const bool burst = state.range(1) == 1;
  const auto pacing = static_cast<Pacing>(state.range(2));
  kata::pipeline::Scratch shared;
  kata::pipeline::Scratch* const scratch = state.range(3) == 1 ? &shared : nullptr;
  std::vector<std::unique_ptr<kata::pipeline::Pipeline>> streams;
  std::vector<kata::pipeline::Result> out(256);
  for (int j = 0; j < k; ++j) {
    streams.push_back(std::make_unique<kata::pipeline::Pipeline>(s.config));
    streams.back()->set_teacher(s.teacher, teacher_options(false));
  }
  const int stride = std::max(1, s.frame_count / k);
  std::vector<kata::pipeline::Pipeline::BurstFrame> frames(static_cast<size_t>(k));
  auto push_all = [&](int64_t i) {
    const double t = static_cast<double>(i) * s.frame_time;
    if (!burst) {
      for (int j = 0; j < k; ++j)
        streams[static_cast<size_t>(j)]->push(t, s.frame(static_cast<int>(i) + j * stride), nullptr, s.joints, 0, scratch);
      return;
    }
    for (int j = 0; j < k; ++j) {
      kata::pipeline::Pipeline::BurstFrame& f = frames[static_cast<size_t>(j)];
      f.pipeline = streams[static_cast<size_t>(j)].get();
      f.capture_time = t;
      f.xyz = s.frame(static_cast<int>(i) + j * stride);
      f.joint_count = s.joints;
      f.arrival_ns = 0;
    }
    kata::pipeline::Pipeline::push_burst(frames.data(), k, scratch);
  };
  auto drain = [&] {
    for (auto& p : streams)
      if (p->pending() >= 128) p->read(out.data(), nullptr, nullptr, out.size());
  };
  int64_t i = 0;
  for (; i < 120; ++i) {
    push_all(i);
    drain();
  }
  std::vector<char> l2, l3;
  char sink = 0;
  std::vector<double> took, cpu;
  took.reserve(static_cast<size_t>(state.max_iterations));
  cpu.reserve(static_cast<size_t>(state.max_iterations));
  for (auto _ : state) {
    sink = static_cast<char>(sink + between_pushes(pacing, l2, l3));
    const double c0 = thread_cpu_seconds();
    const double t0 = wall_seconds();
    push_all(i);
    const double dt = wall_seconds() - t0;
    cpu.push_back(thread_cpu_seconds() - c0);
    state.SetIterationTime(dt);
    took.push_back(dt);
    drain();
    ++i;
  }
  benchmark::DoNotOptimize(sink);
  state.counters["us_per_frame"] = median_us(took) / k;
  // The same on the thread's CPU clock (two clock reads a burst, a few us under KVM): what a
  // preemption within the burst adds to the wall clock is not in it.
  state.counters["cpu_us_per_frame"] = median_us(cpu) / k;
  state.SetItemsProcessed(state.iterations() * k);
}
BENCHMARK(BM_PipelinePushBurst)
    ->ArgNames({"K", "burst", "hot0_evict2_evictall3", "scratch"})
    ->ArgsProduct({{1, 8, 16, 32, 64}, {0, 1}, {0, 2, 3}, {0, 1}})
    ->UseManualTime()
    ->Iterations(240)
    ->Unit(benchmark::kMicrosecond);

void BM_PipelineVsStages(benchmark::State& state) {
  const Setup& s = Setup::get();
  kata::pipeline::Pipeline p(s.config);
  p.set_teacher(s.teacher);
  Stages stages(s);
  std::vector<kata::pipeline::Result> out(256);
  int64_t next = 0;
  double pipeline_s = 0.0, stages_s = 0.0;
  bool pipeline_first = true;
  for (auto _ : state) {
    auto run_pipeline = [&] {
      const double t0 = thread_cpu_seconds();
      for (int k = 0; k < kBlock; ++k) {
        const int64_t i = next + k;
        p.push(static_cast<double>(i) * s.frame_time, s.frame(static_cast<int>(i)), s.joints);
      }
      p.read(out.data(), nullptr, nullptr, out.size());
      pipeline_s += thread_cpu_seconds() - t0;
    };
    auto run_stages = [&] {
      const double t0 = thread_cpu_seconds();
      for (int k = 0; k < kBlock; ++k) {
        const int64_t i = next + k;
        stages.push(static_cast<double>(i) * s.frame_time, s.frame(static_cast<int>(i)), s.joints);
      }
      stages_s += thread_cpu_seconds() - t0;
    };
    if (pipeline_first) {
      run_pipeline();
      run_stages();
    } else {
      run_stages();
      run_pipeline();
    }
    pipeline_first = !pipeline_first;
    next += kBlock;
  }
  const double frames = static_cast<double>(next);
  state.counters["pipeline_us_per_frame"] = 1e6 * pipeline_s / frames;
  state.counters["stages_us_per_frame"] = 1e6 * stages_s / frames;
  state.counters["pipeline_over_stages"] = pipeline_s / stages_s;
  state.SetItemsProcessed(next);
}
BENCHMARK(BM_PipelineVsStages)->Unit(benchmark::kMillisecond);

}  // namespace
