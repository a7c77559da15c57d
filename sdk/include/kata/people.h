/* kata/people.h: several people in one picture: which stream each unlabeled pose belongs to.
 *
 * Part of the C ABI; include "kata/kata.h" (all of it) or this header alone: it includes what it
 * needs. kata.h states the conventions every function here follows. */
#ifndef KATA_PEOPLE_H
#define KATA_PEOPLE_H

#include "core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ##############################################################################################
 * Several people - a multi-person detector gives each frame's poses unlabeled, in any order;
 * the people tracker keeps each person on their own stream
 *
 * kata_people_desc d;  kata_people_desc_init(&d);  d.joint_count = 33;    -- MediaPipe
 * kata_people p;  kata_people_create(ctx, &d, &p);                        -- allocates, once
 * uint32_t ids[16];                                                        -- per frame:
 * kata_people_track(p, t, xyz, confidence, pose_count, ids, 16);          -- no allocation
 * for each pose i: ids[i] is its person's stream id (0: the pose was refused); push pose i to
 * that person's stream (kata_stream_push_confidence), opening one for an id
 * kata_people_opened names, destroying the one of an id kata_people_closed names.
 * ############################################################################################ */

/* ==== The people tracker ================================================================== */
/* Identity without labels. Each frame, every pose is summarised by its centroid (the mean of its
 * confident joints), its size (their RMS distance from the centroid) and its shape (the joints
 * about the centroid). Each open stream predicts where its person is now: the last centroid
 * moved on at the person's smoothed velocity, for at most coast_seconds (a person hidden behind
 * another keeps walking in the prediction, then waits where it stopped). Streams and poses are
 * paired by the assignment of least total cost (the Hungarian method), the cost in body sizes:
 *   |centroid - predicted| / size + shape_weight x mean over joints |shape - stream's shape| / size
 * and a pose may take a stream only inside its gate: within gate + gate_growth x (seconds unseen)
 * body sizes of the prediction, and its size within size_gate times the stream's. A pose outside
 * every gate is a new person: it opens a new stream and never inherits someone's. A stream unseen
 * for longer than forget_seconds closes; its person, coming back later, gets a new stream.
 * Stream ids count up from 1 and are not reused (until 2^32 - 1 wraps).
 * What identity rests on: motion continuity and body size, not appearance. Someone who enters
 * where a hidden or departed person is expected, of a similar size, within forget_seconds, takes
 * that person's stream; lower gate_growth and forget_seconds narrow that window.
 * Poses: joint_count joints of any layout (MediaPipe, COCO/OpenPose keypoints, MoveNet, H36M; 2D
 * keypoints with z = 0 work as well), every pose of a frame in one space (camera or world; a
 * detector's per-person world landmarks, which are centred on each person's hips, must be
 * offset by the person's place first). Units do not matter (sizes are relative).
 * Memory: kata_people_create allocates everything; kata_people_track never allocates.
 * Threads: one tracker is used by one thread at a time. */

/* A tracker of the people of one camera (or any one source of multi-person frames). */
typedef struct kata_people_s* kata_people;

/* How a tracker tracks (1.1). Fill with kata_people_desc_init, then change fields. */
typedef struct kata_people_desc {
  uint32_t struct_size;    /* sizeof(kata_people_desc) */
  uint32_t joint_count;    /* joints per pose (1..4096); no default: set it */
  uint32_t max_people;     /* streams open at once (1..64). Default 8 */
  uint32_t max_poses;      /* poses of a frame taken, the most confident first (1..64). Default 16 */
  double forget_seconds;   /* a stream unseen for longer closes (0..3600]. Default 3 */
  double coast_seconds;    /* a hidden person's predicted motion runs this long [0, 60]. Default 1 */
  double gate;             /* body sizes a pose may lie from a stream seen the frame before. Default 1 */
  double gate_growth;      /* body sizes per second unseen the gate widens by. Default 2 */
  double size_gate;        /* a pose's size within [1/size_gate, size_gate] x the stream's (>= 1). Default 1.5 */
  double shape_weight;     /* weight of the shape term in the cost (>= 0). Default 1 */
  double min_confidence;   /* joints less confident are ignored, whatever their coordinates [0, 1]. Default 0.3 */
} kata_people_desc;

/* Fills the first struct_size bytes of desc with the defaults above and sets desc->struct_size
 * to the smaller of struct_size and sizeof(kata_people_desc) (the rule of
 * kata_retarget_desc_init_sized). [any thread] */
KATA_API void kata_people_desc_init_sized(kata_people_desc* desc, uint32_t struct_size);
/* Fills *desc with the defaults for the caller's own struct: kata_people_desc_init_sized(desc, sizeof *desc). */
#define kata_people_desc_init(desc) kata_people_desc_init_sized((desc), (uint32_t)sizeof *(desc))

/* What a tracker did since it was created (1.1). Written by the library; the caller sets
 * struct_size. Every pose of an accepted frame ends as exactly one of: assigned, or one of the
 * refused_* causes. */
typedef struct kata_people_counters {
  uint32_t struct_size;             /* set by the caller: sizeof(kata_people_counters) */
  uint32_t open_streams;            /* streams open now (seen or hidden) */
  uint64_t frames;                  /* frames accepted */
  uint64_t empty_frames;            /* accepted frames without a pose */
  uint64_t refused_frames;          /* frames refused: time not finite or not after the previous frame's */
  uint64_t poses;                   /* poses in accepted frames */
  uint64_t assigned;                /* poses given a stream (an open one or a new one) */
  uint64_t opened;                  /* streams opened */
  uint64_t closed;                  /* streams closed (unseen for longer than forget_seconds) */
  uint64_t refused_non_finite;      /* poses with a NaN or infinite confident joint or confidence */
  uint64_t refused_out_of_range;    /* poses with a confident joint beyond KATA_MAX_COORDINATE */
  uint64_t refused_few_joints;      /* poses with fewer than 3 confident joints, or all on one point */
  uint64_t refused_too_many_poses;  /* poses beyond max_poses in a frame (the least confident) */
  uint64_t refused_table_full;      /* new people while max_people streams were open */
} kata_people_counters;

/* Creates a tracker. desc may not be NULL (joint_count has no default); desc->struct_size is
 * 1.1's size or more. Errors (a field out of range) are reported on the context. [any thread] */
KATA_API kata_status kata_people_create(kata_context context, const kata_people_desc* desc, kata_people* out);
/* Releases a tracker. NULL is ignored. [tracker owner] */
KATA_API void kata_people_destroy(kata_people people);
/* The message of the last failed call on this tracker, or "". Valid until the next call on it.
 * [tracker owner] */
KATA_API const char* kata_people_last_error(kata_people people);

/* One frame of a multi-person detector. time: seconds, finite, after the previous frame's (an
 * empty frame counts: it ages the streams). xyz: pose_count poses of joint_count x 3 floats (x,
 * y, z interleaved), back to back, in any order (may be NULL when pose_count is 0). confidence:
 * pose_count x joint_count values in [0, 1] (a MediaPipe landmark's visibility), or NULL for all
 * 1; a joint below min_confidence is ignored, whatever its coordinates. ids (capacity >=
 * pose_count) receives, per pose, its person's stream id, or 0 when the pose was refused (a NaN
 * or out-of-range confident joint, too few confident joints, beyond max_poses, or a new person
 * while max_people streams are open: counted by cause in kata_people_counters); the other poses
 * of the frame are tracked as usual. KATA_E_NON_FINITE / KATA_E_TIMESTAMP_NOT_INCREASING for the
 * time (counted in refused_frames), KATA_E_NULL_POINTER, KATA_E_BUFFER_TOO_SMALL: nothing else
 * changed. Does not allocate. [tracker owner] */
KATA_API kata_status kata_people_track(kata_people people, double time, const float* xyz, const float* confidence,
                                       uint32_t pose_count, uint32_t* ids, size_t capacity);
/* The streams the last kata_people_track opened (new people): up to capacity ids into ids,
 * *count (may be NULL) the number opened; KATA_E_BUFFER_TOO_SMALL when capacity is smaller
 * (the first capacity are written). At most max_poses. [tracker owner] */
KATA_API kata_status kata_people_opened(kata_people people, uint32_t* ids, size_t capacity, uint32_t* count);
/* The streams the last kata_people_track closed (unseen for longer than forget_seconds), as
 * kata_people_opened. At most max_people. [tracker owner] */
KATA_API kata_status kata_people_closed(kata_people people, uint32_t* ids, size_t capacity, uint32_t* count);
/* The streams open now, seen or hidden, as kata_people_opened. [tracker owner] */
KATA_API kata_status kata_people_streams(kata_people people, uint32_t* ids, size_t capacity, uint32_t* count);
/* Where a stream's person is predicted at `time` (seconds): centroid[3], in the poses' units.
 * KATA_E_NOT_FOUND for an id that is not open. [tracker owner] */
KATA_API kata_status kata_people_predicted(kata_people people, uint32_t id, double time, double* centroid);
/* Copies the tracker's counters into *counters (counters->struct_size set by the caller).
 * [tracker owner] */
KATA_API kata_status kata_people_get_counters(kata_people people, kata_people_counters* counters);

/* ---- Several people through a runtime (kata serve): the people frame message (1.1) ----
 * A source with a multi-person detector defines one group stream as usual (a skeleton message:
 * the joints of one pose, their layout, the teacher) and then sends, per image, one people frame
 * message (schemas/people_frame.fbs): every pose found, in any order, without ids. The runtime
 * keeps a people tracker per group stream (the defaults of kata_people_desc_init) and pushes each
 * person's poses to their own stream, kata_people_stream_id(group, person), which it opens with
 * the group's definition when the person first appears (announced to subscribers like any
 * stream: results under that stream's topic) and closes when the tracker forgets the person or
 * the group closes. The group stream's own frames, if any, are scored as usual. A pose the
 * tracker refuses (a NaN joint, too few confident joints, beyond max_people) is dropped while the
 * frame's other poses go on; a malformed message is counted by cause in the ingest's counters, a
 * good one as a frame of the group stream (kata_runtime_counters.ingest_frames). What becomes of
 * every people frame and pose (tracked, refused by cause) is counted in
 * kata_runtime_counters.people_*. */

/* The most poses one people frame message carries. */
#define KATA_MAX_PEOPLE_POSES 64

/* One image of a group stream: what kata_message_write_people_frame encodes (1.1). Fill with
 * kata_people_frame_message_init, then set the fields. */
typedef struct kata_people_frame_message {
  uint32_t struct_size;       /* sizeof(kata_people_frame_message) */
  uint32_t joint_count;       /* joints of one pose: the group's skeleton message's (1..1048576) */
  uint64_t stream_id;         /* the group stream (an earlier skeleton message of this sender) */
  uint64_t sequence;          /* +1 per people frame of the group from 0 (as a frame message's) */
  double capture_time;        /* seconds on the source's clock, increasing, within +-9.2e9 */
  uint32_t pose_count;        /* poses in positions (0..KATA_MAX_PEOPLE_POSES; 0: nobody seen) */
  uint32_t reserved;          /* 0 */
  /* pose_count x joint_count x 3 floats, every pose in the skeleton message's joint order and
   * units, all in one space (camera or world); written as given (a pose with a NaN joint is the
   * receiving tracker's to refuse). May be NULL when pose_count is 0. */
  const float* positions;
  /* pose_count x joint_count confidences in [0, 1], or NULL (default): every joint confident. */
  const float* confidences;
} kata_people_frame_message;

/* Fills the first struct_size bytes of message with the defaults (zeros, no pose) and sets
 * message->struct_size as kata_people_desc_init_sized does. [any thread] */
KATA_API void kata_people_frame_message_init_sized(kata_people_frame_message* message, uint32_t struct_size);
/* Fills *message with the defaults for the caller's own struct. */
#define kata_people_frame_message_init(message) \
  kata_people_frame_message_init_sized((message), (uint32_t)sizeof *(message))

/* Writes a people frame message (schemas/people_frame.fbs; the topic is the group stream's; the
 * buffer rules of kata_message_write_frame: KATA_OK with *size the bytes written,
 * KATA_E_BUFFER_TOO_SMALL with *size the bytes needed and nothing written). Refused, writing
 * nothing, with the reason in kata_context_last_error: KATA_E_NULL_POINTER (message, size, or
 * positions with poses), KATA_E_WRONG_JOINT_COUNT, KATA_E_INVALID_ARGUMENT (pose_count above
 * KATA_MAX_PEOPLE_POSES, capture_time out of range), KATA_E_NON_FINITE (capture_time). [any thread] */
KATA_API kata_status kata_message_write_people_frame(const kata_people_frame_message* message, void* buffer,
                                                     size_t capacity, size_t* size);
/* The stream id a runtime gives person `person` (an id of the group's tracker: 1, 2, ...) of group
 * stream `group`: FNV-1a 64 over both as 8 little-endian bytes each, 2 subtracted when it falls on
 * one of the two reserved ids (2^64-2, 2^64-1). [any thread] */
KATA_API uint64_t kata_people_stream_id(uint64_t group, uint32_t person);

#ifdef __cplusplus
}
#endif

#endif /* KATA_PEOPLE_H */
