// kata score: scores every frame of a student clip against a teacher (one pose, or the whole clip
// followed with online alignment) with a .kata model; one CSV row per student frame.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "command.hpp"
#include "common/error.hpp"
#include "data_files.hpp"
#include "io/bvh.hpp"
#include "io/model_file.hpp"
#include "metric/model.hpp"
#include "metric/align_dtw.hpp"
#include "metric/parts.hpp"
#include "metric/reps.hpp"
#include "metric/scorer.hpp"
#include "metric/smoothed_rematch.hpp"
#include "skeleton/skeleton.hpp"
#include "io/clip_features.hpp"
#include "io/motion_source.hpp"

namespace {

// True for the pure name-map presets (a BVH clip is read through them directly).
bool preset_is_name_map(const std::string& layout) {
  for (const std::string& p : kata::preset_names())
    if (p == layout) return true;
  return false;
}

struct ScoreArgs {
  std::string model, teacher, student, preset, name_map, out;
  std::string teacher_layout, student_layout, up = "y";  // per-side layouts (default: --layout)
  std::string time_units = "auto";  // of landmark arrays' timestamps
  double fps = 0.0;
  int teacher_frame = -1;  // -1: the whole teacher clip is the reference
  int first = 0;
  double window = 0.5;
  std::string align = "online";  // online (the live Aligner) or dtw (offline subsequence DTW)
  int teacher_start = -1;        // practice: the lesson starts at this teacher clip frame
  std::vector<int> loop;         // practice: loop teacher clip frames A..B
  double relocate_time = kata::metric::AlignmentOptions{}.relocate_time;
  double rematch_time = -1.0;  // -1: the default, 0.05 s, or kSmoothedRematchTime for a smoothed student
  std::string tolerance = "normal";  // metric::parse_tolerance: strict, normal, lenient or degrees
  std::string reps;               // repetitions CSV (docs/coach/repetitions.md), or empty
  std::vector<double> rep_section;  // the repetition: teacher seconds A B (empty: the whole clip)
};

// Seconds for a message: 0.25, 0.0083, 12.5.
std::string text_seconds(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", s);
  return text;
}

// The repetitions CSV (docs/coach/repetitions.md "The CSV"): one row per repetition, complete or
// partial, in the order they ended.
void write_reps(const ScoreArgs& a, const std::vector<kata::metric::Repetition>& repetitions, int count) {
  using namespace kata;
  std::FILE* out = std::fopen(a.reps.c_str(), "w");
  if (!out) throw Error(ErrorKind::kIo, a.reps + ": cannot open for writing");
  std::fprintf(out, "rep,start_time,end_time,tempo,score,part_to_fix,cue,partial");
  for (int i = 0; i < metric::kRomJoints; ++i)
    std::fprintf(out, ",range_%s,range_%s_teacher", metric::rom_joint_name(i), metric::rom_joint_name(i));
  std::fputc('\n', out);
  int partial = 0;
  double tempo = 0.0;
  for (const metric::Repetition& r : repetitions) {
    char cue[64] = "";
    if (r.cue_joint >= 0) metric::cue_text(r.cue_joint, r.cue_degrees, r.cue_action, cue, sizeof cue);
    std::fprintf(out, "%d,%.6f,%.6f,%.4f,%.2f,%s,%s,%d", r.index, r.start_time, r.end_time, r.tempo, r.score,
                 r.part_to_fix >= 0 ? metric::part_name(r.part_to_fix) : "", cue, r.partial ? 1 : 0);
    for (int i = 0; i < metric::kRomJoints; ++i) std::fprintf(out, ",%.2f,%.2f", r.range[i], r.teacher_range[i]);
    std::fputc('\n', out);
    if (r.partial) ++partial;
    else tempo += r.tempo;
  }
  const bool ok = std::fflush(out) == 0 && !std::ferror(out);
  std::fclose(out);
  if (!ok) throw Error(ErrorKind::kIo, a.reps + ": write failed");
  std::printf("%d repetitions", count);
  if (count > 0) std::printf(" (mean tempo %.2f)", tempo / count);
  if (partial > 0) std::printf(", %d partial (not counted)", partial);
  std::printf(" -> %s\n", a.reps.c_str());
}

void run_score(const ScoreArgs& a) {
  using namespace kata;
  const metric::Tolerance tolerance = metric::parse_tolerance(a.tolerance.c_str());  // before the clips load
  const metric::Model loaded = metric::load_model(a.model);
  // A transition model (its evaluation figures name a transition protocol) scores similarity of
  // futures, not a performance: say so, the scores below are not coaching scores.
  for (const auto& figure : loaded.info.evaluation)
    if (figure.first.find("protocol transition") != std::string::npos) {
      std::fprintf(stderr, "note: %s is a transition model (%s); for coaching scores use models/default.kata "
                           "(%s)\n", a.model.c_str(), figure.first.c_str(), kata::cli::doc_file("model/transition.md").c_str());
      break;
    }
  const auto metric = std::make_shared<const metric::Metric>(loaded);
  // Features must use the stencil the model was trained with.
  // BVH clips through a preset or name map (row i = clip frame first + i); any other source
  // (landmark arrays, other layouts) through its layout, rows = frames that gave features.
  struct Side {
    std::vector<float> features;
    double frame_time = 0.0;
    std::vector<int> rows;  // source frame of each feature row (frames tracking lost have none)
    std::vector<double> times;  // source frame times, seconds (empty: f x frame_time)
    int frames = 0;         // source frames
    std::shared_ptr<const metric::Reference> clip;  // a BVH teacher clip: its Reference, no features
    bool smoothed = false;  // read through a layout that smooths (One-Euro: landmark arrays)
  };
  // The teacher of a clip score is projected chunk by chunk as it is read: its features
  // (6.7 KB a frame, 550 MB for an 11-minute teacher) are never held whole.
  constexpr int kChunkFrames = 1024;
  // A student layout that synthesises its trunk (MediaPipe landmarks: no pelvis, spine or neck
  // point) has the teacher's trunk made by the same rule (skeleton.hpp, trunk_as_student).
  const std::string student_layout = a.student_layout.empty() ? a.preset : a.student_layout;
  std::unique_ptr<GpdMap> student_trunk;
  for (const std::string& n : layout_names())
    if (n == student_layout && !preset_is_name_map(n))
      student_trunk = std::make_unique<GpdMap>(resolve_layout(layout_skeleton(n), n).map);
  auto load_side = [&](const std::string& path, const std::string& layout, bool teacher_clip,
                       const GpdMap* trunk = nullptr) {
    auto read_trunk = [trunk](const GpdMap& map) { return trunk ? trunk_as_student(map, *trunk) : map; };
    Side side;
    const bool bvh = path.size() > 4 && path.compare(path.size() - 4, 4, ".bvh") == 0;
    if (bvh && (!a.name_map.empty() || layout.empty() || preset_is_name_map(layout))) {
      const BvhClip clip = load_bvh(path);
      // (No frames, or --first-frame past the end: the path below says so as before.)
      if (teacher_clip && a.first >= 0 && clip.frame_count() - a.first >= 1) {
        const GpdMap map = read_trunk(resolve_gpd_map(clip, layout, a.name_map));
        const int frames = clip.frame_count() - a.first;
        side.clip = std::make_shared<const metric::Reference>(
            metric,
            [&](const std::function<void(const float*, int)>& sink) {
              clip_features_in_chunks(clip, map, metric->stencil(), a.first, kChunkFrames, sink);
            },
            frames, clip.frame_time);
        side.frame_time = clip.frame_time;
        side.frames = frames;
        return side;
      }
      side.features = clip_features(clip, read_trunk(resolve_gpd_map(clip, layout, a.name_map)), metric->stencil(), a.first);
      side.frame_time = clip.frame_time;
      side.frames = static_cast<int>(side.features.size() / gpd::kDims);
      for (int f = 0; f < side.frames; ++f) side.rows.push_back(f);
      return side;
    }
    const UpAxis up = a.up == "z" ? UpAxis::kZ : a.up == "y-down" ? UpAxis::kYDown : UpAxis::kY;
    MotionSource m = load_motion(path, layout, a.fps, up, a.first, parse_time_units(a.time_units));
    m.layout.map = read_trunk(m.layout.map);
    int lost = 0;
    side.features = motion_features(m, metric->stencil(), &side.rows, &lost);
    side.frame_time = m.frame_time;
    side.smoothed = m.layout.smooth;
    side.times = m.times;
    side.frames = m.frames;
    if (lost) std::printf("%s: %d frames tracking lost (no score)\n", path.c_str(), lost);
    return side;
  };
  // A landmark array has no joint names to read a layout from: the file without one is named with
  // the flags that give it, before either side is read (a BVH teacher read first would be blamed).
  auto ends_with = [](const std::string& path, const char* ext) {
    const size_t n = std::char_traits<char>::length(ext);
    return path.size() > n && path.compare(path.size() - n, n, ext) == 0;
  };
  for (const auto& [path, own, flag] : {std::tuple{a.teacher, a.teacher_layout, "--teacher-layout"},
                                        std::tuple{a.student, a.student_layout, "--student-layout"}})
    if ((ends_with(path, ".npy") || ends_with(path, ".csv")) && own.empty() && a.preset.empty())
      throw Error(ErrorKind::kInvalidArgument, path + ": a landmark array needs a layout: give --layout (both "
                                                   "inputs) or " + std::string(flag) + " (mediapipe, gpd, ...)");
  const Side ts = load_side(a.teacher, a.teacher_layout.empty() ? a.preset : a.teacher_layout, a.teacher_frame < 0,
                            student_trunk.get());
  const Side ss = load_side(a.student, a.student_layout.empty() ? a.preset : a.student_layout, false);
  const std::vector<float>& tf = ts.features;
  const std::vector<float>& sf = ss.features;
  struct {
    double frame_time;
  } teacher{ts.frame_time}, student{ss.frame_time};
  const int teacher_frames = ts.clip ? ts.frames : static_cast<int>(tf.size() / gpd::kDims);
  const int student_frames = ss.frames;  // every source frame gets a CSV row (lost ones: tracking_lost)
  if (teacher_frames < 1 || sf.empty()) throw Error(ErrorKind::kInvalidArgument, "no frames to score");

  std::shared_ptr<const metric::Reference> ref;
  if (a.teacher_frame >= 0) {
    if (a.teacher_frame < a.first || a.teacher_frame - a.first >= teacher_frames)
      throw Error(ErrorKind::kInvalidArgument, "--teacher-frame " + std::to_string(a.teacher_frame) + " is outside " +
                                                   a.teacher + " (frames " + std::to_string(a.first) + ".." +
                                                   std::to_string(a.first + teacher_frames - 1) + ")");
    ref = std::make_shared<const metric::Reference>(metric, tf.data() + static_cast<size_t>(a.teacher_frame - a.first) * gpd::kDims);
  } else if (ts.clip) {
    ref = ts.clip;
  } else {
    ref = std::make_shared<const metric::Reference>(metric, tf.data(), teacher_frames, teacher.frame_time);
  }
  metric::AlignmentOptions options;
  options.window = a.window;
  options.relocate_time = a.relocate_time;
  // As a stream re-matches (pipeline.cpp): a smoothed student within kSmoothedRematchTime.
  options.rematch_time = a.rematch_time >= 0.0 ? a.rematch_time
                         : ss.smoothed         ? metric::kSmoothedRematchTime
                                               : metric::AlignmentOptions{}.rematch_time;
  auto to_row = [&](int clip_frame, const char* flag) {
    if (clip_frame < a.first || clip_frame - a.first >= teacher_frames)
      throw Error(ErrorKind::kInvalidArgument, std::string(flag) + " " + std::to_string(clip_frame) + " is outside " +
                                                   a.teacher + " (frames " + std::to_string(a.first) + ".." +
                                                   std::to_string(a.first + teacher_frames - 1) + ")");
    return clip_frame - a.first;
  };
  if (a.teacher_start >= 0) options.first_frame = to_row(a.teacher_start, "--teacher-start");
  if (!a.loop.empty()) {
    if (a.loop.size() != 2 || a.loop[0] > a.loop[1])
      throw Error(ErrorKind::kInvalidArgument, "--loop takes two teacher clip frames A B with A <= B");
    options.first_frame = to_row(a.loop[0], "--loop");
    options.last_frame = to_row(a.loop[1], "--loop");
    options.loop = true;
  }
  // Repetitions: the section (or the whole clip) is one repetition, looped so that the match comes
  // round from its end to its start when the student starts the next one.
  if (!a.reps.empty()) {
    if (a.teacher_frame >= 0)
      throw Error(ErrorKind::kInvalidArgument, "--reps needs a teacher clip, not --teacher-frame");
    if (!a.loop.empty() || a.teacher_start >= 0)
      throw Error(ErrorKind::kInvalidArgument, "--reps sets the section itself: give --rep-section A B, not --loop or "
                                               "--teacher-start");
    options.first_frame = 0;
    options.last_frame = teacher_frames - 1;
    if (!a.rep_section.empty()) {
      // Teacher clip seconds (clip frame k at k x the frame time): the frames in [A, B), so that
      // the repetition's period is B - A.
      const double A = a.rep_section[0], B = a.rep_section[1];
      const int fa = static_cast<int>(std::ceil(A / teacher.frame_time - 1e-6));
      const int fb = static_cast<int>(std::ceil(B / teacher.frame_time - 1e-6)) - 1;
      if (!(A >= 0.0) || !(B > A) || fb < fa)
        throw Error(ErrorKind::kInvalidArgument, "--rep-section takes teacher seconds A B with 0 <= A < B (got " +
                                                     text_seconds(A) + " " + text_seconds(B) + ")");
      const int last_clip = a.first + teacher_frames - 1;
      if (fa < a.first || fb > last_clip)
        throw Error(ErrorKind::kInvalidArgument, "--rep-section " + text_seconds(A) + " " + text_seconds(B) +
                                                     " is outside " + a.teacher + " (" +
                                                     text_seconds(a.first * teacher.frame_time) + ".." +
                                                     text_seconds((last_clip + 1) * teacher.frame_time) + " s)");
      options.first_frame = fa - a.first;
      options.last_frame = fb - a.first;
    }
    options.loop = true;
  } else if (!a.rep_section.empty()) {
    throw Error(ErrorKind::kInvalidArgument, "--rep-section needs --reps FILE.csv");
  }
  metric::Scorer scorer(ref, options);
  metric::RepCounter reps(ref);
  std::vector<metric::Repetition> repetitions;
  scorer.set_tolerance(tolerance);
  // The offline reference: every student frame's teacher frame from a subsequence DTW over the
  // same static-blocks projections (metric/align_dtw.hpp); the scores are the same scorer's.
  std::vector<int> dtw;
  if (a.align == "dtw" && a.teacher_frame < 0) {
    const metric::Metric& m = *metric;
    const int stride = m.stride(), n = static_cast<int>(sf.size() / gpd::kDims);
    std::vector<float> rows(static_cast<size_t>(n) * stride);
    metric::AlignedFloats p(static_cast<size_t>(metric::kProjectionRows) * stride);
    metric::Metric::Workspace ws = m.make_workspace();
    for (int i = 0; i < n; ++i) {
      m.part_projections(sf.data() + static_cast<size_t>(i) * gpd::kDims, ws, p.data());
      std::copy(p.data() + static_cast<size_t>(metric::kParts) * stride,
                p.data() + static_cast<size_t>(metric::kParts + 1) * stride, rows.data() + static_cast<size_t>(i) * stride);
    }
    dtw = metric::subsequence_dtw(*ref, rows.data(), n);
  }

  std::FILE* out = std::fopen(a.out.c_str(), "w");
  if (!out) throw Error(ErrorKind::kIo, a.out + ": cannot open for writing");
  std::fprintf(out, "frame,time,distance,score");
  for (int q = 0; q < metric::kParts; ++q) std::fprintf(out, ",%s", metric::part_name(q));
  std::fprintf(out, ",matched_teacher_frame");
  for (int q = 0; q < metric::kParts; ++q) std::fprintf(out, ",%s_distance", metric::part_name(q));
  for (int q = 0; q < metric::kParts; ++q) std::fprintf(out, ",%s_score", metric::part_name(q));
  // The correction cue (metric/cue.hpp): the GPD joint to move ("" for none), the angle at it in
  // degrees and the phrase (cue_text: words, digits and one colon, never a comma or a quote, so
  // the cell needs no quoting).
  std::fprintf(out, ",part_to_fix,state,matched_teacher_time,cue_joint,cue_degrees,cue\n");
  // The summary covers the frames with a score to show (state "scoring").
  double score_sum = 0.0, part_score_sum[metric::kParts] = {};
  int named[metric::kParts] = {};  // scored frames whose part_to_fix is each part
  int scored = 0, finished = 0, calibrating = 0, lost = 0;
  static const char* const kStates[] = {"scoring", "calibrating", "tracking_lost", "teacher_finished"};
  size_t row = 0;
  for (int f = 0; f < student_frames; ++f) {
    const double t = ss.times.empty() ? f * student.frame_time : ss.times[static_cast<size_t>(f)];
    const bool has_row = row < ss.rows.size() && ss.rows[row] == f;
    const float* x = has_row ? sf.data() + row * gpd::kDims : nullptr;
    const metric::ScoreRecord& r = !has_row      ? scorer.score_lost(t)
                                   : dtw.empty() ? scorer.score(x, t)
                                                 : scorer.score_matched(x, t, dtw[row]);
    if (has_row) ++row;
    if (!a.reps.empty() && reps.update(r, x, scorer.aligner()) > 0) repetitions.push_back(reps.newest());
    const int matched = a.teacher_frame >= 0 ? a.teacher_frame : r.matched + a.first;
    std::fprintf(out, "%d,%.6f,%.7g,%.4f", f + a.first, t, r.distance, r.score);
    for (float p : r.parts) std::fprintf(out, ",%.7g", p);
    std::fprintf(out, ",%d", matched);
    for (float p : r.part_distance) std::fprintf(out, ",%.7g", p);
    for (float p : r.part_scores) std::fprintf(out, ",%.4f", p);
    std::fprintf(out, ",%s,%s,%.6f", r.part_to_fix >= 0 ? metric::part_name(r.part_to_fix) : "",
                 kStates[static_cast<int>(r.state)], matched * teacher.frame_time);
    if (r.cue_joint >= 0) {
      char cue[64];
      metric::cue_text(r.cue_joint, r.cue_degrees, r.cue_action, cue, sizeof cue);
      std::fprintf(out, ",%s,%.2f,%s\n", kata::kGpdJointNames[static_cast<size_t>(r.cue_joint)], r.cue_degrees, cue);
    } else {
      std::fputs(",,,\n", out);
    }
    if (r.state == metric::ScoreState::kTeacherFinished) ++finished;
    if (r.state == metric::ScoreState::kCalibrating) ++calibrating;
    if (r.state == metric::ScoreState::kTrackingLost) ++lost;
    if (r.state != metric::ScoreState::kScoring) continue;
    ++scored;
    score_sum += r.score;
    for (int q = 0; q < metric::kParts; ++q) part_score_sum[q] += r.part_scores[q];
    if (r.part_to_fix >= 0) ++named[r.part_to_fix];
  }
  const bool ok = std::fflush(out) == 0 && !std::ferror(out);
  std::fclose(out);
  if (!ok) throw Error(ErrorKind::kIo, a.out + ": write failed");
  if (!a.reps.empty()) {
    const double end = ss.times.empty() ? (student_frames - 1) * student.frame_time : ss.times.back();
    if (reps.finish(end) > 0) repetitions.push_back(reps.newest());
    write_reps(a, repetitions, reps.count());
  }

  // Nothing scored: no mean and no part to fix to report (a mean of 0 would read as a terrible
  // performance); say which state every frame was in and why, and fail.
  if (scored == 0) {
    const double calibrating_time = metric::FeedbackOptions{}.calibrating_time;
    const double seconds = ss.times.size() > 1 ? ss.times.back() - ss.times.front()
                                               : static_cast<double>(std::max(student_frames - 1, 0)) * student.frame_time;
    std::string why;
    if (calibrating > 0)
      why += std::to_string(calibrating) + " calibrating (the first " + text_seconds(calibrating_time) +
             " s of a clip settle the alignment and the kinetics; " + a.student + " spans " + text_seconds(seconds) +
             " s)";
    if (lost > 0)
      why += std::string(why.empty() ? "" : ", ") + std::to_string(lost) +
             " tracking lost (fewer than 13 of the 16 GPD joints tracked)";
    if (finished > 0)
      why += std::string(why.empty() ? "" : ", ") + std::to_string(finished) + " after the teacher clip ended";
    throw Error(ErrorKind::kInvalidArgument,
                a.student + ": nothing scored: of its " + std::to_string(student_frames) + " frame(s), " + why +
                    "; no mean score or part to fix (each frame's figures are in " + a.out +
                    "). Give a student clip longer than " + text_seconds(calibrating_time) + " s with the body tracked");
  }
  // The part to fix over the clip is the one the frames' part_to_fix column names most often (as
  // kata coach's summary): one answer to one question (the mean part scores are printed beside it).
  const double mean = score_sum / scored;
  int most = 0;
  for (int q = 1; q < metric::kParts; ++q)
    if (named[q] > named[most]) most = q;
  std::string most_to_fix = "nothing (no frame names a part)";
  if (named[most] > 0)
    most_to_fix = std::string(metric::part_name(most)) + " (part_to_fix on " + std::to_string(named[most]) + " of " +
                  std::to_string(scored) + " scored frames)";
  std::string parts;
  for (int q = 0; q < metric::kParts; ++q)
    parts += std::string(q ? ", " : "") + metric::part_name(q) + " " +
             std::to_string(static_cast<int>(std::lround(part_score_sum[q] / scored)));
  std::printf("%s vs %s: %d frames (%d scored, %d after the teacher clip ended) against %s, mean score %.1f (%s), "
              "most to fix: %s -> %s\n",
              a.student.c_str(), a.teacher.c_str(), student_frames, scored, finished,
              a.teacher_frame >= 0 ? ("teacher frame " + std::to_string(a.teacher_frame)).c_str()
              : dtw.empty()        ? "the teacher clip (aligned online)"
                                   : "the teacher clip (aligned by DTW)",
              mean, parts.c_str(), most_to_fix.c_str(), a.out.c_str());
}

void setup(CLI::App& app) {
  auto args = std::make_shared<ScoreArgs>();
  CLI::App* cmd = app.add_subcommand(
      "score", "score each student frame against a teacher pose or clip: CSV of frame, time (s), distance, score "
               "(0-100), the five parts of distance^2, matched teacher frame, the five part distances and part "
               "scores (0-100), the part to fix and the feedback state");
  cmd->add_option("--model", args->model,
                  ".kata model: models/default.kata for coaching (calibrated scores); the transition models only "
                  "rank transition candidates: models/transition.kata within one subject's takes or one kind of "
                  "motion (leave one subject out, the independent protocol: 0.815 vs JCD 0.764), "
                  "models/transition-static.kata between clips of different motions (0.836 vs JCD 0.620); " +
                      kata::cli::doc_file("model/transition.md"))
      ->required()
      ->transform(kata::cli::default_data_file)->check(CLI::ExistingFile);
  cmd->add_option("--teacher", args->teacher, "teacher motion: .bvh, or a landmark .npy/.csv (see kata features)")
      ->required()
      ->transform(kata::cli::default_data_file)->check(CLI::ExistingFile);
  cmd->add_option("--teacher-frame", args->teacher_frame,
                  "score against this single teacher frame (clip frame index) instead of following the whole clip; "
                  "-1 (default): the whole clip")
      ->check(CLI::Range(-1, std::numeric_limits<int>::max()));
  cmd->add_option("--student", args->student, "student motion: .bvh, or a landmark .npy/.csv (see kata features)")
      ->required()
      ->transform(kata::cli::default_data_file)->check(CLI::ExistingFile);
  auto* preset = cmd->add_option("--layout,--preset", args->preset,
                                 "layout of both inputs (cmu, mediapipe, gpd, ...; --preset is the old name)");
  cmd->add_option("--teacher-layout", args->teacher_layout, "layout of the teacher (overrides --layout)");
  cmd->add_option("--student-layout", args->student_layout, "layout of the student (overrides --layout)");
  cmd->add_option("--fps", args->fps, "frame rate of landmark arrays (.npy/.csv) without timestamps")->check(CLI::PositiveNumber);
  cmd->add_option("--time-units", args->time_units,
                  "units of landmark arrays' timestamps (a .csv's first column, X.times.npy beside X.npy): s, ms or "
                  "auto (default: from the steps between frames; refused when they fit neither)")
      ->check(CLI::IsMember({"s", "ms", "auto"}));
  cmd->add_option("--up", args->up, "axes of landmark arrays whose layout does not fix them: y, z, y-down")
      ->check(CLI::IsMember({"y", "z", "y-down"}));
  cmd->add_option("--name-map", args->name_map, "name-map file for both clips instead of a preset")
      ->excludes(preset)
      ->transform(kata::cli::default_data_file)->check(CLI::ExistingFile);
  cmd->add_option("--first-frame", args->first, "first frame of each clip (1 skips the CMU converter's T-pose); default 0");
  cmd->add_option("--window", args->window, "alignment window ahead of the last match, teacher seconds (default 0.5)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--align", args->align,
                  "online (default): the live re-localising alignment; dtw: the offline reference, a subsequence "
                  "DTW of the whole student clip over the same projections, scored by the same scorer")
      ->check(CLI::IsMember({"online", "dtw"}));
  cmd->add_option("--teacher-start", args->teacher_start,
                  "practice: the lesson starts at this teacher clip frame (the teacher before it is not used)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--relocate-time", args->relocate_time,
                  "online alignment: re-localisation margin, seconds (default 0.2); 0: follow the band only, never "
                  "move elsewhere")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--rematch-time", args->rematch_time,
                  "online alignment: score each frame against the teacher frame within this many seconds of the "
                  "alignment's match where every part but the worst agrees best (default 0.05; 0.1 for a student "
                  "read through a smoothing layout, e.g. mediapipe); 0: the match itself")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--tolerance", args->tolerance,
                  "how far a part may be off before its score falls: strict (a 30-degree error scores <= 50), normal "
                  "(default: a 45-degree error does), lenient (for beginners), or the angle in degrees (5..120) at "
                  "which a part scores 50 (" + kata::cli::doc_file("model/tolerance.md") + ")");
  cmd->add_option("--loop", args->loop, "practice: loop teacher clip frames A..B (two numbers: A B)")->expected(2);
  cmd->add_option("--reps", args->reps,
                  "also count repetitions: the teacher clip (or --rep-section) is one repetition, looped; one CSV "
                  "row per repetition: rep, start_time, end_time, tempo, score, part_to_fix, cue, partial, then "
                  "range_<joint> and range_<joint>_teacher (degrees) per joint (" + kata::cli::doc_file("coach/repetitions.md") + ")");
  cmd->add_option("--rep-section", args->rep_section,
                  "with --reps: the repetition is the teacher's seconds A to B (clip time, frame k at k x the frame "
                  "time; B is where the next repetition would start)")
      ->expected(2);
  cmd->add_option("--out", args->out, "output CSV")->required();
  cmd->callback([args] { run_score(*args); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
