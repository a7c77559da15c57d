// kata coach: a coaching lesson, live. The teacher and student clips are played as two live
// streams (real time, or --speed N) through the runtime `kata serve` runs, which publishes every
// result over ZeroMQ; the student's frames are scored against the teacher (calibrated total and
// per-part scores, the part to fix) and ghosted.
// A terminal view shows progress, scores, the part to fix, frames/s and latency; a browser viewer
// (server-sent events on localhost) draws the student in 3D with the teacher's ghost over it; at
// the end a summary is printed and a self-contained HTML report written. --record keeps the
// lesson in a file, --replay plays a recorded one back into the viewer.
// A client of the public C ABI (kata.h) only: the lesson (coach/lesson.hpp) drives libkata's
// runtime; nothing here includes the SDK's private core (the kata_coach target, CMakeLists.txt).
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdarg>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "coach/lesson.hpp"
#include "coach/present.hpp"
#include "coach/reps_view.hpp"
#include "coach/recording.hpp"
#include "coach/viewer_server.hpp"
#include "coach/vmc_out.hpp"
#include "data_files.hpp"
#include "coach/webcam.hpp"
#include "command.hpp"
#include "kata/kata.h"

namespace {

using namespace kata::coach;
using Clock = std::chrono::steady_clock;

struct CoachArgs {
  LessonSettings lesson;
  bool headless = false, no_viewer = false;
  std::string host = "127.0.0.1";
  int port = 8765;
  std::string viewer_dir, report = "lesson-report.html", csv, record, replay;
  double linger = -1.0;  // seconds to keep serving after the end; < 0: until Ctrl-C (viewer only)
  // --webcam / --record-teacher (coach/webcam.hpp)
  bool webcam = false;
  WebcamSettings cam;
  double duration = 0.0;  // seconds; 0: until Ctrl-C
  bool teacher_given = false;
  std::string vmc, vmc_student;  // --vmc / --vmc-student HOST:PORT (coach/vmc_out.hpp)
};

// The time constant the scorer averages part scores over before it names the part to fix
// (kata/teacher.h "Score calibration and feedback": averaged over 0.5 s).
constexpr double kFeedbackSmoothingTime = 0.5;

std::atomic<bool> g_interrupted{false};
void on_interrupt(int) { g_interrupted = true; }

// Appends printf-style text at `at` (clamped at the buffer's end).
__attribute__((format(printf, 4, 5))) void append_line(char* line, size_t size, int& at, const char* fmt, ...) {
  if (at < 0 || static_cast<size_t>(at) >= size) return;
  va_list args;
  va_start(args, fmt);
  const int n = std::vsnprintf(line + at, size - static_cast<size_t>(at), fmt, args);
  va_end(args);
  if (n > 0) at = std::min(static_cast<int>(size) - 1, at + n);
}

// The terminal view: one line, redrawn in place on a terminal (plain lines every 2 s otherwise):
// progress, the newest total and per-part scores, the part to fix, frames/s, latency p50/p99
// (frame in -> result published, over the lesson so far).
class TerminalView {
 public:
  // show_reps: the repetition counter is shown only when the lesson counts them (--reps).
  TerminalView(bool interactive, size_t frames, bool show_reps) : interactive_(interactive), show_reps_(show_reps) {
    latencies_.reserve(frames);
    sorted_.reserve(frames);
  }

  void update(const LessonData& d, size_t shown, double fps, bool force = false) {
    const auto now = Clock::now();
    const auto every = interactive_ ? std::chrono::milliseconds(100) : std::chrono::milliseconds(2000);
    if (!force && now - last_ < every) return;
    last_ = now;
    const size_t total = static_cast<size_t>(d.student_frames);
    const int width = 20;
    const int filled = total ? static_cast<int>(width * shown / total) : 0;
    std::string bar(static_cast<size_t>(filled), '#');
    bar.resize(width, '.');
    // Only the first `shown` frames are final (later ones may still be written by the runtime's
    // I/O thread), so the view keeps its own running mean and latencies over them.
    for (; latency_count_ < shown; ++latency_count_) {
      const FrameRecord& f = d.frames[latency_count_];
      if (!scored(f)) continue;
      score_sum_ += f.score, ++scored_;
      if (f.latency_ns > 0) latencies_.push_back(f.latency_ns / 1e6);
      // The part scores as the scorer averages them before it names the part to fix and its cue
      // (exponentially over the frames' own time steps, time constant kFeedbackSmoothingTime), so the line's lowest part is the part named. This frame's scores beside
      // a held, averaged cue disagreed for up to a second ("l.arm 99 | fix: left_arm").
      const double keep = parts_time_ < 0.0 ? 0.0 : std::exp(-(f.time - parts_time_) / kFeedbackSmoothingTime);
      for (int p = 0; p < KATA_PART_COUNT; ++p) parts_[p] = f.part_scores[p] + keep * (parts_[p] - f.part_scores[p]);
      parts_time_ = f.time;
    }
    sorted_ = latencies_;  // reserved at the lesson's length: no allocation
    std::sort(sorted_.begin(), sorted_.end());
    auto pct = [&](double q) { return sorted_.empty() ? 0.0 : sorted_[static_cast<size_t>(q * (sorted_.size() - 1))]; };
    char line[512];
    int at = std::snprintf(line, sizeof line, "[%s] %3d%% %5.1fs", bar.c_str(), total ? static_cast<int>(100 * shown / total) : 0,
                           shown ? d.frames[shown - 1].time : 0.0);
    const FrameRecord* r = shown ? &d.frames[shown - 1] : nullptr;
    if (r && scored(*r)) {
      append_line(line, sizeof line, at, " | score %3.0f (mean %4.1f) |", r->score, score_sum_ / std::max(scored_, 1));
      static const char* const kShort[KATA_PART_COUNT] = {"torso", "l.arm", "r.arm", "l.leg", "r.leg"};
      for (int p = 0; p < KATA_PART_COUNT; ++p) append_line(line, sizeof line, at, " %s %3.0f", kShort[p], parts_[p]);
      append_line(line, sizeof line, at, " | fix: %-10s", r->part_to_fix >= 0 ? part_name(r->part_to_fix) : "-");
      // The correction cue ("left knee: bend 30 deg more"), padded so a shorter one overwrites it.
      char cue[64];
      append_line(line, sizeof line, at, " %-32s", cue_phrase(*r, cue, sizeof cue));
      if (r->state == FrameState::kTeacherFinished) append_line(line, sizeof line, at, " (teacher finished)");
    } else if (r) {
      append_line(line, sizeof line, at, " | %-16s", state_name(r->state));
    }
    // The repetition counter (docs/coach/repetitions.md): the one in progress while the lesson
    // runs, the completed ones (as the summary counts them) once it is over.
    if (show_reps_ && finished_)
      append_line(line, sizeof line, at, " | %d repetitions (%d partial)%s%s", counted_, partial_,
                  last_rep_.empty() ? "" : " | last ", last_rep_.c_str());
    else if (show_reps_ && r && scored(*r) && r->repetition > 0)
      append_line(line, sizeof line, at, " | rep %d %3.0f%% | %d done%s%s", r->repetition, 100.0 * r->repetition_progress,
                  counted_, last_rep_.empty() ? "" : " | last ", last_rep_.c_str());
    append_line(line, sizeof line, at, " | %4.0f frames/s | latency p50 %.2f p99 %.2f ms", fps, pct(0.5), pct(0.99));
    if (interactive_) std::printf("\r%s\033[K", line);
    else std::printf("%s\n", line);
    std::fflush(stdout);
  }
  void close() {
    if (interactive_) std::printf("\n");
  }
  // A repetition that ended (complete or partial, in order): counted, and its words ("rep 3: tempo
  // 1.12, ...") shown as the newest.
  void add_repetition(const kata_repetition& r) {
    ++(r.partial ? partial_ : counted_);
    last_rep_ = repetition_words(r);
  }
  // The lesson is over (every repetition added): the line shows the count instead of the one in progress.
  void set_finished() { finished_ = true; }

 private:
  bool interactive_;
  Clock::time_point last_{};
  size_t latency_count_ = 0;  // frames taken into the running figures
  double score_sum_ = 0.0;
  int scored_ = 0;
  double parts_[KATA_PART_COUNT] = {};  // part scores averaged as the scorer does (update)
  double parts_time_ = -1.0;                  // the newest frame taken into parts_, -1: none yet
  std::vector<double> latencies_, sorted_;
  std::string last_rep_;
  bool show_reps_ = false;
  int counted_ = 0, partial_ = 0;  // repetitions added: complete, partial
  bool finished_ = false;
};

// VMC out of a clip lesson (or a replayed one): each settled frame's student joints and its ghost
// (the ghost's joints on the student's skeleton: a joint the ghost leaves out sits on its parent,
// as the clip's zero-offset joints do) to coach/vmc_out.hpp's sender.
class LessonVmc {
 public:
  LessonVmc(const std::string& ghost_target, const std::string& student_target, const LessonData& d) {
    if (ghost_target.empty() && student_target.empty()) return;
    if (kata_context_create(&context_) != KATA_OK) fail("vmc: no context");
    std::vector<const char*> names;
    for (const std::string& n : d.joint_names) names.push_back(n.c_str());
    std::vector<int32_t> parents(d.joint_parents.begin(), d.joint_parents.end());
    kata_skeleton skeleton = nullptr;
    if (kata_skeleton_create(context_, static_cast<uint32_t>(d.joints), names.data(), parents.data(), nullptr,
                             &skeleton) != KATA_OK)
      fail("vmc: " + std::string(kata_context_last_error(context_)));
    VmcPerformer student, ghost;
    student.target = student_target;
    ghost.target = ghost_target;
    student.skeleton = ghost.skeleton = skeleton;
    student.layout = ghost.layout = d.settings.preset;
    try {
      out_ = std::make_unique<VmcOut>(context_, student, ghost);
    } catch (...) {
      kata_skeleton_destroy(skeleton);
      throw;
    }
    kata_skeleton_destroy(skeleton);
    // Student joint -> ghost joint (-1: not in the ghost); parents before children.
    of_student_.assign(static_cast<size_t>(d.joints), -1);
    for (size_t g = 0; g < d.ghost_sources.size(); ++g)
      if (d.ghost_sources[g] >= 0 && d.ghost_sources[g] < d.joints) of_student_[static_cast<size_t>(d.ghost_sources[g])] = static_cast<int>(g);
    full_ghost_.resize(3 * static_cast<size_t>(d.joints));
    if (!ghost_target.empty()) std::printf("vmc: the ghost goes to %s\n", ghost_target.c_str());
    if (!student_target.empty()) std::printf("vmc: the student goes to %s\n", student_target.c_str());
  }
  ~LessonVmc() {
    out_.reset();
    kata_context_destroy(context_);
  }
  // Frame i's student and ghost, once its record is final. [the coach's thread]
  void offer(const LessonData& d, size_t i) {
    if (!out_) return;
    const FrameRecord& r = d.frames[i];
    const float* ghost = nullptr;
    if (r.has_ghost && d.ghost_joints > 0) {
      const float* g = d.frame_ghost(i);
      for (int j = 0; j < d.joints; ++j) {
        const int at = of_student_[static_cast<size_t>(j)], parent = d.joint_parents[static_cast<size_t>(j)];
        const float* from = at >= 0 ? g + 3 * at : parent >= 0 ? &full_ghost_[3 * static_cast<size_t>(parent)] : d.frame_positions(i);
        std::copy(from, from + 3, &full_ghost_[3 * static_cast<size_t>(j)]);
      }
      ghost = full_ghost_.data();
    }
    out_->offer(r.time, d.frame_positions(i), ghost);
  }
  // Sends what is queued and prints the counts.
  void finish() {
    if (!out_) return;
    out_->close();
    const VmcCounters c = out_->counters();
    std::printf("vmc: %llu bundles sent, %llu sends failed, %llu frames dropped (queue full), %llu not posed\n",
                static_cast<unsigned long long>(c.sent), static_cast<unsigned long long>(c.send_failed),
                static_cast<unsigned long long>(c.dropped), static_cast<unsigned long long>(c.pose_failed));
    out_.reset();
  }

 private:
  kata_context context_ = nullptr;
  std::unique_ptr<VmcOut> out_;
  std::vector<int> of_student_;
  std::vector<float> full_ghost_;
};

// A webcam lesson (or a teacher's recording): the page at http://host:port/webcam.html does the
// camera and MediaPipe; this waits until Ctrl-C (or --duration), then prints the summary and
// writes the report and recordings.
void run_webcam(CoachArgs a) {
  a.cam.model = a.lesson.model;
  a.cam.teacher = a.teacher_given ? a.lesson.teacher : kata::cli::default_data_file(a.cam.teacher);
  a.cam.first_frame = a.lesson.first_frame;
  a.cam.window = a.lesson.window;
  a.cam.tolerance = a.lesson.tolerance;
  a.cam.publish = a.lesson.publish;
  a.cam.reps = a.lesson.reps;
  a.cam.rep_start = a.lesson.rep_start, a.cam.rep_end = a.lesson.rep_end;
  a.cam.vmc = a.vmc;
  a.cam.vmc_student = a.vmc_student;
  if (a.cam.complexity < 0 || a.cam.complexity > 2)
    fail("--complexity must be 0 (lite), 1 (full) or 2 (heavy)");
  WebcamCoach coach(a.cam, a.viewer_dir.empty() ? kata::cli::share_dir() + "/viewer" : a.viewer_dir, a.host, a.port);
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  if (a.cam.record_teacher.empty())
    std::printf("webcam lesson: teacher %s; open the page, allow the camera\n", a.cam.teacher.c_str());
  else
    std::printf("recording a teacher from the webcam into %s; open the page, allow the camera\n", a.cam.record_teacher.c_str());
  if (a.cam.people > 1)
    std::printf("up to %d people: each is coached on their own stream\n", a.cam.people);
  std::printf("viewer: http://%s:%d/webcam.html?complexity=%d  (open it in a browser)\n", a.host.c_str(), coach.port(),
              a.cam.complexity);
  std::fflush(stdout);
  const auto start = Clock::now();
  auto last_line = start;
  while (!g_interrupted && (a.duration <= 0 || Clock::now() - start < std::chrono::duration<double>(a.duration))) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (!a.headless && Clock::now() - last_line > std::chrono::seconds(5)) {
      last_line = Clock::now();
      std::printf("%s\n", coach.summary().c_str());
      std::fflush(stdout);
    }
  }
  coach.finish();
  std::printf("%s\n", coach.summary().c_str());
  if (!a.cam.record_teacher.empty()) std::printf("teacher recording: %s (+ .times.npy)\n", a.cam.record_teacher.c_str());
  if (!a.cam.record_student.empty()) std::printf("student recording: %s (+ .times.npy)\n", a.cam.record_student.c_str());
  if (!a.report.empty()) {
    coach.write_report(a.report);
    std::printf("report: %s\n", a.report.c_str());
  }
}

void run_coach(CoachArgs a) {
  // The defaults (the shipped model and lesson) are found from any directory; a path the user gave
  // is taken as given.
  a.lesson.model = kata::cli::default_data_file(a.lesson.model);
  a.lesson.teacher = kata::cli::default_data_file(a.lesson.teacher);
  a.lesson.student = kata::cli::default_data_file(a.lesson.student);
  if (a.webcam || !a.cam.record_teacher.empty()) return run_webcam(a);
  if (a.headless) a.no_viewer = true;
  if (!(a.lesson.speed > 0.0)) fail("--speed must be > 0");

  // The lesson: live (the runtime) or recorded (a file).
  std::unique_ptr<Lesson> live;
  LessonData replayed;
  if (a.replay.empty()) {
    live = std::make_unique<Lesson>(a.lesson);
  } else {
    replayed = read_recording(a.replay);
    replayed.settings.speed = a.lesson.speed;
  }
  const LessonData& data = live ? live->data() : replayed;
  const size_t frames = static_cast<size_t>(live ? data.student_frames : replayed.pushed);

  std::unique_ptr<ViewerServer> viewer;
  if (!a.no_viewer) {
    viewer = std::make_unique<ViewerServer>(a.viewer_dir.empty() ? kata::cli::share_dir() + "/viewer" : a.viewer_dir, a.host, a.port);
    // A token that tells this lesson from the next one on the same port (a page that saw the end
    // of one lesson starts over when /status shows another).
    const std::string lesson_id = std::to_string(std::chrono::system_clock::now().time_since_epoch().count());
    viewer->set_setup(setup_json(data, a.replay.empty() ? "live" : "replay", lesson_id));
    viewer->set_lesson_id(lesson_id);
    std::printf("viewer: http://%s:%d/  (open it in a browser)\n", a.host.c_str(), viewer->port());
  }
  LessonVmc vmc(a.vmc, a.vmc_student, data);
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  if (live)
    std::printf("lesson: student %s, teacher %s, %zu frames at %.3g x real time; results published on %s (teacher "
                "stream %llu, student stream %llu)\n",
                data.settings.student.c_str(), data.settings.teacher.c_str(), frames, a.lesson.speed,
                live->publish_endpoint().c_str(), static_cast<unsigned long long>(Lesson::kTeacherStream),
                static_cast<unsigned long long>(Lesson::kStudentStream));
  else
    std::printf("replay %s: student %s, teacher %s, %zu frames at %.3g x real time\n", a.replay.c_str(),
                data.settings.student.c_str(), data.settings.teacher.c_str(), frames, a.lesson.speed);
  std::fflush(stdout);

  TerminalView view(!a.headless && isatty(STDOUT_FILENO), frames, a.lesson.reps || !data.repetitions.empty());
  size_t published = 0;  // frames handed to the viewer (in order, once their record is final)
  size_t reps_shown = 0;  // repetitions handed to the viewer and the terminal
  // The repetitions that ended by `settled` frames: a live lesson's as the runtime reports them (the
  // last one closed by the lesson's end), a replay's those that ended by the newest frame shown.
  auto repetitions_ended = [&](size_t settled) -> size_t {
    if (live) return live->repetitions_ended();
    size_t n = 0;
    const double shown_time = settled ? replayed.frames[settled - 1].time : -1.0;
    while (n < replayed.repetitions.size() && replayed.repetitions[n].end_time <= shown_time + 1e-9) ++n;
    return n;
  };
  auto repetition = [&](size_t k) -> const kata_repetition& {
    return live ? live->repetition(k) : replayed.repetitions[k];
  };
  // The repetitions ended and not yet handed on, as JSON ("" for none), each added to the terminal's counter.
  auto take_repetitions = [&](size_t ended) {
    std::string reps;
    for (; reps_shown < ended; ++reps_shown) {
      reps += (reps.empty() ? "" : ",") + repetition_json(repetition(reps_shown));
      view.add_repetition(repetition(reps_shown));
    }
    return reps;
  };
  auto publish_settled = [&](size_t settled) {
    for (; published < settled; ++published) {
      std::string json = viewer ? frame_json(data, published) : std::string();
      // The repetitions that ended by now ride on the next frame event ("reps": [...]).
      const std::string reps = take_repetitions(repetitions_ended(published + 1));
      if (viewer && !reps.empty()) json.insert(json.size() - 1, ",\"reps\":[" + reps + "]");
      if (viewer) viewer->publish(std::move(json));
      vmc.offer(data, published);
    }
  };

  const auto start = Clock::now();
  auto window_start = start;
  size_t window_frames = 0;
  double fps = 0.0;
  size_t played = 0;  // frames pushed (live) or revealed (replay)
  for (size_t i = 0; i < frames && !g_interrupted; ++i) {
    const auto due = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                                 static_cast<double>(i) * data.frame_time / a.lesson.speed));
    std::this_thread::sleep_until(due);
    if (live) live->push(static_cast<int>(i));
    played = i + 1;
    publish_settled(live ? live->settle() : played);
    ++window_frames;
    const auto now = Clock::now();
    if (now - window_start >= std::chrono::milliseconds(500)) {
      fps = window_frames / std::chrono::duration<double>(now - window_start).count();
      window_start = now, window_frames = 0;
    }
    view.update(data, published, fps);
  }
  if (live) live->finish();
  const size_t done = played;
  if (!live) replayed.pushed = static_cast<int>(played);  // an interrupted replay reports what was shown
  publish_settled(done);
  // The repetitions that ended with the lesson (kata_runtime_stop closes the one in progress, after
  // every frame's result; a replay's recorded ones) ride on the end event; the terminal's last line
  // counts them too, as the summary does.
  const std::string final_reps = take_repetitions(live ? live->repetitions_ended() : replayed.repetitions.size());
  view.set_finished();
  view.update(data, published, fps, true);
  view.close();
  const double wall = std::chrono::duration<double>(Clock::now() - start).count();

  // Summary.
  int fix_count[KATA_PART_COUNT] = {}, scored_frames = 0, named = 0;
  int cue_count[KATA_GPD_JOINTS] = {};
  double part_sum[KATA_PART_COUNT] = {};
  for (size_t i = 0; i < done; ++i)
    if (scored(data.frames[i])) {
      ++scored_frames;
      for (int p = 0; p < KATA_PART_COUNT; ++p) part_sum[p] += data.frames[i].part_scores[p];
      if (data.frames[i].part_to_fix >= 0) ++fix_count[data.frames[i].part_to_fix], ++named;
      if (data.frames[i].cue_joint >= 0 && data.frames[i].cue_joint < KATA_GPD_JOINTS) ++cue_count[data.frames[i].cue_joint];
    }
  int most_cued = 0;
  for (int j = 1; j < KATA_GPD_JOINTS; ++j)
    if (cue_count[j] > cue_count[most_cued]) most_cued = j;
  int most = 0;
  for (int p = 1; p < KATA_PART_COUNT; ++p)
    if (fix_count[p] > fix_count[most]) most = p;
  std::printf("summary: %zu frames in %.2f s (%.0f frames/s), %d scored, mean score %.2f, mean part scores", done, wall,
              done / std::max(wall, 1e-9), scored_frames, data.mean_score());
  for (int p = 0; p < KATA_PART_COUNT; ++p)
    std::printf(" %s %.1f", part_name(p), scored_frames ? part_sum[p] / scored_frames : 0.0);
  if (named)
    std::printf(", part to fix most often: %s (%d%% of scored frames), joint to move most often: %s (%d%%)",
                part_name(most), 100 * fix_count[most] / scored_frames,
                kata_gpd_joint_words(most_cued), 100 * cue_count[most_cued] / scored_frames);
  else
    std::printf(", no part to fix");
  if (live) {
    const auto c = live->counters();
    std::printf(", %llu results published (teacher %llu), latency in->published p50 %.0f us p99 %.0f us",
                static_cast<unsigned long long>(c.published), static_cast<unsigned long long>(live->teacher_results()),
                live->latency_percentile(0.5) / 1e3, live->latency_percentile(0.99) / 1e3);
  }
  std::printf("%s\n", g_interrupted ? " (interrupted)" : "");
  if (!data.repetitions.empty()) std::printf("repetitions: %s\n", repetitions_summary(data.repetitions).c_str());
  vmc.finish();
  if (!a.csv.empty()) write_results_csv(data, a.csv);
  if (!a.record.empty() && live) {
    write_recording(data, a.record);
    std::printf("recording: %s\n", a.record.c_str());
  }
  if (!a.report.empty()) {
    write_report(data, a.report);
    std::printf("report: %s\n", a.report.c_str());
  }
  if (viewer) {
    // Only a finished lesson ends the page's stream; an interrupted coach just goes away, so a
    // page keeps trying to reconnect (and resumes when a coach is back on the port).
    if (!g_interrupted) {
      // The end event: the summary, the repetitions no frame carried and the count ("reps_done",
      // "reps_partial": the summary's).
      std::string end = end_json(data);
      if (a.lesson.reps || !data.repetitions.empty())
        end.insert(end.size() - 1, ",\"reps\":[" + final_reps + "]," + repetitions_count_json(data.repetitions));
      viewer->end(std::move(end));
    }
    if (a.linger < 0) std::printf("viewer: still at http://%s:%d/ (Ctrl-C to quit)\n", a.host.c_str(), viewer->port());
    std::fflush(stdout);
    const auto until = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::max(a.linger, 0.0)));
    while (!g_interrupted && (a.linger < 0 || Clock::now() < until)) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    viewer->stop();
  }
}

void setup(CLI::App& app) {
  auto a = std::make_shared<CoachArgs>();
  CLI::App* cmd = app.add_subcommand(
      "coach", "a live coaching lesson: the student played as a live stream against the teacher (score, part to fix, "
               "ghost every frame), a terminal view, a 3D viewer in the browser, an HTML report at the end");
  cmd->add_option("--teacher", a->lesson.teacher,
                  "teacher BVH clip (default data/cmu/05_18.bvh); with --webcam also a landmark recording (.npy from "
                  "--record-teacher)")
      ->check(CLI::ExistingFile)
      ->each([a](const std::string&) { a->teacher_given = true; });
  cmd->add_flag("--webcam", a->webcam,
                "the student is a webcam: the page (webcam.html) runs MediaPipe Pose in the browser and sends landmarks");
  cmd->add_option("--record-teacher", a->cam.record_teacher,
                  "record the webcam's person as a teacher: landmarks .npy (frames x 33 x 4) + .times.npy; no scoring");
  cmd->add_option("--record-student", a->cam.record_student, "a webcam lesson also keeps the received landmarks here (.npy)");
  cmd->add_option("--people", a->cam.people,
                  "webcam: coach up to N people in front of the camera at once (1..4, default 1): each their own "
                  "stream, score, ghost and report section (" + kata::cli::doc_file("people.md") + ")")
      ->check(CLI::Range(1, kMaxWebcamPeople));
  cmd->add_option("--complexity", a->cam.complexity, "webcam: MediaPipe Pose model, 0 lite (default), 1 full, 2 heavy");
  cmd->add_option("--teacher-layout", a->cam.teacher_layout, "webcam: layout of a landmark teacher (default mediapipe)");
  cmd->add_option("--time-units", a->cam.time_units, "webcam: units of a landmark teacher's timestamps: s (default: what --record-teacher writes), ms or auto")
      ->check(CLI::IsMember({"s", "ms", "auto"}));
  cmd->add_option("--duration", a->duration, "webcam: stop after this many seconds (default: at Ctrl-C)");
  cmd->add_option("--student", a->lesson.student, "student BVH clip (default data/cmu/05_19_on_02.bvh)")->check(CLI::ExistingFile);
  cmd->add_option("--model", a->lesson.model, ".kata model (default models/default.kata)")->check(CLI::ExistingFile);
  cmd->add_option("--layout,--preset", a->lesson.preset, "layout of both clips (default cmu; --preset: its name before 1.0)");
  cmd->add_option("--first-frame", a->lesson.first_frame, "first frame of each clip (default 1: skips CMU's T-pose)");
  cmd->add_option("--speed", a->lesson.speed, "playback rate, 1 = real time (default 1)");
  cmd->add_option("--window", a->lesson.window, "alignment window, teacher seconds (default 0.5)");
  cmd->add_option("--tolerance", a->lesson.tolerance,
                  "how far a part may be off: strict, normal (default), lenient, or the angle in degrees at which a "
                  "part scores 50 (" + kata::cli::doc_file("model/tolerance.md") + ")");
  cmd->add_option("--teacher-start", a->lesson.teacher_start,
                  "practice: start at this teacher clip frame (the teacher before it is not used)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option_function<std::vector<int>>(
         "--loop",
         [a](const std::vector<int>& v) {
           if (v[0] < 0 || v[0] > v[1]) throw CLI::ValidationError("--loop", "takes teacher clip frames A B, 0 <= A <= B");
           a->lesson.loop_first = v[0], a->lesson.loop_last = v[1];
         },
         "practice: loop teacher clip frames A..B")
      ->expected(2);
  cmd->add_flag("--reps", a->lesson.reps,
                "count repetitions: the teacher (the whole clip, or --rep-section) is one repetition, looped; a "
                "counter, tempo and depth live and in the report (" + kata::cli::doc_file("coach/repetitions.md") + ")");
  cmd->add_option_function<std::vector<double>>(
         "--rep-section",
         [a](const std::vector<double>& v) {
           if (!(v[0] >= 0.0) || !(v[1] > v[0])) throw CLI::ValidationError("--rep-section", "takes teacher seconds A B, 0 <= A < B");
           a->lesson.rep_start = v[0], a->lesson.rep_end = v[1], a->lesson.reps = true;
         },
         "count repetitions of the teacher's seconds A to B (clip time; B: where the next repetition would start); "
         "implies --reps")
      ->expected(2);
  cmd->add_option("--publish", a->lesson.publish,
                  "ZeroMQ endpoint the runtime publishes results on (default tcp://127.0.0.1:*, any free port)");
  cmd->add_option("--vmc", a->vmc,
                  "send the ghost to a VMC receiver (an avatar in Unity, Unreal, Blender, Godot: " + kata::cli::doc_file("vmc.md") +
                      ") at HOST:PORT (its default port is 39539), one OSC bundle per frame over UDP");
  cmd->add_option("--vmc-student", a->vmc_student, "send the student to a VMC receiver at HOST:PORT (a second avatar)");
  cmd->add_flag("--headless", a->headless, "no viewer, plain progress lines (CI)");
  cmd->add_flag("--no-viewer", a->no_viewer, "no browser viewer (the terminal view stays)");
  cmd->add_option("--host", a->host, "viewer address (default 127.0.0.1)");
  cmd->add_option("--port", a->port, "viewer port (default 8765; 0: any free port)");
  cmd->add_option("--viewer-dir", a->viewer_dir, "the viewer's files (default <kata>/../share/kata/viewer)");
  cmd->add_option("--linger", a->linger, "seconds to keep the viewer up after the end (default: until Ctrl-C)");
  cmd->add_option("--report", a->report, "HTML report path (default lesson-report.html; empty: none)");
  cmd->add_option("--csv", a->csv, "also write every frame's result as CSV");
  cmd->add_option("--record", a->record, "record the lesson (incoming frames and results) to this .npz file");
  cmd->add_option("--replay", a->replay, "play a recorded lesson (.npz from --record) instead of a live one")
      ->check(CLI::ExistingFile);
  cmd->callback([a] { run_coach(*a); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
