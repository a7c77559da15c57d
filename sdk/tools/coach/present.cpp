#include "coach/present.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "common/error.hpp"

namespace kata::coach {
namespace {

// Colours of the five parts (lines of the per-part chart) and of the two figures.
const char* const kPartColour[metric::kParts] = {"#6c5ce7", "#0984e3", "#00b894", "#e17055", "#d63031"};
const char* const kPartLabel[metric::kParts] = {"torso and head", "left arm", "right arm", "left leg", "right leg"};
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

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    out += c;
  }
  return out + "\"";
}

std::string html_escape(const std::string& s) {
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

// Draws a skeleton (joints x 3, parents) into an SVG group: x0, y0 = where the root goes,
// scale = pixels per unit; colour per bone from `bone_colour(child joint)`.
template <class BoneColour>
void draw_figure(std::string& svg, const float* joints, const std::vector<int>& parents, const View& v, double x0,
                 double y0, double scale, double width, BoneColour bone_colour) {
  auto px = [&](int j) { return x0 - ((joints[3 * j] * v.ax + joints[3 * j + 2] * v.az) - v.cx) * scale; };
  auto py = [&](int j) { return y0 - (joints[3 * j + 1] - v.cy) * scale; };
  for (size_t j = 1; j < parents.size(); ++j) {
    const int p = parents[j];
    if (p < 0) continue;
    svg += "<line x1=\"";
    append(svg, "%.1f", px(p));
    svg += "\" y1=\"";
    append(svg, "%.1f", py(p));
    svg += "\" x2=\"";
    append(svg, "%.1f", px(static_cast<int>(j)));
    svg += "\" y2=\"";
    append(svg, "%.1f", py(static_cast<int>(j)));
    svg += "\" stroke=\"" + bone_colour(static_cast<int>(j)) + "\" stroke-width=\"";
    append(svg, "%.1f", width);
    svg += "\" stroke-linecap=\"round\"/>";
  }
}

// A line chart of series over time: values 0..ymax, x = seconds.
struct Series {
  std::string colour, label;
  std::vector<double> values;  // NaN = gap
};

std::string chart(const std::vector<double>& time, const std::vector<Series>& series, double ymax,
                  const std::string& ylabel, const std::vector<size_t>& marks) {
  const double w = 860, h = 240, left = 50, right = 15, top = 12, bottom = 34;
  const double tmax = time.empty() ? 1.0 : std::max(time.back(), 1e-6);
  auto X = [&](double t) { return left + (w - left - right) * t / tmax; };
  auto Y = [&](double v) { return top + (h - top - bottom) * (1.0 - std::clamp(v, 0.0, ymax) / ymax); };
  std::string s = "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 860 240\" width=\"860\" height=\"240\">";
  for (int k = 0; k <= 4; ++k) {
    const double v = ymax * k / 4;
    s += "<line x1=\"50\" x2=\"845\" y1=\"";
    append(s, "%.1f", Y(v));
    s += "\" y2=\"";
    append(s, "%.1f", Y(v));
    s += "\" stroke=\"#ddd\"/><text x=\"44\" y=\"";
    append(s, "%.1f", Y(v) + 4);
    s += "\" text-anchor=\"end\" font-size=\"11\">";
    append(s, ymax > 1.5 ? "%.0f" : "%.2f", v);
    s += "</text>";
  }
  const int step = tmax > 20 ? 5 : tmax > 8 ? 2 : 1;
  for (int t = 0; t <= static_cast<int>(tmax); t += step) {
    s += "<text x=\"";
    append(s, "%.1f", X(t));
    s += "\" y=\"";
    append(s, "%.1f", h - 16);
    s += "\" text-anchor=\"middle\" font-size=\"11\">" + std::to_string(t) + " s</text>";
  }
  s += "<text x=\"12\" y=\"120\" font-size=\"11\" transform=\"rotate(-90 12 120)\" text-anchor=\"middle\">" + ylabel +
       "</text>";
  for (size_t m = 0; m < marks.size(); ++m) {
    s += "<line x1=\"";
    append(s, "%.1f", X(time[marks[m]]));
    s += "\" x2=\"";
    append(s, "%.1f", X(time[marks[m]]));
    s += "\" y1=\"12\" y2=\"206\" stroke=\"#c0392b\" stroke-dasharray=\"4 3\"/><text x=\"";
    append(s, "%.1f", X(time[marks[m]]) + 3);
    s += "\" y=\"24\" font-size=\"11\" fill=\"#c0392b\">" + std::to_string(m + 1) + "</text>";
  }
  for (const Series& ser : series) {
    s += "<polyline fill=\"none\" stroke=\"" + ser.colour + "\" stroke-width=\"1.6\" points=\"";
    for (size_t i = 0; i < time.size(); ++i) {
      if (!std::isfinite(ser.values[i])) continue;
      append(s, "%.1f,", X(time[i]));
      append(s, "%.1f ", Y(ser.values[i]));
    }
    s += "\"/>";
  }
  s += "</svg>";
  return s;
}

}  // namespace

std::string setup_json(const LessonData& d, const std::string& source, const std::string& lesson_id) {
  std::string s = "{\"source\":" + json_string(source) + ",\"lesson\":" + json_string(lesson_id) + ",\"parts\":[";
  for (int p = 0; p < metric::kParts; ++p) s += std::string(p ? "," : "") + json_string(metric::part_name(p));
  s += "],\"part_labels\":[";
  for (int p = 0; p < metric::kParts; ++p) s += std::string(p ? "," : "") + json_string(kPartLabel[p]);
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
    append_floats(s, r.part_scores, metric::kParts);
    s += ",\"shares\":[";
    for (int p = 0; p < metric::kParts; ++p) {
      if (p) s += ',';
      append(s, "%.3f", part_share(r, p));
    }
    s += "],\"fix\":" + std::to_string(r.part_to_fix) + ",\"matched\":" + std::to_string(r.matched);
    if (r.matched_time >= 0.0) append(s, ",\"matched_time\":%.3f", r.matched_time);
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
  for (int p = 0; p < metric::kParts; ++p) parts.push_back({kPartColour[p], kPartLabel[p], {}});
  double part_sum[metric::kParts] = {};
  int fix_count[metric::kParts] = {};
  int scored_frames = 0, lost = 0, finished = 0, calibrating = 0, named = 0;
  std::vector<double> latencies;
  for (size_t i = 0; i < static_cast<size_t>(d.pushed); ++i) {
    const FrameRecord& r = d.frames[i];
    time.push_back(r.time);
    const bool ok = scored(r);
    total.values.push_back(ok ? r.score : NAN);
    for (int p = 0; p < metric::kParts; ++p) {
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
  double part_mean[metric::kParts] = {};
  for (int p = 0; p < metric::kParts; ++p) part_mean[p] = scored_frames ? part_sum[p] / scored_frames : 0.0;
  const std::vector<size_t> lows = lowest_moments(d);
  const double mean = d.mean_score();
  int most_fixed = 0, weakest = 0;
  for (int p = 1; p < metric::kParts; ++p) {
    if (fix_count[p] > fix_count[most_fixed]) most_fixed = p;
    if (part_mean[p] < part_mean[weakest]) weakest = p;
  }
  std::sort(latencies.begin(), latencies.end());
  auto pct = [&](double q) { return latencies.empty() ? 0.0 : latencies[static_cast<size_t>(q * (latencies.size() - 1))]; };

  std::string h;
  h += "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>kata lesson report</title>\n"
       "<link rel=\"icon\" href=\"data:,\">\n<style>"
       "body{font-family:system-ui,sans-serif;max-width:900px;margin:24px auto;color:#2d3436;line-height:1.45}"
       "h1{margin-bottom:4px}.big{font-size:44px;font-weight:700}.muted{color:#636e72}"
       "table{border-collapse:collapse}td,th{padding:3px 10px;border-bottom:1px solid #eee;text-align:left}"
       ".moments{display:flex;gap:14px;flex-wrap:wrap}.moment{border:1px solid #ddd;border-radius:8px;padding:8px}"
       ".key span{display:inline-block;margin-right:14px}.sw{display:inline-block;width:12px;height:12px;border-radius:2px;"
       "margin-right:4px;vertical-align:-1px}</style></head><body>\n";
  h += "<h1>Your lesson</h1><p class=\"muted\">" + html_escape(base_name(d.settings.student)) + " (you) following " +
       html_escape(base_name(d.settings.teacher)) + " (the teacher), " + std::to_string(d.pushed) + " frames, ";
  append(h, "%.1f", d.pushed * d.frame_time);
  h += " s.</p>\n<p><span class=\"big\" style=\"color:" + score_colour(mean) + "\">";
  append(h, "%.0f", mean);
  h += "</span> / 100 &nbsp; mean score</p>\n";
  h += "<p>Each moment of your movement is compared with the teacher's matching moment (the teacher's clip is "
       "followed as you go, so being a little faster or slower is fine). <b>100</b> means your pose matches the "
       "teacher's; <b>50</b> means a clear difference; low scores mean a very different pose. Each body part gets "
       "its own score on the same scale. ";
  if (scored_frames) {
    h += std::string("Your weakest part on average: <b>") + kPartLabel[weakest] + "</b> (";
    append(h, "%.0f", part_mean[weakest]);
    h += "). ";
    if (named) {
      h += std::string("The part to fix named most often: <b>") + kPartLabel[most_fixed] + "</b> (" +
           std::to_string(100 * fix_count[most_fixed] / scored_frames) + "% of the time).";
    } else {
      h += "No part needed fixing: every moment scored at or above ";
      append(h, "%.0f", d.good_score);
      h += ".";
    }
  }
  h += "</p>\n<h2>Score over time</h2>\n";
  h += chart(time, {total}, 100.0, "score (0-100)", lows);
  h += "<p class=\"muted\">Dashed red lines: the three lowest moments, shown below. Gaps: moments without a score "
       "(the start, or tracking lost).</p>\n";
  h += "<h2>Each body part over time</h2>\n<p>The score of each body part, 0-100, on the same scale as the total. "
       "The part to fix is the lowest one, named when the total is below ";
  append(h, "%.0f", d.good_score);
  h += " and it has stayed the lowest for half a second.</p>\n";
  h += chart(time, parts, 100.0, "part score (0-100)", {});
  h += "<p class=\"key\">";
  for (int p = 0; p < metric::kParts; ++p)
    h += std::string("<span><i class=\"sw\" style=\"background:") + kPartColour[p] + "\"></i>" + kPartLabel[p] + "</span>";
  h += "</p>\n";

  // Body diagram: each bone coloured by its part's mean score (red 0 -> amber 50 -> green 100).
  h += "<h2>Your body, part by part</h2>\n<div style=\"display:flex;gap:24px;align-items:center\">";
  if (d.pushed > 0) {
    const float* pose = d.frame_positions(0);
    const View v = view_of(d, pose);
    double lo = 1e30, hi = -1e30;
    for (int j = 0; j < d.joints; ++j) lo = std::min(lo, double(pose[3 * j + 1])), hi = std::max(hi, double(pose[3 * j + 1]));
    const double scale = 300.0 / std::max(hi - lo, 1e-6);
    std::string svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 260 360\" width=\"260\" height=\"360\">";
    auto colour = [&](int j) { return score_colour(part_mean[d.joint_part[static_cast<size_t>(j)]]); };
    draw_figure(svg, pose, d.joint_parents, v, 130, 330 - (pose[1] - lo) * scale, scale, 9, colour);
    svg += "</svg>";
    h += svg;
  }
  h += "<table><tr><th>part</th><th>mean score</th><th>named as the part to fix</th></tr>";
  for (int p = 0; p < metric::kParts; ++p) {
    h += "<tr><td><i class=\"sw\" style=\"background:" + score_colour(part_mean[p]) + "\"></i>" + kPartLabel[p] + "</td><td>";
    append(h, "%.0f", part_mean[p]);
    h += "</td><td>";
    append(h, "%.0f%% of the time", scored_frames ? 100.0 * fix_count[p] / scored_frames : 0.0);
    h += "</td></tr>";
  }
  h += "</table></div>\n<p class=\"muted\">Colours: each part's mean score: green = close to the teacher (100), amber "
       "= a clear difference (50), red = far from it (0).</p>\n";

  // The three lowest moments: student and ghost (the teacher's pose on your body) side by side.
  h += "<h2>The three lowest moments</h2>\n<p>Left: <b>you</b>, each body part in the colour of its score at that "
       "moment. Right: the <b style=\"color:" + std::string(kGhostColour) +
       "\">teacher's pose on your body</b> (the \"ghost\": same moment, your bone lengths). Both are drawn facing "
       "you.</p>\n<div class=\"moments\">";
  for (size_t m = 0; m < lows.size(); ++m) {
    const size_t i = lows[m];
    const FrameRecord& r = d.frames[i];
    const float* pose = d.frame_positions(i);
    const View v = view_of(d, pose);
    double lo = 1e30, hi = -1e30;
    for (int j = 0; j < d.joints; ++j) lo = std::min(lo, double(pose[3 * j + 1])), hi = std::max(hi, double(pose[3 * j + 1]));
    const double scale = 200.0 / std::max(hi - lo + 6.0, 1e-6);
    std::string svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 260 250\" width=\"260\" height=\"250\">";
    const double root_y = 230 - (pose[1] - lo) * scale;
    // You: each bone in its part's score at that moment; the ghost in one colour.
    draw_figure(svg, pose, d.joint_parents, v, 70, root_y, scale, 5,
                [&](int j) { return score_colour(r.part_scores[d.joint_part[static_cast<size_t>(j)]]); });
    if (r.has_ghost) {
      const std::vector<int> gp = ghost_parents(d);
      draw_figure(svg, d.frame_ghost(i), gp, v, 190, root_y, scale, 5, [](int) { return std::string(kGhostColour); });
    }
    svg += "<text x=\"70\" y=\"246\" text-anchor=\"middle\" font-size=\"11\">you</text><text x=\"190\" y=\"246\" "
           "text-anchor=\"middle\" font-size=\"11\">teacher (ghost)</text></svg>";
    h += "<div class=\"moment\"><b>" + std::to_string(m + 1) + ".</b> at ";
    append(h, "%.2f s", r.time);
    h += ", score ";
    append(h, "%.0f", r.score);
    if (r.part_to_fix >= 0) h += std::string(", fix: <b>") + kPartLabel[r.part_to_fix] + "</b>";
    h += "<br>" + svg + "<br><span class=\"muted\" style=\"font-size:12px\">";
    for (int p = 0; p < metric::kParts; ++p) {
      h += std::string(p ? ", " : "") + kPartLabel[p] + " ";
      append(h, "%.0f", r.part_scores[p]);
    }
    h += "</span></div>";
  }
  h += "</div>\n";

  h += "<h2>Settings</h2>\n<table>";
  auto row = [&](const std::string& k, const std::string& v) { h += "<tr><td>" + k + "</td><td>" + html_escape(v) + "</td></tr>"; };
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
  h += "</table>\n<p class=\"muted\">Made by <code>kata coach</code>.</p></body></html>\n";

  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error(ErrorKind::kIo, path + ": cannot open for writing");
  out << h;
  if (!out.flush()) throw Error(ErrorKind::kIo, path + ": write failed");
}

}  // namespace kata::coach
