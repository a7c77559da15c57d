// What a lesson looks like to its student: the viewer's JSON events and the HTML report.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "coach/lesson.hpp"

namespace kata::coach {

// The viewer's "setup" event: skeleton (parents, part of each joint), ghost tree, part names,
// frame counts, settings, the lesson's id.
std::string setup_json(const LessonData& data, const std::string& source, const std::string& lesson_id);
// The viewer's "frame" event of frame i: time, state, score, part shares, part to fix, matched
// teacher frame, latency, student joints and ghost joints (x y z, input units).
std::string frame_json(const LessonData& data, size_t i);
// The "end" event: the summary.
std::string end_json(const LessonData& data);

// The three lowest-score moments, at least half a second apart (frame indices, lowest first).
std::vector<size_t> lowest_moments(const LessonData& data, size_t count = 3);

// Writes the self-contained HTML report: coach/report.html.mustache rendered by kainjow Mustache,
// the figures as inline SVG, the charts drawn by uPlot inlined with their data (no external file,
// nothing fetched). Throws kata::Error(kIo).
void write_report(const LessonData& data, const std::string& path);

}  // namespace kata::coach
