// What lies behind kata.h's opaque handles, and the one place exceptions become status codes.
// Private to libkata (and the internal tests).
#pragma once

#include <cstdio>
#include <memory>
#include <new>
#include <string>

#include "common/error.hpp"
#include "common/status.hpp"
#include "io/bvh.hpp"
#include "kata/kata.h"
#include "skeleton/skeleton.hpp"
#include "stream/stream.hpp"

namespace kata::capi {

// Scoring state a stream may carry, defined in capi_metric.cpp, which attaches it with its own
// deleter: stream->scoring = AttachedPtr<StreamScoring>(new StreamScoring(...), &destroy_scoring).
// (Retargeting has its own handle, kata_retargeter, that may be made from a stream.)
struct StreamScoring;
template <class T>
using AttachedPtr = std::unique_ptr<T, void (*)(T*)>;

// Sets / reads the calling thread's context error message.
void set_context_error(const char* message) noexcept;
const char* context_error() noexcept;

inline kata_status to_status(ErrorKind kind) noexcept {
  switch (kind) {
    case ErrorKind::kInvalidArgument: return KATA_E_INVALID_ARGUMENT;
    case ErrorKind::kParse: return KATA_E_PARSE;
    case ErrorKind::kIo: return KATA_E_IO;
    case ErrorKind::kModel: return KATA_E_MODEL;
    case ErrorKind::kNotFound: return KATA_E_NOT_FOUND;
  }
  return KATA_E_INTERNAL;
}

inline kata_status to_status(Status s) noexcept { return static_cast<kata_status>(static_cast<int>(s)); }

// Runs body() and turns any exception into a status, storing the message with `store`
// (a callable taking const char*). Every exported function that can throw goes through here.
template <class Store, class Body>
kata_status guarded(Store&& store, Body&& body) noexcept {
  try {
    return body();
  } catch (const Error& e) {
    store(e.what());
    return to_status(e.kind());
  } catch (const std::bad_alloc&) {
    store("out of memory");
    return KATA_E_OUT_OF_MEMORY;
  } catch (const std::exception& e) {
    store(e.what());
    return KATA_E_INTERNAL;
  } catch (...) {
    store("unknown internal error");
    return KATA_E_INTERNAL;
  }
}

// Context-level calls: errors go to the thread's context message.
template <class Body>
kata_status guarded_context(Body&& body) noexcept {
  return guarded([](const char* m) { set_context_error(m); }, std::forward<Body>(body));
}

}  // namespace kata::capi

struct kata_context_s {
  int reserved = 0;  // a place for the future runtime (thread pool, transports)
};

struct kata_skeleton_s {
  kata::Skeleton skeleton;
};

struct kata_clip_s {
  kata::BvhClip clip;
};

struct kata_stream_s {
  explicit kata_stream_s(const kata::StreamConfig& config, kata::Skeleton skel)
      : stream(config), skeleton(std::move(skel)) {}
  kata::Stream stream;
  kata::Skeleton skeleton;  // the input skeleton (rest lengths for kata_retargeter_create_for_stream)
  kata::capi::AttachedPtr<kata::capi::StreamScoring> scoring{nullptr, nullptr};
  char error[256] = {0};

  // Copies a message into the stream's fixed buffer (no allocation: used on the frame path).
  void set_error(const char* message) noexcept { std::snprintf(error, sizeof error, "%s", message); }
};
