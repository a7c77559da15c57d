// What the wire's encoder and decoder share: the generated FlatBuffers tables of every message
// and the schema versions this build writes and reads (schemas/*.fbs).
#pragma once

#include <cstdint>

#include "kata_schemas/frame_batch_generated.h"
#include "kata_schemas/frame_generated.h"
#include "kata_schemas/practice_generated.h"
#include "kata_schemas/repetition_generated.h"
#include "kata_schemas/result_generated.h"
#include "kata_schemas/skeleton_generated.h"
#include "kata_schemas/stats_generated.h"

namespace kata::transport {

constexpr uint16_t kFrameVersion = 1, kSkeletonVersion = 1, kResultVersion = 1, kPracticeVersion = 1,
                   kFrameBatchVersion = 1;
constexpr uint16_t kRepetitionVersion = 1;

}  // namespace kata::transport
