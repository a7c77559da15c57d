// Per-frame results of the C++ core, returned (never thrown) on the hot path. Values mirror
// kata_status in kata.h one to one, so the C ABI passes them through unchanged.
#pragma once

namespace kata {

enum class Status : int {
  kOk = 0,
  kNoData = 1,                // nothing to read yet (a result, not an error)
  kInvalidArgument = 2,
  kNullPointer = 3,
  kWrongJointCount = 4,
  kNonFinite = 5,             // NaN or Inf in a frame
  kTimestampNotIncreasing = 6,
  kParse = 7,
  kIo = 8,
  kModel = 9,
  kNotFound = 10,
  kOutOfMemory = 11,
  kBufferTooSmall = 12,
  kInternal = 13,
  kState = 14,                // the call is not valid in the object's current state
  kTrackingLost = 15,         // a frame was accepted but too many joints are missing: no features
  kStopped = 16,              // the runtime is stopping or stopped: the frame was not taken
  kQueueFull = 17,            // a runtime stream's worker queue is full: dropped and counted
  kNoClipTeacher = 18,        // the call needs a clip teacher and the stream has none
};

}  // namespace kata
