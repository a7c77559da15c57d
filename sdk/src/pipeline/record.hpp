// The one translation of a pipeline Result into the public result record (kata/result.h): the C
// ABI's stream reads, the runtime's published messages and sink plugins all start from it, so a
// field is named, scaled and defaulted in this one place.
#pragma once

#include <cstdint>

#include "kata/result.h"
#include "pipeline/pipeline.hpp"

namespace kata::pipeline {

// Writes every field a pipeline knows into *out (struct_size = sizeof(kata_result_record)):
// result_sequence = the pipeline's sequence, frame_sequence = frame_index, the times, and when
// scored the score, parts, part scores, part to fix, state and matched teacher frame (else 0 and
// -1); ghost_joint_count when the result has a ghost. stream_id, published_ns, the ghost pointer
// and the practice section are the runtime's (0 here). Allocation-free.
void fill_record(const Result& result, uint32_t ghost_joint_count, kata_result_record* out) noexcept;

// The one translation of a repetition (metric/reps.hpp) into the public kata_repetition
// (struct_size = sizeof(kata_repetition)). Allocation-free.
void fill_repetition(const metric::Repetition& repetition, uint64_t stream_id, kata_repetition* out) noexcept;

// Copies a record into a caller's struct of caller_size bytes (a 1.0 caller's smaller struct
// gets the fields it knows), keeping caller_size as its struct_size. caller_size must be at least
// the struct_size field.
void copy_record_out(const kata_result_record& record, uint32_t caller_size, void* out) noexcept;

// The other way: a caller's record of record->struct_size bytes (at least the struct_size field)
// into *out, a full record: the fields the caller's struct lacks keep out's values (its
// defaults), and out->struct_size becomes sizeof(kata_result_record).
void copy_record_in(const kata_result_record* record, kata_result_record* out) noexcept;

}  // namespace kata::pipeline
