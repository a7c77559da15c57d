// C shims for models and scoring (kata.h section "Models and scoring"): a kata_model holds the
// compiled metric (shared, immutable).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "capi/capi_internal.hpp"
#include "common/text.hpp"
#include "io/model_file.hpp"
#include "metric/model.hpp"
#include "metric/scorer.hpp"
#include "io/clip_features.hpp"
#include "pipeline/pipeline.hpp"


namespace {

using kata::capi::guarded_stream;
using kata::capi::refuse;

kata_status make_model(kata::metric::Model model, kata_model* out) {
  auto m = std::make_unique<kata_model_s>();
  m->metric = std::make_shared<const kata::metric::Metric>(model);
  m->layout = model.layout_id;
  m->info = std::move(model.info);
  *out = m.release();
  return KATA_OK;
}

}  // namespace

extern "C" {

KATA_API kata_status kata_model_load(kata_context context, const char* path, kata_model* out) {
  const kata::capi::ContextScope scope(context);
  if (!context || !path || !out) {
    kata::capi::set_context_error("kata_model_load: context, path and out must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  *out = nullptr;
  return kata::capi::guarded_context([&] { return make_model(kata::metric::load_model(kata::capi::shipped_file(path)), out); });
}

KATA_API kata_status kata_model_load_memory(kata_context context, const void* data, size_t size, kata_model* out) {
  const kata::capi::ContextScope scope(context);
  if (!context || !data || !out) {
    kata::capi::set_context_error("kata_model_load_memory: context, data and out must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  *out = nullptr;
  return kata::capi::guarded_context(
      [&] { return make_model(kata::metric::parse_model(static_cast<const uint8_t*>(data), size), out); });
}

KATA_API void kata_model_destroy(kata_model model) { delete model; }

KATA_API uint32_t kata_model_rank(kata_model model) {
  return model ? static_cast<uint32_t>(model->metric->rank()) : 0u;
}

KATA_API double kata_model_delta_star(kata_model model) { return model ? model->metric->delta_star() : 0.0; }

KATA_API kata_stencil kata_model_stencil(kata_model model) {
  return model && model->metric->stencil() == kata::gpd::Stencil::kCentral ? KATA_STENCIL_CENTRAL
                                                                            : KATA_STENCIL_BACKWARD;
}

KATA_API const char* kata_model_metadata(kata_model model, const char* key) {
  if (!model || !key) return nullptr;
  if (std::strcmp(key, "layout") == 0) return model->layout.c_str();
  if (std::strcmp(key, "date") == 0) return model->info.date.c_str();
  if (std::strcmp(key, "data") == 0) return model->info.data.c_str();
  if (std::strcmp(key, "parameters") == 0) return model->info.parameters.c_str();
  return nullptr;
}

KATA_API kata_status kata_stream_set_practice_section(kata_stream stream, int32_t first_frame, int32_t last_frame,
                                                      int32_t loop) {
  if (!stream) return KATA_E_NULL_POINTER;
  kata::metric::Scorer* scorer = stream->pipeline.scorer();
  if (!scorer) return refuse(stream, KATA_E_STATE, "kata_stream_set_practice_section: no teacher is attached");
  if (scorer->reference().kind() != kata::metric::ReferenceKind::kClip)
    return refuse(stream, KATA_E_STATE, "kata_stream_set_practice_section: the teacher is a pose, not a clip");
  return guarded_stream(stream, [&] {
    scorer->set_section(first_frame, last_frame, loop != 0);
    return KATA_OK;
  });
}

KATA_API kata_status kata_model_calibration(kata_model model, kata_score_calibration* out) {
  if (!model || !out) return KATA_E_NULL_POINTER;
  const kata::metric::ScoreCalibration& c = model->metric->calibration();
  kata_score_calibration k{};
  k.d50 = c.d50;
  k.slope = c.slope;
  for (int q = 0; q < KATA_PART_COUNT; ++q) {
    k.part_d50[q] = c.part_d50[q];
    k.part_slope[q] = c.part_slope[q];
  }
  k.good_score = c.good_score;
  return kata::capi::write_sized(k, kata::capi::kScoreCalibration10, out) ? KATA_OK : KATA_E_INVALID_ARGUMENT;
}

KATA_API kata_status kata_stream_set_calibration(kata_stream stream, const kata_score_calibration* calibration) {
  if (!stream) return KATA_E_NULL_POINTER;
  kata::metric::Scorer* scorer = stream->pipeline.scorer();
  if (!scorer) return refuse(stream, KATA_E_STATE, "kata_stream_set_calibration: no reference is set on this stream");
  kata_score_calibration given{};
  if (calibration && !kata::capi::read_sized(calibration, given, kata::capi::kScoreCalibration10, &given))
    return refuse(stream, KATA_E_INVALID_ARGUMENT, "kata_stream_set_calibration: struct_size is below 1.0's kata_score_calibration");
  if (calibration) calibration = &given;
  return guarded_stream(stream, [&] {
    kata::metric::ScoreCalibration c = scorer->reference().metric().calibration();
    if (calibration) {
      c.d50 = calibration->d50;
      c.slope = calibration->slope;
      for (int q = 0; q < KATA_PART_COUNT; ++q) {
        c.part_d50[q] = calibration->part_d50[q];
        c.part_slope[q] = calibration->part_slope[q];
      }
      c.good_score = calibration->good_score;
      c.method = "set by the application";
    }
    try {
      scorer->set_calibration(c);
    } catch (const kata::Error& e) {  // a value out of range is the caller's argument, not a model
      throw kata::Error(kata::ErrorKind::kInvalidArgument, std::string("kata_stream_set_calibration: ") + e.what());
    }
    return KATA_OK;
  });
}

}  // extern "C"

KATA_API const char* kata_gpd_joint_name(int32_t joint) {
  return joint >= 0 && joint < kata::kGpdJoints ? kata::kGpdJointNames[static_cast<size_t>(joint)] : nullptr;
}

KATA_API int32_t kata_gpd_joint_part(int32_t joint) {
  return joint >= 0 && joint < kata::kGpdJoints ? kata::metric::joint_part(joint) : -1;
}

KATA_API const char* kata_body_part_name(int32_t part) {
  return part >= 0 && part < kata::metric::kParts ? kata::metric::part_name(part) : nullptr;
}

KATA_API const char* kata_gpd_joint_words(int32_t joint) {
  return joint >= 0 && joint < kata::kGpdJoints ? kata::metric::cue_joint_words(joint) : nullptr;
}

KATA_API size_t kata_cue_text(const kata_result_record* record, char* buf, size_t size) {
  if (size > 0 && !buf) return 0;
  const bool has = record && KATA_RESULT_HAS(record, cue_action);
  const int n = kata::metric::cue_text(has ? record->cue_joint : -1, has ? record->cue_degrees : 0.0f,
                                       has ? record->cue_action : -1, buf, size);
  return n > 0 ? static_cast<size_t>(n) : 0u;
}
