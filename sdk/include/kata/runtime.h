/* kata/runtime.h: tasks 5 to 7, run many streams, read and write messages: a runtime with its
 * workers and ZeroMQ in and out, shards, reading a published result in C and writing the messages
 * a source sends to a runtime's ingest.
 *
 * Part of the C ABI; include "kata/kata.h" (all of it) or this header alone: it includes what it
 * needs. kata.h states the conventions every function here follows. */
#ifndef KATA_RUNTIME_H
#define KATA_RUNTIME_H

#include "result.h"
#include "stream.h"

#ifdef __cplusplus
extern "C" {
#endif

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
/* (section: runtime)
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

/* A consumer of every result inside the process (1.1; kata_runtime_desc.on_result): an app that
 * runs the runtime and draws or records its results itself (kata coach) needs no subscriber of
 * its own publisher. Called by the runtime thread that holds the publisher (a worker or the I/O
 * thread: one call at a time; each stream's results in order), after the result was published,
 * with the runtime's own record: result->struct_size is this library's sizeof(kata_result_record)
 * (a caller built against an older kata.h reads the fields it knows), stream_id and
 * published_ns are set, and result->ghost (ghost_joint_count x 3 floats, or NULL) and the record
 * are valid only during the call: copy what is kept. It must return quickly and must not call
 * kata_runtime_* on its runtime (stop and destroy wait for it). `user` is on_result_user. */
typedef void (*kata_result_callback)(void* user, const kata_result_record* result);
/* A consumer of every repetition that ends inside the process (1.1; kata_runtime_desc.on_repetition;
 * docs/coach/repetitions.md): called as on_result is, right after the result of the frame that
 * ended the repetition (and after the Repetition message was published), with the runtime's own
 * kata_repetition (struct_size this library's, stream_id set), valid only during the call. `user`
 * is on_result_user. */
typedef void (*kata_repetition_callback)(void* user, const kata_repetition* repetition);

/* A consumer of every frame a runtime queues for a stream (1.1; kata_runtime_desc.on_frame): the
 * frame's joints as queued (by kata_runtime_push, an ingest Frame message or a source plugin), e.g.
 * to send the student's pose on (kata serve's [vmc]), where results carry only the ghost. Called on
 * the pushing thread right after the frame was queued (the I/O thread for ingest frames, a source
 * plugin's own thread, the app's for kata_runtime_push), so calls for different streams may run at
 * once; one stream's come in its order when it has one producer. A frame that was not queued (full
 * queue, unknown stream) is not handed over. xyz (joint_count x 3 floats, the stream's units and
 * axes) is valid only during the call. It must return quickly, must neither block nor allocate
 * (it is on the live path) and must not call kata_runtime_* on its runtime. `user` is
 * on_frame_user. */
typedef void (*kata_frame_callback)(void* user, uint64_t stream_id, uint64_t sequence, double capture_time,
                                    const float* xyz, uint32_t joint_count);

/* What a skeleton definition says of the stream it opens (1.1; kata_runtime_desc.on_stream_open).
 * Written by the library: struct_size is this library's sizeof(kata_stream_open_info) (a caller
 * built against an older kata.h reads the fields it knows); valid only during the call. */
typedef struct kata_stream_open_info {
  uint32_t struct_size;     /* this library's sizeof(kata_stream_open_info) */
  uint32_t joint_count;     /* joints per frame of the stream's skeleton */
  uint64_t stream_id;       /* the stream the definition opens */
  uint32_t revision;        /* the definition's revision (a new skeleton opens the stream anew) */
  int32_t has_rest_pose;    /* 1: the definition carries rest offsets (a ghost on its own joints) */
  const char* layout;       /* the definition's layout name ("cmu", "mediapipe"...), "" for a name map */
  double frame_rate;        /* Hz as the source declared it; 0 unknown */
  kata_skeleton skeleton;   /* the stream's skeleton (owned by the library: valid during the call;
                               kata_skeleton_joint_name etc. may read it) */
} kata_stream_open_info;

/* Called when a skeleton definition (from the ingest sockets or kata_runtime_offer) opens a
 * stream, on the runtime's I/O thread (also for kata_runtime_offer's), before the
 * stream's first frame (1.1; kata_runtime_desc.on_stream_open). `stream` is the new stream, opened
 * with the definition's layout and kata_runtime_desc.stream_stencil; inside the call the app may
 * configure it with the calls of the stream owner: kata_stream_attach_shared_teacher (the cheap
 * way: the teacher built once with kata_teacher_create), kata_stream_attach_teacher,
 * kata_stream_set_practice_section, kata_stream_set_calibration. After the call the runtime owns
 * it: the app must not keep or use the handle. Return KATA_OK to open the stream; any other status
 * refuses it (its frames are dropped as an unknown stream's until a definition is accepted;
 * counted in kata_runtime_counters.streams_refused_by_app, and within ingest_dropped), and
 * other streams are untouched. The I/O thread carries every stream's frames: the call must not
 * block or load anything (build teachers before kata_runtime_start), and must not call
 * kata_runtime_* on its runtime. `user` is on_stream_open_user. */
typedef kata_status (*kata_stream_open_callback)(void* user, const kata_stream_open_info* info, kata_stream stream);

/* A plugin for kata_runtime_desc.plugins (since 1.1). */
typedef struct kata_runtime_plugin {
  const char* path;    /* the plugin's shared module (.so) */
  const char* config;  /* its configuration, "key=value;..." as the plugin documents it, or NULL ("") */
} kata_runtime_plugin;

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
  /* ---- who may send what (docs/deploy.md, docs/runtime.md) ----
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
  /* ---- 1.1 ---- */
  kata_result_callback on_result;   /* every result, in the process (above), or NULL (default) */
  void* on_result_user;             /* passed to on_result as is. Default NULL */
  /* 1: the ingest is fed by the app's own transport through kata_runtime_offer (a NATS client, a
   * message queue) instead of sockets: ingest_endpoints must then be NULL or "". Its messages are
   * judged as a socket's are (the sender limits, max_frame_age_seconds, the ingest counters).
   * 0 (default): sockets, or no ingest. Since 1.1. */
  int32_t direct_ingest;
  /* Called when a skeleton definition opens a stream (kata_stream_open_callback above), so the
   * app attaches its teacher to streams it did not open itself. NULL (default): streams open with
   * no teacher (features only). Since 1.1. */
  kata_stream_open_callback on_stream_open;
  void* on_stream_open_user;        /* passed to on_stream_open as is. Default NULL */
  /* The stencil of the streams definitions open (kata_stream_desc.stencil): a teacher attached in
   * on_stream_open needs its model's (kata_model_stencil). Default KATA_STENCIL_BACKWARD. Since 1.1. */
  kata_stencil stream_stencil;
  /* ---- 1.1: the rest of what a `kata serve` config sets (docs/config.md) ---- */
  /* This runtime is shard shard_index of shard_count: it scores exactly the streams for which
   * kata_shard_of(stream_id, shard_count) == shard_index; the others' ingest messages are counted
   * in kata_runtime_counters.ingest_other_shard and dropped (not refused). shard_count 1..65536,
   * shard_index below it. Default 1 and 0: every stream. Since 1.1. */
  uint32_t shard_count;
  uint32_t shard_index;             /* see shard_count. Default 0. Since 1.1 */
  /* 1 (default): ingest frames that carry no checksum are refused as malformed; 0 takes them
   * (a source that predates checksums). Since 1.1. */
  int32_t require_checksum;
  /* How a worker out of frames waits (docs/runtime.md): 0 (default) parks at
   * once (no CPU while idle); 1 spins, then yields, for a few microseconds before it parks (for
   * dedicated cores: frames of a burst that arrive a little apart find it awake). Since 1.1. */
  int32_t idle_backoff;
  /* Results a worker holds before they are sent (>= 2; rounded up to a power of two). 0
   * (default): queue_capacity. Since 1.1. */
  uint32_t result_queue_capacity;
  /* With key_file: the server .pub file of the results proxy a "connect:" publish endpoint
   * connects to (`kata proxy`, docs/deploy.md), or NULL (default). Since 1.1. */
  const char* publish_server_key_file;
  /* An ingest frame whose sequence is more than this after its stream's last is dropped
   * (kata_runtime_counters.ingest_out_of_window), >= 1. Default 65536. Since 1.1. */
  uint64_t sequence_window;
  /* Plugins the runtime hosts (kata/kata_plugin.h; since 1.1): plugin_count entries, read during
   * kata_runtime_create only. Each is loaded and activated with its config by create, in order
   * (a refusal, the plugin's own message included, fails create naming its file): a sink gets
   * every result (before on_result), a source is started once the runtime runs and stopped first
   * thing in kata_runtime_stop. NULL / 0 (default): none. */
  const kata_runtime_plugin* plugins;
  uint32_t plugin_count;            /* entries in plugins. Default 0. Since 1.1 */
  /* ---- 1.1, later ---- */
  kata_repetition_callback on_repetition; /* every repetition that ends, in the process (above), or
                                             NULL (default). Since 1.1 */
  kata_frame_callback on_frame;     /* every frame queued, in the process (above), or NULL
                                       (default). Since 1.1 */
  void* on_frame_user;              /* passed to on_frame as is. Default NULL. Since 1.1 */
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
  /* the causes inside ingest_dropped that an attack or a misconfigured sender shows */
  uint64_t ingest_not_owner;        /* messages for a stream another sender owns */
  uint64_t ingest_refused_limit;    /* definitions beyond a streams limit */
  uint64_t ingest_out_of_window;    /* sequence numbers far beyond the last one */
  uint64_t ingest_stale;            /* frames older than max_frame_age_seconds */
  uint64_t closed_streams;          /* streams closed (by their owner, idle, a new skeleton) */
  /* with practice messages (schemas/practice.fbs, docs/runtime.md): applied, and the
   * causes of those refused (inside ingest_dropped; another sender's are in ingest_not_owner) */
  uint64_t ingest_practices;              /* practice settings applied */
  uint64_t ingest_practice_bad_values;    /* a time not finite or negative, an empty loop, both */
  uint64_t ingest_practice_outside_clip;  /* outside the stream's teacher clip */
  uint64_t ingest_practice_no_clip;       /* for a stream without a clip teacher */
  uint64_t ingest_practice_queue_full;    /* the stream's worker queue was full */
  /* ---- 1.1 ---- */
  uint64_t streams_refused_by_app;  /* definitions kata_runtime_desc.on_stream_open refused (within
                                      ingest_dropped) */
  /* ---- 1.1: every ingest outcome and every result loss by cause (what `kata serve` prints) ----
   * Every ingest message has one outcome, a frame batch counted as its frames:
   * ingest_received - ingest_batches + ingest_batch_frames = ingest_frames + ingest_skeletons +
   * ingest_repeated_skeletons + ingest_closes + ingest_practices + ingest_repeated_practices +
   * ingest_other_shard + ingest_dropped. */
  uint64_t ingest_frames;               /* frames handed to their streams */
  uint64_t ingest_skeletons;            /* skeleton definitions handed on (new streams, new revisions) */
  uint64_t ingest_repeated_skeletons;   /* periodic re-sends of a known definition (not a drop) */
  uint64_t ingest_closes;               /* streams closed by their source's message */
  uint64_t ingest_repeated_practices;   /* re-sends of the practice setting in force (not a drop) */
  uint64_t ingest_other_shard;          /* messages of streams another shard owns (not a drop) */
  uint64_t ingest_batches;              /* frame batches read (their frames are judged one by one) */
  uint64_t ingest_batch_frames;         /* the frames those batches carried */
  /* the other causes inside ingest_dropped */
  uint64_t ingest_malformed;            /* refused by the verifier (truncated, corrupt, a bad checksum) */
  uint64_t ingest_refused_skeletons;    /* definitions verified but refused (inconsistent, no such layout) */
  uint64_t ingest_unknown_stream;       /* frames before (or without) their stream's definition */
  uint64_t ingest_wrong_joint_count;    /* frames with another joint count than their definition's */
  uint64_t ingest_out_of_order;         /* frames whose sequence is not after the last one */
  uint64_t ingest_other_kind;           /* valid kata messages that are not ingest's (a result) */
  /* the ingest's connections (sockets only) */
  uint64_t ingest_connections;          /* connections accepted or made */
  uint64_t ingest_disconnections;       /* connections closed */
  uint64_t ingest_connections_refused;  /* connections closed at once: max_connections reached */
  uint64_t ingest_handshake_failures;   /* connections closed before their ZeroMQ handshake finished */
  uint64_t ingest_last_handshake_error; /* ZeroMQ's ZMQ_PROTOCOL_ERROR_* of the last such failure
                                           that had a reason; 0 none */
  /* results_dropped by cause, and the results ZeroMQ refused */
  uint64_t pipeline_dropped;            /* results overwritten in a stream's ring before they were read */
  uint64_t result_queue_full;           /* results dropped: the queue to the publisher was full */
  uint64_t send_failed;                 /* results ZeroMQ refused to take (never blocks) */
  /* ---- 1.1: people frames (kata/people.h, "Several people through a runtime"), over every group
   * stream since the start (a closed group's counts stay). A people frame handed to its group
   * (within ingest_frames) is tracked or refused: people_frames + people_refused_frames. Every pose
   * of a tracked frame ends as exactly one of: people_poses = people_poses_tracked +
   * people_refused_non_finite + people_refused_out_of_range + people_refused_few_joints +
   * people_refused_too_many_poses + people_refused_table_full. A tracked pose is pushed to its
   * person's stream as a frame of it (frames_in and the stream's counters take it from there), or
   * counted in people_poses_unopened. */
  uint64_t people_frames;                 /* people frames tracked (empty ones included) */
  uint64_t people_empty_frames;           /* tracked people frames without a pose */
  uint64_t people_refused_frames;         /* people frames not tracked: capture time not after the group's
                                             previous one, or the group stream closed by the app */
  uint64_t people_poses;                  /* poses in tracked people frames */
  uint64_t people_poses_tracked;          /* poses given a person (one seen before or a new one) */
  uint64_t people_refused_non_finite;     /* poses with a NaN or infinite confident joint or confidence */
  uint64_t people_refused_out_of_range;   /* poses with a confident joint beyond KATA_MAX_COORDINATE */
  uint64_t people_refused_few_joints;     /* poses with fewer than 3 confident joints, or all on one point */
  uint64_t people_refused_too_many_poses; /* poses beyond the tracker's max_poses in a frame (the least
                                             confident; a runtime's tracker takes KATA_MAX_PEOPLE_POSES) */
  uint64_t people_refused_table_full;     /* new people while a group had 8 persons (kata_people_desc's
                                             default max_people) */
  uint64_t people_streams_opened;         /* person streams opened (announced like any stream; counted in
                                             streams while open, then in closed_streams) */
  uint64_t people_streams_closed;         /* person streams closed: the tracker forgot the person, or their
                                             group stream closed */
  uint64_t people_streams_refused;        /* new persons whose stream could not be opened (max_streams) */
  uint64_t people_poses_unopened;         /* tracked poses dropped: their person's stream could not be opened */
} kata_runtime_counters;

/* One stream's counters (1.1; kata_runtime_get_stream_counters): every frame pushed or ingested
 * for the stream ends as one published result or as one count of exactly one of the causes
 * between stopped and send_failed. Written by the library; the caller sets struct_size. */
typedef struct kata_stream_counters {
  uint32_t struct_size;       /* set by the caller: sizeof(kata_stream_counters) */
  uint32_t reserved;          /* 0 */
  uint64_t stream_id;         /* the stream these counters are of */
  uint64_t frames_in;         /* frames queued */
  uint64_t results;           /* results computed */
  uint64_t published;         /* results handed to ZeroMQ */
  uint64_t queue_full;        /* frames dropped: the worker's queue was full */
  uint64_t stopped;           /* frames refused because kata_runtime_stop had begun */
  uint64_t stale;             /* ingest frames too old to score (kata_runtime_desc.max_frame_age_seconds) */
  uint64_t unauthorised;      /* ingest frames from a sender the stream does not belong to */
  uint64_t out_of_sequence;   /* ingest frames out of order or outside the sequence window */
  uint64_t wrong_joints;      /* ingest frames with another joint count than the stream's */
  uint64_t refused;           /* frames the pipeline refused (kata_stream_push's reasons) */
  uint64_t pipeline_dropped;  /* results overwritten in the stream's ring before they were read */
  uint64_t result_queue_full; /* results dropped: the queue to the publisher was full */
  uint64_t send_failed;       /* results ZeroMQ refused */
} kata_stream_counters;

/* The runtime's histograms (1.1; kata_runtime_get_histogram). Both count nanoseconds in
 * KATA_LATENCY_BUCKETS buckets: bucket i holds [2^(i/8), 2^((i+1)/8)) ns, the last also
 * anything longer. */
typedef enum kata_histogram_kind {
  /* a frame's arrival to its result's hand-over to ZeroMQ, every published result (what
   * kata_runtime_latency_percentile reads) */
  KATA_HISTOGRAM_LATENCY = 0,
  /* a source's age of every ingest frame handed on: its arrival minus its capture time, beyond
   * the stream's quickest delivery (a source that falls behind shows here) */
  KATA_HISTOGRAM_SOURCE_AGE = 1
} kata_histogram_kind;

/* Buckets of a kata_runtime_get_histogram histogram (see kata_histogram_kind). */
#define KATA_LATENCY_BUCKETS 288

/* Fills the first struct_size bytes of desc with the defaults above and sets desc->struct_size
 * to the smaller of struct_size and sizeof(kata_runtime_desc): nothing past the caller's own struct is
 * written, so a caller built against an older kata.h (a smaller struct) is safe with a
 * newer library, which then reads only that much (the later fields keep their defaults).
 * struct_size below 4 writes nothing. Bindings that declare the struct themselves (ctypes,
 * P/Invoke) pass their own size. [any thread] */
KATA_API void kata_runtime_desc_init_sized(kata_runtime_desc* desc, uint32_t struct_size);
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
 * layout: NULL, or the name of that same layout (another is refused: KATA_E_INVALID_ARGUMENT).
 * publish_features: 1 puts each result's features in its message (the stream needs
 * desc.keep_features). KATA_E_INVALID_ARGUMENT for a used id or a full runtime. [any thread] */
KATA_API kata_status kata_runtime_add_stream(kata_runtime runtime, uint64_t stream_id, kata_stream* stream,
                                             const char* layout, int32_t publish_features);
/* As kata_runtime_add_stream, and the published skeleton definition also announces the source's
 * frame rate (Hz) and units (metres per unit: 1 metres, 0.01 centimetres), as a source's own
 * definition does (kata_skeleton_message); kata_runtime_add_stream announces both as 0, unknown.
 * KATA_E_NON_FINITE for a NaN or infinite value, KATA_E_INVALID_ARGUMENT for a negative one
 * (nothing added: the stream stays the caller's). Since 1.1. [any thread] */
KATA_API kata_status kata_runtime_add_stream_ex(kata_runtime runtime, uint64_t stream_id, kata_stream* stream,
                                                const char* layout, int32_t publish_features, float frame_rate,
                                                float metres_per_unit);
/* Queues one frame of a stream: the source's sequence number, capture time in seconds (must
 * increase), positions (joint_count x 3 floats). KATA_E_NOT_FOUND (no such stream),
 * KATA_E_WRONG_JOINT_COUNT (more than max_joints), KATA_E_QUEUE_FULL (the worker's queue is full:
 * dropped and counted), KATA_E_STOPPED (kata_runtime_stop has begun: not taken, counted).
 * Values are checked by the worker (bad frames counted as refused).
 * Never blocks, never allocates. [any thread] */
KATA_API kata_status kata_runtime_push(kata_runtime runtime, uint64_t stream_id, uint64_t sequence,
                                       double capture_time, const float* positions, uint32_t joint_count);
/* kata_runtime_push with a confidence per joint (joint_count floats, e.g. MediaPipe's visibility;
 * NULL = all confident), copied with the frame: the worker pushes it as kata_stream_push_confidence
 * does (a joint below the stream's confidence gate is held; too many missing: the result says
 * KATA_SCORE_TRACKING_LOST). Statuses as kata_runtime_push. Never blocks, never allocates. [any thread] */
KATA_API kata_status kata_runtime_push_confidence(kata_runtime runtime, uint64_t stream_id, uint64_t sequence,
                                                  double capture_time, const float* positions,
                                                  const float* confidences, uint32_t joint_count);
/* Practice (as a practice message from an ingest stream's source does,
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
/* Hands one ingest message to a runtime created with direct_ingest = 1: the bytes a ZeroMQ
 * ingest socket would receive (the 16-byte topic and the FlatBuffer, as kata_message_write_*
 * write them), copied into a ring the runtime's I/O thread reads, in the order offered. The
 * message is judged there (a malformed, unknown-stream or refused one is counted in
 * kata_runtime_counters, never seen by another stream). KATA_OK: taken, and handled before
 * kata_runtime_stop returns; KATA_E_QUEUE_FULL: not taken (the ring, 4 MiB or two messages of
 * max_message_bytes, is full because the I/O thread fell behind; a message larger than half the
 * ring; or stop has begun): the caller counts or drops it; KATA_E_STATE: the runtime has no direct
 * ingest; KATA_E_NULL_POINTER. One thread at a time (the transport's delivery thread), and never
 * after kata_runtime_destroy has begun: stop the transport first. Never blocks, never allocates.
 * Since 1.1. */
KATA_API kata_status kata_runtime_offer(kata_runtime runtime, const void* message, size_t size);
/* Finishes every queued frame, flushes every stream, publishes every result (and the repetition
 * each stream's flush ended, after its last result), stops the threads and closes the sockets.
 * Idempotent. [any thread but the runtime's own]
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
/* The latency from a frame's arrival to its result's hand-over to ZeroMQ (arrival_ns to
 * published_ns of kata_result_record), over every result the runtime published so far, all
 * streams: the value in nanoseconds below which a fraction q (0..1) of them lies. The runtime
 * counts them in a histogram whose bucket i holds [2^(i/8), 2^((i+1)/8)) ns (9 % wide; i < 288,
 * the last also holding anything longer); the answer is the upper edge of the bucket where the
 * running count first reaches q x the total. 0 before the first published result, without a
 * publisher, for NULL or for q outside 0..1 or NaN. Does not allocate. Since 1.1. [any thread] */
KATA_API double kata_runtime_latency_percentile(kata_runtime runtime, double q);
/* Copies a histogram of the runtime since it was created (kata_histogram_kind) into buckets,
 * which holds `capacity` counts: at least KATA_LATENCY_BUCKETS (else KATA_E_BUFFER_TOO_SMALL,
 * nothing written); KATA_E_INVALID_ARGUMENT for another kind. The difference of two copies is
 * the histogram of the time between them (a status line's window: kata_histogram_percentile
 * reads it). Does not allocate. Since 1.1. [any thread] */
KATA_API kata_status kata_runtime_get_histogram(kata_runtime runtime, kata_histogram_kind kind, uint64_t* buckets,
                                                uint32_t capacity);
/* The value in nanoseconds below which a fraction q (0..1) of a histogram's counts lies
 * (KATA_LATENCY_BUCKETS buckets as kata_runtime_get_histogram writes them): the upper edge,
 * 2^((i+1)/8), of the bucket i where the running count first reaches q x the total. 0 for an
 * empty histogram, NULL, a count other than KATA_LATENCY_BUCKETS, or q outside 0..1 or NaN.
 * Since 1.1. [any thread] */
KATA_API double kata_histogram_percentile(const uint64_t* buckets, uint32_t count, double q);
/* Every stream's counters (kata_stream_counters), in the order the streams were opened, the
 * closed ones the runtime still keeps included: out holds `capacity` structs, each
 * out[0].struct_size bytes (set it; 1.1's size or more). *count is set to the streams there are;
 * with capacity below that, KATA_E_BUFFER_TOO_SMALL and nothing written (out may then be NULL
 * with capacity 0: asks the count). Allocates (a report, not for the live path). Since 1.1.
 * [any thread] */
KATA_API kata_status kata_runtime_get_stream_counters(kata_runtime runtime, kata_stream_counters* out,
                                                      uint32_t capacity, uint32_t* count);

/* ---- CURVE key files and endpoints (docs/deploy.md; since 1.1) ----
 * What an app checks before it fills kata_runtime_desc's key fields, so that a bad key is refused
 * where the app read its name (a config's line) rather than later by kata_runtime_create.
 * Key files, as `kata keygen` writes them and kata_runtime_create reads them:
 *   NAME.pub     public = "<40 Z85 characters>"
 *   NAME.secret  public = "<40 Z85 characters>", secret = "<40 Z85 characters>"   (mode 0600)
 * Lines starting with '#' and blank lines are ignored. A client key directory holds *.pub files;
 * anything else in it is ignored. */

/* Size of a Z85 key as text: 40 characters and the terminating NUL. */
#define KATA_KEY_TEXT_SIZE 41

/* Reads a key file. public_key (KATA_KEY_TEXT_SIZE bytes) receives its public key; secret_key
 * (KATA_KEY_TEXT_SIZE bytes, or NULL) its secret key, "" for a .pub file. A file that cannot be
 * read is KATA_E_IO; a malformed one (a line that is not key = "value", a key that is not 40
 * Z85 characters, no public key, a secret that does not belong to the public key) KATA_E_PARSE;
 * the reason, naming the file and its line, is kata_context_last_error(context). context may be NULL: the reason is then filed
 * on the calling thread (kata_context_last_error of NULL or of any context of the thread, as for
 * kata_clip_positions). [any thread] */
KATA_API kata_status kata_key_file_read(kata_context context, const char* path, char* public_key, char* secret_key);
/* Checks a client key directory as a runtime's client_keys_dir is read: every *.pub file in it
 * must be a public key file (kata_key_file_read). *count receives the number of keys. A missing
 * directory is KATA_E_IO, a bad file the status and reason of kata_key_file_read, naming that file.
 * context: as for kata_key_file_read. [any thread] */
KATA_API kata_status kata_key_directory_check(kata_context context, const char* dir, uint32_t* count);
/* 1 when a bind endpoint is reachable from beyond this host, 0 otherwise: tcp:// on a host other
 * than 127.x.x.x, localhost, ::1 or lo ("*" and 0.0.0.0 included; "tcp://source;host:port" is
 * judged by host). ipc:// and inproc:// are local; NULL is 0. A runtime that binds such an
 * endpoint without key_file takes frames from anyone on the network. [any thread] */
KATA_API int32_t kata_endpoint_reachable_beyond_host(const char* endpoint);

/* ---- Shards (docs/deploy.md) ----
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
/* Reads a Repetition message (schemas/repetition.fbs; the runtime publishes one on the stream's
 * topic right after the result of the frame that ended a repetition: docs/coach/repetitions.md)
 * into *out (as much as out->struct_size holds; set it to sizeof(kata_repetition)), verified
 * first. KATA_OK: a repetition; KATA_NO_DATA: a valid kata message of another kind (a result,
 * stats); KATA_E_PARSE: refused. kata_message_read_result returns KATA_NO_DATA for it. Since 1.1.
 * [any thread] */
KATA_API kata_status kata_message_read_repetition(const void* message, size_t size, kata_repetition* out);

/* Reads a runtime's refusal of a stream's skeleton definition, which it publishes on the stream's
 * results topic (a skeleton message with `refused` set, schemas/skeleton.fbs): the source learns
 * that its stream was refused and why ("unknown layout 'cmuu' ..."); its frames are dropped until
 * a definition is accepted. KATA_OK: *stream_id is the stream and `reason` holds the reason,
 * NUL-terminated, cut to capacity - 1 bytes (capacity 0: reason may be NULL, not written);
 * KATA_NO_DATA: a valid kata message that is not a refusal (a result, an accepted definition,
 * stats); KATA_E_PARSE: refused (truncated, corrupt, unknown). Since 1.1. [any thread] */
KATA_API kata_status kata_message_read_refusal(const void* message, size_t size, uint64_t* stream_id, char* reason,
                                              size_t capacity);

/* ##############################################################################################
 * Task 7 - write messages: a source of frames for a runtime's ingest, in C (kata send is one)
 *
 * kata_skeleton_message d;  kata_skeleton_message_init(&d);
 * d.stream_id = 42;  d.skeleton = skel;  d.layout = "cmu";
 * kata_message_write_skeleton(&d, buffer, sizeof buffer, &n);  zmq_send(push, buffer, n, 0);
 * kata_frame_message f;  kata_frame_message_init(&f);
 * f.stream_id = 42;  f.sequence = i;  f.capture_time = t;  f.positions = xyz;  f.joint_count = joints;
 * kata_message_write_frame(&f, buffer, sizeof buffer, &n);  zmq_send(push, buffer, n, 0);
 * ############################################################################################ */

/* ---- Writing ingest messages (for sources in C: a mocap stage, a game engine; since 1.1) ----
 * Each writer encodes one message of a runtime's ingest (docs/runtime.md) with the codec the
 * runtime reads: the 16-byte topic (the stream id as 16 lowercase hex digits) followed by the
 * FlatBuffer (schemas/skeleton.fbs, frame.fbs, practice.fbs); send it as one ZeroMQ message (or one
 * NATS message on the stream's ingest subject). A source sends a stream's skeleton message first
 * and again every second or so (a receiver that starts later learns it then), then its frames.
 * Buffers: each writer fills the caller's buffer of `capacity` bytes and sets *size: KATA_OK with
 * *size = the bytes written; KATA_E_BUFFER_TOO_SMALL with *size = the bytes the message needs and
 * nothing written (buffer NULL with capacity 0 asks the size). A refused message writes nothing,
 * sets *size to 0 and says why in kata_context_last_error (these calls take no context: any
 * context of the calling thread shows it). KATA_E_NULL_POINTER: the message or size is NULL, or
 * buffer is NULL with a capacity. The message structs start with struct_size (see Versions; their
 * first size is 1.1's): fill them with their _init macro, then set the fields.
 * Memory: each thread keeps one encoder, grown to the largest message it wrote; a writer allocates
 * only when a message is larger than any before on its thread. [any thread] */

/* A stream's skeleton definition (schemas/skeleton.fbs). Fill with kata_skeleton_message_init. */
typedef struct kata_skeleton_message {
  uint32_t struct_size;          /* sizeof(kata_skeleton_message) */
  uint32_t revision;             /* +1 on every change of the definition (the receiver restarts the
                                    stream with it); a re-send keeps it. Default 1 */
  uint64_t stream_id;            /* the stream (chosen by the source, unique per session) */
  kata_skeleton skeleton;        /* joint names and parents, and rest offsets when it has them (sent
                                    as floats); read during the call only. At most 32767 joints */
  /* A built-in layout's name ("cmu", ...: kata_layout_name; not checked here, the receiver judges
   * it), or NULL and name_map. One of the two is required. */
  const char* layout;
  /* KATA_GPD_JOINTS joint names of the skeleton read as the 16 GPD joints (spec GPD v1 order,
   * kata/stream.h "Layouts"), or NULL and layout. */
  const char* const* name_map;
  kata_up_axis up_axis;          /* KATA_UP_Y (default) or KATA_UP_Z: the message carries no other */
  float metres_per_unit;         /* units of positions and offsets: 1 metres, 0.01 centimetres; 0
                                    (default) unknown */
  float frame_rate;              /* the source's nominal rate in Hz (informational); 0 (default) unknown */
  int32_t closed;                /* 1: the source ends the stream (the receiver closes it and
                                    forgets its owner); 0 (default) */
} kata_skeleton_message;

/* One frame of a stream (schemas/frame.fbs, its checksum filled in). Fill with kata_frame_message_init. */
typedef struct kata_frame_message {
  uint32_t struct_size;          /* sizeof(kata_frame_message) */
  uint32_t joint_count;          /* joints in positions: the skeleton message's (1..1048576) */
  uint64_t stream_id;            /* the stream of an earlier skeleton message */
  uint64_t sequence;             /* +1 per frame from 0; a return to 0 says the source restarted */
  double capture_time;           /* seconds on the source's clock, increasing, within +-9.2e9;
                                    carried as whole nanoseconds (rounded), as a result's */
  /* joint_count x 3 floats, x, y, z interleaved, in the skeleton message's joint order and units;
   * every one finite (a joint the source lost goes with confidence 0 at any finite place). */
  const float* positions;
  /* joint_count confidences in [0, 1] (MediaPipe's visibility; NaN: the joint is missing, as in
   * kata_stream_push_confidence), or NULL (default): every joint confident. */
  const float* confidences;
  /* joint_count presences in [0, 1] (MediaPipe's second landmark channel: the likelihood the joint
   * is in the image at all; NaN: missing), or NULL (default): none sent. The receiver scores a
   * joint by the smaller of its confidence and presence (schemas/frame.fbs "presence"); the
   * checksum covers them. Since 1.1's first writer (a caller's struct without it sends none). */
  const float* presences;
} kata_frame_message;

/* A stream's practice setting (schemas/practice.fbs): what kata_runtime_set_practice does, sent
 * by the stream's own source. Neither a start nor a loop: the whole teacher clip. Fill with
 * kata_practice_message_init. */
typedef struct kata_practice_message {
  uint32_t struct_size;          /* sizeof(kata_practice_message) */
  uint32_t revision;             /* echoed by every result under it (practice_revision): 1 and up, a
                                    new one per change; a re-send of the one in force changes
                                    nothing. Default 1 */
  uint64_t stream_id;            /* the stream */
  double teacher_start;          /* the lesson starts at this teacher time, seconds from the
                                    teacher's first frame (as matched_teacher_time). Default 0 */
  int32_t loop;                  /* 1: loop the section loop_start..loop_end (teacher_start then 0).
                                    Default 0 */
  double loop_start;             /* the section's first teacher time, seconds (with loop) */
  double loop_end;               /* the section's last teacher time, seconds, after loop_start (with loop) */
} kata_practice_message;

/* Fills the first struct_size bytes of message with the defaults above and sets
 * message->struct_size to the smaller of struct_size and sizeof(kata_skeleton_message), as
 * kata_runtime_desc_init_sized does. [any thread] */
KATA_API void kata_skeleton_message_init_sized(kata_skeleton_message* message, uint32_t struct_size);
/* Fills *message with the defaults for the caller's own struct. */
#define kata_skeleton_message_init(message) kata_skeleton_message_init_sized((message), (uint32_t)sizeof *(message))
/* As kata_skeleton_message_init_sized, for a frame message. [any thread] */
KATA_API void kata_frame_message_init_sized(kata_frame_message* message, uint32_t struct_size);
/* Fills *message with the defaults for the caller's own struct. */
#define kata_frame_message_init(message) kata_frame_message_init_sized((message), (uint32_t)sizeof *(message))
/* As kata_skeleton_message_init_sized, for a practice message. [any thread] */
KATA_API void kata_practice_message_init_sized(kata_practice_message* message, uint32_t struct_size);
/* Fills *message with the defaults for the caller's own struct. */
#define kata_practice_message_init(message) kata_practice_message_init_sized((message), (uint32_t)sizeof *(message))

/* Writes a skeleton definition message (buffers: see above). KATA_E_NULL_POINTER also for no
 * skeleton; KATA_E_INVALID_ARGUMENT for a struct_size below the struct's first, a layout and a
 * name map both or neither, a name map entry NULL or empty, an up
 * axis other than KATA_UP_Y / KATA_UP_Z, a negative metres_per_unit or frame_rate, closed other
 * than 0 or 1, more than 32767 joints; KATA_E_NON_FINITE for a NaN or infinite metres_per_unit,
 * frame_rate or rest offset. [any thread] */
KATA_API kata_status kata_message_write_skeleton(const kata_skeleton_message* message, void* buffer, size_t capacity,
                                                 size_t* size);
/* Writes a frame message (buffers: see above). KATA_E_NULL_POINTER also for no positions;
 * KATA_E_INVALID_ARGUMENT for a struct_size below the struct's first; KATA_E_WRONG_JOINT_COUNT
 * for joint_count 0 or above 1048576; KATA_E_NON_FINITE for a NaN or infinite coordinate or
 * capture_time, or an infinite confidence (the message names the joint); KATA_E_INVALID_ARGUMENT
 * also for a capture_time beyond +-9.2e9 s. Does not allocate once
 * its thread has written a message as large. [any thread] */
KATA_API kata_status kata_message_write_frame(const kata_frame_message* message, void* buffer, size_t capacity,
                                              size_t* size);
/* Writes a frame batch message (schemas/frame_batch.fbs; buffers: see above): the frames of many
 * streams of one source in one message, for a source that sends a frame of each of its streams
 * per tick (a mocap stage with many performers, a proxy): the transport's and the runtime's cost
 * per message is then paid once per tick instead of once per stream. The runtime takes each frame
 * as if it had come alone, in the array's order (two frames of one stream: in a row), and judges
 * each alone: a frame it refuses (not the sender's stream, out of order, a wrong joint count, a
 * bad checksum) is counted by cause and the others go on. Each frame carries its own checksum.
 * Its topic is "fffffffffffffffe" (stream id 2^64-2, reserved): send it as one ZeroMQ message to
 * the runtime's ingest. frames: frame_count pointers to frame messages, each filled as for
 * kata_message_write_frame and refused as it refuses one (the reason names the frame's index);
 * read during the call only. KATA_E_NULL_POINTER also for frames or one of its pointers NULL;
 * KATA_E_INVALID_ARGUMENT for frame_count 0 or above 4096. Does not allocate once its thread has
 * written a batch as large. Since 1.1. [any thread] */
KATA_API kata_status kata_message_write_frame_batch(const kata_frame_message* const* frames, size_t frame_count,
                                                    void* buffer, size_t capacity, size_t* size);
/* Writes a practice message (buffers: see above). KATA_E_INVALID_ARGUMENT for a struct_size below
 * the struct's first, loop other than 0 or 1, and what a runtime refuses whatever its clip: a time
 * not finite or negative, loop_end not after loop_start, a teacher_start with a loop (the runtime
 * judges the times against the stream's teacher clip). [any thread] */
KATA_API kata_status kata_message_write_practice(const kata_practice_message* message, void* buffer, size_t capacity,
                                                 size_t* size);

/* Writes a result message (schemas/result.fbs; buffers: see above) from a result record, as a
 * runtime publishes it: for an app that carries a runtime's results over its own transport (a
 * NATS shard: on_result, then this, then its publish). The message of an on_result record equals,
 * byte for byte, the one the runtime's ZeroMQ publisher sent for that result (the features of
 * publish_features are not in the record and not written). record->struct_size is the caller's
 * sizeof(kata_result_record), at least 1.0's (fields a smaller record lacks are written as
 * "none"); record->ghost (ghost_joint_count x 3 floats) is read during the call, NULL for none.
 * KATA_E_NULL_POINTER also for no record, or a ghost_joint_count with no ghost;
 * KATA_E_INVALID_ARGUMENT for a struct_size below 1.0's or more than 1048576 ghost joints;
 * KATA_E_NON_FINITE for a NaN or infinite ghost coordinate, distance, score, matched teacher
 * time or practice time. Does not allocate once its thread has written a message as large.
 * Since 1.1. [any thread] */
KATA_API kata_status kata_message_write_result(const kata_result_record* record, void* buffer, size_t capacity,
                                               size_t* size);
/* Writes the Repetition message a runtime publishes for *repetition (its stream_id the topic;
 * published_time now), for an app that carries a runtime's messages over its own transport, and
 * for tests of subscribers. repetition->struct_size is the caller's sizeof(kata_repetition).
 * KATA_E_NULL_POINTER for no repetition or size; KATA_E_INVALID_ARGUMENT for a smaller
 * struct_size; KATA_E_NON_FINITE for a NaN or infinite time, tempo, score or range;
 * KATA_E_BUFFER_TOO_SMALL (*size the bytes needed). Since 1.1. [any thread] */
KATA_API kata_status kata_message_write_repetition(const kata_repetition* repetition, void* buffer, size_t capacity,
                                                   size_t* size);

#ifdef __cplusplus
}
#endif

#endif /* KATA_RUNTIME_H */
