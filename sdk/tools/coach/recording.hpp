// A recorded lesson: the incoming frames and every result, in one NumPy .npz file (a zip of
// .npy arrays, stored uncompressed; `numpy.load(path)` reads it). F = frames pushed, J = student
// joints, G = ghost joints, P = 5 body parts (torso_head, left_arm, right_arm, left_leg, right_leg).
//
//   positions     float32 (F, J, 3)  the student frames as pushed (input units, +Y up)
//   time          float64 (F)        capture time, seconds from the first frame
//   state         uint8   (F)        0 calibrating, 1 tracking, 2 tracking lost, 3 teacher finished
//   score         float32 (F)        0-100 (0 when not scored)
//   distance      float32 (F)        the metric distance
//   parts         float32 (F, P)     the split of distance^2 over the parts
//   part_scores   float32 (F, P)     each part's calibrated 0-100 score
//   part_to_fix   int32   (F)        the scorer's part to fix (-1: none)
//   matched       int32   (F)        teacher frame matched, from first_frame (-1: none)
//   latency_ns    int64   (F)        frame in -> result published, steady clock
//   ghosts        float32 (F, G, 3)  the teacher's pose on the student's body (zeros: none)
//   has_ghost     uint8   (F)
//   joint_parents int32   (J)        the student skeleton (parents[0] = -1)
//   joint_part    int32   (J)        body part of each joint
//   ghost_sources int32   (G)        student joint each ghost joint stands for
//   hips          int32   (2)        student joints of the left and right hip
//   numbers       float64 (9)        frame_time, delta_star, speed, window, first_frame,
//                                    teacher_frames, student_frames, d50, good_score
//   text          uint8   (n)        UTF-8 lines: model, teacher, student, preset, then the J joint names
//   matched_time  float64 (F)        where the student is in the routine: the matched teacher frame's
//                                    time, seconds from first_frame (-1: not scored; optional on read)
//   practice      int32   (3)        teacher_start, loop_first, loop_last (teacher clip frames; -1:
//                                    unset; optional on read)
//   cue_joint     int32   (F)        the correction cue's GPD joint (-1: none; optional on read)
//   cue_degrees   float32 (F)        its angle, degrees (0: none; optional on read)
//   cue_action    int32   (F)        its kata_cue_action (-1: none; optional on read)
//   repetition    int32   (F)        the repetition in progress (kata_result_record.repetition; 0:
//                                    none; optional on read)
//   repetition_progress float32 (F)  the progress through the teacher's section, 0..1 (optional)
//   repetitions   float64 (R, 27)    every repetition that ended (kata_repetition), one row each:
//                                    index, partial, start_time, end_time, tempo, score,
//                                    part_to_fix, cue_joint, cue_action, cue_degrees, coverage, then
//                                    range[8] and teacher_range[8] (kata_rom_joint order; optional)
#pragma once

#include <string>

#include "coach/lesson.hpp"

namespace kata::coach {

// Writes a lesson's frames and results. Throws kata::Error(kIo).
void write_recording(const LessonData& data, const std::string& path);
// Reads a file written by write_recording. Throws kata::Error(kIo / kParse) naming the file and
// the array at fault.
LessonData read_recording(const std::string& path);

// Every frame's result as CSV: frame, time, state, score, distance, the five parts (split of
// distance^2), the five part scores (<part>_score), part_to_fix, matched_teacher_frame,
// matched_teacher_time, then the cue as `kata score` writes it: cue_joint (GPD name, "" for
// none), cue_degrees, cue (the phrase), then repetition and repetition_progress (the record's).
// Throws kata::Error(kIo).
void write_results_csv(const LessonData& data, const std::string& path);

}  // namespace kata::coach
