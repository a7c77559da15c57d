/* kata/teacher.h: tasks 2 and 3, attach a teacher and read results: models, the teacher a stream
 * is scored against (and its ghost), the score's calibration and cue, practice sections, and
 * the stream's ring of results, and a teacher shared by many streams.
 *
 * Part of the C ABI; include "kata/kata.h" (all of it) or this header alone: it includes what it
 * needs. kata.h states the conventions every function here follows. */
#ifndef KATA_TEACHER_H
#define KATA_TEACHER_H

#include "result.h"
#include "retarget.h"
#include "stream.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ##############################################################################################
 * Task 2 - attach a teacher: what the stream is compared with (a model and a teacher motion)
 *
 * kata_model m;  kata_model_load(ctx, "models/default.kata", &m);
 * kata_teacher_desc t;  kata_teacher_desc_init(&t);
 * t.model = m;  t.clip = teacher_clip;  t.first_frame = 1;   -- or t.features / t.joints, ghost = 0
 * kata_stream_attach_teacher(s, &t);                         -- allocates, once
 * kata_stream_restart_teacher(s);  kata_stream_detach_teacher(s);
 * ############################################################################################ */

/* ==== Models and scoring ================================================================== */
/* (section: models and scoring)
 * A model (.kata file: normalisation ranges, the learned W, the threshold delta*) scores a
 * stream's frames against its teacher (kata_stream_attach_teacher; spec gpd-v1.md section 6):
 *   d = |W^T (x'' - y'')|   (x'', y'': normalised, unit-length GPD v1 features; d dimensionless)
 * (the score a coach sees is built from d and the joint angles: "Score calibration and feedback")
 * and splits d^2 over five body parts (they sum to d^2; a part may be slightly negative). The
 * teacher is one pose, or a clip that the stream follows with an online alignment: each frame is
 * matched to the best teacher frame just ahead of the last match, and the match moves anywhere in
 * the clip when the student is clearly elsewhere (joined late, skipped ahead or back); a student
 * who pauses holds the teacher (docs/model/alignment.md). The frame scored (matched_teacher_frame)
 * is the teacher frame within 0.05 s of that match where the body but its worst part agrees best,
 * so a joint held wrong throughout is not absorbed by the match (docs/model/scores.md "The
 * total").
 * Memory: loading a model and attaching a teacher allocate; scoring never does.
 * Threads: a model is immutable and may be shared by any number of streams and threads; a
 * stream keeps what it needs from the model, which may be freed while streams still use it. */
/* Which shipped model for which job (their evaluation figures and protocols: docs/model/scores.md,
 * docs/model/transition.md, and `kata model-info MODEL`):
 *   models/default.kata     coaching, a student against a teacher; it carries the calibrated
 *                           score map (kata_model_calibration).
 *   models/transition.kata  ranking candidate cut points between takes of one subject, or
 *                           within one kind of motion (a walk into another walk): the joint form,
 *                           a quadratic form on each joint's position, velocity and acceleration
 *                           differences.
 *   models/transition-static.kata  candidates between clips of different motions (a run into a
 *                           climb): a static W. Near chance within one motion.
 *                           Neither transition model has a calibration: not a coaching score.
 * kata_model_metadata(m, "data") names the training data. */
/* A loaded, verified model. */
typedef struct kata_model_s* kata_model;

/* Loads a .kata file. Every check runs before anything is used: the FlatBuffers verifier, the
 * identifier, the layout id ("gpd-v1"), the dimensions (W 1683 x r, min/max 1683), NaN/Inf,
 * max < min, r = 0, implausible magnitudes (|min|, |max| > 1e15, 0 < max - min < 1e-9,
 * |W| > 1e6), the checksum, and the canonical byte layout (so any flipped bit is refused); a refused file returns KATA_E_MODEL (KATA_E_IO when it
 * cannot be read, is a directory or special file, or is larger than KATA_MAX_MODEL_BYTES) with
 * the reason in kata_context_last_error. The 12-byte header (size prefix, identifier) is checked
 * against the file size before the rest is read. A relative path not found from the current
 * folder is looked for in the share/kata folder beside libkata ("models/default.kata" works from
 * any folder, as in the CLI); found nowhere: KATA_E_IO naming every folder looked in. *out is
 * owned by the caller. [any thread] */
KATA_API kata_status kata_model_load(kata_context context, const char* path, kata_model* out);
/* The same from a buffer in memory (size bytes, any alignment); the buffer is copied and may
 * be released after the call. [any thread] */
KATA_API kata_status kata_model_load_memory(kata_context context, const void* data, size_t size, kata_model* out);
/* Releases a model. Streams scoring with it keep working. NULL is ignored. [any thread, not
 * concurrently with other calls on the same model] */
KATA_API void kata_model_destroy(kata_model model);
/* Rank r (columns of W); 0 for NULL. [any thread] */
KATA_API uint32_t kata_model_rank(kata_model model);
/* Decision threshold delta* (a distance: score 50); 0 for NULL. [any thread] */
KATA_API double kata_model_delta_star(kata_model model);
/* The stencil the model was trained with; streams scored with it must use the same. [any thread] */
KATA_API kata_stencil kata_model_stencil(kata_model model);
/* Training metadata by key: "layout", "date" (ISO 8601), "data", "parameters" (JSON). The
 * string is owned by the model (valid until kata_model_destroy); NULL for an unknown key or a
 * NULL model. [any thread] */
KATA_API const char* kata_model_metadata(kata_model model, const char* key);

/* ==== Pipeline: every frame scored, with the teacher's pose on the student's body ========= */
/* (section: pipeline)
 * A stream with a teacher attached runs, in each push, for every feature vector it emits:
 *   score against the teacher (clip alignment picks the matched teacher frame)
 *   -> that teacher frame retargeted onto the student's bones (warm-started solve, exact bones)
 *   -> placed over the student's pose of the same frame: the "ghost" to draw over the student.
 * Each emitted vector becomes one kata_result_record in a ring of desc.result_capacity entries; the
 * caller drains them with kata_stream_read_results at any rate (push at 120 Hz, read at 30 Hz:
 * nothing is lost while the ring holds what arrives between reads; when it is full the oldest
 * unread result is overwritten and counted by kata_stream_results_dropped).
 * Times: capture_time is the caller's timestamp of the frame (seconds); arrival_ns and
 * computed_ns are CLOCK_MONOTONIC nanoseconds (C++ steady_clock): when the push began and when
 * the result was complete. Memory: kata_stream_attach_teacher allocates; pushes and reads never
 * do. Threads: [stream owner] for every call. */

/* A teacher's loading progress (1.1; kata_teacher_desc.on_progress): `done` of `frames` teacher
 * frames have their features; `user` is on_progress_user. It must not call kata_stream_* on the
 * stream being attached. */
typedef void (*kata_progress_callback)(void* user, uint32_t done, uint32_t frames);

/* What a stream is compared with: its teacher. One concept, whatever the teacher is given as:
 *   motion         how it is given                                   a ghost?
 *   a recorded clip   clip (BVH)                                     yes
 *   joint positions   skeleton + positions + frames + frame_time     yes
 *   GPD features      features + frames + frame_time (kata_stream_features of a teacher stream)  no
 *   the 16 GPD joints joints + body_height, one held pose (frames = 1)   no
 * Exactly one of clip, skeleton/positions, features, joints is set. A clip (frames > 1, pose_frame
 * -1) is followed by the online alignment; pose_frame >= first_frame makes that one frame a
 * single-pose teacher. A teacher given as features or GPD joints has no joint positions to
 * retarget: set ghost = 0 for it (ghost = 1 is refused). Fill with kata_teacher_desc_init. */
typedef struct kata_teacher_desc {
  uint32_t struct_size;      /* sizeof(kata_teacher_desc); 1.0's size or more (see Versions) */
  kata_model model;          /* required; the stream must use the model's stencil */
  /* The teacher's motion: a recorded clip ... */
  kata_clip clip;            /* a BVH clip, or NULL and one of the forms below */
  /* ... or frames of joint positions: `frames` x kata_skeleton_joint_count(skeleton) x 3 floats,
   * row-major, +Y up, frame_time seconds apart (copied). */
  kata_skeleton skeleton;
  const float* positions;    /* frames x joints x 3 floats, or NULL */
  uint32_t frames;           /* frames of positions or features (joints: 1) */
  double frame_time;         /* seconds between frames of positions or features */
  const char* layout;        /* the teacher's layout (kata_layout_name), read as a stream of that
                                layout reads its frames: its axes and smoothing where it fixes them
                                ("mediapipe" positions on kata_skeleton_create_layout's skeleton,
                                since 1.1; 1.0 refused that layout here). NULL: "cmu". Attached
                                to a stream whose layout synthesises its trunk ("mediapipe") and
                                given one with real trunk joints, the teacher's Hip, Chest and Neck
                                are made by the stream layout's rule from its own hip, shoulder and
                                head joints (1.1), so both trunks are built alike */
  uint32_t first_frame;      /* teacher frames first_frame..end (1 skips CMU's T-pose). Default 0 */
  int32_t pose_frame;        /* -1 (default): follow the whole clip; >= first_frame: that frame only */
  int32_t ghost;             /* 1 (default): make a ghost per result (the student skeleton needs rest
                                offsets and the same joint names as the teacher); 0: scores only */
  const kata_retarget_desc* retarget;  /* the ghost's solver (joint set "cmu" or "gpd"); NULL: defaults */
  /* ... or GPD v1 feature vectors: `frames` x KATA_GPD_DIMS floats, row-major (copied) ... */
  const float* features;
  /* ... or one pose as the 16 GPD joints' world positions: KATA_GPD_JOINTS x 3 floats, GPD joint
   * order, +Y up, any units (copied), held still (kinetics zero), with its body height in the same
   * units. (A moving teacher of 16 GPD joints: positions on kata_skeleton_create_layout "gpd".) */
  const float* joints;
  double body_height;        /* the joints' body height, in their units */
  /* ---- 1.1 ---- */
  /* 1: the ghost across layouts, for a teacher of one layout and a student stream of another (a
   * CMU clip, a MediaPipe webcam student): the teacher's frames read through `layout`, the
   * student's through the stream's own layout, retargeted on the 16 GPD joints both map and
   * placed over the student, as kata_retargeter_create_across + kata_retargeter_place do. The
   * ghost is then 16 joints in GPD order (kata_stream_ghost_joint_count 16), in the student
   * stream's axes and units; kata_stream_ghost_joint_source gives the student joint each stands
   * for (-1 for one its layout synthesises). The student's bone lengths come from its rest pose,
   * or else from the stream's estimate: results carry no ghost (has_ghost 0) until
   * kata_stream_bone_lengths has them, and the solver is then built once (one allocation, in
   * that push). Needs ghost = 1 and a teacher given as a clip or positions; desc->retarget's
   * joint_set is ignored. 0 (default): the ghost on the student's own joints, as in 1.0. */
  int32_t ghost_across;
  /* The online alignment's tracking window, teacher seconds (> 0, at most 60): each frame is
   * matched within this far ahead of the last match (kata/teacher.h "Models and scoring").
   * Default 0.5; a clip teacher only (a one-pose teacher ignores it). Since 1.1 (a caller's struct
   * without it gets 0.5). */
  double alignment_window;
  /* Called on the attaching thread as the teacher's features are computed, with the teacher frames
   * done so far and the teacher's frame count (done = frames on the last call), so an app can say
   * how far a long teacher's loading is (a 20-minute routine takes seconds). Never called for a
   * teacher given as features or joints. NULL (default): none. Since 1.1. */
  kata_progress_callback on_progress;
  void* on_progress_user;    /* passed to on_progress as is. Default NULL */
  /* ---- 1.1, later ---- */
  /* The lesson's tolerance, how far a part may be off before its score falls: "strict" (a
   * 30-degree error at one joint scores 50 or less), "normal" (a 45-degree error does; 1.1's
   * scores), "lenient" (for beginners: another person's same motion scores higher, and a
   * 45-degree error at one joint is no longer caught), or the angle in degrees (5..120, e.g. "35")
   * at which a part scores 50. Part score = 100 / (1 + (angle / angle50)^slope), normal 40, 5; a
   * number: that angle, slope 5 (each level's map and what it catches: the coaching manual's
   * tolerance table). The model's map of the distance is the same at every level, so another motion
   * scores low at each. A per-stream field, like alignment_window. NULL (default): "normal".
   * Anything else is refused (KATA_E_INVALID_ARGUMENT, naming it). Since 1.1 (a caller's struct
   * without it gets "normal"). */
  const char* tolerance;
} kata_teacher_desc;

/* Fills the first struct_size bytes of desc with the defaults above and sets desc->struct_size
 * to the smaller of struct_size and sizeof(kata_teacher_desc): nothing past the caller's own struct is
 * written, so a caller built against an older kata.h (a smaller struct) is safe with a
 * newer library, which then reads only that much (the later fields keep their defaults).
 * struct_size below 4 writes nothing. Bindings that declare the struct themselves (ctypes,
 * P/Invoke) pass their own size. [any thread] */
KATA_API void kata_teacher_desc_init_sized(kata_teacher_desc* desc, uint32_t struct_size);
/* Fills *desc with the defaults for the caller's own struct: kata_teacher_desc_init_sized(desc, sizeof *desc). */
#define kata_teacher_desc_init(desc) kata_teacher_desc_init_sized((desc), (uint32_t)sizeof *(desc))
/* Attaches a teacher to a stream in one call: model, teacher motion, and (from the stream's own
 * skeleton) the student's body. Replaces any teacher; a refused call leaves the old one in
 * place. The alignment starts at the teacher's first frame. Errors (stencil mismatch, unknown
 * layout, a ghost joint missing from one skeleton, bad frames or features, two motions given,
 * desc->struct_size below 1.0's kata_teacher_desc) go to
 * kata_stream_last_error. Allocates. [stream owner] */
KATA_API kata_status kata_stream_attach_teacher(kata_stream stream, const kata_teacher_desc* desc);
/* Removes the stream's teacher: later results are not scored (scored 0) and carry
 * no ghost. KATA_OK without one too. [stream owner] */
KATA_API kata_status kata_stream_detach_teacher(kata_stream stream);
/* Restarts the teacher: the next frame is matched from the teacher's first frame, the ghost's
 * solve starts cold and the score calibrates again (KATA_SCORE_CALIBRATING). A clip teacher's
 * repetition in progress ends first, as at kata_stream_flush (complete or partial:
 * kata_stream_read_repetitions returns it), then the count starts again from 1 (1.1). KATA_E_STATE
 * without a teacher. [stream owner] */
KATA_API kata_status kata_stream_restart_teacher(kata_stream stream);

/* ---- A teacher shared by many streams (1.1) ------------------------------------------------
 * kata_stream_attach_teacher loads (or copies) the teacher for each stream it is given to. A
 * server scoring many students against one clip builds the teacher once instead:
 *   kata_teacher t;  kata_teacher_create(ctx, &desc, &t);         -- loads, once
 *   kata_stream_attach_shared_teacher(s1, t, NULL);  kata_stream_attach_shared_teacher(s2, t, NULL);
 *   kata_teacher_destroy(t);                                      -- the streams keep it
 * The streams then read one copy of the teacher's frames (kata_teacher_memory_bytes), and score
 * exactly as if each had been given the same desc by kata_stream_attach_teacher. */
/* An immutable teacher, built once: its frames' features (the scorer's reference) and joint
 * positions (the ghost's source). Reference-counted inside: every stream it is attached to keeps
 * it alive, so the handle may be destroyed while streams still use it. Since 1.1. */
typedef struct kata_teacher_s* kata_teacher;
/* Builds the teacher desc describes, as kata_stream_attach_teacher would for a stream with the
 * model's stencil: desc->model and exactly one motion are required; desc's per-stream fields
 * (ghost, ghost_across, retarget, alignment_window, tolerance) are kept as the defaults of
 * kata_stream_attach_shared_teacher; on_progress is called on this thread while the features are
 * computed. The model may be destroyed afterwards. Errors (as kata_stream_attach_teacher's, less
 * the ones that need a student stream) return their status with the message in
 * kata_context_last_error; *out is then NULL. *out is owned by the caller. Allocates. Since 1.1.
 * [any thread] */
KATA_API kata_status kata_teacher_create(kata_context context, const kata_teacher_desc* desc, kata_teacher* out);
/* Releases the caller's handle. Streams it is attached to keep the teacher until they detach it,
 * attach another or are destroyed. NULL is ignored. Since 1.1. [any thread, not concurrently with
 * other calls on the same handle] */
KATA_API void kata_teacher_destroy(kata_teacher teacher);
/* Teacher frames the alignment follows (from desc->first_frame to the end; 1 for a one-pose
 * teacher); 0 for NULL. Since 1.1. [any thread] */
KATA_API uint32_t kata_teacher_frame_count(kata_teacher teacher);
/* Seconds between teacher frames (0 for a one-pose teacher or NULL). Since 1.1. [any thread] */
KATA_API double kata_teacher_frame_time(kata_teacher teacher);
/* Bytes the teacher's frames hold (the scorer's reference and the ghost's joint positions): held
 * once however many streams share it. 0 for NULL. Since 1.1. [any thread] */
KATA_API uint64_t kata_teacher_memory_bytes(kata_teacher teacher);
/* Attaches a shared teacher to a stream, as kata_stream_attach_teacher does with the desc the
 * teacher was created from (same scores, matched frames and ghosts, bit for bit), without copying
 * it: the stream takes a reference. options: NULL for the per-stream fields the teacher was
 * created with, or a kata_teacher_desc (kata_teacher_desc_init) whose ghost, ghost_across,
 * retarget, alignment_window and tolerance apply to this stream only (its model and on_progress are ignored;
 * a motion in it is refused). A practice section is set afterwards with
 * kata_stream_set_practice_section, as for any clip teacher. Replaces any teacher; a refused call
 * leaves the old one in place, with the message in kata_stream_last_error (a stream whose stencil
 * is not the model's, a ghost the student's skeleton cannot carry). Allocates the stream's scorer
 * and ghost solver, never the teacher's frames. Since 1.1. [stream owner; any number of streams
 * may attach the same teacher from their own threads at once] */
KATA_API kata_status kata_stream_attach_shared_teacher(kata_stream stream, kata_teacher teacher,
                                                       const kata_teacher_desc* options);

/* kata_body_part (the five parts of a score breakdown) is in kata/result.h. */

/* ==== Score calibration and feedback ====================================================== */
/* The score is the coaching total (docs/model/scores.md "The total"):
 *     score = min(model_score, the lowest part score)      so  score <= the worst part's score
 * a part at 10 cannot hide in a total of 90. Each part's score is a map of its joint angle: the
 * largest angle between one of the student's bones of that part and the teacher's, each bone read
 * in the body frame it hangs from (spine and legs in the hips' frame, head and arms in the chest's),
 * 100 / (1 + (angle / 40 deg)^5), the same map for every part: 15 deg scores 99, 30 deg 81, 45 deg
 * 36, at any joint, either way, left or right. model_score is the model's calibrated map of the
 * learned distance d, 100 / (1 + (d / d50)^slope): it keeps another motion low whatever the
 * angles (for the shipped model a loose gate, d50 0.085, slope 10; good_score 92). A model file without a
 * calibration uses d50 = delta*, slope 2, good_score 75; the part maps d50_p, slope_p of the
 * struct below are kept for old readers and no longer read by the scorer.
 * part_to_fix (averaged over 0.5 s): while the lowest part score's average or the total's is
 * below good_score, the part with the lowest averaged score, unless a part scoring below 99 within
 * 30 points of it has its joints farther from the teacher's (averaged local-frame mean joint distance,
 * the torso's counted 3.25 times while it is below good_score; equal scores rank the same way); named
 * at once when nothing is named; another part (or none) replaces a named one only after holding for
 * 0.3 s, so cues do not flicker (docs/model/scores.md "The part to fix and the cue").
 * The correction cue (cue_joint, cue_degrees, cue_action; present iff part_to_fix >= 0) says what
 * to change in that part, as a coach does: "left knee: bend 30 deg more". cue_joint is the joint
 * to move (a bone turns about the joint at its start: a bent knee names LKnee), the one of the
 * part whose bone is farthest from the teacher's, measured at the joint (a forearm or shin
 * against its upper arm or thigh, so a turned hip names the hip, not the knee as well);
 * cue_degrees that angle. Both averaged like the part scores and held like the part: named at once
 * with a new part, replaced within a part only after 0.3 s. cue_action from the body frame: knees
 * and elbows bend / straighten (the inner angle), shoulders and hips raise / lower (the bone's
 * height), the chest and lower back bend / straighten (the forward lean), the neck raises /
 * lowers the head; "turn" when most of the angle is sideways or a twist (docs/model/scores.md "The cue").
 * The record's state (kata_score_state, kata/result.h) says when there is no score to show. */

/* The GPD joint name of joint 0..15 ("Hip", "Chest", "Neck", "Head", "LShoulder", "LElbow",
 * "LHand", "RShoulder", "RElbow", "RHand", "LHip", "LKnee", "LFoot", "RHip", "RKnee", "RFoot":
 * spec GPD v1 order), e.g. of a record's cue_joint; NULL out of range. A static string. Does not
 * allocate. [any thread] */
KATA_API const char* kata_gpd_joint_name(int32_t joint);
/* The kata_body_part GPD joint 0..15 belongs to (kata/result.h lists each part's joints: the
 * parts a record's parts and part_scores split the score into), or -1 out of range. Since 1.1.
 * [any thread] */
KATA_API int32_t kata_gpd_joint_part(int32_t joint);
/* The short name of a kata_body_part ("torso_head", "left_arm", "right_arm", "left_leg",
 * "right_leg"), e.g. of a record's part_to_fix; NULL out of range. A static string. Since 1.1.
 * [any thread] */
KATA_API const char* kata_body_part_name(int32_t part);
/* GPD joint 0..15 in the words kata_cue_text starts its phrase with, lower case ("lower back",
 * "chest", "neck", "left shoulder", "left elbow", "right shoulder", "right elbow", "left hip",
 * "left knee", "right hip", "right knee"), e.g. for "joint to move most often: left knee"; "" for
 * the five end joints (Head, LHand, RHand, LFoot, RFoot), which no cue names (a bone turns about
 * the joint at its start); NULL out of range. A static string. Since 1.1. [any thread] */
KATA_API const char* kata_gpd_joint_words(int32_t joint);
/* The record's correction cue in English into buf ("left knee: bend 30 deg more", "right
 * shoulder: raise 25 deg"; lower-case joint words, whole degrees), "" when it has none (no cue,
 * or a record whose struct_size predates the cue). Writes at most size bytes with the
 * terminating 0 (truncated to fit; 64 bytes always suffice) and returns the phrase's length, as
 * snprintf does; buf may be NULL when size is 0. Does not allocate. [any thread] */
KATA_API size_t kata_cue_text(const kata_result_record* record, char* buf, size_t size);

/* A score map. The caller sets struct_size = sizeof(kata_score_calibration). */
typedef struct kata_score_calibration {
  uint32_t struct_size;              /* sizeof(kata_score_calibration), set by the caller */
  uint32_t reserved;                 /* 0 */
  double d50;                        /* distance that scores 50, > 0 */
  double slope;                      /* > 0 */
  double part_d50[KATA_PART_COUNT];  /* per kata_body_part, > 0 */
  double part_slope[KATA_PART_COUNT];/* per kata_body_part, > 0 */
  double good_score;                 /* 0..100: at or above it (total and part) no part is named */
} kata_score_calibration;

/* The model's calibration (or the default above) into *out. KATA_E_INVALID_ARGUMENT when
 * out->struct_size is below 1.0's struct (see Versions). Does not allocate. [any thread] */
KATA_API kata_status kata_model_calibration(kata_model model, kata_score_calibration* out);
/* Overrides the calibration of the stream's current teacher (e.g. fitted on a teacher's own
 * takes); NULL restores the model's. Attaching a new teacher returns to the model's calibration.
 * KATA_E_STATE without a teacher; KATA_E_INVALID_ARGUMENT for a value out of range (message
 * in kata_stream_last_error). Takes effect from the next scored frame; kept across
 * kata_stream_restart_teacher. Allocates. [stream owner] */
KATA_API kata_status kata_stream_set_calibration(kata_stream stream, const kata_score_calibration* calibration);

/* Practice modes on a clip teacher: from the next frame the stream follows only the teacher's
 * frames first_frame..last_frame (0-based, as matched_teacher_frame; last_frame -1: the clip's
 * end), so first_frame alone is "start here"; loop != 0 joins the section's end to its start (a
 * section practised over and over: never "teacher finished"). The alignment restarts; the score
 * calibration is kept. KATA_E_STATE without a teacher (or with a one-pose teacher),
 * KATA_E_INVALID_ARGUMENT for a section outside the clip (nothing changes). Allocates: call it
 * between frames. [stream owner] */
KATA_API kata_status kata_stream_set_practice_section(kata_stream stream, int32_t first_frame, int32_t last_frame,
                                                      int32_t loop);

/* ##############################################################################################
 * Task 3 - read results: every pushed frame's score, matched teacher frame and ghost
 *
 * kata_result_record r[64];  uint32_t n;
 * r[0].struct_size = sizeof r[0];
 * kata_stream_read_results(s, r, NULL, 0, NULL, 0, 64, &n);  -- every frame, oldest first
 * kata_stream_read_newest(s, r, NULL, 0, NULL, 0);           -- or only the newest
 * draw(r[0].score, r[0].part_to_fix, r[0].matched_teacher_frame);
 * ############################################################################################ */

/* ==== Results ================================================================== */
/* Each result is one kata_result_record (kata/result.h): here stream_id and published_ns are 0,
 * frame_sequence = frame_index, ghost NULL (ghosts go to the caller's array), has_practice 0. */

/* Moves every unread result, oldest first (at most `capacity`), to the caller's arrays and sets
 * *count. Each array may be NULL except results:
 *   results  capacity entries of results[0].struct_size bytes (set it to sizeof(kata_result_record));
 *   ghosts   ghost_capacity floats: entry i at i x 3 x kata_stream_ghost_joint_count() (x, y, z
 *            per ghost joint, the student's units, placed over the student; zeros without one);
 *   features feature_capacity floats: entry i at i x KATA_GPD_DIMS (needs desc.keep_features).
 * KATA_E_BUFFER_TOO_SMALL (nothing moved) when ghosts or features hold fewer than capacity
 * entries. *count = 0 and KATA_OK when nothing is unread. Does not allocate. [stream owner] */
KATA_API kata_status kata_stream_read_results(kata_stream stream, kata_result_record* results, float* ghosts, size_t ghost_capacity, float* features,
                                              size_t feature_capacity, uint32_t capacity, uint32_t* count);
/* The newest result, for a caller that only draws the latest frame: the newest unread result
 * into *result (result->struct_size set by the caller) and, each when not NULL, its ghost (ghost_capacity >= 3 x kata_stream_ghost_joint_count() floats)
 * and features (feature_capacity >= KATA_GPD_DIMS floats; needs desc.keep_features). Every older
 * unread result is passed over (marked read; not counted as dropped): the same as draining the
 * ring with kata_stream_read_results and keeping the last entry. KATA_NO_DATA (nothing written)
 * when nothing is unread: no new result since the last read. Does not allocate. [stream owner] */
KATA_API kata_status kata_stream_read_newest(kata_stream stream, kata_result_record* result, float* ghost, size_t ghost_capacity, float* features,
                                             size_t feature_capacity);
/* The repetitions (kata/result.h kata_repetition) the stream's clip teacher saw end since the last
 * call, oldest first, at most `capacity` into repetitions[] (entries of repetitions[0].struct_size
 * bytes: set it to sizeof(kata_repetition)); *count says how many. The stream keeps the newest 16:
 * read at least that often (each result's repetition field says when one ended). stream_id is 0.
 * *count = 0 and KATA_OK without a clip teacher or a new repetition; a new teacher's repetitions
 * are read from its first. Since 1.1. Does not allocate. [stream owner] */
KATA_API kata_status kata_stream_read_repetitions(kata_stream stream, kata_repetition* repetitions, uint32_t capacity,
                                                  uint32_t* count);
/* Results overwritten before they were read (a full ring), since the stream was opened; 0 for
 * NULL. [stream owner] */
KATA_API uint64_t kata_stream_results_dropped(kata_stream stream);
/* Unread results in the ring; 0 for NULL. [stream owner] */
KATA_API uint32_t kata_stream_results_pending(kata_stream stream);
/* Joints of the stream's ghosts (0 without a ghost). [stream owner] */
KATA_API uint32_t kata_stream_ghost_joint_count(kata_stream stream);
/* For ghost joint i, the index of the student skeleton joint it stands for (-1 when out of
 * range). [stream owner] */
KATA_API int32_t kata_stream_ghost_joint_source(kata_stream stream, uint32_t i);

#ifdef __cplusplus
}
#endif

#endif /* KATA_TEACHER_H */
