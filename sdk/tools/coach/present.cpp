// The viewer's events are JSON written here by hand (frame_json runs for every frame the viewer
// gets); the report is data handed to a Mustache template (coach/report.html.mustache), its
// figures computed here, its charts drawn by uPlot in the reader's browser.
#include "coach/present.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include <kainjow/mustache.hpp>
#include <nlohmann/json.hpp>

#include "coach/report_assets.hpp"
#include "coach/reps_view.hpp"

namespace kata::coach {
namespace {

namespace mustache = kainjow::mustache;

// Colours of the five parts (lines of the per-part chart) and of the two figures.
const char* const kPartColour[KATA_PART_COUNT] = {"#6c5ce7", "#0984e3", "#00b894", "#e17055", "#d63031"};
const char* const kPartLabel[KATA_PART_COUNT] = {"torso and head", "left arm", "right arm", "left leg", "right leg"};
const char* const kGhostColour = "#f39c12";

void append(std::string& out, const char* fmt, double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, fmt, v);
  out += buf;
}

void append_floats(std::string& out, const float* v, size_t n) {
  out += '[';
  for (size_t k = 0; k < n; ++k) {
    if (k) out += ',';
    append(out, "%.2f", std::isfinite(v[k]) ? v[k] : 0.0);
  }
  out += ']';
}

template <class T>
void append_ints(std::string& out, const std::vector<T>& v) {
  out += '[';
  for (size_t k = 0; k < v.size(); ++k) {
    if (k) out += ',';
    out += std::to_string(v[k]);
  }
  out += ']';
}

// The correction cue's phrase of a frame ("left knee: bend 30 deg more"; "" for none).
std::string cue_phrase(const FrameRecord& r) {
  char cue[64];
  return coach::cue_phrase(r, cue, sizeof cue);
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    out += c;
  }
  return out + "\"";
}

// The file name of a path (reports carry no absolute paths of this machine).
std::string base_name(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

// Ghost joint -> parent ghost joint (the ghost joint of the nearest student ancestor), -1 at the root.
std::vector<int> ghost_parents(const LessonData& d) {
  std::vector<int> ghost_of(static_cast<size_t>(d.joints), -1);
  for (size_t k = 0; k < d.ghost_sources.size(); ++k) ghost_of[static_cast<size_t>(d.ghost_sources[k])] = static_cast<int>(k);
  std::vector<int> parents(d.ghost_sources.size(), -1);
  for (size_t k = 0; k < d.ghost_sources.size(); ++k) {
    int j = d.joint_parents[static_cast<size_t>(d.ghost_sources[k])];
    while (j >= 0 && ghost_of[static_cast<size_t>(j)] < 0) j = d.joint_parents[static_cast<size_t>(j)];
    parents[k] = j >= 0 ? ghost_of[static_cast<size_t>(j)] : -1;
  }
  return parents;
}

// Red (0) -> amber (50) -> green (100).
std::string score_colour(double score) {
  const double s = std::clamp(score, 0.0, 100.0) / 100.0;
  const int r = static_cast<int>(s < 0.5 ? 220 : 220 - (s - 0.5) * 2 * 180);
  const int g = static_cast<int>(s < 0.5 ? 60 + s * 2 * 140 : 200);
  char buf[16];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", std::clamp(r, 0, 255), std::clamp(g, 0, 255), 60);
  return buf;
}

// A front view of one posture: the horizontal axis is the body's left-right (hips), so a turning
// dancer is always drawn facing the reader.
struct View {
  double ax = 1, az = 0;  // unit left-right direction in the ground plane
  double cx = 0, cy = 0;  // centre (root) in world units
};

View view_of(const LessonData& d, const float* joints) {
  View v;
  if (d.left_hip >= 0 && d.right_hip >= 0) {
    const double x = joints[3 * d.left_hip] - joints[3 * d.right_hip];
    const double z = joints[3 * d.left_hip + 2] - joints[3 * d.right_hip + 2];
    const double n = std::hypot(x, z);
    if (n > 1e-9) v.ax = x / n, v.az = z / n;
  }
  v.cx = joints[0] * v.ax + joints[2] * v.az;
  v.cy = joints[1];
  return v;
}

std::string fixed(const char* fmt, double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

// A skeleton (joints x 3, parents) as the bones of an SVG drawing: x0, y0 = where the root goes,
// scale = pixels per unit; colour per bone from `bone_colour(child joint)`.
template <class BoneColour>
void add_bones(mustache::list& bones, const float* joints, const std::vector<int>& parents, const View& v, double x0,
               double y0, double scale, BoneColour bone_colour) {
  auto px = [&](int j) { return fixed("%.1f", x0 - ((joints[3 * j] * v.ax + joints[3 * j + 2] * v.az) - v.cx) * scale); };
  auto py = [&](int j) { return fixed("%.1f", y0 - (joints[3 * j + 1] - v.cy) * scale); };
  for (size_t j = 1; j < parents.size(); ++j) {
    const int p = parents[j];
    if (p < 0) continue;
    const int c = static_cast<int>(j);
    bones.push_back(mustache::object{
        {"x1", px(p)}, {"y1", py(p)}, {"x2", px(c)}, {"y2", py(c)}, {"colour", bone_colour(c)}});
  }
}

// A chart's line: its values over time (NaN = gap).
struct Series {
  std::string colour, label;
  std::vector<double> values;
};

// A chart series' values as JSON: NaN (no score) -> null, a gap in the line.
nlohmann::json chart_values(const std::vector<double>& values) {
  nlohmann::json out = nlohmann::json::array();
  for (double v : values) out.push_back(std::isfinite(v) ? nlohmann::json(std::round(v * 100.0) / 100.0) : nlohmann::json());
  return out;
}

}  // namespace

std::string setup_json(const LessonData& d, const std::string& source, const std::string& lesson_id) {
  std::string s = "{\"source\":" + json_string(source) + ",\"lesson\":" + json_string(lesson_id) + ",\"parts\":[";
  for (int p = 0; p < KATA_PART_COUNT; ++p) s += std::string(p ? "," : "") + json_string(part_name(p));
  s += "],\"part_labels\":[";
  for (int p = 0; p < KATA_PART_COUNT; ++p) s += std::string(p ? "," : "") + json_string(kPartLabel[p]);
  s += "],\"joints\":" + std::to_string(d.joints) + ",\"parents\":";
  append_ints(s, d.joint_parents);
  s += ",\"joint_part\":";
  append_ints(s, d.joint_part);
  s += ",\"ghost_parents\":";
  append_ints(s, ghost_parents(d));
  s += ",\"ghost_sources\":";
  append_ints(s, d.ghost_sources);
  s += ",\"frames\":" + std::to_string(d.student_frames) + ",\"teacher_frames\":" + std::to_string(d.teacher_frames) +
       ",\"frame_time\":";
  append(s, "%.7g", d.frame_time);
  s += ",\"speed\":";
  append(s, "%.4g", d.settings.speed);
  s += ",\"good_score\":";
  append(s, "%.4g", d.good_score);
  s += ",\"teacher\":" + json_string(base_name(d.settings.teacher)) + ",\"student\":" +
       json_string(base_name(d.settings.student)) + ",\"model\":" + json_string(base_name(d.settings.model)) + "}";
  return s;
}

std::string frame_json(const LessonData& d, size_t i) {
  const FrameRecord& r = d.frames[i];
  std::string s;
  s.reserve(2048);
  s += "{\"i\":" + std::to_string(i) + ",\"t\":";
  append(s, "%.4f", r.time);
  s += ",\"state\":" + json_string(state_name(r.state));
  if (scored(r)) {
    s += ",\"score\":";
    append(s, "%.2f", r.score);
    s += ",\"part_scores\":";
    append_floats(s, r.part_scores, KATA_PART_COUNT);
    s += ",\"shares\":[";
    for (int p = 0; p < KATA_PART_COUNT; ++p) {
      if (p) s += ',';
      append(s, "%.3f", part_share(r, p));
    }
    s += "],\"fix\":" + std::to_string(r.part_to_fix) + ",\"matched\":" + std::to_string(r.matched);
    // The correction cue: the GPD joint (-1: none) and the phrase ("" for none).
    char cue[64];
    s += ",\"cue_joint\":" + std::to_string(r.cue_joint) + ",\"cue\":" + json_string(coach::cue_phrase(r, cue, sizeof cue));
    if (r.matched_time >= 0.0) append(s, ",\"matched_time\":%.3f", r.matched_time);
    // The repetition in progress and the progress through it (docs/coach/repetitions.md).
    if (r.repetition > 0) s += ",\"rep\":" + std::to_string(r.repetition), append(s, ",\"rep_progress\":%.3f", r.repetition_progress);
    s += ",\"latency_us\":";
    append(s, "%.1f", r.latency_ns / 1e3);
  }
  s += ",\"joints\":";
  append_floats(s, d.frame_positions(i), 3 * static_cast<size_t>(d.joints));
  if (r.has_ghost) {
    s += ",\"ghost\":";
    append_floats(s, d.frame_ghost(i), 3 * static_cast<size_t>(d.ghost_joints));
  }
  return s + "}";
}

std::string end_json(const LessonData& d) {
  std::string s = "{\"mean_score\":";
  append(s, "%.2f", d.mean_score());
  return s + ",\"frames\":" + std::to_string(d.pushed) + "}";
}

std::vector<size_t> lowest_moments(const LessonData& d, size_t count) {
  std::vector<size_t> order;
  for (size_t i = 0; i < static_cast<size_t>(d.pushed) && i < d.frames.size(); ++i)
    if (scored(d.frames[i])) order.push_back(i);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return d.frames[a].score < d.frames[b].score; });
  std::vector<size_t> picked;
  const double apart = 0.5;
  for (size_t i : order) {
    if (picked.size() == count) break;
    bool near = false;
    for (size_t p : picked) near = near || std::fabs(d.frames[p].time - d.frames[i].time) < apart;
    if (!near) picked.push_back(i);
  }
  return picked;
}

void write_report(const LessonData& d, const std::string& path) {
  std::vector<double> time;
  Series total{"#2d3436", "total", {}};
  std::vector<Series> parts;
  for (int p = 0; p < KATA_PART_COUNT; ++p) parts.push_back({kPartColour[p], kPartLabel[p], {}});
  double part_sum[KATA_PART_COUNT] = {};
  int fix_count[KATA_PART_COUNT] = {};
  int scored_frames = 0, lost = 0, finished = 0, calibrating = 0, named = 0;
  std::vector<double> latencies;
  for (size_t i = 0; i < static_cast<size_t>(d.pushed); ++i) {
    const FrameRecord& r = d.frames[i];
    time.push_back(r.time);
    const bool ok = scored(r);
    total.values.push_back(ok ? r.score : NAN);
    for (int p = 0; p < KATA_PART_COUNT; ++p) {
      parts[static_cast<size_t>(p)].values.push_back(ok ? r.part_scores[p] : NAN);
      if (ok) part_sum[p] += r.part_scores[p];
    }
    if (ok) {
      ++scored_frames;
      if (r.part_to_fix >= 0) ++fix_count[r.part_to_fix], ++named;
      latencies.push_back(r.latency_ns / 1e6);
    }
    lost += r.state == FrameState::kTrackingLost;
    finished += r.state == FrameState::kTeacherFinished;
    calibrating += r.state == FrameState::kCalibrating;
  }
  double part_mean[KATA_PART_COUNT] = {};
  for (int p = 0; p < KATA_PART_COUNT; ++p) part_mean[p] = scored_frames ? part_sum[p] / scored_frames : 0.0;
  const std::vector<size_t> lows = lowest_moments(d);
  const double mean = d.mean_score();
  int most_fixed = 0, weakest = 0;
  for (int p = 1; p < KATA_PART_COUNT; ++p) {
    if (fix_count[p] > fix_count[most_fixed]) most_fixed = p;
    if (part_mean[p] < part_mean[weakest]) weakest = p;
  }
  std::sort(latencies.begin(), latencies.end());
  auto pct = [&](double q) { return latencies.empty() ? 0.0 : latencies[static_cast<size_t>(q * (latencies.size() - 1))]; };

  mustache::data page;
  page.set("student", base_name(d.settings.student));
  page.set("teacher", base_name(d.settings.teacher));
  page.set("frames", std::to_string(d.pushed));
  page.set("seconds", fixed("%.1f", d.pushed * d.frame_time));
  page.set("mean", fixed("%.0f", mean));
  page.set("mean_colour", score_colour(mean));
  page.set("good_score", fixed("%.0f", d.good_score));
  page.set("scored", scored_frames > 0);
  page.set("weakest_part", kPartLabel[weakest]);
  page.set("weakest_mean", fixed("%.0f", part_mean[weakest]));
  page.set("named", named > 0);
  page.set("most_fixed_part", kPartLabel[most_fixed]);
  page.set("most_fixed_percent", std::to_string(scored_frames ? 100 * fix_count[most_fixed] / scored_frames : 0));
  page.set("ghost_colour", kGhostColour);

  mustache::list part_rows;
  for (int p = 0; p < KATA_PART_COUNT; ++p) {
    part_rows.push_back(mustache::object{
        {"label", kPartLabel[p]},
        {"colour", kPartColour[p]},
        {"mean", fixed("%.0f", part_mean[p])},
        {"mean_colour", score_colour(part_mean[p])},
        {"fix_percent", fixed("%.0f", scored_frames ? 100.0 * fix_count[p] / scored_frames : 0.0)}});
  }
  page.set("parts", part_rows);

  // Body diagram: each bone coloured by its part's mean score (red 0 -> amber 50 -> green 100).
  mustache::list body;
  if (d.pushed > 0) {
    const float* pose = d.frame_positions(0);
    const View v = view_of(d, pose);
    double lo = 1e30, hi = -1e30;
    for (int j = 0; j < d.joints; ++j) lo = std::min(lo, double(pose[3 * j + 1])), hi = std::max(hi, double(pose[3 * j + 1]));
    const double scale = 300.0 / std::max(hi - lo, 1e-6);
    add_bones(body, pose, d.joint_parents, v, 130, 330 - (pose[1] - lo) * scale, scale,
              [&](int j) { return score_colour(part_mean[d.joint_part[static_cast<size_t>(j)]]); });
  }
  page.set("has_body", d.pushed > 0);
  page.set("bones", body);

  // The three lowest moments: student and ghost (the teacher's pose on your body) side by side.
  mustache::list moments;
  const std::vector<int> gp = ghost_parents(d);
  for (size_t m = 0; m < lows.size(); ++m) {
    const size_t i = lows[m];
    const FrameRecord& r = d.frames[i];
    const float* pose = d.frame_positions(i);
    const View v = view_of(d, pose);
    double lo = 1e30, hi = -1e30;
    for (int j = 0; j < d.joints; ++j) lo = std::min(lo, double(pose[3 * j + 1])), hi = std::max(hi, double(pose[3 * j + 1]));
    const double scale = 200.0 / std::max(hi - lo + 6.0, 1e-6);
    const double root_y = 230 - (pose[1] - lo) * scale;
    // You: each bone in its part's score at that moment; the ghost in one colour.
    mustache::list bones;
    add_bones(bones, pose, d.joint_parents, v, 70, root_y, scale,
              [&](int j) { return score_colour(r.part_scores[d.joint_part[static_cast<size_t>(j)]]); });
    if (r.has_ghost) add_bones(bones, d.frame_ghost(i), gp, v, 190, root_y, scale, [](int) { return std::string(kGhostColour); });
    mustache::list scores;
    for (int p = 0; p < KATA_PART_COUNT; ++p)
      scores.push_back(mustache::object{
          {"label", kPartLabel[p]}, {"score", fixed("%.0f", r.part_scores[p])}, {"last", p + 1 == KATA_PART_COUNT}});
    moments.push_back(mustache::object{{"number", std::to_string(m + 1)},
                                       {"time", fixed("%.2f", r.time)},
                                       {"score", fixed("%.0f", r.score)},
                                       {"has_fix", r.part_to_fix >= 0},
                                       {"fix", r.part_to_fix >= 0 ? kPartLabel[r.part_to_fix] : ""},
                                       {"has_cue", r.cue_joint >= 0},
                                       {"cue", cue_phrase(r)},
                                       {"bones", bones},
                                       {"part_scores", scores}});
  }
  page.set("moments", moments);

  mustache::list settings;
  auto row = [&](const std::string& k, const std::string& v) { settings.push_back(mustache::object{{"key", k}, {"value", v}}); };
  row("teacher", base_name(d.settings.teacher) + " (" + std::to_string(d.teacher_frames) + " frames from frame " +
                     std::to_string(d.settings.first_frame) + ")");
  row("student", base_name(d.settings.student) + " (" + std::to_string(d.student_frames) + " frames from frame " +
                     std::to_string(d.settings.first_frame) + ")");
  row("model", base_name(d.settings.model));
  char buf[200];
  std::snprintf(buf, sizeof buf, "calibrated: distance %.4g scores 50 (model threshold %.4g); a part is named below %.0f",
                d.d50, d.delta_star, d.good_score);
  row("score map", buf);
  row("skeleton preset", d.settings.preset);
  std::snprintf(buf, sizeof buf, "%.3g x real time, both clips as live streams through the kata runtime", d.settings.speed);
  row("playback", buf);
  std::snprintf(buf, sizeof buf, "%.2f s of teacher ahead of the last match", d.settings.window);
  row("alignment window", buf);
  std::snprintf(buf, sizeof buf, "%d scored, %d calibrating, %d tracking lost, %d after the teacher finished",
                scored_frames, calibrating, lost, finished);
  row("frames", buf);
  std::snprintf(buf, sizeof buf, "p50 %.2f ms, p99 %.2f ms (frame in -> score and ghost published)", pct(0.5), pct(0.99));
  row("latency", buf);
  page.set("settings", settings);

  // The charts' data, read by the page's script: seconds, the total and each part (null: no score),
  // the lowest moments' times.
  nlohmann::json chart = {{"time", time}, {"total", chart_values(total.values)}, {"marks", nlohmann::json::array()}};
  for (size_t i : lows) chart["marks"].push_back(time[i]);
  for (const Series& s : parts)
    chart["parts"].push_back({{"label", s.label}, {"colour", s.colour}, {"values", chart_values(s.values)}});
  std::string chart_json = chart.dump();
  // Inside <script>: "</" would end the element; "<\/" is the same JSON string.
  for (size_t at = chart_json.find("</"); at != std::string::npos; at = chart_json.find("</", at + 3)) chart_json.insert(at + 1, "\\");
  page.set("chart_json", chart_json);
  page.set("has_repetitions", !d.repetitions.empty());
  page.set("repetitions_html", repetitions_report_html(d.repetitions));
  page.set("uplot_js", report_assets::kUplotJs);
  page.set("uplot_css", report_assets::kUplotCss);
  page.set("uplot_license", report_assets::kUplotLicense);
  page.set("uplot_version", report_assets::kUplotVersion);

  mustache::mustache report_template(report_assets::kReportTemplate);
  if (!report_template.is_valid())
    throw std::logic_error("report template (a bug of this build): " + report_template.error_message());
  const std::string h = report_template.render(page);
  if (!report_template.error_message().empty())
    throw std::logic_error("report template (a bug of this build): " + report_template.error_message());

  std::ofstream out(path, std::ios::binary);
  if (!out) fail(path + ": cannot open for writing");
  out << h;
  if (!out.flush()) fail(path + ": write failed");
}

}  // namespace kata::coach
