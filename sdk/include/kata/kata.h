/*
 * kata.h - the C ABI of kata, a real-time SDK for 3D human pose: GPD v1 features on live
 * streams, scoring against a teacher with a learned metric, and retargeting.
 *
 * This umbrella header includes the whole ABI, one header per part, each opening with an example
 * and read in this order:
 *   kata/core.h      the basics: versions, limits, status codes, the context
 *   kata/stream.h    task 1, open a stream: skeletons, clips, layouts, frames in, features out
 *   kata/teacher.h   tasks 2 and 3, attach a teacher and read results: models, scores, the cue
 *   kata/result.h    the one result record every reader fills
 *   kata/retarget.h  task 4, retarget: a teacher's posture on a student's body
 *   kata/runtime.h   tasks 5 to 7, run many streams (ZeroMQ in and out), read and write messages
 *   kata/humanoid.h  the student and the ghost as humanoid (VRM) bone rotations, for game engines
 *   kata/people.h    several people in one picture: which stream each unlabeled pose belongs to
 *   kata/vmc.h       avatars in game engines: humanoid poses out and in over the VMC protocol
 *   kata/kata_plugin.h (not included here) the plugin ABI of a runtime's sinks
 *
 * Conventions (they hold for every function below unless it says otherwise):
 * - Every fallible call returns a kata_status. KATA_OK is 0; KATA_NO_DATA is a result, not an
 *   error. Values are never reassigned; new ones are only added.
 * - Handles are opaque pointers. The caller owns what a *_create/_open/_load call returns and
 *   releases it with the matching *_destroy call (which accepts NULL).
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
 * - Strings from the caller (layout names, paths, keys) are read up to KATA_MAX_STRING_BYTES: one
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

#include "core.h"     /* KATA_API, versions, limits, kata_status, kata_context */
#include "result.h"   /* kata_result_record, kata_body_part, kata_score_state, kata_cue_action */
#include "stream.h"   /* kata_skeleton, kata_clip, kata_stream */
#include "retarget.h" /* kata_retarget_desc, kata_retargeter */
#include "teacher.h"  /* kata_model, kata_teacher_desc, reading results */
#include "runtime.h"  /* kata_runtime, kata_message_read_result, kata_message_write_* */
#include "humanoid.h" /* kata_humanoid_rig, kata_humanoid_pose: VRM bone rotations */
#include "people.h"   /* kata_people: identity of unlabeled multi-person detections */
#include "vmc.h"      /* kata_vmc_write_pose, kata_vmc_reader: the VMC protocol (OSC) */

#endif /* KATA_KATA_H */
