/*
 * kata.h - the C ABI of kata, a real-time SDK for 3D human pose: GPD v1 features on live
 * streams, scoring against a teacher with a learned metric, and retargeting.
 *
 * Reading order: the basics (versions, limits, status codes, context), then one group per task,
 * each opening with an example: 1 open a stream, 2 attach a teacher, 3 read results, 4 retarget,
 * 5 run many streams, 6 read messages; the deprecated calls last.
 *
 * Conventions (they hold for every function below unless it says otherwise):
 * - Every fallible call returns a kata_status. KATA_OK is 0; KATA_NO_DATA is a result, not an
 *   error. Values are never reassigned; new ones are only added.
 * - Handles are opaque pointers. The caller owns what a *_create/_open/_load call returns and
 *   releases it with the matching *_destroy/_close/_free call (which accept NULL).
 * - After a failed call, kata_*_last_error(handle) returns a readable message for the handle
 *   the call was made on (a context for calls that create objects). The text stays valid
 *   until the next call on that handle.
 * - No exception ever crosses this boundary.
 * - Threads: a context may be used from any thread. A stream (and everything attached to it)
 *   is used by one thread at a time; different streams run on different threads in parallel
 *   with no shared lock. Skeletons and clips are immutable once created and may be read from
 *   any thread.
 * - Memory: kata_stream_open allocates everything a stream needs. kata_stream_push and the
 *   stream readers never allocate.
 * - Units: time in seconds; positions in the units of the input (a BVH file's units), +Y up
 *   unless the stream says otherwise; features in body heights (spec GPD v1).
 * - Strings from the caller (presets, paths, keys) are read up to KATA_MAX_STRING_BYTES: one
 *   without a terminating NUL within that bound is refused with KATA_E_INVALID_ARGUMENT.
 *   Messages quote caller text cut to a bounded length.
 * - Files: a path that is a directory, a FIFO, a device or a socket, or a file larger than the
 *   loader's bound (below), is refused with KATA_E_IO naming the path before anything is read.
 * - Outputs are finite: every feature vector and score is checked before it is returned; a
 *   non-finite value would be a bug in kata, and is withheld and reported as KATA_E_INTERNAL.
 * - Caller errors that cannot be detected: passing a handle after it was destroyed (use after
 *   destroy, double destroy), a handle of another type cast to this one, buffers smaller than
 *   the count passed with them, or calls on one stream from two threads at once. These are
 *   undefined behaviour, as with free() in C; the sanitizer build (KATA_SANITIZE) reports most.
 */
#ifndef KATA_KATA_H
#define KATA_KATA_H

#include <stddef.h>
#include <stdint.h>

#include "result.h" /* kata_result_record, kata_body_part, kata_score_state */

#if defined(_WIN32)
#  if defined(KATA_BUILDING_SHARED)
#    define KATA_API __declspec(dllexport)
#  else
#    define KATA_API __declspec(dllimport)
#  endif
#else
#  define KATA_API __attribute__((visibility("default")))
#endif

/* Deprecated calls still work as documented until the release named in their comment; the
 * compiler warns at each use. Define KATA_ALLOW_DEPRECATED before including kata.h to silence the
 * warnings (e.g. while moving a code base over). */
#if defined(KATA_ALLOW_DEPRECATED)
#  define KATA_DEPRECATED(message)
#elif defined(__GNUC__) || defined(__clang__)
#  define KATA_DEPRECATED(message) __attribute__((deprecated(message)))
#elif defined(_MSC_VER)
#  define KATA_DEPRECATED(message) __declspec(deprecated(message))
#else
#  define KATA_DEPRECATED(message)
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ==== Versions ============================================================================ */

/* Semantic versioning (README "Versions and compatibility"): within a major version the ABI only
 * grows (new functions, new enumerators, fields appended to a struct that starts with
 * struct_size); libkata's soname is libkata.so.MAJOR. CI checks this with abidiff (abi/README.md).
 * One rule for every struct that starts with struct_size, read or written by the library: any
 * struct_size from the struct as 1.0 released it up is accepted. A caller built against an older
 * 1.x kata.h (a smaller struct) gets the defaults of the fields it lacks when read, and nothing
 * written past its struct; a caller built against a newer one (a larger struct) has the fields
 * this library does not know ignored when read and zeroed when written. A struct_size below
 * 1.0's (an uninitialised struct; no 0.x struct is read) is refused with KATA_E_INVALID_ARGUMENT. */
#define KATA_VERSION_MAJOR 1
#define KATA_VERSION_MINOR 0 /* additions since the major's first release */
#define KATA_VERSION_PATCH 0 /* fixes only */
/* The feature layout this library computes (spec gpd-v1.md); stored in every model file. */
#define KATA_GPD_LAYOUT "gpd-v1"
/* Dimensions of a GPD v1 feature vector, and of its 16-joint skeleton. */
#define KATA_GPD_DIMS 1683
#define KATA_GPD_JOINTS 16 /* the GPD skeleton's joints (spec GPD v1 order, kata.h "Layouts") */

/* The library's version at run time, as MAJOR * 10000 + MINOR * 100 + PATCH. [any thread] */
KATA_API uint32_t kata_version(void);

/* ==== Input limits ========================================================================= */
/* The plausibility range of stream input (kata_stream_push): inside it every output is finite. */
#define KATA_MIN_TIME_STEP 1e-5      /* seconds: frames closer than this are refused (100 kHz) */
#define KATA_MAX_COORDINATE 1e9      /* input units: |x|, |y|, |z| of a mapped joint */
#define KATA_MIN_BODY_HEIGHT 1e-6    /* input units: a smaller body height is refused */
#define KATA_MAX_REACH 100.0         /* body heights: a mapped joint's distance from the hip */
#define KATA_MAX_HISTORY 65536       /* frames: kata_stream_desc.history_capacity */
/* Caller strings: read up to this many bytes looking for the terminating NUL. */
#define KATA_MAX_STRING_BYTES 4096
/* File bounds, checked from the file size before reading. */
#define KATA_MAX_BVH_BYTES 2147483648u    /* 2 GiB */
#define KATA_MAX_MODEL_BYTES 67108864     /* 64 MiB (a full-rank gpd-v1 model is ~11 MiB) */
#define KATA_MAX_NAME_MAP_BYTES 1048576   /* 1 MiB */

/* ==== Status codes ======================================================================== */

/* What every fallible call returns. */
typedef enum kata_status {
  KATA_OK = 0,
  KATA_NO_DATA = 1,                   /* nothing to read yet: a result, not an error */
  KATA_E_INVALID_ARGUMENT = 2,        /* a value is out of range or inconsistent */
  KATA_E_NULL_POINTER = 3,            /* a required pointer is NULL */
  KATA_E_WRONG_JOINT_COUNT = 4,       /* a frame's joint count differs from the stream's */
  KATA_E_NON_FINITE = 5,              /* NaN or Inf in a frame or a timestamp */
  KATA_E_TIMESTAMP_NOT_INCREASING = 6,/* a frame's timestamp is not after the previous one */
  KATA_E_PARSE = 7,                   /* a file or buffer is malformed (message: file and line) */
  KATA_E_IO = 8,                      /* a file cannot be opened, read or written */
  KATA_E_MODEL = 9,                   /* a model file is refused (message: the reason) */
  KATA_E_NOT_FOUND = 10,              /* a named preset, joint or file is unknown */
  KATA_E_OUT_OF_MEMORY = 11,
  KATA_E_BUFFER_TOO_SMALL = 12,       /* the caller's buffer is smaller than the result */
  KATA_E_INTERNAL = 13,               /* a bug in kata: please report it */
  KATA_E_STATE = 14,                  /* the call is not valid in the object's current state */
  KATA_TRACKING_LOST = 15,            /* a result, not an error: the frame was accepted (its timestamp
                                         counts) but too many joints are missing to compute features
                                         (see kata_stream_push_confidence); the stream recovers by itself */
  KATA_E_STOPPED = 16,                /* the runtime is stopping or stopped: the frame was not taken
                                         (kata_runtime_push) */
  KATA_E_QUEUE_FULL = 17,             /* a runtime stream's worker queue is full: the frame or setting
                                         was dropped (counted); send again later */
  KATA_E_NO_CLIP_TEACHER = 18         /* the call needs a clip teacher and the stream has none (no
                                         teacher, or one given as a pose or features) */
} kata_status;

/* A static English name for a status ("KATA_OK", ...). Never NULL. [any thread] */
KATA_API const char* kata_status_string(kata_status status);

/* ==== Context ============================================================================= */

/* The library instance that streams, skeletons and models are created from. */
typedef struct kata_context_s* kata_context;

/* Creates a context. *out receives it (owned by the caller). [any thread] */
KATA_API kata_status kata_context_create(kata_context* out);
/* Destroys a context. Every stream, skeleton, clip and model made from it must be released
 * first. NULL is ignored. [any thread, not concurrently with other calls on the context] */
KATA_API void kata_context_destroy(kata_context context);
/* The message of the last failed call made on this context from the calling thread, or "": two
 * contexts used on one thread keep their own messages. A call that takes no context
 * (kata_clip_positions, kata_time_units_detect; a runtime's calls report on the context it was
 * created on) reports on the calling thread, shown here on any context when it is the thread's
 * newest failure. Valid until that thread's next failed call on the context. [any thread] */
KATA_API const char* kata_context_last_error(kata_context context);

/* ##############################################################################################
 * Task 1 - open a stream: skeletons, clips, a live stream of frames in and GPD features out
 *
 * kata_context ctx;  kata_clip clip;  kata_skeleton skel;  kata_stream s;  kata_stream_desc d;
 * kata_context_create(&ctx);  kata_clip_load_bvh(ctx, "data/cmu/02_01.bvh", &clip);
 * kata_clip_skeleton(clip, &skel);  kata_stream_desc_init(&d);  d.preset = "cmu";
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
/* Reads the skeleton (HIERARCHY) of a BVH file. [any thread] */
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
 * [any thread] */
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
 * A layout says how a source's joints become the 16 GPD joints. Every preset below is one (a
 * pure name map), and so is:
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
 *          (Fitted so they land where the "cmu" preset's Hips, Spine1, Neck1 and Head sit on CMU
 *          mocap, so a webcam student and a CMU teacher are compared on the same joints.) A
 *          synthesised joint's confidence is the smallest of its landmarks'. World landmarks have
 *          no floor: each frame the floor under the Hip height is the lowest of landmarks 27..32
 *          (ankles, heels, foot indices), so a jump does not raise the Hip height.
 * Pass visibility as the per-joint confidence (kata_stream_push_confidence), or MediaPipe's
 * whole frame (x, y, z, visibility, presence; milliseconds) to kata_stream_push_landmarks. */

/* The name of built-in layout i (the presets, then "mediapipe"), or NULL past the last.
 * [any thread] */
KATA_API const char* kata_layout_name(uint32_t i);
/* The joint list of a built-in layout as a skeleton without rest pose, for a source that sends
 * bare landmark arrays: "mediapipe" (33 landmarks, named as above, in order), "gpd" (the 16
 * GPD joints, spec parents), "azure-kinect" (Azure Kinect Body Tracking's 32 joints in
 * k4abt_joint_id_t order, named "PELVIS", "SPINE_NAVEL", ...: millimetres, camera axes, so stream
 * with KATA_UP_Y_DOWN) or "xsens" (Xsens MVN's 23 segments, "Pelvis", "L5", ..., MVN order;
 * metres, Z up: KATA_UP_Z). KATA_E_NOT_FOUND for other names (build their skeleton with
 * kata_skeleton_create from the source's joint names). *out is owned by the caller. [any thread] */
KATA_API kata_status kata_skeleton_create_layout(kata_context context, const char* layout, kata_skeleton* out);

/* How a stream maps and treats its input. Fill with kata_stream_desc_init, then change fields.
 * Starts with struct_size so later versions can grow it. */
typedef struct kata_stream_desc {
  uint32_t struct_size;        /* sizeof(kata_stream_desc) */
  /* Joint map onto the 16 GPD joints: a preset name ("cmu", see kata_preset_name), or NULL
   * and a name-map file (JSON {"Hip": "pelvis", ...} or "Hip = pelvis" lines, at most
   * KATA_MAX_NAME_MAP_BYTES). Both set is refused (KATA_E_INVALID_ARGUMENT). */
  const char* preset;
  const char* name_map_path;   /* a name-map file's path, or NULL (see preset) */
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
  /* ---- since 0.2 */
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
/* Fills 1.0's kata_stream_desc (72 bytes) with the defaults: the entry point of programs built
 * before kata_stream_desc_init_sized; it never writes more than 1.0's struct, however the struct grows.
 * In C and C++ the macro of the same name below calls kata_stream_desc_init_sized. [any thread] */
KATA_API void kata_stream_desc_init(kata_stream_desc* desc);
/* Fills *desc with the defaults for the caller's own struct: kata_stream_desc_init_sized(desc, sizeof *desc). */
#define kata_stream_desc_init(desc) kata_stream_desc_init_sized((desc), (uint32_t)sizeof *(desc))
/* The name of built-in preset i ("cmu", ...), or NULL past the last. [any thread] */
KATA_API const char* kata_preset_name(uint32_t i);

/* Opens a stream for frames of `skeleton`: a pipeline that runs every feature vector the stream
 * emits through the score and the ghost of an attached teacher (kata_stream_attach_teacher) in
 * the push that emitted it, and keeps each result in a ring until read (kata_stream_read_results).
 * Allocates all its memory now. The skeleton is
 * copied; it may be destroyed afterwards. Errors (unknown preset, a mapped joint missing from
 * the skeleton, bad values) are reported on the context. desc->struct_size: 1.0's size or more
 * (see Versions). [any thread] */
KATA_API kata_status kata_stream_open(kata_context context, kata_skeleton skeleton, const kata_stream_desc* desc,
                                      kata_stream* out);
/* kata_stream_open with a name map held in memory (the contents of a name-map file: JSON
 * {"Hip": "pelvis", ...} or "Hip = pelvis" lines; copied) instead of desc->preset and
 * desc->name_map_path. Errors name the map "<name map>" and its line. [any thread] */
KATA_API kata_status kata_stream_open_name_map(kata_context context, kata_skeleton skeleton,
                                               const kata_stream_desc* desc, const char* name_map_text,
                                               kata_stream* out);
/* Closes a stream and frees its memory. NULL is ignored. [stream owner] */
KATA_API void kata_stream_close(kata_stream stream);
/* The message of the last failed call on this stream, or "". [stream owner] */
KATA_API const char* kata_stream_last_error(kata_stream stream);

/* Pushes one frame: timestamp in seconds (must increase), positions of every joint of the
 * stream's skeleton (joint_count x 3 floats, x, y, z interleaved, input units). A refused frame
 * (KATA_E_NULL_POINTER, KATA_E_WRONG_JOINT_COUNT, KATA_E_NON_FINITE,
 * KATA_E_TIMESTAMP_NOT_INCREASING, KATA_E_INVALID_ARGUMENT) changes nothing; the stream stays
 * usable. Plausibility range (the message names the joint):
 * - the timestamp must be at least KATA_MIN_TIME_STEP after the previous accepted frame's
 *   (else KATA_E_TIMESTAMP_NOT_INCREASING; merge such frames before pushing);
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
 * seconds or 1..500 in milliseconds (the ranges do not overlap). A step that fits neither, or
 * timestamps that do not increase, is refused (KATA_E_INVALID_ARGUMENT, the reason in
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
 * computed now with the backward formulas. The next frame starts a new segment. KATA_E_INTERNAL
 * as for kata_stream_push. [stream owner] */
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
 *   score = 100 / (1 + (d / delta*)^2)   (100 at d = 0, 50 at d = delta*, 20 at 2 delta*)
 * and splits d^2 over five body parts (they sum to d^2; a part may be slightly negative). The
 * teacher is one pose, or a clip that the stream follows with an online alignment: each frame is
 * matched to the best teacher frame just ahead of the last match, and the match moves anywhere in
 * the clip when the student is clearly elsewhere (joined late, skipped ahead or back); a student
 * who pauses holds the teacher (docs/model/alignment.md).
 * Memory: loading a model and attaching a teacher allocate; scoring never does.
 * Threads: a model is immutable and may be shared by any number of streams and threads; a
 * stream keeps what it needs from the model, which may be freed while streams still use it. */
/* Which shipped model for which job (figures: docs/model/scores.md, docs/model/transition.md):
 *   models/default.kata     coaching, a student against a teacher: cross-body precision 1.000 on
 *                           held-out subjects 1 and 9; it carries the calibrated score map.
 *   models/transition.kata  ranking candidate cut points between takes of one subject, or
 *                           within one kind of motion (a walk into another walk): the joint form,
 *                           a quadratic form on each joint's position, velocity and acceleration
 *                           differences. Leave one subject out, issue 27's protocol: mean 0.815
 *                           vs JCD 0.764, above JCD on every subject (walking 0.987 vs 0.975);
 *                           the project's protocol: 0.805 vs 0.769.
 *   models/transition-static.kata  candidates between clips of different motions (a run into a
 *                           climb): a static W, 0.836 vs JCD 0.620 on held-out subjects 1+9
 *                           pooled (transition.kata: 0.804). Near chance within one motion.
 *                           Neither transition model has a calibration: not a coaching score.
 * kata_model_metadata(m, "data") names the training data; the evaluation figures and the
 * protocol they used are listed by `kata model-info`. */

/* A loaded, verified model. */
typedef struct kata_model_s* kata_model;

/* Loads a .kata file. Every check runs before anything is used: the FlatBuffers verifier, the
 * identifier, the layout id ("gpd-v1"), the dimensions (W 1683 x r, min/max 1683), NaN/Inf,
 * max < min, r = 0, implausible magnitudes (|min|, |max| > 1e15, 0 < max - min < 1e-9,
 * |W| > 1e6), the checksum, and the canonical byte layout (so any flipped bit is refused); a refused file returns KATA_E_MODEL (KATA_E_IO when it
 * cannot be read, is a directory or special file, or is larger than KATA_MAX_MODEL_BYTES) with
 * the reason in kata_context_last_error. The 12-byte header (size prefix, identifier) is checked
 * against the file size before the rest is read. *out is owned by the caller. [any thread] */
KATA_API kata_status kata_model_load(kata_context context, const char* path, kata_model* out);
/* The same from a buffer in memory (size bytes, any alignment); the buffer is copied and may
 * be released after the call. [any thread] */
KATA_API kata_status kata_model_load_memory(kata_context context, const void* data, size_t size, kata_model* out);
/* Releases a model. Streams scoring with it keep working. NULL is ignored. [any thread, not
 * concurrently with other calls on the same model] */
KATA_API void kata_model_free(kata_model model);
/* Rank r (columns of W); 0 for NULL. [any thread] */
KATA_API uint32_t kata_model_rank(kata_model model);
/* Decision threshold delta* (a distance: score 50); 0 for NULL. [any thread] */
KATA_API double kata_model_delta_star(kata_model model);
/* The stencil the model was trained with; streams scored with it must use the same. [any thread] */
KATA_API kata_stencil kata_model_stencil(kata_model model);
/* Training metadata by key: "layout", "date" (ISO 8601), "data", "parameters" (JSON). The
 * string is owned by the model (valid until kata_model_free); NULL for an unknown key or a
 * NULL model. [any thread] */
KATA_API const char* kata_model_metadata(kata_model model, const char* key);

/* ---- The ghost's solver settings (kata_teacher_desc.retarget, kata_retargeter_create) ---- */
/* How a retargeter solves. Fill with kata_retarget_desc_init, then change fields. */
typedef struct kata_retarget_desc {
  uint32_t struct_size;        /* sizeof(kata_retarget_desc) */
  const char* preset;          /* joint set: "cmu" (default) or "gpd" */
  double gradient_tolerance;   /* stop when |grad| <= this x sqrt(sum pi delta^2). Default 3e-5;
                                  warm frames stop at 3x this (their quasi-Newton steps start from
                                  the previous frame's; docs/retarget/README.md) */
  uint32_t max_iterations;     /* SPG iteration cap per frame. Default 200 */
  int32_t warm_start;          /* 1 (default): start from the previous frame's solution */
  int32_t restore_bone_lengths;/* 1 (default): reset every bone to the student's exact length */
} kata_retarget_desc;

/* Fills the first struct_size bytes of desc with the defaults above and sets desc->struct_size
 * to the smaller of struct_size and sizeof(kata_retarget_desc): nothing past the caller's own struct is
 * written, so a caller built against an older kata.h (a smaller struct) is safe with a
 * newer library, which then reads only that much (the later fields keep their defaults).
 * struct_size below 4 writes nothing. Bindings that declare the struct themselves (ctypes,
 * P/Invoke) pass their own size. [any thread] */
KATA_API void kata_retarget_desc_init_sized(kata_retarget_desc* desc, uint32_t struct_size);
/* Fills 1.0's kata_retarget_desc (40 bytes) with the defaults: the entry point of programs built
 * before kata_retarget_desc_init_sized; it never writes more than 1.0's struct, however the struct grows.
 * In C and C++ the macro of the same name below calls kata_retarget_desc_init_sized. [any thread] */
KATA_API void kata_retarget_desc_init(kata_retarget_desc* desc);
/* Fills *desc with the defaults for the caller's own struct: kata_retarget_desc_init_sized(desc, sizeof *desc). */
#define kata_retarget_desc_init(desc) kata_retarget_desc_init_sized((desc), (uint32_t)sizeof *(desc))

/* ==== Pipeline: every frame scored, with the teacher's pose on the student's body ========= */
/* (section: pipeline, since 0.2)
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
  const char* preset;        /* the teacher's GPD joint map (kata_preset_name). NULL: "cmu" */
  uint32_t first_frame;      /* teacher frames first_frame..end (1 skips CMU's T-pose). Default 0 */
  int32_t pose_frame;        /* -1 (default): follow the whole clip; >= first_frame: that frame only */
  int32_t ghost;             /* 1 (default): make a ghost per result (the student skeleton needs rest
                                offsets and the same joint names as the teacher); 0: scores only */
  const kata_retarget_desc* retarget;  /* the ghost's solver (joint set "cmu" or "gpd"); NULL: defaults */
  /* ---- since 1.0 */
  /* ... or GPD v1 feature vectors: `frames` x KATA_GPD_DIMS floats, row-major (copied) ... */
  const float* features;
  /* ... or one pose as the 16 GPD joints' world positions: KATA_GPD_JOINTS x 3 floats, GPD joint
   * order, +Y up, any units (copied), held still (kinetics zero), with its body height in the same
   * units. (A moving teacher of 16 GPD joints: positions on kata_skeleton_create_layout "gpd".) */
  const float* joints;
  double body_height;        /* the joints' body height, in their units */
} kata_teacher_desc;

/* Fills the first struct_size bytes of desc with the defaults above and sets desc->struct_size
 * to the smaller of struct_size and sizeof(kata_teacher_desc): nothing past the caller's own struct is
 * written, so a caller built against an older kata.h (a smaller struct, e.g. 0.2's 88 bytes) is safe with a
 * newer library, which then reads only that much (the later fields keep their defaults).
 * struct_size below 4 writes nothing. Bindings that declare the struct themselves (ctypes,
 * P/Invoke) pass their own size. [any thread] */
KATA_API void kata_teacher_desc_init_sized(kata_teacher_desc* desc, uint32_t struct_size);
/* Fills 1.0's kata_teacher_desc (112 bytes) with the defaults: the entry point of programs built
 * before kata_teacher_desc_init_sized; it never writes more than 1.0's struct, however the struct grows.
 * In C and C++ the macro of the same name below calls kata_teacher_desc_init_sized. [any thread] */
KATA_API void kata_teacher_desc_init(kata_teacher_desc* desc);
/* Fills *desc with the defaults for the caller's own struct: kata_teacher_desc_init_sized(desc, sizeof *desc). */
#define kata_teacher_desc_init(desc) kata_teacher_desc_init_sized((desc), (uint32_t)sizeof *(desc))
/* Attaches a teacher to a stream in one call: model, teacher motion, and (from the stream's own
 * skeleton) the student's body. Replaces any teacher; a refused call leaves the old one in
 * place. The alignment starts at the teacher's first frame. Errors (stencil mismatch, unknown
 * preset, a ghost joint missing from one skeleton, bad frames or features, two motions given,
 * desc->struct_size below 1.0's kata_teacher_desc) go to
 * kata_stream_last_error. Allocates. [stream owner] */
KATA_API kata_status kata_stream_attach_teacher(kata_stream stream, const kata_teacher_desc* desc);
/* Removes the stream's teacher: later results are not scored (scored 0) and carry
 * no ghost. KATA_OK without one too. [stream owner] */
KATA_API kata_status kata_stream_detach_teacher(kata_stream stream);
/* Restarts the teacher: the next frame is matched from the teacher's first frame, the ghost's
 * solve starts cold and the score calibrates again (KATA_SCORE_CALIBRATING). KATA_E_STATE
 * without a teacher. [stream owner] */
KATA_API kata_status kata_stream_restart_teacher(kata_stream stream);

/* kata_body_part (the five parts of a score breakdown) is in kata/result.h. */

/* ==== Score calibration and feedback ====================================================== */
/* The score is the coaching total (issue 34; docs/model/scores.md "The coaching total"):
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
 * below good_score, the part with the lowest averaged score (equal scores: the one whose joints are
 * farthest from the teacher's, each in its own frame); named at once when nothing is named; another part (or none) replaces a named one only after
 * holding for 0.5 s, so cues do not flicker.
 * The correction cue (cue_joint, cue_degrees, cue_action; present iff part_to_fix >= 0) says what
 * to change in that part, as a coach does: "left knee: bend 30 deg more". cue_joint is the joint
 * to move (a bone turns about the joint at its start: a bent knee names LKnee), the one of the
 * part whose bone is farthest from the teacher's, measured at the joint (a forearm or shin
 * against its upper arm or thigh, so a turned hip names the hip, not the knee as well);
 * cue_degrees that angle. Both averaged like the part scores and held like the part: named at once
 * with a new part, replaced within a part only after 0.5 s. cue_action from the body frame: knees
 * and elbows bend / straighten (the inner angle), shoulders and hips raise / lower (the bone's
 * height), the chest and lower back bend / straighten (the forward lean), the neck raises /
 * lowers the head; "turn" when most of the angle is sideways or a twist (docs/model/scores.md "The cue").
 * The record's state (kata_score_state, kata/result.h) says when there is no score to show. */

/* The GPD joint name of joint 0..15 ("Hip", "Chest", "Neck", "Head", "LShoulder", "LElbow",
 * "LHand", "RShoulder", "RElbow", "RHand", "LHip", "LKnee", "LFoot", "RHip", "RKnee", "RFoot":
 * spec GPD v1 order), e.g. of a record's cue_joint; NULL out of range. A static string. Does not
 * allocate. [any thread] */
KATA_API const char* kata_gpd_joint_name(int32_t joint);
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

/* ##############################################################################################
 * Task 4 - retarget: a teacher's posture on a student's body, frame by frame
 *
 * kata_retargeter rt;  kata_retargeter_create(ctx, student_skeleton, NULL, &rt);
 * float ghost[3 * 64];  kata_retarget_info info;  info.struct_size = sizeof info;
 * kata_retargeter_solve(rt, teacher_xyz, teacher_joints, ghost, 3 * 64, &info);
 * kata_retargeter_place(rt, student_xyz, student_joints, ghost, 3 * 64);
 * kata_retargeter_destroy(rt);
 * ############################################################################################ */

/* ==== Retargeting ========================================================================= */
/* Puts a teacher's posture onto a student's body, frame after frame (skeleton-independent
 * distance matrices + a warm-started non-monotone spectral gradient solve, then exact bone
 * lengths). The student is a skeleton with rest offsets (its bone lengths); teacher frames come
 * in the same skeleton layout (same joints, same order: e.g. two CMU subjects) with their own
 * bone lengths. The retargeter works on a subset of the joints chosen by a preset:
 *   "cmu" (default): every joint that carries a bone; joints with a zero offset, sitting on their
 *         parent, are dropped (CMU BVH: 31 -> 21 joints);
 *   "gpd": the 16 GPD joints, read through the "cmu" name preset.
 * Units: positions in the student skeleton's units (teacher frames must use the same unit),
 * +Y up. Memory: kata_retargeter_create allocates everything; the per-frame calls never do.
 * Threads: a retargeter is used by one thread at a time (different retargeters in parallel). */

/* Per-student retargeting state (warm start, buffers). */
typedef struct kata_retargeter_s* kata_retargeter;

/* What one kata_retargeter_solve did. */
typedef struct kata_retarget_info {
  uint32_t struct_size;         /* set by the caller: sizeof(kata_retarget_info) */
  uint32_t iterations;          /* SPG iterations this frame */
  int32_t converged;            /* 1 when the gradient tolerance was met (else the cap) */
  int32_t warm;                 /* 1 when warm-started from the previous frame */
  double stress;                /* the paper's stress at the SPG optimum, units^2 */
  double max_bone_error_solved; /* largest relative bone-length error at the optimum (0.01 = 1%) */
  double max_bone_error;        /* the same for the returned ghost (after the restoring step) */
} kata_retarget_info;

/* Creates a retargeter for the student `student` (a skeleton with rest offsets; copied, may be
 * destroyed afterwards). desc may be NULL for the defaults; else desc->struct_size is 1.0's
 * size or more (see Versions). Errors (unknown preset, missing
 * joint, no rest pose, zero bone length) are reported on the context. [any thread] */
KATA_API kata_status kata_retargeter_create(kata_context context, kata_skeleton student,
                                            const kata_retarget_desc* desc, kata_retargeter* out);
/* The same with a stream's skeleton as the student (its rest offsets give the bone lengths).
 * A stream whose skeleton has no rest pose uses its estimated GPD bone lengths
 * (kata_stream_bone_lengths; KATA_E_STATE until they are ready) on the 16 GPD joints (as
 * kata_retargeter_create_across with the stream's own layout as the teacher's). The retargeter
 * is independent of the stream afterwards. [stream owner] */
KATA_API kata_status kata_retargeter_create_for_stream(kata_context context, kata_stream student,
                                                       const kata_retarget_desc* desc, kata_retargeter* out);
/* Across layouts: a teacher on another skeleton (e.g. a CMU BVH) onto the student stream's
 * layout (e.g. MediaPipe). solve() then takes frames of `teacher` (teacher_layout names its layout,
 * e.g. "cmu"; read in teacher_up_axis unless the layout fixes its axes; its units do not matter)
 * and works on the 16 GPD joints both layouts map: the ghost is the 16 GPD joints (GPD order) in
 * the student stream's axes and units, root (Hip) at the origin until kata_retargeter_place puts
 * it over the student; kata_retargeter_joint_source gives the student joint each stands for (-1
 * for a synthesised one). The student's bone lengths come from its rest pose, or else from the
 * stream's estimate (KATA_E_STATE until kata_stream_bone_lengths has them). desc may be NULL
 * (its preset is ignored). [stream owner] */
KATA_API kata_status kata_retargeter_create_across(kata_context context, kata_stream student, kata_skeleton teacher,
                                                   const char* teacher_layout, kata_up_axis teacher_up_axis,
                                                   const kata_retarget_desc* desc, kata_retargeter* out);
/* Releases a retargeter. NULL is ignored. [retargeter owner] */
KATA_API void kata_retargeter_destroy(kata_retargeter retargeter);
/* The message of the last failed call on this retargeter, or "". Valid until the next call on
 * it. [retargeter owner] */
KATA_API const char* kata_retargeter_last_error(kata_retargeter retargeter);
/* Number of joints the retargeter outputs (21 for "cmu" on CMU, 16 for "gpd"); 0 for NULL.
 * [retargeter owner] */
KATA_API uint32_t kata_retargeter_joint_count(kata_retargeter retargeter);
/* The skeleton joint that output joint i stands for (an index into the student skeleton), or
 * -1 when out of range. [retargeter owner] */
KATA_API int32_t kata_retargeter_joint_source(kata_retargeter retargeter, uint32_t i);

/* Retargets one teacher frame. teacher: every joint of the skeleton (teacher_joint_count x 3
 * floats, x, y, z interleaved, student units; across layouts: every joint of the teacher
 * skeleton, its own units, and the ghost's root (Hip) is at the origin). ghost (capacity floats) receives
 * kata_retargeter_joint_count() x 3 floats: the posture on the student's bones, root on the
 * teacher's root, oriented like the teacher. info (may be NULL; set info->struct_size) receives
 * the solve's figures. KATA_E_WRONG_JOINT_COUNT, KATA_E_NON_FINITE, KATA_E_BUFFER_TOO_SMALL and
 * KATA_E_NULL_POINTER leave the state unchanged. Does not allocate. [retargeter owner] */
KATA_API kata_status kata_retargeter_solve(kata_retargeter retargeter, const float* teacher,
                                           uint32_t teacher_joint_count, float* ghost, size_t capacity,
                                           kata_retarget_info* info);
/* Places a ghost from kata_retargeter_solve (in/out, joint_count() x 3 floats) over the
 * student's current posture (student: every skeleton joint, student_joint_count x 3 floats):
 * root on the student's root, turned about +Y (a proper rotation, never a mirror) to face like
 * the student. Does not allocate. [retargeter owner] */
KATA_API kata_status kata_retargeter_place(kata_retargeter retargeter, const float* student,
                                           uint32_t student_joint_count, float* ghost, size_t capacity);
/* Forgets the previous frame: the next solve starts cold (forward-kinematics baseline: the
 * student's bone lengths laid along the teacher's bone directions). Call at a cut in the
 * teacher's motion. [retargeter owner] */
KATA_API kata_status kata_retargeter_reset(kata_retargeter retargeter);

/* ---- The ghost as local rotations (what a game engine animates) ----
 * For a student skeleton with a rest pose (kata_retargeter_create, or _create_for_stream /
 * _create_across on a stream whose skeleton has rest offsets): per joint of the student's whole
 * hierarchy a rotation relative to its parent, and the root's position, whose forward kinematics
 *   G_root = R_root, X_root = root_position;  G_j = G_parent R_j,  X_j = X_parent + G_parent offset_j
 * (offset_j from kata_skeleton_joint_offset; quaternions act on column vectors) put every ghost
 * joint on the ghost's position. Each joint turns its bone onto the ghost's bone with the
 * smallest rotation added to its parent's (a swing; the twist about a bone is the parent's); a
 * joint carrying several bones takes the rotation that best turns all of them (least squares).
 * Exact (to float rounding) when every joint with a bone is a ghost joint and each joint carries
 * at most one bone, branches going through zero-offset joints (a CMU BVH with the "cmu" joint
 * set); where a joint carries several bones (a game rig's hips) they move rigidly, so the ghost is
 * reproduced as closely as a rotation can: *residual says how far. */

/* Joints of the student hierarchy the rotations cover (kata_skeleton_joint_count of the
 * student); 0 when the retargeter has no rest pose to rotate (or NULL). [retargeter owner] */
KATA_API uint32_t kata_retargeter_rotation_joint_count(kata_retargeter retargeter);
/* ghost: a ghost from kata_retargeter_solve (placed or not), ghost_count = 3 x
 * kata_retargeter_joint_count() floats. rotations (rotation_capacity >= 4 x
 * kata_retargeter_rotation_joint_count() floats) receives unit quaternions (x, y, z, w), w >= 0,
 * one per student joint in skeleton order, each relative to its parent (the root's: world);
 * root_position[3] the root's position. positions (may be NULL; 3 x joints floats) receives every
 * joint's forward-kinematics position; residual (may be NULL) the largest distance between a
 * ghost joint and its FK position (student units). KATA_E_STATE without a rest pose;
 * KATA_E_WRONG_JOINT_COUNT, KATA_E_BUFFER_TOO_SMALL, KATA_E_NON_FINITE as for solve. Does not
 * allocate. [retargeter owner] */
KATA_API kata_status kata_retargeter_local_rotations(kata_retargeter retargeter, const float* ghost,
                                                     size_t ghost_count, float* rotations,
                                                     size_t rotation_capacity, float* root_position,
                                                     float* positions, size_t position_capacity,
                                                     double* residual);

/* ##############################################################################################
 * Task 5 - run many streams: a runtime, its workers and ZeroMQ in and out
 *
 * kata_runtime_desc rd;  kata_runtime rt;  kata_runtime_desc_init(&rd);
 * rd.publish_endpoints = "tcp://127.0.0.1:5555";  kata_runtime_create(ctx, &rd, &rt);
 * kata_runtime_add_stream(rt, 42, &s, "cmu", 0);         -- the runtime owns s now (s = NULL)
 * kata_runtime_push(rt, 42, sequence, t, xyz, joints);   -- any thread, never blocks
 * kata_runtime_stop(rt);  kata_runtime_destroy(rt);
 * ############################################################################################ */

/* ==== Runtime: many streams, ZeroMQ in and out ============================================ */
/* (section: runtime, since 0.2)
 * A runtime owns many streams and publishes every result as a FlatBuffers message
 * (schemas/result.fbs, installed in share/kata/schemas) on a ZeroMQ PUB socket, topic = the
 * stream id as 16 lowercase hex digits; each stream's skeleton definition (schemas/skeleton.fbs)
 * is published when it opens, when a subscriber joins and every skeleton_resend_seconds. It can
 * also read frames (schemas/frame.fbs) from a ZeroMQ SUB or PULL socket: a stream is created from
 * its skeleton definition; malformed, unknown-stream and out-of-order messages are counted and
 * dropped.
 * Threads: kata_runtime_push may be called from any thread (one producer per stream keeps that
 * stream's order); it copies the frame into the bounded, lock-free queue of the worker that owns
 * the stream (workers = threads; stream id modulo workers), so no lock is shared between
 * streams. Each worker runs its streams' pipelines; one I/O thread owns every socket (ZeroMQ
 * sockets are not thread-safe) and sends without ever blocking. A full queue drops and counts.
 * Clock: capture_time is the caller's (seconds); arrival, computed and published times in the
 * messages are CLOCK_MONOTONIC nanoseconds, comparable between processes on one host.
 * Memory: create and add_stream allocate; push never does. */

/* Many streams, ZeroMQ in and out (above). */
typedef struct kata_runtime_s* kata_runtime;

/* How a runtime is built. Fill with kata_runtime_desc_init, then change fields. */
typedef struct kata_runtime_desc {
  uint32_t struct_size;             /* sizeof(kata_runtime_desc) */
  uint32_t workers;                 /* worker threads (>= 1). Default 2 */
  uint32_t max_streams;             /* streams the runtime can hold. Default 1024 */
  uint32_t max_joints;              /* largest skeleton pushed. Default 128 */
  uint32_t queue_capacity;          /* frames (and results) queued per worker. Default 4096 */
  /* Comma-separated endpoints the publisher binds ("tcp://127.0.0.1:5555,ipc:///tmp/k.sock";
   * port "*" picks a free one, see kata_runtime_publish_endpoint). NULL or "": no publisher. */
  const char* publish_endpoints;
  int32_t send_hwm;                 /* ZMQ_SNDHWM per subscriber. Default 10000 */
  /* Comma-separated ingest endpoints: connected, or bound with a "bind:" prefix. NULL: none. */
  const char* ingest_endpoints;
  int32_t ingest_pull;              /* 1: a PULL socket; 0 (default): SUB to every topic */
  uint32_t max_message_bytes;       /* larger ingest messages are dropped. Default 1 MiB */
  double skeleton_resend_seconds;   /* periodic re-send of skeleton definitions. Default 1 */
  /* ---- since 1.0: who may send what (docs/deploy.md, docs/runtime.md) ----
   * CURVE: key_file is this runtime's key pair (the .secret file of `kata keygen`); with it the
   * publisher and a bound ingest are CURVE servers that admit only the public keys in
   * client_keys_dir (*.pub files); a connecting ingest is a client of ingest_server_key_file
   * (the stage's .pub). NULL: no CURVE (then bind to this host only). */
  const char* key_file;               /* this runtime's .secret key file, or NULL */
  const char* client_keys_dir;        /* directory of the admitted clients' .pub files, or NULL */
  const char* ingest_server_key_file; /* a connecting ingest's server .pub file, or NULL */
  uint32_t max_streams_per_sender;  /* streams one ingest sender may define. Default 64 */
  uint32_t max_connections;         /* ingest connections held at once (0: no limit). Default 256 */
  double max_frame_age_seconds;     /* older ingest frames are dropped (0: never). Default 0.25 */
  double idle_stream_seconds;       /* ingest streams without traffic are closed (0: never). Default 300 */
} kata_runtime_desc;

/* Counters since the runtime was created (sums over streams). */
typedef struct kata_runtime_counters {
  uint32_t struct_size;             /* set by the caller: sizeof(kata_runtime_counters) */
  uint32_t streams;                 /* streams open */
  uint64_t frames_in;               /* frames queued */
  uint64_t queue_full;              /* frames dropped: a worker queue was full */
  uint64_t refused;                 /* frames a pipeline refused (kata_stream_push's reasons) */
  uint64_t results;                 /* results computed */
  uint64_t results_dropped;         /* results lost inside the runtime (rings, queues) */
  uint64_t published;               /* results handed to ZeroMQ */
  uint64_t ingest_received;         /* ingest messages read */
  uint64_t ingest_dropped;          /* ingest messages refused (malformed, unknown stream, ...) */
  uint64_t ingest_sequence_gaps;    /* frames missing between accepted ingest frames */
  uint64_t ingest_restarts;         /* sources that restarted (sequence back to 0) */
  /* since 1.0: the causes inside ingest_dropped that an attack or a misconfigured sender shows */
  uint64_t ingest_not_owner;        /* messages for a stream another sender owns */
  uint64_t ingest_refused_limit;    /* definitions beyond a streams limit */
  uint64_t ingest_out_of_window;    /* sequence numbers far beyond the last one */
  uint64_t ingest_stale;            /* frames older than max_frame_age_seconds */
  uint64_t closed_streams;          /* streams closed (by their owner, idle, a new skeleton) */
  /* since 1.0, with practice messages (schemas/practice.fbs, docs/runtime.md): applied, and the
   * causes of those refused (inside ingest_dropped; another sender's are in ingest_not_owner) */
  uint64_t ingest_practices;              /* practice settings applied */
  uint64_t ingest_practice_bad_values;    /* a time not finite or negative, an empty loop, both */
  uint64_t ingest_practice_outside_clip;  /* outside the stream's teacher clip */
  uint64_t ingest_practice_no_clip;       /* for a stream without a clip teacher */
  uint64_t ingest_practice_queue_full;    /* the stream's worker queue was full */
} kata_runtime_counters;

/* Fills the first struct_size bytes of desc with the defaults above and sets desc->struct_size
 * to the smaller of struct_size and sizeof(kata_runtime_desc): nothing past the caller's own struct is
 * written, so a caller built against an older kata.h (a smaller struct, e.g. 0.2's 64 bytes) is safe with a
 * newer library, which then reads only that much (the later fields keep their defaults).
 * struct_size below 4 writes nothing. Bindings that declare the struct themselves (ctypes,
 * P/Invoke) pass their own size. [any thread] */
KATA_API void kata_runtime_desc_init_sized(kata_runtime_desc* desc, uint32_t struct_size);
/* Fills 1.0's kata_runtime_desc (112 bytes) with the defaults: the entry point of programs built
 * before kata_runtime_desc_init_sized; it never writes more than 1.0's struct, however the struct grows.
 * In C and C++ the macro of the same name below calls kata_runtime_desc_init_sized. [any thread] */
KATA_API void kata_runtime_desc_init(kata_runtime_desc* desc);
/* Fills *desc with the defaults for the caller's own struct: kata_runtime_desc_init_sized(desc, sizeof *desc). */
#define kata_runtime_desc_init(desc) kata_runtime_desc_init_sized((desc), (uint32_t)sizeof *(desc))
/* Creates a runtime: binds / connects its sockets and starts its threads. Errors (an endpoint
 * that cannot be bound, bad values) are reported on the context. [any thread] */
KATA_API kata_status kata_runtime_create(kata_context context, const kata_runtime_desc* desc, kata_runtime* out);
/* Stops (kata_runtime_stop) and frees the runtime and every stream it owns. NULL is ignored.
 * Results published but not yet delivered to connected subscribers still go out: this waits for
 * them at most 2 s (a stalled subscriber loses what it had not taken). [any thread but the
 * runtime's own] */
KATA_API void kata_runtime_destroy(kata_runtime runtime);
/* Hands an open stream (kata_stream_open, teacher attached or not) to the runtime under
 * stream_id; on success the runtime owns it and *stream is set to NULL (do not close it).
 * The published skeleton definition announces the layout the stream was opened with (its built-in
 * layout, or its name map's 16 joint names), so subscribers and shards map it as the stream does.
 * preset: NULL, or the name of that same layout (another is refused: KATA_E_INVALID_ARGUMENT).
 * publish_features: 1 puts each result's features in its message (the stream needs
 * desc.keep_features). KATA_E_INVALID_ARGUMENT for a used id or a full runtime. [any thread] */
KATA_API kata_status kata_runtime_add_stream(kata_runtime runtime, uint64_t stream_id, kata_stream* stream,
                                             const char* preset, int32_t publish_features);
/* Queues one frame of a stream: the source's sequence number, capture time in seconds (must
 * increase), positions (joint_count x 3 floats). KATA_E_NOT_FOUND (no such stream),
 * KATA_E_WRONG_JOINT_COUNT (more than max_joints), KATA_E_QUEUE_FULL (the worker's queue is full:
 * dropped and counted), KATA_E_STOPPED (kata_runtime_stop has begun: not taken, counted).
 * Values are checked by the worker (bad frames counted as refused).
 * Never blocks, never allocates. [any thread] */
KATA_API kata_status kata_runtime_push(kata_runtime runtime, uint64_t stream_id, uint64_t sequence,
                                       double capture_time, const float* positions, uint32_t joint_count);
/* Practice (since 1.0; as a practice message from an ingest stream's source does,
 * schemas/practice.fbs): from the frames pushed after this call on, the stream follows its clip
 * teacher from teacher_start seconds (0: the teacher's first frame), or with loop != 0 only the
 * section loop_start..loop_end seconds, looped (teacher_start then 0). Times are teacher seconds
 * from the teacher's first frame, as kata_result_record.matched_teacher_time; each is rounded to
 * the nearest teacher frame. Queued in order with the frames pushed before it from the same
 * thread; every result from then on says it (kata_result_record.practice_*, practice_revision =
 * revision: give each change its own). KATA_E_NOT_FOUND (no such stream), KATA_E_INVALID_ARGUMENT
 * (a time not finite, negative or outside the clip, an empty loop, a start and a loop),
 * KATA_E_NO_CLIP_TEACHER (the stream has no clip teacher), KATA_E_QUEUE_FULL (its worker queue is
 * full, or stop has begun: send it again); the reason in kata_context_last_error. Nothing changes on a refusal. Never blocks.
 * [any thread] */
KATA_API kata_status kata_runtime_set_practice(kata_runtime runtime, uint64_t stream_id, uint32_t revision,
                                               double teacher_start, int32_t loop, double loop_start,
                                               double loop_end);
/* Finishes every queued frame, flushes every stream, publishes every result, stops the threads
 * and closes the sockets. Idempotent. [any thread but the runtime's own]
 * A kata_runtime_push racing stop on another thread is either taken (it returns KATA_OK and its
 * result is published before stop returns) or refused (it returns KATA_E_STOPPED); never lost.
 * Every push after stop began returns KATA_E_STOPPED. */
KATA_API kata_status kata_runtime_stop(kata_runtime runtime);
/* Copies the counters (out->struct_size: 1.0's size or more, see Versions). [any thread] */
KATA_API kata_status kata_runtime_get_counters(kata_runtime runtime, kata_runtime_counters* out);
/* The endpoint the publisher bound last, resolved (a "tcp://127.0.0.1:*" shows its port), or
 * "" without a publisher; valid while the runtime lives. [any thread] */
KATA_API const char* kata_runtime_publish_endpoint(kata_runtime runtime);
/* Likewise for the ingest socket. [any thread] */
KATA_API const char* kata_runtime_ingest_endpoint(kata_runtime runtime);

/* ---- Shards (since 0.2; docs/deploy.md) ----
 * Several `kata serve` processes split the streams: with [shard] count = N, index = i in its
 * config, a shard scores exactly the streams for which kata_shard_of(stream_id, N) == i and drops
 * the others' messages (counted). The hash is stable (never changes between versions):
 *   h = 14695981039346656037 (FNV-1a 64 offset basis)
 *   for byte b in the stream id's 8 bytes, least significant first: h ^= b; h *= 1099511628211
 *   shard = h mod N  (0 when N is 0 or 1)
 * so a producer in any language computes which shard owns a stream. [any thread] */
KATA_API uint32_t kata_shard_of(uint64_t stream_id, uint32_t shard_count);

/* ##############################################################################################
 * Task 6 - read messages: a subscriber of a runtime's results, in C
 *
 * -- a ZeroMQ SUB socket connected to kata_runtime_publish_endpoint(rt), subscribed to ""
 * int n = zmq_recv(sub, buffer, sizeof buffer, 0);
 * kata_result_record msg;  msg.struct_size = sizeof msg;
 * if (kata_message_read_result(buffer, (size_t)n, &msg) == KATA_OK)
 *   draw(msg.stream_id, msg.score, msg.ghost, msg.ghost_joint_count);
 * ############################################################################################ */

/* ---- Reading published messages (for subscribers in C; no FlatBuffers library needed) ---- */

/* A result message reads into one kata_result_record (kata/result.h); a message from a runtime
 * older than a field leaves it at its default (part_to_fix -1, matched_teacher_time -1, the rest 0). */

/* Reads one ZeroMQ message of a kata runtime (16-byte topic + FlatBuffer, schemas/result.fbs):
 * the FlatBuffers verifier checks it first. KATA_OK: *out holds the result (as much as
 * out->struct_size holds); KATA_NO_DATA: a valid kata message that is not a result (a skeleton
 * definition, a frame, stats, a practice setting: the runtime publishes stats on the results'
 * socket); KATA_E_PARSE: refused (truncated, corrupt, unknown). Allocates once per thread
 * (a scratch buffer for misaligned messages). [any thread] */
KATA_API kata_status kata_message_read_result(const void* message, size_t size, kata_result_record* out);

/* ##############################################################################################
 * Deprecated - kept for one major version (each names its replacement)
 *
 * ############################################################################################ */

/* ---- Deprecated: the 0.x "reference" calls ----
 * DEPRECATED since 1.0; removed in 2.0, not before 2027-06-01. Each is a thin wrapper over the
 * teacher (kata_stream_attach_teacher with ghost = 0, kata_stream_detach_teacher,
 * kata_stream_restart_teacher) and behaves as it did in 0.2; the replacement is named per call. */

/* Use kata_stream_attach_teacher with kata_teacher_desc.features, frames = 1, ghost = 0.
 * Sets a single-pose reference on a stream: features is one GPD v1 vector (count =
 * KATA_GPD_DIMS floats, e.g. a frame from kata_stream_features of a teacher stream), copied.
 * Replaces any previous reference. KATA_E_INVALID_ARGUMENT when the stream's stencil differs
 * from the model's or the features are not finite. Errors go to kata_stream_last_error.
 * Allocates. [stream owner] */
KATA_API KATA_DEPRECATED("since 1.0, removed in 2.0: kata_stream_attach_teacher with desc.features")
kata_status kata_stream_set_reference_pose(kata_stream stream, kata_model model, const float* features,
                                           size_t count);
/* Use kata_stream_attach_teacher with kata_teacher_desc.joints and .body_height, ghost = 0.
 * Sets a single-pose reference from the 16 GPD joints' world positions (KATA_GPD_JOINTS x 3
 * floats in GPD joint order, +Y up, any units) and the body height in the same units: a held
 * pose (kinetics zero). [stream owner] */
KATA_API KATA_DEPRECATED("since 1.0, removed in 2.0: kata_stream_attach_teacher with desc.joints")
kata_status kata_stream_set_reference_joints(kata_stream stream, kata_model model, const float* joints,
                                             size_t count, double body_height);
/* Use kata_stream_attach_teacher with kata_teacher_desc.features, .frames, .frame_time, ghost = 0.
 * Sets a clip reference: `frames` GPD v1 vectors (frames x KATA_GPD_DIMS floats, row-major),
 * frame_time seconds apart; copied into projections computed once. [stream owner] */
KATA_API KATA_DEPRECATED("since 1.0, removed in 2.0: kata_stream_attach_teacher with desc.features")
kata_status kata_stream_set_reference_clip(kata_stream stream, kata_model model, const float* features,
                                           uint32_t frames, double frame_time);
/* Use kata_stream_attach_teacher with kata_teacher_desc.clip (.preset, .first_frame,
 * .pose_frame), ghost = 0.
 * Sets a reference from a recorded clip, its features computed here with the model's stencil
 * (clip frames first_frame.. end; 1 skips the CMU converter's T-pose) through the named preset
 * ("cmu", ...). pose_frame >= 0: only that clip frame, as a pose reference; -1: the whole clip;
 * below -1: KATA_E_INVALID_ARGUMENT. [stream owner] */
KATA_API KATA_DEPRECATED("since 1.0, removed in 2.0: kata_stream_attach_teacher with desc.clip")
kata_status kata_stream_set_reference_bvh(kata_stream stream, kata_model model, kata_clip clip,
                                          const char* preset, uint32_t first_frame, int32_t pose_frame);
/* Use kata_stream_detach_teacher.
 * Removes the stream's reference (kata_stream_score then returns KATA_E_STATE). [stream owner] */
KATA_API KATA_DEPRECATED("since 1.0, removed in 2.0: kata_stream_detach_teacher")
kata_status kata_stream_clear_reference(kata_stream stream);
/* Use kata_stream_restart_teacher.
 * Restarts a clip reference's alignment: the next frame is matched from the clip's start.
 * [stream owner] */
KATA_API KATA_DEPRECATED("since 1.0, removed in 2.0: kata_stream_restart_teacher")
kata_status kata_stream_restart_reference(kata_stream stream);
/* Use kata_stream_read_newest (or kata_stream_read_results for every frame).
 * Copies the result record of the stream's newest feature vector into *out. Every vector is
 * scored in the push that emits it (so the alignment sees every frame, whatever the read rate);
 * a vector emitted before the reference was set is scored by this call. A later call without a
 * new push returns the same record. KATA_NO_DATA before the first feature vector; KATA_E_STATE
 * without a reference; KATA_E_INTERNAL (a bug, the record is withheld) when the score is not
 * finite. Does not allocate. [stream owner] */
KATA_API KATA_DEPRECATED("since 1.0, removed in 2.0: kata_stream_read_newest")
kata_status kata_stream_score(kata_stream stream, kata_result_record* out);

#ifdef __cplusplus
}
#endif

#endif /* KATA_KATA_H */
