/* kata/core.h: the basics: the export macro, versions, input limits, status codes and the
 * context every object is made from.
 *
 * Part of the C ABI; include "kata/kata.h" (all of it) or this header alone: it includes what it
 * needs. kata.h states the conventions every function here follows. */
#ifndef KATA_CORE_H
#define KATA_CORE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32)
#  if defined(KATA_BUILDING_SHARED)
#    define KATA_API __declspec(dllexport)
#  else
#    define KATA_API __declspec(dllimport)
#  endif
#else
#  define KATA_API __attribute__((visibility("default")))
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
#define KATA_VERSION_MINOR 1 /* additions since the major's first release */
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
#define KATA_MAX_TIME_STEP 1e6       /* seconds (11.6 days): a frame later than this after the previous is refused */
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
  KATA_E_NOT_FOUND = 10,              /* a named layout, joint or file is unknown */
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

#ifdef __cplusplus
}
#endif

#endif /* KATA_CORE_H */
