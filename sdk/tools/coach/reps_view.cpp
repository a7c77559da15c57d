#include "coach/reps_view.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "coach/lesson.hpp"

namespace kata::coach {

namespace {

constexpr const char* kRomLabel[KATA_ROM_JOINT_COUNT] = {"left knee",  "right knee",  "left hip",      "right hip",
                                                        "left elbow", "right elbow", "left shoulder", "right shoulder"};

std::string format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

// The repetition's cue phrase ("left knee: bend 30 deg more"; "" for none), as kata_cue_text says it.
std::string cue_of(const kata_repetition& r) {
  if (r.cue_joint < 0 || r.part_to_fix < 0) return "";
  FrameRecord f;
  f.part_to_fix = r.part_to_fix;
  f.cue_joint = r.cue_joint;
  f.cue_degrees = r.cue_degrees;
  f.cue_action = r.cue_action;
  char buf[64];
  return cue_phrase(f, buf, sizeof buf);
}

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else if (c == '"') out += "&quot;";
    else out += c;
  }
  return out;
}

std::string json_text(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) >= 0x20) out += c;
  }
  return out + "\"";
}

// One plot: a bar per repetition (partial ones hatched grey), and a dashed line at each
// repetition's reference (the teacher's value), 0..top up.
std::string plot(const std::vector<kata_repetition>& reps, const char* title, const char* unit,
                 double (*value)(const kata_repetition&), double (*reference)(const kata_repetition&), double top) {
  const double w = 360, h = 150, left = 38, bottom = 22, right = 8, head = 18;
  const size_t n = reps.size();
  const double slot = (w - left - right) / std::max<size_t>(n, 1);
  std::string s = "<svg class=\"repplot\" viewBox=\"0 0 360 150\" width=\"360\" height=\"150\" role=\"img\" aria-label=\"" +
                  std::string(title) + "\"><text x=\"4\" y=\"13\" class=\"t\">" + title + "</text>";
  const auto y = [&](double v) { return head + (h - head - bottom) * (1.0 - std::clamp(v / top, 0.0, 1.0)); };
  for (double tick : {0.0, top / 2, top})
    s += "<line x1=\"" + format("%.1f", left) + "\" x2=\"" + format("%.1f", w - right) + "\" y1=\"" +
         format("%.1f", y(tick)) + "\" y2=\"" + format("%.1f", y(tick)) + "\" class=\"g\"/><text x=\"2\" y=\"" +
         format("%.1f", y(tick) + 4) + "\" class=\"a\">" + format("%.3g", tick) + unit + "</text>";
  for (size_t k = 0; k < n; ++k) {
    const kata_repetition& r = reps[k];
    const double x = left + slot * k + slot * 0.15, bw = slot * 0.7, v = value(r);
    s += "<rect x=\"" + format("%.1f", x) + "\" y=\"" + format("%.1f", y(v)) + "\" width=\"" + format("%.1f", bw) +
         "\" height=\"" + format("%.1f", y(0) - y(v)) + "\" class=\"" + (r.partial ? "p" : "b") + "\"><title>rep " +
         std::to_string(r.index) + (r.partial ? " (partial)" : "") + ": " + format("%.3g", v) + unit + "</title></rect>";
    if (reference)
      s += "<line x1=\"" + format("%.1f", x - slot * 0.1) + "\" x2=\"" + format("%.1f", x + bw + slot * 0.1) + "\" y1=\"" +
           format("%.1f", y(reference(r))) + "\" y2=\"" + format("%.1f", y(reference(r))) + "\" class=\"r\"/>";
    s += "<text x=\"" + format("%.1f", x + bw / 2) + "\" y=\"" + format("%.1f", h - 6) + "\" class=\"a\" text-anchor=\"middle\">" +
         std::to_string(r.index) + (r.partial ? "*" : "") + "</text>";
  }
  return s + "</svg>";
}

}  // namespace

double repetition_depth(const kata_repetition& r, bool teacher) {
  const float* range = teacher ? r.teacher_range : r.range;
  return std::max(range[KATA_ROM_LEFT_KNEE], range[KATA_ROM_RIGHT_KNEE]);
}

std::string repetition_json(const kata_repetition& r) {
  return "{\"index\":" + std::to_string(r.index) + ",\"partial\":" + (r.partial ? "true" : "false") +
         ",\"start\":" + format("%.3f", r.start_time) + ",\"end\":" + format("%.3f", r.end_time) +
         ",\"tempo\":" + format("%.3f", r.tempo) + ",\"score\":" + format("%.1f", r.score) +
         ",\"depth\":" + format("%.1f", repetition_depth(r)) + ",\"teacher_depth\":" +
         format("%.1f", repetition_depth(r, true)) + ",\"part_to_fix\":" + std::to_string(r.part_to_fix) +
         ",\"cue\":" + json_text(cue_of(r)) + "}";
}

std::string repetitions_count_json(const std::vector<kata_repetition>& reps) {
  const auto partial = std::count_if(reps.begin(), reps.end(), [](const kata_repetition& r) { return r.partial != 0; });
  return "\"reps_done\":" + std::to_string(static_cast<long>(reps.size()) - partial) +
         ",\"reps_partial\":" + std::to_string(partial);
}

std::string repetition_words(const kata_repetition& r) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "rep %d%s: tempo %.2f, score %.0f, depth %.0f/%.0f deg", r.index,
                r.partial ? " (partial)" : "", r.tempo, r.score, repetition_depth(r), repetition_depth(r, true));
  return buf;
}

std::string repetitions_summary(const std::vector<kata_repetition>& reps) {
  int counted = 0, partial = 0, best = -1;
  double tempo_lo = 0, tempo_hi = 0, tempo_sum = 0, score_sum = 0;
  for (const kata_repetition& r : reps) {
    if (r.partial) {
      ++partial;
      continue;
    }
    tempo_lo = counted ? std::min(tempo_lo, r.tempo) : r.tempo;
    tempo_hi = counted ? std::max(tempo_hi, r.tempo) : r.tempo;
    tempo_sum += r.tempo;
    score_sum += r.score;
    if (best < 0 || r.score > reps[static_cast<size_t>(best)].score) best = static_cast<int>(&r - reps.data());
    ++counted;
  }
  if (reps.empty()) return "";
  char buf[256];
  if (!counted) {
    std::snprintf(buf, sizeof buf, "no repetition completed (%d partial)", partial);
    return buf;
  }
  std::snprintf(buf, sizeof buf, "%d repetitions%s, tempo %.2f-%.2f (mean %.2f), mean score %.1f, best: rep %d (%.0f)",
                counted, partial ? (" (" + std::to_string(partial) + " partial, not counted)").c_str() : "", tempo_lo,
                tempo_hi, tempo_sum / counted, score_sum / counted, reps[static_cast<size_t>(best)].index,
                reps[static_cast<size_t>(best)].score);
  return buf;
}

std::string repetitions_report_html(const std::vector<kata_repetition>& reps) {
  if (reps.empty()) return "";
  std::string h = "<p>" + escape(repetitions_summary(reps)) +
                  ". Tempo is the repetition's duration over the teacher's (above 1: slower); depth the larger "
                  "knee range of motion, the teacher's as the dashed line; * partial (not counted).</p>";
  h += "<div class=\"repplots\">";
  h += plot(reps, "score per repetition", "", [](const kata_repetition& r) { return static_cast<double>(r.score); },
            nullptr, 100.0);
  double tempo_top = 1.5;
  for (const kata_repetition& r : reps) tempo_top = std::max(tempo_top, std::ceil(r.tempo * 4.0) / 4.0);
  h += plot(reps, "tempo per repetition (teacher: 1)", "", [](const kata_repetition& r) { return r.tempo; },
            [](const kata_repetition&) { return 1.0; }, std::min(tempo_top, 4.0));
  double depth_top = 30.0;
  for (const kata_repetition& r : reps)
    depth_top = std::max({depth_top, repetition_depth(r), repetition_depth(r, true)});
  depth_top = std::ceil(depth_top / 30.0) * 30.0;
  h += plot(reps, "depth per repetition (knee range, deg)", "",
            [](const kata_repetition& r) { return repetition_depth(r); },
            [](const kata_repetition& r) { return repetition_depth(r, true); }, depth_top);
  h += "</div><table class=\"reps\"><tr><th>rep</th><th>start (s)</th><th>end (s)</th><th>tempo</th><th>score</th>"
       "<th>part to fix</th><th>cue</th>";
  for (int j = 0; j < KATA_ROM_JOINT_COUNT; ++j) h += std::string("<th>") + kRomLabel[j] + "<br>you / teacher</th>";
  h += "</tr>";
  for (const kata_repetition& r : reps) {
    h += std::string("<tr") + (r.partial ? " class=\"partial\"" : "") + "><td>" + std::to_string(r.index) +
         (r.partial ? " (partial)" : "") + "</td><td>" + format("%.2f", r.start_time) + "</td><td>" +
         format("%.2f", r.end_time) + "</td><td>" + format("%.2f", r.tempo) + "</td><td>" + format("%.0f", r.score) +
         "</td><td>" + (r.part_to_fix >= 0 ? part_name(r.part_to_fix) : "-") + "</td><td>" + escape(cue_of(r)) + "</td>";
    for (int j = 0; j < KATA_ROM_JOINT_COUNT; ++j)
      h += "<td>" + format("%.0f", r.range[j]) + " / " + format("%.0f", r.teacher_range[j]) + "</td>";
    h += "</tr>";
  }
  return h + "</table>";
}

}  // namespace kata::coach
