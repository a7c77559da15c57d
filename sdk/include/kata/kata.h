/*
 * kata.h - the C ABI of kata, a real-time SDK for 3D human pose: GPD v1 features on live
 * streams, scoring against a teacher with a learned metric, and retargeting.
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
 */
#ifndef KATA_KATA_H
#define KATA_KATA_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32)
#  if defined(KATA_BUILDING_SHARED)
#    define KATA_API __declspec(dllexport)
#  else
#    define KATA_API __declspec(dllimport)
#  endif
#else
#  define KATA_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ==== Versions ============================================================================ */

#define KATA_VERSION_MAJOR 0
#define KATA_VERSION_MINOR 1
#define KATA_VERSION_PATCH 0
/* The feature layout this library computes (spec gpd-v1.md); stored in every model file. */
#define KATA_GPD_LAYOUT "gpd-v1"
/* Dimensions of a GPD v1 feature vector, and of its 16-joint skeleton. */
#define KATA_GPD_DIMS 1683
#define KATA_GPD_JOINTS 16

/* The library's version at run time, as MAJOR * 10000 + MINOR * 100 + PATCH. [any thread] */
KATA_API uint32_t kata_version(void);

/* ==== Status codes ======================================================================== */

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
  KATA_E_STATE = 14                   /* the call is not valid in the object's current state */
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
/* The message of the last failed call made on this context from the calling thread, or "".
 * Valid until that thread's next call on the context. [any thread] */
KATA_API const char* kata_context_last_error(kata_context context);

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

/* ==== Clips (recorded motion) ============================================================== */

/* A recorded motion (a BVH file) with its skeleton; immutable. */
typedef struct kata_clip_s* kata_clip;

/* Loads a BVH file. A malformed file is refused with KATA_E_PARSE and a message naming the
 * file and line. [any thread] */
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

typedef enum kata_up_axis {
  KATA_UP_Y = 0, /* +Y up (BVH, most engines) */
  KATA_UP_Z = 1  /* +Z up: (x, y, z) is read as (x, z, -y) */
} kata_up_axis;

/* How a stream maps and treats its input. Fill with kata_stream_desc_init, then change fields.
 * Starts with struct_size so later versions can grow it. */
typedef struct kata_stream_desc {
  uint32_t struct_size;        /* sizeof(kata_stream_desc) */
  /* Joint map onto the 16 GPD joints: a preset name ("cmu", see kata_preset_name), or NULL
   * and a name-map file (JSON {"Hip": "pelvis", ...} or "Hip = pelvis" lines). */
  const char* preset;
  const char* name_map_path;
  kata_stencil stencil;        /* default KATA_STENCIL_BACKWARD */
  kata_up_axis up_axis;        /* default KATA_UP_Y */
  double max_gap;              /* seconds; a larger gap restarts the kinetics. Default 0.25 */
  uint32_t history_capacity;   /* frames kept in the ring buffer (>= 4). Default 16 */
  /* Body height H in input units. 0 (default): from the skeleton's rest pose when it has one,
   * else the median over the first calibration_frames frames (held until then). */
  double body_height;
  uint32_t calibration_frames; /* default 8 */
} kata_stream_desc;

/* Fills desc with the defaults above (struct_size set). [any thread] */
KATA_API void kata_stream_desc_init(kata_stream_desc* desc);
/* The name of built-in preset i ("cmu", ...), or NULL past the last. [any thread] */
KATA_API const char* kata_preset_name(uint32_t i);

/* Opens a stream for frames of `skeleton`. Allocates all its memory now. The skeleton is
 * copied; it may be destroyed afterwards. Errors (unknown preset, a mapped joint missing from
 * the skeleton, bad values) are reported on the context. [any thread] */
KATA_API kata_status kata_stream_open(kata_context context, kata_skeleton skeleton, const kata_stream_desc* desc,
                                      kata_stream* out);
/* Closes a stream and frees its memory. NULL is ignored. [stream owner] */
KATA_API void kata_stream_close(kata_stream stream);
/* The message of the last failed call on this stream, or "". [stream owner] */
KATA_API const char* kata_stream_last_error(kata_stream stream);

/* Pushes one frame: timestamp in seconds (must increase), positions of every joint of the
 * stream's skeleton (joint_count x 3 floats, x, y, z interleaved, input units). A refused frame
 * (KATA_E_NULL_POINTER, KATA_E_WRONG_JOINT_COUNT, KATA_E_NON_FINITE,
 * KATA_E_TIMESTAMP_NOT_INCREASING) changes nothing; the stream stays usable. Does not allocate.
 * [stream owner] */
KATA_API kata_status kata_stream_push(kata_stream stream, double timestamp, const float* positions,
                                      uint32_t joint_count);
/* Ends the current segment (end of a take): with the central stencil the held frame is
 * computed now with the backward formulas. The next frame starts a new segment. [stream owner] */
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

/* ==== Models and scoring ================================================================== */
/* (section: models and scoring) */

/* ==== Retargeting ========================================================================= */
/* (section: retargeting) */

#ifdef __cplusplus
}
#endif

#endif /* KATA_KATA_H */
