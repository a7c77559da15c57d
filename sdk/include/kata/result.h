/* kata/result.h: the one result record. C99, no other kata header needed.
 *
 * Every place a kata result reaches a caller carries this record: a stream's results
 * (kata_stream_read_results / kata_stream_read_newest in kata.h), a runtime's published result
 * messages read in C (kata_message_read_result in kata.h; schemas/result.fbs on the wire), and a
 * sink plugin's on_result (kata_plugin.h). The same field has the same name, unit and meaning in
 * all three; a field a source cannot know is 0 (named below).
 *
 * Growth: fields are only added at the end. The caller (or, for plugins, the host) sets
 * struct_size to the sizeof it was built with; a writer fills only that many bytes and keeps
 * struct_size, so a 1.0 caller keeps working with a later library, and a reader checks
 * KATA_RESULT_HAS(record, field) before reading a field added after 1.0. */
#ifndef KATA_RESULT_H
#define KATA_RESULT_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The five body parts of a score breakdown, in array order. */
typedef enum kata_body_part {
  KATA_PART_TORSO_HEAD = 0, /* Hip, Chest, Neck, Head */
  KATA_PART_LEFT_ARM = 1,   /* LShoulder, LElbow, LHand */
  KATA_PART_RIGHT_ARM = 2,  /* RShoulder, RElbow, RHand */
  KATA_PART_LEFT_LEG = 3,   /* LHip, LKnee, LFoot */
  KATA_PART_RIGHT_LEG = 4,  /* RHip, RKnee, RFoot */
  KATA_PART_COUNT = 5
} kata_body_part;

/* What a scored record's state says (kata.h "Score calibration and feedback" says when each
 * applies). */
typedef enum kata_score_state {
  KATA_SCORE_SCORING = 0,          /* the scores are this frame's */
  KATA_SCORE_CALIBRATING = 1,      /* the first 0.25 s after a teacher is attached or restarted */
  KATA_SCORE_TRACKING_LOST = 2,    /* fewer than 13 of the 16 GPD joints are tracked in the frame
                                      (a joint at exactly (0,0,0) counts as lost); scores are 0 */
  KATA_SCORE_TEACHER_FINISHED = 3  /* the student has outlasted the teacher clip by 0.25 s */
} kata_score_state;

/* The action of a correction cue (cue_action below; kata.h "Score calibration and feedback"
 * says how it is chosen). Values are never reused. */
typedef enum kata_cue_action {
  KATA_CUE_NONE = -1,       /* no cue (part_to_fix is -1) */
  KATA_CUE_BEND = 0,        /* bend the joint more (knee, elbow), or lean the chest / lower back forward */
  KATA_CUE_STRAIGHTEN = 1,  /* the opposite of bend */
  KATA_CUE_RAISE = 2,       /* raise the limb (shoulder, hip) or the head (neck) */
  KATA_CUE_LOWER = 3,       /* the opposite of raise */
  KATA_CUE_TURN = 4         /* the error is mostly sideways or a twist */
} kata_cue_action;

/* One result: one frame of one stream, scored against its teacher when it has one. */
typedef struct kata_result_record {
  uint32_t struct_size;          /* the caller's sizeof(kata_result_record); kept by every writer */
  int32_t scored;                /* 1: a teacher scored the frame (distance .. part_to_fix, state and
                                    the matched teacher frame are valid); 0: they are 0 / -1 */
  uint64_t stream_id;            /* the runtime's stream id (the message topic); 0 for a kata_stream */
  uint64_t result_sequence;      /* 0, 1, 2... per stream, +1 per result: a gap means results were
                                    dropped (a full ring, ZeroMQ's high-water mark) */
  uint64_t frame_sequence;       /* the source's sequence number of the frame (a runtime's Frame
                                    message); for a kata_stream, frame_index */
  int64_t frame_index;           /* the frame's 0-based index in the stream since it was opened or
                                    restarted (accepted frames) */
  double capture_time;           /* the frame's capture time, seconds on the source's clock, as it
                                    was pushed (kata_stream_push, Frame.capture_time) */
  int64_t arrival_ns;            /* CLOCK_MONOTONIC ns of the computing host: the frame arrived */
  int64_t computed_ns;           /* CLOCK_MONOTONIC ns: its features, score and ghost were done */
  int64_t published_ns;          /* CLOCK_MONOTONIC ns: handed to ZeroMQ; 0 for a kata_stream */
  int32_t matched_teacher_frame; /* teacher frame matched (0-based from the teacher's first frame),
                                    -1 unless scored */
  int32_t state;                 /* kata_score_state; KATA_SCORE_SCORING unless scored */
  double matched_teacher_time;   /* the matched frame's time, seconds from the teacher's first
                                    frame (where the student is in the routine); -1 unless scored */
  float distance;                /* d = |W^T (x'' - y'')|, dimensionless (>= 0) */
  float score;                   /* 0..100 (100 at d = 0) */
  float parts[KATA_PART_COUNT];  /* split of d^2 by kata_body_part; sums to d^2 */
  float part_scores[KATA_PART_COUNT]; /* each part's calibrated score, 0..100 */
  int32_t part_to_fix;           /* kata_body_part to correct, -1 for none (held 0.3 s, see kata.h) */
  uint32_t ghost_joint_count;    /* joints of this result's ghost (0: none was made) */
  const float* ghost;            /* ghost_joint_count x 3 floats (student units, placed over the
                                    student), or NULL. Messages and plugins: valid until the next
                                    read on the thread / the end of on_result. A kata_stream
                                    writes its ghosts into the caller's array instead: NULL. */
  int32_t has_practice;          /* 1: the stream follows a teacher clip and practice_* say which
                                    section; 0: no clip teacher (practice_* are 0) */
  uint32_t practice_revision;    /* the Practice message that set the section; 0: the stream's
                                    configured setting (kata serve's [scoring], or the whole clip) */
  double practice_start_time;    /* the section's first teacher frame, s (the axis of
                                    matched_teacher_time: a scored result's lies in the section) */
  double practice_end_time;      /* its last teacher frame, s */
  int32_t practice_loop;         /* 1: the section is looped (its end is followed by its start) */
  uint32_t reserved0;            /* 0 */
  /* The correction cue (added after reserved0: check KATA_RESULT_HAS(r, cue_action)), present iff
   * part_to_fix >= 0 ("left knee: bend 30 deg more": kata_cue_text in kata.h). */
  int32_t cue_joint;             /* the GPD joint to move (0..15, kata_gpd_joint_name: "LKnee"),
                                    always one of part_to_fix's joints; -1 for none */
  float cue_degrees;             /* the angle at cue_joint between the student's bone and the
                                    teacher's, each in the body's frame, degrees (0..180, averaged
                                    over 0.5 s like the part scores); 0 for none */
  int32_t cue_action;            /* kata_cue_action; KATA_CUE_NONE (-1) for none */
  uint32_t reserved1;            /* 0 */
  /* ---- 1.1, later: repetitions (check KATA_RESULT_HAS(r, repetition)) ----
   * The teacher's section (the clip, or its practice section, best looped) is one repetition; a
   * repetition ends when the match comes round from the section's end to its start (a
   * kata_repetition then says how it went: kata_stream_read_repetitions, or a Repetition message
   * beside the results, kata_message_read_repetition). */
  int32_t repetition;            /* the repetition in progress: 1 + the complete ones so far; 0
                                    unless scored against a clip */
  float repetition_progress;     /* where the match is in the section, 0..1 (0 unless scored
                                    against a clip) */
} kata_result_record;

/* The joint angles whose range of motion a repetition reports, in array order. Each is the angle
 * at a joint between its two segments, degrees (0..180): a knee at the knee between the hip and
 * the ankle (180 straight); a hip between the trunk (pelvis -> neck) and the thigh (180 standing,
 * 90 with the thigh level: flexion or abduction alike); an elbow at the elbow between the shoulder
 * and the wrist (180 straight); a shoulder between the trunk (neck -> pelvis) and the upper arm (0
 * hanging, 90 level: flexion or abduction alike). Since 1.1. */
typedef enum kata_rom_joint {
  KATA_ROM_LEFT_KNEE = 0,      /* at LKnee between LHip and LFoot */
  KATA_ROM_RIGHT_KNEE = 1,     /* at RKnee between RHip and RFoot */
  KATA_ROM_LEFT_HIP = 2,       /* between Hip -> Neck and LHip -> LKnee */
  KATA_ROM_RIGHT_HIP = 3,      /* between Hip -> Neck and RHip -> RKnee */
  KATA_ROM_LEFT_ELBOW = 4,     /* at LElbow between LShoulder and LHand */
  KATA_ROM_RIGHT_ELBOW = 5,    /* at RElbow between RShoulder and RHand */
  KATA_ROM_LEFT_SHOULDER = 6,  /* between Neck -> Hip and LShoulder -> LElbow */
  KATA_ROM_RIGHT_SHOULDER = 7, /* between Neck -> Hip and RShoulder -> RElbow */
  KATA_ROM_JOINT_COUNT = 8     /* the number of angles */
} kata_rom_joint;

/* One repetition of the teacher's section by the student, complete or partial (1.1;
 * docs/coach/repetitions.md). A repetition ends when the match comes round from the section's end
 * to its start (or jumps back to its start, or holds at its end for 0.5 s, or the take ends:
 * kata_stream_flush, the runtime's stream closed or the runtime stopped); it is complete when
 * the student went through at least 70 % of the section and reached its end, partial (reported,
 * not counted) when abandoned after 20 % or more. A pause between repetitions belongs to neither.
 * Growth as kata_result_record: fields only appended; the writer fills struct_size bytes. */
typedef struct kata_repetition {
  uint32_t struct_size;          /* the caller's sizeof(kata_repetition); kept by every writer */
  int32_t index;                 /* 1, 2, 3...: the count of complete repetitions with this one; a
                                    partial one carries the index the attempt would have had (the
                                    next complete one gets it: the count goes on) */
  uint64_t stream_id;            /* the runtime's stream id; 0 for a kata_stream */
  double start_time;             /* student seconds (capture_time's clock): it started */
  double end_time;               /* its last step forward in the section */
  double tempo;                  /* (end - start) / the teacher's section duration: 1 the teacher's
                                    pace, 1.2 20 % slower */
  float score;                   /* mean total score over its scoring frames, 0..100 */
  int32_t partial;               /* 1: abandoned before the end, not counted */
  int32_t part_to_fix;           /* the kata_body_part shown on most of its frames, -1 for none */
  int32_t cue_joint;             /* the cue shown most while that part was (GPD joint), -1 none */
  float cue_degrees;             /* that cue's mean degrees while shown; 0 for none */
  int32_t cue_action;            /* kata_cue_action of that cue; KATA_CUE_NONE for none */
  float range[KATA_ROM_JOINT_COUNT];          /* the student's range of motion per kata_rom_joint,
                                                 max - min over the repetition, degrees */
  float teacher_range[KATA_ROM_JOINT_COUNT];  /* the teacher's over the section, degrees */
  float coverage;                /* the fraction of the section the student went through, 0..1 */
  uint32_t reserved0;            /* 0 */
} kata_repetition;

/* 1 when a record written for a caller's struct_size holds FIELD. */
#define KATA_RESULT_HAS(r, field) \
  ((r)->struct_size >= offsetof(kata_result_record, field) + sizeof((r)->field))

#ifdef __cplusplus
}
#endif

#endif /* KATA_RESULT_H */
