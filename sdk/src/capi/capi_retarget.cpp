// C shims for retargeting (kata.h section "Retargeting"): a kata_retargeter wraps one
// kata::retarget::Retargeter plus the float <-> double buffers of the frame path, all sized at
// creation so solve/place never allocate.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "capi/capi_internal.hpp"
#include "common/text.hpp"
#include "retarget/joint_set.hpp"
#include "retarget/local_rotations.hpp"
#include "retarget/mapped.hpp"
#include "retarget/retargeter.hpp"

struct kata_retargeter_s {
  // Same layout: a joint set ("cmu", "gpd") on the student skeleton.
  kata_retargeter_s(const kata::Skeleton& student, const kata::retarget::JointSelection& sel,
                    const kata::retarget::RetargetOptions& options)
      : selection(sel),
        skeleton_joints(student.joint_count()),
        teacher_joints(student.joint_count()),
        retargeter(std::make_unique<kata::retarget::Retargeter>(
            sel.parents, kata::retarget::selected_rest_lengths(student, sel), options,
            kata::retarget::selected_rest_directions(student, sel))),
        teacher(3 * sel.source.size()),
        ghost(3 * sel.source.size()),
        student_pose(3 * sel.source.size()) {}
  // GPD mode (across layouts, or a student without rest pose): the 16 GPD joints.
  kata_retargeter_s(const kata::retarget::MappedSide& teacher_side, const kata::retarget::MappedSide& student_side,
                    const std::array<double, kata::kGpdJoints>& lengths, const kata::retarget::RetargetOptions& options)
      : skeleton_joints(student_side.joints),
        teacher_joints(teacher_side.joints),
        mapped(std::make_unique<kata::retarget::MappedRetargeter>(teacher_side, student_side, lengths, options)) {
    selection.preset = "gpd";
    for (int g = 0; g < kata::kGpdJoints; ++g) {
      selection.names.emplace_back(kata::kGpdJointNames[static_cast<size_t>(g)]);
      selection.parents.push_back(kata::kGpdParents[static_cast<size_t>(g)]);
      selection.source.push_back(student_side.map.source[static_cast<size_t>(g)]);
    }
  }

  kata::retarget::JointSelection selection;  // output joint -> skeleton joint (-1: synthesised)
  int skeleton_joints;                       // joints of the student skeleton (input layout)
  int teacher_joints;                        // joints of a teacher frame
  std::unique_ptr<kata::retarget::Retargeter> retargeter;        // same layout
  std::unique_ptr<kata::retarget::MappedRetargeter> mapped;      // GPD mode
  std::vector<double> teacher, ghost, student_pose;  // selected joints x 3
  // Ghost as local rotations on the student's hierarchy (student skeletons with a rest pose).
  std::unique_ptr<kata::retarget::LocalRotations> rotations;
  std::vector<double> rotation_out, fk_out;  // skeleton joints x 4, x 3
  char error[256] = {0};

  void enable_rotations(const kata::Skeleton& student) {
    if (!student.has_rest_pose) return;
    rotations = std::make_unique<kata::retarget::LocalRotations>(student, selection.source);
    rotation_out.assign(4 * static_cast<size_t>(student.joint_count()), 0.0);
    fk_out.assign(3 * static_cast<size_t>(student.joint_count()), 0.0);
    if (ghost.size() < 3 * selection.source.size()) ghost.assign(3 * selection.source.size(), 0.0);
  }

  // Copies a message into the fixed buffer (no allocation: used on the frame path).
  void set_error(const char* message) noexcept { std::snprintf(error, sizeof error, "%s", message); }
};


namespace {

// The caller's desc over the defaults (only the part its possibly older, smaller struct has).
kata_retarget_desc effective_desc(const kata_retarget_desc* desc) {
  kata_retarget_desc defaults;
  kata_retarget_desc_init(&defaults);
  kata_retarget_desc d = defaults;
  if (desc && !kata::capi::read_sized(desc, defaults, kata::capi::kRetargetDesc10, &d))
    throw kata::Error(kata::ErrorKind::kInvalidArgument,
                      "retargeter: desc->struct_size is below 1.0's kata_retarget_desc (call kata_retarget_desc_init)");
  if (!d.joint_set || !d.joint_set[0]) d.joint_set = "cmu";
  (void)kata::c_string(d.joint_set, "desc->joint_set");  // refuses a name without a terminator in bounds
  if (!(d.gradient_tolerance > 0.0) || !std::isfinite(d.gradient_tolerance) || d.max_iterations == 0) {
    throw kata::Error(kata::ErrorKind::kInvalidArgument, "retargeter: gradient_tolerance and max_iterations must be positive");
  }
  return d;
}

kata::retarget::RetargetOptions options_of(const kata_retarget_desc& d) {
  kata::retarget::RetargetOptions o;
  o.solver.gradient_tolerance = d.gradient_tolerance;
  o.solver.max_iterations = static_cast<int>(std::min<uint32_t>(d.max_iterations, 1u << 30));
  o.warm_start = d.warm_start != 0;
  o.restore_bone_lengths = d.restore_bone_lengths != 0;
  return o;
}

kata::UpAxis axes_of(kata_up_axis a) {
  if (a != KATA_UP_Y && a != KATA_UP_Z && a != KATA_UP_Y_DOWN)
    throw kata::Error(kata::ErrorKind::kInvalidArgument, "retargeter: unknown up axis");
  return static_cast<kata::UpAxis>(static_cast<int>(a));
}

kata::retarget::MappedSide side_of(const kata::Skeleton& skeleton, const char* layout_name, kata_up_axis axes) {
  const kata::Layout layout = kata::resolve_layout(skeleton, layout_name && layout_name[0] ? layout_name : "cmu");
  return {layout.map, layout.fixed_axes ? layout.axes : axes_of(axes), skeleton.joint_count()};
}

// GPD mode on a stream: the student side is the stream's layout and axes; its bone lengths from
// the rest pose or the stream's estimate. teacher: null = the student's own layout.
kata_status create_mapped(const char* who, kata_stream stream, const kata::retarget::MappedSide* teacher,
                          const kata_retarget_desc& d, kata_retargeter* out) {
  const kata::Skeleton& skel = stream->pipeline.student();
  const kata::StreamConfig& config = stream->pipeline.stream().config();
  const kata::retarget::MappedSide side{config.map, config.up_axis, skel.joint_count()};
  std::array<double, kata::kGpdJoints> lengths{};
  if (skel.has_rest_pose) {
    lengths = kata::retarget::gpd_rest_lengths(skel, config.map);
  } else if (!stream->pipeline.stream().bone_lengths(lengths.data(), nullptr)) {
    kata::capi::set_context_error((std::string(who) +
                                   ": the stream's bone lengths are not estimated yet (60 good frames needed; see "
                                   "kata_stream_bone_lengths)").c_str());
    return KATA_E_STATE;
  }
  for (int g = 1; g < kata::kGpdJoints; ++g)
    if (!(lengths[static_cast<size_t>(g)] > 0.0))
      throw kata::Error(kata::ErrorKind::kInvalidArgument, "retargeter: the student's bone to " +
                                                               std::string(kata::kGpdJointNames[static_cast<size_t>(g)]) +
                                                               " has zero length");
  auto rt = std::make_unique<kata_retargeter_s>(teacher ? *teacher : side, side, lengths, options_of(d));
  rt->enable_rotations(skel);
  *out = rt.release();
  return KATA_OK;
}

kata_status create(const kata::Skeleton& student, const kata_retarget_desc* desc, kata_retargeter* out) {
  const kata_retarget_desc d = effective_desc(desc);
  if (!student.has_rest_pose) {
    throw kata::Error(kata::ErrorKind::kInvalidArgument,
                      "retargeter: the student skeleton has no rest offsets (its bone lengths are unknown; "
                      "kata_retargeter_create_for_stream estimates them from a stream)");
  }
  const kata::retarget::RetargetOptions o = options_of(d);
  const auto sel = kata::retarget::select_joints(student, student, d.joint_set);
  auto rt = std::make_unique<kata_retargeter_s>(student, sel, o);
  rt->enable_rotations(student);
  *out = rt.release();
  return KATA_OK;
}

bool all_finite(const float* p, size_t n) {
  for (size_t i = 0; i < n; ++i)
    if (!std::isfinite(p[i])) return false;
  return true;
}

}  // namespace

namespace kata::capi {

kata::retarget::RetargetOptions retarget_options(const kata_retarget_desc* desc, std::string* joint_set) {
  const kata_retarget_desc d = effective_desc(desc);
  kata::retarget::RetargetOptions o;
  o.solver.gradient_tolerance = d.gradient_tolerance;
  o.solver.max_iterations = static_cast<int>(std::min<uint32_t>(d.max_iterations, 1u << 30));
  o.warm_start = d.warm_start != 0;
  o.restore_bone_lengths = d.restore_bone_lengths != 0;
  *joint_set = d.joint_set;
  return o;
}

}  // namespace kata::capi

namespace {
// The defaults kata.h lists for kata_retarget_desc.
kata_retarget_desc retarget_desc_defaults() {
  kata_retarget_desc d;
  std::memset(&d, 0, sizeof d);
  d.struct_size = sizeof d;
  d.joint_set = "cmu";
  d.gradient_tolerance = 3e-5;
  d.max_iterations = 200;
  d.warm_start = 1;
  d.restore_bone_lengths = 1;
  return d;
}
// What the unsized init writes, for ever: 1.0's struct (programs built before the sized init
// call it by that name). When the struct grows, this stays at 40.
constexpr uint32_t kRetargetDescSize10 = 40;
static_assert(sizeof(kata_retarget_desc) >= kRetargetDescSize10, "the struct only grows");
}  // namespace

extern "C" {

KATA_API void kata_retarget_desc_init_sized(kata_retarget_desc* desc, uint32_t struct_size) {
  kata::capi::init_sized(desc, struct_size, retarget_desc_defaults());
}

// In parentheses: kata.h's macro of the same name is not expanded here.
KATA_API kata_status kata_retargeter_create(kata_context context, kata_skeleton student,
                                            const kata_retarget_desc* desc, kata_retargeter* out) {
  const kata::capi::ContextScope scope(context);
  return kata::capi::guarded_context([&] {
    if (!context || !student || !out) {
      kata::capi::set_context_error("kata_retargeter_create: context, student and out must not be NULL");
      return KATA_E_NULL_POINTER;
    }
    *out = nullptr;
    return create(student->skeleton, desc, out);
  });
}

KATA_API kata_status kata_retargeter_create_for_stream(kata_context context, kata_stream student,
                                                       const kata_retarget_desc* desc, kata_retargeter* out) {
  const kata::capi::ContextScope scope(context);
  return kata::capi::guarded_context([&] {
    if (!context || !student || !out) {
      kata::capi::set_context_error("kata_retargeter_create_for_stream: context, student and out must not be NULL");
      return KATA_E_NULL_POINTER;
    }
    *out = nullptr;
    const kata_retarget_desc d = effective_desc(desc);
    if (student->pipeline.student().has_rest_pose) return create(student->pipeline.student(), desc, out);
    return create_mapped("kata_retargeter_create_for_stream", student, nullptr, d, out);
  });
}

KATA_API kata_status kata_retargeter_create_across(kata_context context, kata_stream student, kata_skeleton teacher,
                                                   const char* teacher_layout, kata_up_axis teacher_up_axis,
                                                   const kata_retarget_desc* desc, kata_retargeter* out) {
  const kata::capi::ContextScope scope(context);
  return kata::capi::guarded_context([&] {
    if (!context || !student || !teacher || !out) {
      kata::capi::set_context_error("kata_retargeter_create_across: context, student, teacher and out must not be NULL");
      return KATA_E_NULL_POINTER;
    }
    *out = nullptr;
    const kata_retarget_desc d = effective_desc(desc);
    const kata::retarget::MappedSide side = side_of(teacher->skeleton, teacher_layout, teacher_up_axis);
    return create_mapped("kata_retargeter_create_across", student, &side, d, out);
  });
}

KATA_API void kata_retargeter_destroy(kata_retargeter retargeter) { delete retargeter; }

KATA_API const char* kata_retargeter_last_error(kata_retargeter retargeter) {
  return retargeter ? retargeter->error : "";
}

KATA_API uint32_t kata_retargeter_joint_count(kata_retargeter retargeter) {
  return retargeter ? static_cast<uint32_t>(retargeter->selection.source.size()) : 0u;
}

KATA_API int32_t kata_retargeter_joint_source(kata_retargeter retargeter, uint32_t i) {
  if (!retargeter || i >= retargeter->selection.source.size()) return -1;
  return retargeter->selection.source[i];
}

KATA_API kata_status kata_retargeter_solve(kata_retargeter rt, const float* teacher, uint32_t teacher_joint_count,
                                           float* ghost, size_t capacity, kata_retarget_info* info) {
  if (!rt) return KATA_E_NULL_POINTER;
  if (!teacher || !ghost) {
    rt->set_error("kata_retargeter_solve: teacher and ghost must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  if (teacher_joint_count != static_cast<uint32_t>(rt->teacher_joints)) {
    rt->set_error("kata_retargeter_solve: teacher_joint_count differs from the teacher skeleton's joint count");
    return KATA_E_WRONG_JOINT_COUNT;
  }
  const size_t n = rt->selection.source.size();
  if (capacity < 3 * n) {
    rt->set_error("kata_retargeter_solve: ghost holds fewer than 3 x kata_retargeter_joint_count() floats");
    return KATA_E_BUFFER_TOO_SMALL;
  }
  if (!all_finite(teacher, 3 * static_cast<size_t>(teacher_joint_count))) {
    rt->set_error("kata_retargeter_solve: the teacher frame has a NaN or Inf");
    return KATA_E_NON_FINITE;
  }
  if (info && info->struct_size < kata::capi::kRetargetInfo10) {
    rt->set_error("kata_retargeter_solve: info->struct_size is below 1.0's kata_retarget_info");
    return KATA_E_INVALID_ARGUMENT;
  }
  return kata::capi::guarded([rt](const char* m) { rt->set_error(m); }, [&] {
    const kata::retarget::RetargetReport* report;
    if (rt->mapped) {
      report = &rt->mapped->retarget(teacher, ghost);
    } else {
      for (size_t k = 0; k < n; ++k)
        for (size_t c = 0; c < 3; ++c)
          rt->teacher[3 * k + c] = teacher[3 * static_cast<size_t>(rt->selection.source[k]) + c];
      report = &rt->retargeter->retarget(rt->teacher.data(), rt->ghost.data());
      for (size_t i = 0; i < 3 * n; ++i) ghost[i] = static_cast<float>(rt->ghost[i]);
    }
    const kata::retarget::RetargetReport& r = *report;
    if (info) {
      kata_retarget_info full{};
      full.iterations = static_cast<uint32_t>(r.iterations);
      full.converged = r.converged ? 1 : 0;
      full.warm = r.warm ? 1 : 0;
      full.stress = r.stress;
      full.max_bone_error_solved = r.max_bone_error_solved;
      full.max_bone_error = r.max_bone_error;
      kata::capi::write_sized(full, kata::capi::kRetargetInfo10, info);  // size checked above
    }
    rt->error[0] = '\0';
    return KATA_OK;
  });
}

KATA_API kata_status kata_retargeter_place(kata_retargeter rt, const float* student, uint32_t student_joint_count,
                                           float* ghost, size_t capacity) {
  if (!rt) return KATA_E_NULL_POINTER;
  if (!student || !ghost) {
    rt->set_error("kata_retargeter_place: student and ghost must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  if (student_joint_count != static_cast<uint32_t>(rt->skeleton_joints)) {
    rt->set_error("kata_retargeter_place: student_joint_count differs from the student skeleton's joint count");
    return KATA_E_WRONG_JOINT_COUNT;
  }
  const size_t n = rt->selection.source.size();
  if (capacity < 3 * n) {
    rt->set_error("kata_retargeter_place: ghost holds fewer than 3 x kata_retargeter_joint_count() floats");
    return KATA_E_BUFFER_TOO_SMALL;
  }
  if (!all_finite(student, 3 * static_cast<size_t>(student_joint_count)) || !all_finite(ghost, 3 * n)) {
    rt->set_error("kata_retargeter_place: a NaN or Inf in the student frame or the ghost");
    return KATA_E_NON_FINITE;
  }
  if (rt->mapped) {
    rt->mapped->place(student, ghost);
    rt->error[0] = '\0';
    return KATA_OK;
  }
  for (size_t k = 0; k < n; ++k)
    for (size_t c = 0; c < 3; ++c) {
      rt->student_pose[3 * k + c] = student[3 * static_cast<size_t>(rt->selection.source[k]) + c];
      rt->ghost[3 * k + c] = ghost[3 * k + c];
    }
  kata::retarget::place_over_student(static_cast<int>(n), rt->student_pose.data(), rt->ghost.data());
  for (size_t i = 0; i < 3 * n; ++i) ghost[i] = static_cast<float>(rt->ghost[i]);
  rt->error[0] = '\0';
  return KATA_OK;
}

KATA_API kata_status kata_retargeter_reset(kata_retargeter rt) {
  if (!rt) return KATA_E_NULL_POINTER;
  if (rt->mapped) rt->mapped->reset();
  else rt->retargeter->reset();
  return KATA_OK;
}

KATA_API uint32_t kata_retargeter_rotation_joint_count(kata_retargeter rt) {
  return rt && rt->rotations ? static_cast<uint32_t>(rt->rotations->joint_count()) : 0u;
}

KATA_API kata_status kata_retargeter_local_rotations(kata_retargeter rt, const float* ghost, size_t ghost_count,
                                                     float* rotations, size_t rotation_capacity, float* root_position,
                                                     float* positions, size_t position_capacity, double* residual) {
  if (!rt) return KATA_E_NULL_POINTER;
  if (!ghost || !rotations || !root_position) {
    rt->set_error("kata_retargeter_local_rotations: ghost, rotations and root_position must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  if (!rt->rotations) {
    rt->set_error("kata_retargeter_local_rotations: the student skeleton has no rest pose (no hierarchy to rotate)");
    return KATA_E_STATE;
  }
  const size_t g = rt->selection.source.size();
  const size_t n = static_cast<size_t>(rt->rotations->joint_count());
  if (ghost_count != 3 * g) {
    rt->set_error("kata_retargeter_local_rotations: ghost_count is not 3 x kata_retargeter_joint_count()");
    return KATA_E_WRONG_JOINT_COUNT;
  }
  if (rotation_capacity < 4 * n || (positions && position_capacity < 3 * n)) {
    rt->set_error("kata_retargeter_local_rotations: rotations hold fewer than 4 x, or positions fewer than 3 x, "
                  "kata_retargeter_rotation_joint_count() floats");
    return KATA_E_BUFFER_TOO_SMALL;
  }
  if (!all_finite(ghost, ghost_count)) {
    rt->set_error("kata_retargeter_local_rotations: the ghost has a NaN or Inf");
    return KATA_E_NON_FINITE;
  }
  for (size_t i = 0; i < 3 * g; ++i) rt->ghost[i] = ghost[i];
  double root[3];
  rt->rotations->solve(rt->ghost.data(), rt->rotation_out.data(), root, rt->fk_out.data());
  for (size_t i = 0; i < 4 * n; ++i) rotations[i] = static_cast<float>(rt->rotation_out[i]);
  for (int k = 0; k < 3; ++k) root_position[k] = static_cast<float>(root[k]);
  if (positions)
    for (size_t i = 0; i < 3 * n; ++i) positions[i] = static_cast<float>(rt->fk_out[i]);
  if (residual) *residual = rt->rotations->residual();
  rt->error[0] = '\0';
  return KATA_OK;
}

}  // extern "C"
