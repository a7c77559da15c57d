/* kata_plugin.h: the C ABI of kata plugins (sources and sinks loaded by `kata serve` or any
 * host using the runtime). C99; the result record it receives is kata/result.h's.
 *
 * A plugin is a shared library exporting ONE symbol, KATA_PLUGIN_ENTRY ("kata_plugin_entry"),
 * a function returning a pointer to a static kata_plugin table. The table starts with the ABI
 * version and its own size, so a host can check both before reading any other field:
 *   - a different major version is refused;
 *   - a table larger than the host knows (a plugin built against a newer minor) is refused, a
 *     smaller one is read up to its size (fields added later are treated as absent);
 *   - a missing required function is refused.
 * Every refusal names the plugin file and the reason.
 *
 * Threads (tags as in CLAP): [main] the thread that loads, activates and stops plugins;
 * [io] the runtime's I/O thread (one thread, the same for every call); [plugin] a thread the
 * plugin starts itself (sources). Memory: a plugin allocates in activate() and frees in
 * deactivate(); the per-result / per-frame calls must not allocate or block.
 *
 * Versioning: KATA_PLUGIN_ABI_VERSION = major << 16 | minor. Fields are only added at the end of
 * the structs (minor + 1); constants never change. */
#ifndef KATA_PLUGIN_H
#define KATA_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

#include "result.h" /* kata_result_record and kata_repetition: what a sink receives */

#ifdef __cplusplus
extern "C" {
#endif

#define KATA_PLUGIN_ABI_MAJOR 2u /* a host refuses a plugin of another major (2: on_result takes the
                                    one kata_result_record of kata/result.h) */
#define KATA_PLUGIN_ABI_MINOR 1u /* + 1 when fields are added at the end of a table (1: on_repetition) */
#define KATA_PLUGIN_ABI_VERSION ((KATA_PLUGIN_ABI_MAJOR << 16) | KATA_PLUGIN_ABI_MINOR) /* kata_plugin.abi_version */
#define KATA_PLUGIN_ENTRY "kata_plugin_entry" /* the one exported symbol's name */

#if defined(_WIN32)
#define KATA_PLUGIN_EXPORT __declspec(dllexport)
#else
#define KATA_PLUGIN_EXPORT __attribute__((visibility("default")))
#endif

/* kata_plugin.kinds */
#define KATA_PLUGIN_SOURCE 1u /* produces frames (start / stop required) */
#define KATA_PLUGIN_SINK 2u   /* consumes results (on_result required; on_repetition optional) */

/* A sink receives each result as a kata_result_record (kata/result.h), struct_size set by the
 * host: read a field added after 1.0 only when KATA_RESULT_HAS(r, field). Its ghost pointer is
 * valid during the call only; stream_id is the runtime's. */

/* What the host offers a plugin (valid from activate to deactivate). */
typedef struct kata_plugin_host {
  uint32_t struct_size;          /* sizeof(kata_plugin_host) of the host */
  void* host_data;               /* pass back to every call */
  /* Announces a stream (sources, before its first frame): joint names and parents (parents[0]
   * = -1, parents[i] < i), rest offsets (joint_count x 3 floats, or NULL when unknown), the GPD
   * layout ("cmu", ...: kata_layout_name). 0 on success, else a kata_status value. [main] or [plugin] */
  int32_t (*open_stream)(void* host_data, uint64_t stream_id, uint32_t joint_count, const char* const* names,
                         const int32_t* parents, const float* rest_offsets, const char* layout);
  /* Queues one frame of an announced stream (joint_count x 3 floats, copied). Never blocks; a
   * full queue drops the frame (counted) and returns a non-zero kata_status. [plugin] */
  int32_t (*push_frame)(void* host_data, uint64_t stream_id, uint64_t sequence, double capture_time,
                        const float* positions, uint32_t joint_count);
  /* A line for the host's log. [any] */
  void (*log)(void* host_data, const char* message);
} kata_plugin_host;

/* The table a plugin's entry returns. */
typedef struct kata_plugin {
  uint32_t abi_version;          /* KATA_PLUGIN_ABI_VERSION the plugin was built with */
  uint32_t struct_size;          /* sizeof(kata_plugin) the plugin was built with */
  const char* name;              /* short name ("csv-sink") */
  const char* description;       /* one line */
  uint32_t kinds;                /* KATA_PLUGIN_SOURCE and/or KATA_PLUGIN_SINK */
  /* Required. Creates an instance: config is the plugin's own "key=value;key=value" text (may
   * be ""). Allocate everything here. Returns NULL and writes a message into error (at most
   * error_capacity bytes, terminated) on failure. [main] */
  void* (*activate)(const kata_plugin_host* host, const char* config, char* error, size_t error_capacity);
  /* Required. Frees the instance (after stop / the last on_result). [main] */
  void (*deactivate)(void* instance);
  /* Sources: required. Starts producing (typically a thread of the plugin's that calls
   * host->push_frame). 0 on success. [main] */
  int32_t (*start)(void* instance);
  /* Sources: required. Stops producing; returns when the plugin's threads have ended. [main] */
  void (*stop)(void* instance);
  /* Sinks: required. One result; must neither block nor allocate. [io] */
  void (*on_result)(void* instance, const kata_result_record* result);
  /* Sinks: optional. Writes out what is buffered (at shutdown, after the last result). [io] */
  void (*flush)(void* instance);
  /* Sinks: optional (ABI 2.1; a table of 2.0 ends before it and is read as without it). One
   * repetition that ended (kata/result.h kata_repetition), complete or partial, as the runtime
   * publishes its Repetition message: right after the result of the frame that ended it, or
   * alone when the end of a take (a stream closed, a restart, the runtime stopped) ended it;
   * stream_id is the runtime's. struct_size is the host's sizeof(kata_repetition): read a field
   * appended later only when struct_size covers it. The pointer is valid during the call only.
   * Must neither block nor allocate. [io] */
  void (*on_repetition)(void* instance, const kata_repetition* repetition);
} kata_plugin;

/* The type of the entry symbol. */
typedef const kata_plugin* (*kata_plugin_entry_fn)(void);

#ifdef __cplusplus
}
#endif

#endif /* KATA_PLUGIN_H */
