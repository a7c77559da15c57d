// Repetitions in `kata coach` (docs/coach/repetitions.md): the counter in the terminal and the
// viewer, the summary, and the report's per-repetition table and plots (score, tempo and depth per
// repetition). The repetitions themselves are libkata's (kata_repetition, the runtime's
// on_repetition); nothing here counts.
#pragma once

#include <string>
#include <vector>

#include "kata/kata.h"

namespace kata::coach {

// The depth of a repetition: the larger of the two knees' ranges of motion, degrees (the
// student's, or with teacher the teacher's over the section).
double repetition_depth(const kata_repetition& r, bool teacher = false);
// The viewer's JSON of one repetition: index, partial, start, end, tempo, score, depth,
// teacher_depth, part_to_fix, cue.
std::string repetition_json(const kata_repetition& r);
// The count as the summary gives it, JSON members for an event: "reps_done":8,"reps_partial":1.
std::string repetitions_count_json(const std::vector<kata_repetition>& reps);
// The terminal's few words of the newest repetition: "rep 3: tempo 1.12, score 74, depth 61/65 deg".
std::string repetition_words(const kata_repetition& r);
// The summary's line: "8 repetitions (1 partial), tempo 0.93-1.21 (mean 1.05), score ..." ("" for none).
std::string repetitions_summary(const std::vector<kata_repetition>& reps);
// The report's section: the per-repetition table and three inline SVG plots (score, tempo and
// depth against the teacher's, per repetition). HTML, "" without a repetition.
std::string repetitions_report_html(const std::vector<kata_repetition>& reps);

}  // namespace kata::coach
