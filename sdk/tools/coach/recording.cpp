#include "coach/recording.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "io/npz.hpp"

namespace kata::coach {
namespace {

// The array `name` of a recording as T with the given shape (0: any length). Throws naming the
// file, the array and what it holds.
template <class T>
std::vector<T> take(const std::map<std::string, NpyArray>& arrays, const std::string& path, const std::string& name,
                    std::vector<size_t> shape) {
  const auto it = arrays.find(name);
  if (it == arrays.end()) fail(path + ": no array '" + name + "'");
  const NpyArray& a = it->second;
  for (size_t k = 0; k < shape.size(); ++k)
    if (shape[k] == 0 && k < a.shape.size()) shape[k] = a.shape[k];  // 0: any length
  if (a.shape != shape)
    fail(path + ": array '" + name + "' has shape " + npy_shape_text(a.shape) + ", expected " +
                                       npy_shape_text(shape));
  return npy_values<T>(a, path + ": array '" + name + "'");
}

// A repetition's row in the array 'repetitions' (recording.hpp).
constexpr size_t kRepetitionColumns = 11 + 2 * KATA_ROM_JOINT_COUNT;

void repetition_row(const kata_repetition& r, double* row) {
  const double head[11] = {static_cast<double>(r.index), static_cast<double>(r.partial), r.start_time, r.end_time,
                           r.tempo, r.score, static_cast<double>(r.part_to_fix), static_cast<double>(r.cue_joint),
                           static_cast<double>(r.cue_action), r.cue_degrees, r.coverage};
  std::copy(head, head + 11, row);
  std::copy(r.range, r.range + KATA_ROM_JOINT_COUNT, row + 11);
  std::copy(r.teacher_range, r.teacher_range + KATA_ROM_JOINT_COUNT, row + 11 + KATA_ROM_JOINT_COUNT);
}

// The row back, checked (finite, the integers in range); false for a row that is not a repetition.
bool repetition_of_row(const double* row, kata_repetition* out) {
  for (size_t k = 0; k < kRepetitionColumns; ++k)
    if (!std::isfinite(row[k])) return false;
  const auto integer = [&](size_t k, double lo, double hi) { return row[k] == std::floor(row[k]) && row[k] >= lo && row[k] <= hi; };
  if (!integer(0, 0, 1e9) || !integer(1, 0, 1) || !integer(6, -1, KATA_PART_COUNT - 1) ||
      !integer(7, -1, KATA_GPD_JOINTS - 1) || !integer(8, -1, 4) || !(row[3] >= row[2]) || !(row[4] >= 0.0))
    return false;
  kata_repetition r{};
  r.struct_size = sizeof r;
  r.index = static_cast<int32_t>(row[0]);
  r.partial = static_cast<int32_t>(row[1]);
  r.start_time = row[2], r.end_time = row[3], r.tempo = row[4];
  r.score = static_cast<float>(row[5]);
  r.part_to_fix = static_cast<int32_t>(row[6]);
  r.cue_joint = static_cast<int32_t>(row[7]);
  r.cue_action = static_cast<int32_t>(row[8]);
  r.cue_degrees = static_cast<float>(row[9]);
  r.coverage = static_cast<float>(row[10]);
  for (int j = 0; j < KATA_ROM_JOINT_COUNT; ++j) {
    r.range[j] = static_cast<float>(row[11 + j]);
    r.teacher_range[j] = static_cast<float>(row[11 + KATA_ROM_JOINT_COUNT + j]);
  }
  *out = r;
  return true;
}

// Every array of a recording, in the order of the file (the list in recording.hpp).
NpzArrays recording_arrays(const LessonData& d) {
  const size_t F = static_cast<size_t>(d.pushed), J = static_cast<size_t>(d.joints), G = static_cast<size_t>(d.ghost_joints);
  const size_t K = static_cast<size_t>(KATA_PART_COUNT);
  std::vector<double> time(F);
  std::vector<uint8_t> state(F), has_ghost(F);
  std::vector<float> score(F), distance(F), parts(F * K), part_scores(F * K);
  std::vector<int32_t> fix(F), matched(F);
  std::vector<int64_t> latency(F);
  std::vector<double> matched_time(F);
  std::vector<int32_t> cue_joint(F), cue_action(F);
  std::vector<float> cue_degrees(F);
  std::vector<int32_t> repetition(F);
  std::vector<float> repetition_progress(F);
  for (size_t i = 0; i < F; ++i) {
    const FrameRecord& r = d.frames[i];
    repetition[i] = r.repetition, repetition_progress[i] = r.repetition_progress;
    cue_joint[i] = r.cue_joint, cue_degrees[i] = r.cue_degrees, cue_action[i] = r.cue_action;
    matched_time[i] = r.matched_time;
    time[i] = r.time, state[i] = static_cast<uint8_t>(r.state), has_ghost[i] = r.has_ghost;
    score[i] = r.score, distance[i] = r.distance, fix[i] = r.part_to_fix, matched[i] = r.matched;
    latency[i] = r.latency_ns;
    std::copy(r.parts, r.parts + K, parts.begin() + static_cast<ptrdiff_t>(i * K));
    std::copy(r.part_scores, r.part_scores + K, part_scores.begin() + static_cast<ptrdiff_t>(i * K));
  }
  const std::vector<int32_t> parents(d.joint_parents.begin(), d.joint_parents.end());
  const std::vector<int32_t> joint_part(d.joint_part.begin(), d.joint_part.end());
  const std::vector<int32_t> sources(d.ghost_sources.begin(), d.ghost_sources.end());
  const int32_t hips[2] = {d.left_hip, d.right_hip};
  const double numbers[9] = {d.frame_time, d.delta_star, d.settings.speed, d.settings.window,
                             static_cast<double>(d.settings.first_frame), static_cast<double>(d.teacher_frames),
                             static_cast<double>(d.student_frames), d.d50, d.good_score};
  std::string text = d.settings.model + "\n" + d.settings.teacher + "\n" + d.settings.student + "\n" + d.settings.preset + "\n";
  for (const std::string& n : d.joint_names) text += n + "\n";
  const int32_t practice[3] = {d.settings.teacher_start, d.settings.loop_first, d.settings.loop_last};
  const size_t R = d.repetitions.size();
  std::vector<double> repetitions(R * kRepetitionColumns);
  for (size_t i = 0; i < R; ++i) repetition_row(d.repetitions[i], repetitions.data() + i * kRepetitionColumns);
  return {
      {"positions", npy_array({F, J, 3}, d.positions.data())},
      {"time", npy_array({F}, time.data())},
      {"state", npy_array({F}, state.data())},
      {"score", npy_array({F}, score.data())},
      {"distance", npy_array({F}, distance.data())},
      {"parts", npy_array({F, K}, parts.data())},
      {"part_scores", npy_array({F, K}, part_scores.data())},
      {"part_to_fix", npy_array({F}, fix.data())},
      {"matched", npy_array({F}, matched.data())},
      {"latency_ns", npy_array({F}, latency.data())},
      {"ghosts", npy_array({F, G, 3}, d.ghosts.data())},
      {"has_ghost", npy_array({F}, has_ghost.data())},
      {"joint_parents", npy_array({J}, parents.data())},
      {"joint_part", npy_array({J}, joint_part.data())},
      {"ghost_sources", npy_array({G}, sources.data())},
      {"hips", npy_array({2}, hips)},
      {"numbers", npy_array({9}, numbers)},
      {"text", npy_array({text.size()}, reinterpret_cast<const uint8_t*>(text.data()))},
      // Added with the practice modes; a recording without them reads as before.
      {"matched_time", npy_array({F}, matched_time.data())},
      {"practice", npy_array({3}, practice)},
      // Added with the correction cue; optional on read.
      {"cue_joint", npy_array({F}, cue_joint.data())},
      {"cue_degrees", npy_array({F}, cue_degrees.data())},
      {"cue_action", npy_array({F}, cue_action.data())},
      // Added with repetitions; optional on read.
      {"repetition", npy_array({F}, repetition.data())},
      {"repetition_progress", npy_array({F}, repetition_progress.data())},
      {"repetitions", npy_array({R, kRepetitionColumns}, repetitions.data())},
  };
}

}  // namespace

void write_recording(const LessonData& d, const std::string& path) { write_npz(path, recording_arrays(d)); }

LessonData read_recording(const std::string& path) {
  const auto arrays = read_npz(path);
  LessonData d;
  const std::vector<double> numbers = take<double>(arrays, path, "numbers", {9});
  d.frame_time = numbers[0], d.delta_star = numbers[1], d.settings.speed = numbers[2], d.settings.window = numbers[3];
  d.d50 = numbers[7], d.good_score = numbers[8];
  for (double v : numbers)
    if (!std::isfinite(v)) fail(path + ": array 'numbers' holds a non-finite value");
  if (!(d.frame_time > 0.0)) fail(path + ": frame_time (numbers[0]) must be > 0");
  d.settings.first_frame = static_cast<int>(numbers[4]), d.teacher_frames = static_cast<int>(numbers[5]);
  const std::vector<int32_t> parents = take<int32_t>(arrays, path, "joint_parents", {0});
  const std::vector<int32_t> sources = take<int32_t>(arrays, path, "ghost_sources", {0});
  const size_t J = parents.size(), G = sources.size();
  const std::vector<double> time = take<double>(arrays, path, "time", {0});
  const size_t F = time.size();
  d.joints = static_cast<int>(J), d.ghost_joints = static_cast<int>(G);
  d.pushed = d.student_frames = static_cast<int>(F);
  d.joint_parents.assign(parents.begin(), parents.end());
  d.ghost_sources.assign(sources.begin(), sources.end());
  const std::vector<int32_t> joint_part = take<int32_t>(arrays, path, "joint_part", {J});
  d.joint_part.assign(joint_part.begin(), joint_part.end());
  const std::vector<int32_t> hips = take<int32_t>(arrays, path, "hips", {2});
  d.left_hip = hips[0], d.right_hip = hips[1];
  for (size_t j = 0; j < J; ++j)
    if (parents[j] >= static_cast<int32_t>(j) || (j > 0 && parents[j] < 0) || joint_part[j] < 0 || joint_part[j] >= KATA_PART_COUNT)
      fail(path + ": joint_parents / joint_part is not a skeleton");
  for (int32_t s : sources)
    if (s < 0 || static_cast<size_t>(s) >= J) fail(path + ": ghost_sources out of range");
  if (d.left_hip >= static_cast<int>(J) || d.right_hip >= static_cast<int>(J)) fail(path + ": hips out of range");
  d.positions = take<float>(arrays, path, "positions", {F, J, 3});
  d.ghosts = take<float>(arrays, path, "ghosts", {F, G, 3});
  const auto state = take<uint8_t>(arrays, path, "state", {F});
  const auto has_ghost = take<uint8_t>(arrays, path, "has_ghost", {F});
  const auto score = take<float>(arrays, path, "score", {F});
  const auto distance = take<float>(arrays, path, "distance", {F});
  const auto parts = take<float>(arrays, path, "parts", {F, static_cast<size_t>(KATA_PART_COUNT)});
  const auto part_scores = take<float>(arrays, path, "part_scores", {F, static_cast<size_t>(KATA_PART_COUNT)});
  const auto fix = take<int32_t>(arrays, path, "part_to_fix", {F});
  const auto matched = take<int32_t>(arrays, path, "matched", {F});
  const auto latency = take<int64_t>(arrays, path, "latency_ns", {F});
  // Optional (recordings from before the practice modes have neither): where the student was in the routine,
  // and the practice section (teacher_start, loop_first, loop_last; -1: unset).
  const auto matched_time =
      arrays.count("matched_time") ? take<double>(arrays, path, "matched_time", {F}) : std::vector<double>(F, -1.0);
  const bool has_cue = arrays.count("cue_joint") != 0;
  const auto cue_joint = has_cue ? take<int32_t>(arrays, path, "cue_joint", {F}) : std::vector<int32_t>(F, -1);
  const auto cue_degrees = has_cue ? take<float>(arrays, path, "cue_degrees", {F}) : std::vector<float>(F, 0.0f);
  const auto cue_action = has_cue ? take<int32_t>(arrays, path, "cue_action", {F}) : std::vector<int32_t>(F, -1);
  const bool has_reps = arrays.count("repetition") != 0;
  const auto repetition = has_reps ? take<int32_t>(arrays, path, "repetition", {F}) : std::vector<int32_t>(F, 0);
  const auto repetition_progress =
      has_reps ? take<float>(arrays, path, "repetition_progress", {F}) : std::vector<float>(F, 0.0f);
  if (arrays.count("repetitions")) {
    const auto rows = take<double>(arrays, path, "repetitions", {0, kRepetitionColumns});
    d.repetitions.resize(rows.size() / kRepetitionColumns);
    for (size_t i = 0; i < d.repetitions.size(); ++i)
      if (!repetition_of_row(rows.data() + i * kRepetitionColumns, &d.repetitions[i]))
        fail(path + ": repetitions row " + std::to_string(i) + " is not a repetition (a non-finite value, or an index, "
                    "part, joint or action out of range)");
  }
  if (arrays.count("practice")) {
    const auto practice = take<int32_t>(arrays, path, "practice", {3});
    d.settings.teacher_start = practice[0], d.settings.loop_first = practice[1], d.settings.loop_last = practice[2];
  }
  const auto text_bytes = take<uint8_t>(arrays, path, "text", {0});
  std::vector<std::string> lines;
  std::string line;
  for (uint8_t c : text_bytes) {
    if (c == '\n') lines.push_back(line), line.clear();
    else line += static_cast<char>(c);
  }
  if (lines.size() != 4 + J) fail(path + ": 'text' does not hold 4 settings and the joint names");
  d.settings.model = lines[0], d.settings.teacher = lines[1], d.settings.student = lines[2], d.settings.preset = lines[3];
  d.joint_names.assign(lines.begin() + 4, lines.end());
  d.frames.resize(F);
  for (size_t i = 0; i < F; ++i) {
    FrameRecord& r = d.frames[i];
    if (state[i] > 3 || fix[i] < -1 || fix[i] >= KATA_PART_COUNT)
      fail(path + ": frame " + std::to_string(i) + ": state or part_to_fix out of range");
    r.frame = static_cast<int64_t>(i), r.time = time[i], r.state = static_cast<FrameState>(state[i]);
    r.score = score[i], r.distance = distance[i], r.part_to_fix = fix[i], r.matched = matched[i];
    r.latency_ns = latency[i], r.has_ghost = has_ghost[i] != 0 && G > 0;
    if (!std::isfinite(matched_time[i])) fail(path + ": frame " + std::to_string(i) + ": matched_time is not finite");
    r.matched_time = matched_time[i];
    if (cue_joint[i] < -1 || cue_joint[i] >= KATA_GPD_JOINTS || cue_action[i] < -1 || cue_action[i] > 4 ||
        !(cue_degrees[i] >= 0.0f && cue_degrees[i] <= 180.0f))
      fail(path + ": frame " + std::to_string(i) + ": the cue is out of range");
    r.cue_joint = cue_joint[i], r.cue_degrees = cue_degrees[i], r.cue_action = cue_action[i];
    if (repetition[i] < 0 || !(repetition_progress[i] >= 0.0f && repetition_progress[i] <= 1.0f))
      fail(path + ": frame " + std::to_string(i) + ": the repetition is out of range");
    r.repetition = repetition[i], r.repetition_progress = repetition_progress[i];
    std::copy(parts.begin() + static_cast<ptrdiff_t>(i * KATA_PART_COUNT),
              parts.begin() + static_cast<ptrdiff_t>((i + 1) * KATA_PART_COUNT), r.parts);
    std::copy(part_scores.begin() + static_cast<ptrdiff_t>(i * KATA_PART_COUNT),
              part_scores.begin() + static_cast<ptrdiff_t>((i + 1) * KATA_PART_COUNT), r.part_scores);
  }
  return d;
}

void write_results_csv(const LessonData& d, const std::string& path) {
  std::FILE* out = std::fopen(path.c_str(), "w");
  if (!out) fail(path + ": cannot open for writing");
  std::fprintf(out, "frame,time,state,score,distance");
  for (int p = 0; p < KATA_PART_COUNT; ++p) std::fprintf(out, ",%s", part_name(p));
  for (int p = 0; p < KATA_PART_COUNT; ++p) std::fprintf(out, ",%s_score", part_name(p));
  std::fprintf(out, ",part_to_fix,matched_teacher_frame,matched_teacher_time,cue_joint,cue_degrees,cue,repetition,"
                   "repetition_progress\n");
  for (size_t i = 0; i < static_cast<size_t>(d.pushed); ++i) {
    const FrameRecord& r = d.frames[i];
    std::fprintf(out, "%lld,%.6f,%d,%.9g,%.9g", static_cast<long long>(r.frame), r.time, static_cast<int>(r.state), r.score,
                 r.distance);
    for (float p : r.parts) std::fprintf(out, ",%.9g", p);
    for (float p : r.part_scores) std::fprintf(out, ",%.9g", p);
    std::fprintf(out, ",%d,%d,%.6f", r.part_to_fix, r.matched, r.matched_time);
    if (r.cue_joint >= 0 && r.cue_joint < KATA_GPD_JOINTS) {
      char cue[64];
      std::fprintf(out, ",%s,%.2f,%s", kata_gpd_joint_name(r.cue_joint), r.cue_degrees, cue_phrase(r, cue, sizeof cue));
    } else {
      std::fputs(",,,", out);
    }
    std::fprintf(out, ",%d,%.4f\n", r.repetition, r.repetition_progress);
  }
  const bool ok = std::fflush(out) == 0 && !std::ferror(out);
  std::fclose(out);
  if (!ok) fail(path + ": write failed");
}

}  // namespace kata::coach
