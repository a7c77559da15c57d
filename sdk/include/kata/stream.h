/* kata/stream.h: task 1, open a stream: skeletons, clips, layouts and a live stream of frames
 * in and GPD v1 features out.
 *
 * Part of the C ABI; include "kata/kata.h" (all of it) or this header alone: it includes what it
 * needs. kata.h states the conventions every function here follows. */
#ifndef KATA_STREAM_H
#define KATA_STREAM_H

#include "core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ##############################################################################################
 * Task 1 - open a stream: skeletons, clips, a live stream of frames in and GPD features out
 *
 * kata_context ctx;  kata_clip clip;  kata_skeleton skel;  kata_stream s;  kata_stream_desc d;
 * kata_context_create(&ctx);  kata_clip_load_bvh(ctx, "data/cmu/02_01.bvh", &clip);
 * kata_clip_skeleton(clip, &skel);  kata_stream_desc_init(&d);  d.layout = "cmu";
 * kata_stream_open(ctx, skel, &d, &s);                           -- allocates, once
 * kata_stream_push(s, t, xyz, kata_skeleton_joint_count(skel));  -- per frame: no allocation
 * ############################################################################################ */

/* ==== Skeletons =========================================================================== */

/* An immutable joint tree: names, parents, rest offsets. */
typedef struct kata_skeleton_s* kata_skeleton;

/* Builds a skeleton from arrays of joint_count entries. Joints must be in topological order
 * (parents[0] = -1, 0 <= parents[i] < i). rest_offsets (joint_count x 3, offset from the
 * parent, input units; the root's is its rest position) may be NULL for a bare live source:
 * the body height is then estimated from the first frames (see kata_stream_desc). The arrays
 * are copied. [any thread] */
KATA_API kata_status kata_skeleton_create(kata_context context, uint32_t joint_count, const char* const* names,
                                          const int32_t* parents, const double* rest_offsets,
                                          kata_skeleton* out);
/* Reads the skeleton (HIERARCHY) of a BVH file (found as kata_clip_load_bvh finds it). [any thread] */
KATA_API kata_status kata_skeleton_load_bvh(kata_context context, const char* path, kata_skeleton* out);
/* Releases a skeleton. Streams opened on it keep their own copy. NULL is ignored. */
KATA_API void kata_skeleton_destroy(kata_skeleton skeleton);
/* Number of joints; 0 for NULL. [any thread] */
KATA_API uint32_t kata_skeleton_joint_count(kata_skeleton skeleton);
/* Name of joint i (owned by the skeleton), or NULL when out of range. [any thread] */
KATA_API const char* kata_skeleton_joint_name(kata_skeleton skeleton, uint32_t i);
/* Parent of joint i (-1 for the root, -2 when out of range). [any thread] */
KATA_API int32_t kata_skeleton_joint_parent(kata_skeleton skeleton, uint32_t i);
/* Rest offset of joint i from its parent (the root's: its rest position), skeleton units, into
 * out[3]. KATA_E_STATE for a skeleton without rest offsets (a bare live source),
 * KATA_E_INVALID_ARGUMENT when i is out of range. For forward kinematics of
 * kata_retargeter_local_rotations. [any thread] */
KATA_API kata_status kata_skeleton_joint_offset(kata_skeleton skeleton, uint32_t i, double* out);

/* ==== Clips (recorded motion) ============================================================== */

/* A recorded motion (a BVH file) with its skeleton; immutable. */
typedef struct kata_clip_s* kata_clip;

/* Loads a BVH file. A malformed file is refused with KATA_E_PARSE and a message naming the
 * file and line; a directory, special file or a file over KATA_MAX_BVH_BYTES with KATA_E_IO.
 * A relative path not found from the current folder is looked for in the share/kata folder
 * beside libkata (the shipped clips, "data/cmu/05_18.bvh", as the CLI finds them); found
 * nowhere: KATA_E_IO naming every folder looked in. [any thread] */
KATA_API kata_status kata_clip_load_bvh(kata_context context, const char* path, kata_clip* out);
/* Releases a clip. NULL is ignored. */
KATA_API void kata_clip_destroy(kata_clip clip);
/* Number of frames (frame 0 included); 0 for NULL. [any thread] */
KATA_API uint32_t kata_clip_frame_count(kata_clip clip);
/* Seconds between frames; 0 for NULL. [any thread] */
KATA_API double kata_clip_frame_time(kata_clip clip);
/* The clip's skeleton as a new handle (owned by the caller). [any thread] */
KATA_API kata_status kata_clip_skeleton(kata_clip clip, kata_skeleton* out);
/* World positions of every joint at `frame` by forward kinematics: writes joint_count x 3
 * floats (x, y, z interleaved, file units) to out, which holds `capacity` floats.
 * KATA_E_BUFFER_TOO_SMALL when capacity < 3 * joint count. Does not allocate. [any thread] */
KATA_API kata_status kata_clip_positions(kata_clip clip, uint32_t frame, float* out, size_t capacity);

/* ---- Landmark recordings (since 1.1) ----
 * A landmark array recorded from a layout's source (a webcam's MediaPipe landmarks, `kata coach
 * --record-teacher`), to give to kata_teacher_desc as skeleton (kata_skeleton_create_layout) +
 * positions: a NumPy .npy of shape (frames, joints, 3), (frames, joints, 4) (x, y, z, confidence)
 * or (frames, joints, 5) (MediaPipe's x, y, z, visibility, presence), or a CSV with one row per
 * frame of joints x 3, 4 or 5 numbers, optionally after a leading timestamp column (a first line
 * that is not numeric is a header). Timing: the CSV's timestamp column, or for "X.npy" a 1-D
 * "X.times.npy" beside it; else `fps`. Immutable. */
typedef struct kata_landmarks_s* kata_landmarks;
/* Loads a landmark recording of a built-in layout whose joint list kata_skeleton_create_layout
 * gives ("mediapipe", "gpd", "azure-kinect", "xsens"; the joints in its order). fps: the frame
 * rate of a recording without timestamps (> 0; ignored with timestamps). time_units: the
 * timestamps' units, KATA_TIME_SECONDS, KATA_TIME_MILLISECONDS, or -1 to infer them as
 * kata_time_units_detect does. Errors (KATA_E_IO, KATA_E_PARSE with the file and line,
 * KATA_E_NOT_FOUND for an unknown layout, KATA_E_INVALID_ARGUMENT for a missing fps, timestamps
 * that do not increase or ambiguous units) name the file on the context. *out is owned by the
 * caller. [any thread] */
KATA_API kata_status kata_landmarks_load(kata_context context, const char* path, const char* layout, double fps,
                                         int32_t time_units, kata_landmarks* out);
/* Releases a recording. NULL is ignored. */
KATA_API void kata_landmarks_destroy(kata_landmarks landmarks);
/* Frames; 0 for NULL. [any thread] */
KATA_API uint32_t kata_landmarks_frame_count(kata_landmarks landmarks);
/* Joints per frame (the layout's); 0 for NULL. [any thread] */
KATA_API uint32_t kata_landmarks_joint_count(kata_landmarks landmarks);
/* Seconds between frames: with timestamps their median step (the upper of the middle two for an
 * even count of steps), else 1 / fps; 0 for NULL. [any thread] */
KATA_API double kata_landmarks_frame_time(kata_landmarks landmarks);
/* Frame `frame`'s capture time, seconds from the first frame (frame x frame_time without
 * timestamps); -1 out of range or for NULL. [any thread] */
KATA_API double kata_landmarks_capture_time(kata_landmarks landmarks, uint32_t frame);
/* Every frame's positions, frames x joints x 3 floats (x, y, z as recorded: the layout's units and
 * axes), owned by the recording (valid until kata_landmarks_destroy); NULL for NULL. [any thread] */
KATA_API const float* kata_landmarks_positions(kata_landmarks landmarks);

/* ==== Streams ============================================================================= */

/* A live pose stream: frames in, GPD v1 features (and, when set up, scores and ghosts) out. */
typedef struct kata_stream_s* kata_stream;

/* Finite-difference stencil of the kinetics block (spec section 5). */
typedef enum kata_stencil {
  KATA_STENCIL_BACKWARD = 0, /* derivatives at the newest frame (no latency; the default) */
  KATA_STENCIL_CENTRAL = 1   /* derivatives one frame behind (more accurate velocity) */
} kata_stencil;

/* How a stream reads its frames' axes (kata_stream_desc.up_axis). */
typedef enum kata_up_axis {
  KATA_UP_Y = 0,     /* +Y up (BVH, most engines) */
  KATA_UP_Z = 1,     /* +Z up: (x, y, z) is read as (x, z, -y) */
  KATA_UP_Y_DOWN = 2 /* a camera frame, x right, y down, z away from the camera (MediaPipe world
                        landmarks, Azure Kinect): (x, y, z) is read as (x, -y, -z), a rotation of
                        180 degrees about x (never a mirror) */
} kata_up_axis;

/* ---- Layouts ----
 * A layout says how a source's joints become the 16 GPD joints: a built-in name map ("cmu",
 * "kinect2", ...: kata_layout_name lists them), a name-map file, or one of these:
 *   "gpd": the identity, for a source that already names the 16 GPD joints ("Hip", "Chest",
 *          "Neck", "Head", "LShoulder", "LElbow", "LHand", "RShoulder", "RElbow", "RHand",
 *          "LHip", "LKnee", "LFoot", "RHip", "RKnee", "RFoot": spec GPD v1 order);
 *   "mediapipe": MediaPipe Pose world landmarks: the 33 landmarks in MediaPipe's documented order
 *          (0 nose, 1-6 eyes, 7 left_ear, 8 right_ear, 9-10 mouth, 11 left_shoulder,
 *          12 right_shoulder, 13-14 elbows, 15-16 wrists, 17-22 pinky/index/thumb, 23 left_hip,
 *          24 right_hip, 25-26 knees, 27-28 ankles, 29-30 heels, 31-32 foot_index; names
 *          "nose", "left_eye_inner", ... as in MediaPipe's guide), in metres with the origin at
 *          the midpoint of the hips, axes as the Pose Landmarker emits world landmarks: x to the
 *          image's right, y down, z away from the camera (MediaPipe documents world landmarks in
 *          metres, origin at the centre of the hips, "the smaller the [z] value the closer the
 *          landmark is to the camera"; x and y follow the image axes). A stream with this layout
 *          always reads frames in these axes (up_axis is ignored) and smooths by default.
 *          Pelvis, chest, neck and head have no landmark and are synthesised; with h = midpoint
 *          of the hips (23, 24), s = midpoint of the shoulders (11, 12), e = midpoint of the ears
 *          (7, 8), f = (l_hip - r_hip) x (s - h) / |l_hip - r_hip| (points forward, |f| = |s - h|):
 *            Hip = h + 0.264 (s - h) - 0.07 f,  Chest = h + 0.868 (s - h),
 *            Neck = (Chest + e) / 2,  Head = e.
 *          (Fitted so they land where the "cmu" layout's Hips, Spine1, Neck1 and Head sit on CMU
 *          mocap, so a webcam student and a CMU teacher are compared on the same joints.) A
 *          synthesised joint's confidence is the smallest of its landmarks'. World landmarks have
 *          no floor: each frame the floor under the Hip height is the lowest of landmarks 27..32
 *          (ankles, heels, foot indices), so a jump does not raise the Hip height.
 * Pass visibility as the per-joint confidence (kata_stream_push_confidence), or MediaPipe's
 * whole frame (x, y, z, visibility, presence; milliseconds) to kata_stream_push_landmarks. */

/* The name of built-in layout i ("cmu", ..., "gpd", ..., "mediapipe"), or NULL past the last.
 * [any thread] */
KATA_API const char* kata_layout_name(uint32_t i);
/* The joint list of a built-in layout as a skeleton without rest pose, for a source that sends
 * bare landmark arrays: "mediapipe" (33 landmarks, named as above, in order), "gpd" (the 16
 * GPD joints, spec parents), "azure-kinect" (Azure Kinect Body Tracking's 32 joints in
 * k4abt_joint_id_t order, named "PELVIS", "SPINE_NAVEL", ...: millimetres, camera axes, so stream
 * with KATA_UP_Y_DOWN) or "xsens" (Xsens MVN's 23 segments, "Pelvis", "L5", ..., MVN order;
 * metres, Z up: KATA_UP_Z), "cmu" (a CMU BVH's 31 joints) or "vrm" (the 22 VRM humanoid bones a VMC
 * performer sends, KATA_VMC_JOINTS in kata/vmc.h; metres, +Y up). KATA_E_NOT_FOUND for other names (build their skeleton with
 * kata_skeleton_create from the source's joint names). *out is owned by the caller. [any thread] */
KATA_API kata_status kata_skeleton_create_layout(kata_context context, const char* layout, kata_skeleton* out);

/* How a stream maps and treats its input. Fill with kata_stream_desc_init, then change fields.
 * Starts with struct_size so later versions can grow it. */
typedef struct kata_stream_desc {
  uint32_t struct_size;        /* sizeof(kata_stream_desc) */
  /* Joint map onto the 16 GPD joints: a built-in layout's name ("cmu", see kata_layout_name), or NULL
   * and a name-map file (JSON {"Hip": "pelvis", ...} or "Hip = pelvis" lines, at most
   * KATA_MAX_NAME_MAP_BYTES). Both set is refused (KATA_E_INVALID_ARGUMENT). */
  const char* layout;
  const char* name_map_path;   /* a name-map file's path, or NULL (see layout) */
  kata_stencil stencil;        /* default KATA_STENCIL_BACKWARD; other values are refused */
  kata_up_axis up_axis;        /* default KATA_UP_Y; other values are refused */
  double max_gap;              /* seconds (> 0); a larger gap restarts the kinetics. Default 0.25 */
  uint32_t history_capacity;   /* frames kept in the ring buffer (4..KATA_MAX_HISTORY). Default 16 */
  /* Body height H in input units: KATA_MIN_BODY_HEIGHT..KATA_MAX_COORDINATE, or 0 (default):
   * from the skeleton's rest pose when it has one, else the median over the first
   * calibration_frames frames (held until then; a collapsed body gives H = 1 input unit).
   * Negative, NaN or out-of-range values are refused (KATA_E_INVALID_ARGUMENT). */
  double body_height;
  uint32_t calibration_frames; /* 1..history_capacity - 1 when H is estimated. Default 8 */
  uint32_t result_capacity;    /* results kept until read (kata_stream_read_results). Default 64 */
  int32_t keep_features;       /* 1: each result also keeps its feature vector. Default 0 */
} kata_stream_desc;

/* Fills the first struct_size bytes of desc with the defaults above and sets desc->struct_size
 * to the smaller of struct_size and sizeof(kata_stream_desc): nothing past the caller's own struct is
 * written, so a caller built against an older kata.h (a smaller struct) is safe with a
 * newer library, which then reads only that much (the later fields keep their defaults).
 * struct_size below 4 writes nothing. Bindings that declare the struct themselves (ctypes,
 * P/Invoke) pass their own size. [any thread] */
KATA_API void kata_stream_desc_init_sized(kata_stream_desc* desc, uint32_t struct_size);
/* Fills *desc with the defaults for the caller's own struct: kata_stream_desc_init_sized(desc, sizeof *desc). */
#define kata_stream_desc_init(desc) kata_stream_desc_init_sized((desc), (uint32_t)sizeof *(desc))

/* Opens a stream for frames of `skeleton`: a pipeline that runs every feature vector the stream
 * emits through the score and the ghost of an attached teacher (kata_stream_attach_teacher) in
 * the push that emitted it, and keeps each result in a ring until read (kata_stream_read_results).
 * Allocates all its memory now. The skeleton is
 * copied; it may be destroyed afterwards. Errors (unknown layout, a mapped joint missing from
 * the skeleton, bad values) are reported on the context. desc->struct_size: 1.0's size or more
 * (see Versions). [any thread] */
KATA_API kata_status kata_stream_open(kata_context context, kata_skeleton skeleton, const kata_stream_desc* desc,
                                      kata_stream* out);
/* kata_stream_open with a name map held in memory (the contents of a name-map file: JSON
 * {"Hip": "pelvis", ...} or "Hip = pelvis" lines; copied) instead of desc->layout and
 * desc->name_map_path. Errors name the map "<name map>" and its line. [any thread] */
KATA_API kata_status kata_stream_open_name_map(kata_context context, kata_skeleton skeleton,
                                               const kata_stream_desc* desc, const char* name_map_text,
                                               kata_stream* out);
/* Destroys a stream and frees its memory. NULL is ignored. [stream owner] */
KATA_API void kata_stream_destroy(kata_stream stream);
/* The message of the last failed call on this stream, or "". [stream owner] */
KATA_API const char* kata_stream_last_error(kata_stream stream);

/* Pushes one frame: timestamp in seconds (must increase), positions of every joint of the
 * stream's skeleton (joint_count x 3 floats, x, y, z interleaved, input units). A refused frame
 * (KATA_E_NULL_POINTER, KATA_E_WRONG_JOINT_COUNT, KATA_E_NON_FINITE,
 * KATA_E_TIMESTAMP_NOT_INCREASING, KATA_E_INVALID_ARGUMENT) changes nothing; the stream stays
 * usable. Plausibility range (the message names the joint):
 * - the timestamp must be at least KATA_MIN_TIME_STEP after the previous accepted frame's
 *   (else KATA_E_TIMESTAMP_NOT_INCREASING; merge such frames before pushing) and at most
 *   KATA_MAX_TIME_STEP after it (else KATA_E_INVALID_ARGUMENT: no live source pauses for 11.6
 *   days; a clock in other units, or a source restarted without kata_stream_reset);
 * - every coordinate of a mapped joint (one of the 16 GPD joints' sources) must be within
 *   +-KATA_MAX_COORDINATE input units (else KATA_E_INVALID_ARGUMENT);
 * - once H is known, every mapped joint must be within KATA_MAX_REACH body heights of the hip
 *   (else KATA_E_INVALID_ARGUMENT): a tracker glitch is refused, not turned into features.
 * Joints no GPD joint reads are only checked for NaN/Inf. KATA_E_INTERNAL (a bug) when a
 * computed vector is not finite: it is withheld. Does not allocate. [stream owner] */
KATA_API kata_status kata_stream_push(kata_stream stream, double timestamp, const float* positions,
                                      uint32_t joint_count);
/* kata_stream_push with a confidence per joint (joint_count floats, e.g. MediaPipe's
 * visibility; NULL = all confident). A joint below the desc's confidence_threshold, with a NaN
 * confidence or a NaN/Inf coordinate is missing: held at its last good position for up to
 * max_hold seconds (it never reaches the features as NaN). Returns KATA_OK, KATA_TRACKING_LOST
 * (too many joints missing, or one missing too long: the frame is accepted without features;
 * kata_stream_last_error says which) or the errors of kata_stream_push. Does not allocate.
 * [stream owner] */
KATA_API kata_status kata_stream_push_confidence(kata_stream stream, double timestamp, const float* positions,
                                                 const float* confidences, uint32_t joint_count);
/* Pushes `frames` frames at once, as kata_stream_push_confidence would one by one: frame i at
 * timestamps[i] (seconds), its joint_count x 3 floats at positions + i x 3 x joint_count, its
 * confidences at confidences + i x joint_count (NULL: all confident). A frame reported
 * KATA_TRACKING_LOST is accepted and counted in *tracking_lost (may be NULL). Stops at the first
 * frame refused: returns its status with *pushed (may be NULL) = its index (the frames before it
 * were pushed; kata_stream_last_error says why); else KATA_OK with *pushed = frames. For bindings
 * whose per-call cost exceeds the push's (Python: one call per chunk). Does not allocate.
 * [stream owner] */
KATA_API kata_status kata_stream_push_many(kata_stream stream, const double* timestamps, const float* positions,
                                           const float* confidences, uint32_t joint_count, uint32_t frames,
                                           uint32_t* pushed, uint32_t* tracking_lost);
/* Units of a source's timestamps (kata_stream_push_landmarks). Values are never reused. */
typedef enum kata_time_units {
  KATA_TIME_SECONDS = 0,      /* kata's own unit (every other push) */
  KATA_TIME_MILLISECONDS = 1  /* MediaPipe's (timestamp_ms, performance.now()) */
} kata_time_units;
/* kata_stream_push_confidence for a landmark source's own frame shape: `values` holds joint_count
 * x channels floats, joint by joint: channels 3 (x, y, z: all confident), 4 (x, y, z, confidence)
 * or 5 (MediaPipe's x, y, z, visibility, presence: the joint's confidence is the smaller of
 * visibility and presence, so a joint counts only when it is both in the picture and unoccluded;
 * NaN in either makes it missing). The timestamp is in `units` (converted to seconds: results
 * carry seconds). KATA_E_INVALID_ARGUMENT for other channel counts or units (nothing changed),
 * KATA_E_WRONG_JOINT_COUNT when joint_count is not the stream's, else as
 * kata_stream_push_confidence. Does not allocate (the stream holds its scratch). [stream owner] */
KATA_API kata_status kata_stream_push_landmarks(kata_stream stream, double timestamp, kata_time_units units,
                                                const float* values, uint32_t joint_count, uint32_t channels);
/* The units of a recorded source's timestamps (count >= 2, increasing) from the median step
 * between frames: plausible camera and mocap rates are 2..1000 Hz, i.e. a step of 0.001..0.5 in
 * seconds or 1..500 in milliseconds (the ranges do not overlap). A step that fits neither,
 * timestamps that do not increase, or frame numbers (0 or 1, then every step exactly 1) are
 * refused (KATA_E_INVALID_ARGUMENT, the reason in
 * kata_context_last_error): state the units instead of guessing. Fewer than two timestamps:
 * KATA_TIME_SECONDS. [any thread] */
KATA_API kata_status kata_time_units_detect(const double* timestamps, size_t count, kata_time_units* out);
/* Confidence gate of kata_stream_push_confidence: a GPD joint (confidence = smallest of the input
 * joints it reads) below `threshold` (default 0.5), NaN, or with a non-finite coordinate is
 * missing and held at its last good position for at most `max_hold` seconds (default 0.5). A
 * frame with a joint missing for longer, or with more than max_missing_share x 16 joints missing
 * (default 0.25: more than 4), returns KATA_TRACKING_LOST: no features, the kinetics restart at
 * the next good frame. Takes effect at the next push. Does not allocate. [stream owner] */
KATA_API kata_status kata_stream_set_confidence_gate(kata_stream stream, float threshold, double max_hold,
                                                     double max_missing_share);
/* One-Euro filter (Casiez, Roussel, Vogel, CHI 2012) on the 16 mapped joints, before features
 * (the kinetics see the filtered positions): per coordinate, cutoff = min_cutoff + beta x |speed|
 * (Hz; speed in input units per second, itself low-passed at d_cutoff Hz). On by default for the
 * "mediapipe" layout (min_cutoff 2 Hz, beta 1.0 per m/s, d_cutoff 1 Hz: the best of a sweep on
 * CMU motion as landmarks with 1 cm noise), off otherwise (mocap is clean). enabled: 0 or 1. The
 * filter restarts at every segment start. Does not allocate. [stream owner] */
KATA_API kata_status kata_stream_set_smoothing(kata_stream stream, int32_t enabled, double min_cutoff, double beta,
                                               double d_cutoff);
/* Frames reported KATA_TRACKING_LOST so far. [stream owner] */
KATA_API int64_t kata_stream_lost_frames(kata_stream stream);
/* Bone lengths of the GPD tree estimated from the live frames: the first 60 frames whose 16 joints
 * are all good (2 s at 30 fps; unfiltered positions) give, per bone g (input units, GPD joint
 * order, lengths[0] = 0), with d = joint g - parent g per frame:
 *   lengths[g] = sqrt(mean|d|^2 - 3 s^2),  s^2 = median over consecutive frames of
 *                |d[t-1] - 2 d[t] + d[t+1]|^2 / (6 x 2.366)
 * (position noise lengthens a measured bone: s^2, each coordinate's noise variance, comes from
 * the second differences, where the motion's share is negligible at 30..120 Hz; the mean skips
 * frames whose |d| is more than 4 spreads from the median; the correction is capped at a
 * quarter of mean|d|^2), and spread[g] = 1.4826 x the median absolute deviation of |d|. Either
 * pointer may be NULL; capacity = entries of each array (>= KATA_GPD_JOINTS). KATA_NO_DATA until
 * those 60 frames were seen. [stream owner] */
KATA_API kata_status kata_stream_bone_lengths(kata_stream stream, double* lengths, double* spread, size_t capacity);
/* Ends the current segment (end of a take): with the central stencil the held frame is
 * computed now with the backward formulas. The next frame starts a new segment. With a clip
 * teacher it also ends the repetition in progress (complete if it reached the section's end, else
 * partial: kata_stream_read_repetitions). KATA_E_INTERNAL as for kata_stream_push. [stream owner] */
KATA_API kata_status kata_stream_flush(kata_stream stream);
/* The next frame starts a new segment (kinetics restart). [stream owner] */
KATA_API kata_status kata_stream_reset(kata_stream stream);

/* Copies the newest feature vector (KATA_GPD_DIMS floats) into out (capacity floats), with the
 * timestamp and the 0-based index of the frame it belongs to (either may be NULL). With the
 * central stencil it is one frame behind the newest push. KATA_NO_DATA before the first vector.
 * Does not allocate. [stream owner] */
KATA_API kata_status kata_stream_features(kata_stream stream, float* out, size_t capacity, double* timestamp,
                                          int64_t* frame_index);
/* Number of feature vectors computed so far (grows by at most one per push once calibrated).
 * [stream owner] */
KATA_API int64_t kata_stream_feature_count(kata_stream stream);
/* The stream's body height H in input units (0 while calibrating). [stream owner] */
KATA_API double kata_stream_body_height(kata_stream stream);
/* The index of the stream skeleton's joint that the stream reads as GPD joint 0..15 (spec GPD v1
 * order, kata_gpd_joint_name) under its layout or name map; -1 for a GPD joint the layout
 * synthesises from several joints ("mediapipe"'s Hip, Chest, Neck, Head), for gpd_joint out of
 * range and for NULL. E.g. an app colours the student's own joints by body part
 * (kata_gpd_joint_part) or finds which way the body faces from the hips. Since 1.1. Does not
 * allocate. [stream owner] */
KATA_API int32_t kata_stream_gpd_joint_source(kata_stream stream, uint32_t gpd_joint);

#ifdef __cplusplus
}
#endif

#endif /* KATA_STREAM_H */
