// C ABI shim of kata/humanoid.h: the humanoid (VRM) rig over kata::humanoid::Rig.
#include <cmath>
#include <cstring>
#include <memory>

#include <Eigen/Geometry>

#include "capi/capi_internal.hpp"
#include "common/text.hpp"
#include "humanoid/bones.hpp"
#include "humanoid/rig.hpp"

namespace h = kata::humanoid;

static_assert(KATA_BONE_COUNT == h::kBoneCount, "kata_humanoid_bone and humanoid/bones.hpp disagree");
static_assert(static_cast<int>(KATA_BONE_RIGHT_TOES) == static_cast<int>(h::kRightToes),
              "kata_humanoid_bone and humanoid/bones.hpp disagree");

// A rig: the student's (the stream's or skeleton's frames) and, for a stream with a ghost, the
// ghost's, which reads the ghost's joints on the student's bones.
struct kata_humanoid_rig_s {
  std::unique_ptr<h::Rig> student, ghost;
  enum class GhostKind { kNone, kJoints, kGpd } ghost_kind = GhostKind::kNone;
  std::vector<int> ghost_sources;  // kJoints: the student joint of each ghost joint
  uint32_t ghost_joints = 0;
  h::Points scratch;               // one frame's points (no allocation per frame)
  char error[256] = {0};
  void set_error(const char* message) noexcept { std::snprintf(error, sizeof error, "%s", message); }
};

namespace {

using kata::capi::guarded;

// The sizes these structs first shipped with (struct_size below them is refused).
constexpr uint32_t kPoseReleased = KATA_CAPI_END_OF(kata_humanoid_pose, reserved);
constexpr uint32_t kDescReleased = KATA_CAPI_END_OF(kata_humanoid_desc, metres_per_unit);

kata_humanoid_desc desc_defaults() {
  kata_humanoid_desc d;
  std::memset(&d, 0, sizeof d);
  d.struct_size = sizeof d;
  d.layout = nullptr;
  d.up_axis = KATA_UP_Y;
  d.metres_per_unit = 0.0;
  return d;
}

kata_humanoid_desc read_desc(const kata_humanoid_desc* desc, const char* call) {
  kata_humanoid_desc d = desc_defaults();
  if (desc && !kata::capi::read_sized(desc, desc_defaults(), kDescReleased, &d))
    throw kata::Error(kata::ErrorKind::kInvalidArgument,
                      std::string(call) + ": desc->struct_size is below kata_humanoid_desc's (use kata_humanoid_desc_init)");
  if (!(d.metres_per_unit >= 0.0) || !std::isfinite(d.metres_per_unit) || d.metres_per_unit > 1e6 ||
      (d.metres_per_unit > 0.0 && d.metres_per_unit < 1e-9))
    throw kata::Error(kata::ErrorKind::kInvalidArgument,
                      std::string(call) + ": metres_per_unit must be 0 (the layout's) or within 1e-9..1e6");
  return d;
}

kata::UpAxis up_axis_of(kata_up_axis a, const char* call) {
  if (a != KATA_UP_Y && a != KATA_UP_Z && a != KATA_UP_Y_DOWN)
    throw kata::Error(kata::ErrorKind::kInvalidArgument, std::string(call) + ": unknown up_axis");
  return static_cast<kata::UpAxis>(static_cast<int>(a));
}

// A skeleton's rest pose as one input frame (its own units and axes).
std::vector<float> rest_frame(const kata::Skeleton& skeleton) {
  const Eigen::MatrixX3d rest = kata::rest_positions(skeleton);
  std::vector<float> out(3 * static_cast<size_t>(skeleton.joint_count()));
  for (int j = 0; j < skeleton.joint_count(); ++j)
    for (int c = 0; c < 3; ++c) out[static_cast<size_t>(3 * j + c)] = static_cast<float>(rest(j, c));
  return out;
}

// A student frame as the ghost's joints (for measuring the ghost's rest on the student's bones).
void ghost_frame(const kata_humanoid_rig_s& rig, const float* student, float* ghost) {
  if (rig.ghost_kind == kata_humanoid_rig_s::GhostKind::kJoints) {
    for (size_t i = 0; i < rig.ghost_sources.size(); ++i)
      for (int c = 0; c < 3; ++c) ghost[3 * i + static_cast<size_t>(c)] = student[3 * rig.ghost_sources[i] + c];
    return;
  }
  const h::Mapping& m = rig.student->mapping();
  float up[3];
  for (int g = 0; g < kata::kGpdJoints; ++g) {
    kata::map_gpd_joint(m.gpd, m.axes, g, student, up);
    kata::from_y_up(m.axes, up, ghost + 3 * g);
  }
}

// Measures the student's rest (and the ghost's) from frames of the student's input.
void measure(kata_humanoid_rig_s& rig, const float* frames, uint32_t count) {
  const h::Mapping& m = rig.student->mapping();
  const size_t stride = 3 * static_cast<size_t>(m.input_joints);
  std::vector<h::Points> pts(count);
  for (uint32_t f = 0; f < count; ++f) rig.student->points(frames + f * stride, pts[f]);
  rig.student->measure(pts.data(), static_cast<int>(count));
  if (!rig.ghost) return;
  std::vector<float> g(3 * static_cast<size_t>(rig.ghost_joints));
  for (uint32_t f = 0; f < count; ++f) {
    ghost_frame(rig, frames + f * stride, g.data());
    rig.ghost->points(g.data(), pts[f]);
  }
  rig.ghost->measure(pts.data(), static_cast<int>(count));
}

std::unique_ptr<kata_humanoid_rig_s> make_rig(const kata::Skeleton& skeleton, const kata::GpdMap& map,
                                              const std::string& layout, kata::UpAxis axes, double metres) {
  auto rig = std::make_unique<kata_humanoid_rig_s>();
  rig->student = std::make_unique<h::Rig>(h::make_mapping(skeleton, map, layout, axes, metres));
  return rig;
}

// Checks a frame's joints the rig reads: finite and within KATA_MAX_COORDINATE.
kata_status check_frame(kata_humanoid_rig_s* rig, const h::Rig& r, const float* xyz, const char* call) {
  for (int j : r.read_joints()) {
    for (int c = 0; c < 3; ++c) {
      const float v = xyz[3 * j + c];
      if (!std::isfinite(v) || std::fabs(v) > KATA_MAX_COORDINATE) {
        const std::vector<std::string>& names = r.mapping().joint_names;
        const char* name = static_cast<size_t>(j) < names.size() ? names[static_cast<size_t>(j)].c_str() : "?";
        std::snprintf(rig->error, sizeof rig->error, "%s: joint %d ('%.64s') is %s", call, j, name,
                      std::isfinite(v) ? "beyond KATA_MAX_COORDINATE" : "NaN or infinite");
        return std::isfinite(v) ? KATA_E_INVALID_ARGUMENT : KATA_E_NON_FINITE;
      }
    }
  }
  return KATA_OK;
}

// The pose in the caller's struct and frame.
void write_pose(const h::Pose& p, int32_t frame, kata_humanoid_pose* out) {
  kata_humanoid_pose v;
  std::memset(&v, 0, sizeof v);
  v.struct_size = sizeof v;
  v.placed = p.placed;
  v.degenerate = p.degenerate;
  v.frame = KATA_HUMANOID_RIGHT_HANDED;
  for (int c = 0; c < 3; ++c) v.hips_position[c] = static_cast<float>(p.hips[c]);
  for (int b = 0; b < KATA_BONE_COUNT; ++b) {
    for (int c = 0; c < 4; ++c) v.rotation[b][c] = static_cast<float>(p.rotation[static_cast<size_t>(b)][c]);
    for (int c = 0; c < 3; ++c) v.offset[b][c] = static_cast<float>(p.offset[static_cast<size_t>(b)][c]);
  }
  kata_humanoid_pose_convert(&v, frame);
  kata::capi::write_sized(v, kPoseReleased, out);
}

bool known_frame(int32_t frame) { return frame == KATA_HUMANOID_RIGHT_HANDED || frame == KATA_HUMANOID_UNITY; }

kata_status pose_common(kata_humanoid_rig_s* rig, h::Rig* r, const float* xyz, uint32_t joint_count, int32_t frame,
                        kata_humanoid_pose* out, const char* call) {
  if (!xyz || !out) {
    std::snprintf(rig->error, sizeof rig->error, "%s: positions and out must not be NULL", call);
    return KATA_E_NULL_POINTER;
  }
  if (joint_count != static_cast<uint32_t>(r->mapping().input_joints)) {
    std::snprintf(rig->error, sizeof rig->error, "%s: %u joints, the rig reads %d", call, joint_count,
                  r->mapping().input_joints);
    return KATA_E_WRONG_JOINT_COUNT;
  }
  if (!known_frame(frame) || out->struct_size < kPoseReleased) {
    std::snprintf(rig->error, sizeof rig->error, "%s: %s", call,
                  known_frame(frame) ? "out->struct_size is below kata_humanoid_pose's" : "unknown kata_humanoid_frame");
    return KATA_E_INVALID_ARGUMENT;
  }
  const kata_status s = check_frame(rig, *r, xyz, call);
  if (s != KATA_OK) return s;
  r->points(xyz, rig->scratch);
  // An unmeasured rig takes its rest from the first frame that has every bone.
  if (!r->measured() && r->complete(rig->scratch)) r->measure(&rig->scratch, 1);
  h::Pose p;
  r->pose(rig->scratch, p);
  write_pose(p, frame, out);
  return KATA_OK;
}

}  // namespace

extern "C" {

KATA_API const char* kata_humanoid_bone_name(int bone) {
  if (bone < 0 || bone >= h::kBoneCount) return nullptr;
  return h::kBoneNames[static_cast<size_t>(bone)];
}

KATA_API int kata_humanoid_bone_find(const char* name) {
  // kata.h: caller strings are read up to KATA_MAX_STRING_BYTES.
  if (!name || ::strnlen(name, kata::kMaxCStringBytes) == kata::kMaxCStringBytes) return -1;
  return h::find_bone(name);
}

KATA_API int kata_humanoid_bone_parent(int bone) {
  if (bone < 0 || bone >= h::kBoneCount) return -2;
  return h::kBoneParents[static_cast<size_t>(bone)];
}

KATA_API void kata_humanoid_desc_init_sized(kata_humanoid_desc* desc, uint32_t struct_size) {
  kata::capi::init_sized(desc, struct_size, desc_defaults());
}

KATA_API kata_status kata_humanoid_rig_create(kata_context context, kata_skeleton skeleton,
                                              const kata_humanoid_desc* desc, kata_humanoid_rig* out) {
  const kata::capi::ContextScope scope(context);
  return kata::capi::guarded_context([&] {
    if (!context || !skeleton || !out) {
      kata::capi::set_context_error("kata_humanoid_rig_create: context, skeleton and out must not be NULL");
      return KATA_E_NULL_POINTER;
    }
    *out = nullptr;
    const char* call = "kata_humanoid_rig_create";
    const kata_humanoid_desc d = read_desc(desc, call);
    const std::string layout = d.layout ? kata::c_string(d.layout, "desc->layout") : std::string("cmu");
    const kata::Skeleton& sk = skeleton->skeleton;
    const kata::Layout resolved = kata::resolve_layout(sk, layout);
    const kata::UpAxis axes = resolved.fixed_axes ? resolved.axes : up_axis_of(d.up_axis, call);
    const double metres = d.metres_per_unit > 0 ? d.metres_per_unit : h::default_metres_per_unit(layout);
    auto rig = make_rig(sk, resolved.map, layout, axes, metres);
    if (sk.has_rest_pose) {
      const std::vector<float> rest = rest_frame(sk);
      measure(*rig, rest.data(), 1);
    }
    *out = rig.release();
    return KATA_OK;
  });
}

KATA_API kata_status kata_humanoid_rig_create_for_stream(kata_context context, kata_stream stream,
                                                         const kata_humanoid_desc* desc, kata_humanoid_rig* out) {
  const kata::capi::ContextScope scope(context);
  return kata::capi::guarded_context([&] {
    if (!context || !stream || !out) {
      kata::capi::set_context_error("kata_humanoid_rig_create_for_stream: context, stream and out must not be NULL");
      return KATA_E_NULL_POINTER;
    }
    *out = nullptr;
    const char* call = "kata_humanoid_rig_create_for_stream";
    const kata_humanoid_desc d = read_desc(desc, call);
    const kata::Skeleton& sk = stream->pipeline.student();
    const kata::StreamConfig& config = stream->pipeline.stream().config();
    const std::string& layout = stream->layout_name;  // "" for a name map
    const double metres = d.metres_per_unit > 0 ? d.metres_per_unit : h::default_metres_per_unit(layout);
    auto rig = make_rig(sk, config.map, layout, config.up_axis, metres);
    // The ghost: the student's own joints (a subset of its skeleton), or the 16 GPD joints.
    const int ghost_joints = stream->pipeline.ghost_joint_count();
    if (stream->pipeline.has_ghost() && ghost_joints > 0) {
      const std::vector<int>& sources = stream->pipeline.ghost_sources();
      bool own = static_cast<int>(sources.size()) == ghost_joints;
      for (int s : sources) own = own && s >= 0 && s < sk.joint_count();
      kata::Skeleton sub;
      kata::GpdMap sub_map;
      if (own) {
        for (int i = 0; i < ghost_joints; ++i) {
          sub.names.push_back(sk.names[static_cast<size_t>(sources[static_cast<size_t>(i)])]);
          sub.parents.push_back(i == 0 ? -1 : 0);
          sub.offsets.emplace_back(Eigen::Vector3d::Zero());
        }
        try {
          sub_map = layout.empty() ? kata::make_gpd_map(sub, [&] {
            std::array<std::string, kata::kGpdJoints> names;
            for (int g = 0; g < kata::kGpdJoints; ++g)
              names[static_cast<size_t>(g)] = stream->name_map.at(static_cast<size_t>(g));
            return names;
          }())
                                   : kata::resolve_layout(sub, layout).map;
        } catch (const kata::Error&) {
          own = false;  // the ghost's joints do not carry the layout's: read them as GPD joints
        } catch (const std::out_of_range&) {
          own = false;
        }
      }
      if (own) {
        rig->ghost_kind = kata_humanoid_rig_s::GhostKind::kJoints;
        rig->ghost_sources = sources;
        rig->ghost = std::make_unique<h::Rig>(h::make_mapping(sub, sub_map, layout, config.up_axis, metres));
      } else if (ghost_joints == kata::kGpdJoints) {
        rig->ghost_kind = kata_humanoid_rig_s::GhostKind::kGpd;
        const kata::Skeleton gpd = kata::layout_skeleton("gpd");
        rig->ghost = std::make_unique<h::Rig>(
            h::make_mapping(gpd, kata::resolve_layout(gpd, "gpd").map, "gpd", config.up_axis, metres));
      } else {
        throw kata::Error(kata::ErrorKind::kInvalidArgument,
                          std::string(call) + ": the stream's ghost joints carry neither its layout nor the 16 GPD joints");
      }
      rig->ghost_joints = static_cast<uint32_t>(ghost_joints);
    }
    if (sk.has_rest_pose) {
      const std::vector<float> rest = rest_frame(sk);
      measure(*rig, rest.data(), 1);
    }
    *out = rig.release();
    return KATA_OK;
  });
}

KATA_API void kata_humanoid_rig_destroy(kata_humanoid_rig rig) { delete rig; }

KATA_API const char* kata_humanoid_rig_last_error(kata_humanoid_rig rig) { return rig ? rig->error : ""; }

KATA_API uint32_t kata_humanoid_rig_joint_count(kata_humanoid_rig rig) {
  return rig ? static_cast<uint32_t>(rig->student->mapping().input_joints) : 0;
}

KATA_API uint32_t kata_humanoid_rig_ghost_joint_count(kata_humanoid_rig rig) { return rig ? rig->ghost_joints : 0; }

KATA_API uint32_t kata_humanoid_rig_placed(kata_humanoid_rig rig) { return rig ? rig->student->placed() : 0; }

KATA_API double kata_humanoid_rig_metres_per_unit(kata_humanoid_rig rig) {
  return rig ? rig->student->mapping().metres_per_unit : 0.0;
}

KATA_API int32_t kata_humanoid_rig_bone_source(kata_humanoid_rig rig, int32_t bone) {
  return rig ? rig->student->bone_source(bone) : -1;
}

KATA_API kata_status kata_humanoid_rig_calibrate(kata_humanoid_rig rig, const float* positions, uint32_t joint_count,
                                                 uint32_t frames) {
  if (!rig) return KATA_E_NULL_POINTER;
  return guarded([rig](const char* m) { rig->set_error(m); }, [&] {
    const char* call = "kata_humanoid_rig_calibrate";
    if (!positions) {
      rig->set_error("kata_humanoid_rig_calibrate: positions must not be NULL");
      return KATA_E_NULL_POINTER;
    }
    const int n = rig->student->mapping().input_joints;
    if (joint_count != static_cast<uint32_t>(n)) {
      std::snprintf(rig->error, sizeof rig->error, "%s: %u joints, the rig reads %d", call, joint_count, n);
      return KATA_E_WRONG_JOINT_COUNT;
    }
    if (frames == 0 || frames > 65536) {
      std::snprintf(rig->error, sizeof rig->error, "%s: frames must be 1..65536 (got %u)", call, frames);
      return KATA_E_INVALID_ARGUMENT;
    }
    for (uint32_t f = 0; f < frames; ++f) {
      const kata_status s = check_frame(rig, *rig->student, positions + static_cast<size_t>(f) * 3 * static_cast<size_t>(n), call);
      if (s != KATA_OK) return s;
    }
    measure(*rig, positions, frames);
    return KATA_OK;
  });
}

KATA_API int32_t kata_humanoid_rig_calibrated(kata_humanoid_rig rig) { return rig && rig->student->measured() ? 1 : 0; }

KATA_API kata_status kata_humanoid_rig_rest_pose(kata_humanoid_rig rig, int32_t frame, kata_humanoid_pose* out) {
  if (!rig) return KATA_E_NULL_POINTER;
  if (!out) {
    rig->set_error("kata_humanoid_rig_rest_pose: out must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  if (!known_frame(frame) || out->struct_size < kPoseReleased) {
    rig->set_error(known_frame(frame) ? "kata_humanoid_rig_rest_pose: out->struct_size is below kata_humanoid_pose's"
                                      : "kata_humanoid_rig_rest_pose: unknown kata_humanoid_frame");
    return KATA_E_INVALID_ARGUMENT;
  }
  if (!rig->student->measured()) {
    rig->set_error("kata_humanoid_rig_rest_pose: the rig has no rest yet (kata_humanoid_rig_calibrate)");
    return KATA_E_STATE;
  }
  h::Pose p;
  rig->student->rest_pose(p);
  write_pose(p, frame, out);
  return KATA_OK;
}

KATA_API kata_status kata_humanoid_rig_pose(kata_humanoid_rig rig, const float* positions, uint32_t joint_count,
                                            int32_t frame, kata_humanoid_pose* out) {
  if (!rig) return KATA_E_NULL_POINTER;
  return pose_common(rig, rig->student.get(), positions, joint_count, frame, out, "kata_humanoid_rig_pose");
}

KATA_API kata_status kata_humanoid_rig_pose_ghost(kata_humanoid_rig rig, const float* ghost, uint32_t ghost_joint_count,
                                                  int32_t frame, kata_humanoid_pose* out) {
  if (!rig) return KATA_E_NULL_POINTER;
  if (!rig->ghost) {
    rig->set_error("kata_humanoid_rig_pose_ghost: the rig reads no ghost (create it for a stream after attaching a "
                   "teacher with a ghost)");
    return KATA_E_STATE;
  }
  return pose_common(rig, rig->ghost.get(), ghost, ghost_joint_count, frame, out, "kata_humanoid_rig_pose_ghost");
}

KATA_API kata_status kata_humanoid_pose_convert(kata_humanoid_pose* pose, int32_t frame) {
  if (!pose) return KATA_E_NULL_POINTER;
  if (!known_frame(frame) || !known_frame(pose->frame) || pose->struct_size < kPoseReleased)
    return KATA_E_INVALID_ARGUMENT;
  if (pose->frame == frame) return KATA_OK;
  // Both directions are the same mirror through the YZ plane.
  pose->hips_position[0] = -pose->hips_position[0];
  for (int b = 0; b < KATA_BONE_COUNT; ++b) {
    pose->rotation[b][1] = -pose->rotation[b][1];
    pose->rotation[b][2] = -pose->rotation[b][2];
    pose->offset[b][0] = -pose->offset[b][0];
  }
  pose->frame = frame;
  return KATA_OK;
}

KATA_API kata_status kata_humanoid_pose_joints(const kata_humanoid_pose* pose, float* positions, size_t capacity,
                                               float* rotations, size_t rotation_capacity) {
  if (!pose || !positions) return KATA_E_NULL_POINTER;
  if (pose->struct_size < kPoseReleased) return KATA_E_INVALID_ARGUMENT;
  if (capacity < 3u * KATA_BONE_COUNT || (rotations && rotation_capacity < 4u * KATA_BONE_COUNT))
    return KATA_E_BUFFER_TOO_SMALL;
  std::array<Eigen::Quaterniond, h::kBoneCount> world;
  std::array<Eigen::Vector3d, h::kBoneCount> at;
  for (int b = 0; b < KATA_BONE_COUNT; ++b) {
    const float* q = pose->rotation[b];
    Eigen::Quaterniond local(q[3], q[0], q[1], q[2]);
    // A caller's quaternion is normalised; a zero (or non-finite) one reads as the identity.
    const double n = local.norm();
    local = n > 1e-12 && std::isfinite(n) ? Eigen::Quaterniond(local.coeffs() / n) : Eigen::Quaterniond::Identity();
    const int p = h::kBoneParents[static_cast<size_t>(b)];
    const Eigen::Vector3d off(pose->offset[b][0], pose->offset[b][1], pose->offset[b][2]);
    if (p < 0) {
      world[0] = local;
      at[0] = Eigen::Vector3d(pose->hips_position[0], pose->hips_position[1], pose->hips_position[2]);
    } else {
      world[static_cast<size_t>(b)] = world[static_cast<size_t>(p)] * local;
      at[static_cast<size_t>(b)] = at[static_cast<size_t>(p)] + world[static_cast<size_t>(p)] * off;
    }
    for (int c = 0; c < 3; ++c) positions[3 * b + c] = static_cast<float>(at[static_cast<size_t>(b)][c]);
    if (rotations) {
      const Eigen::Quaterniond& w = world[static_cast<size_t>(b)];
      rotations[4 * b] = static_cast<float>(w.x());
      rotations[4 * b + 1] = static_cast<float>(w.y());
      rotations[4 * b + 2] = static_cast<float>(w.z());
      rotations[4 * b + 3] = static_cast<float>(w.w());
    }
  }
  return KATA_OK;
}

}  // extern "C"
