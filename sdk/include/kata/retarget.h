/* kata/retarget.h: task 4, retarget: a teacher's posture on a student's body, frame by frame (also
 * the ghost's solver settings, kata_retarget_desc, used by kata_teacher_desc).
 *
 * Part of the C ABI; include "kata/kata.h" (all of it) or this header alone: it includes what it
 * needs. kata.h states the conventions every function here follows. */
#ifndef KATA_RETARGET_H
#define KATA_RETARGET_H

#include "stream.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- The ghost's solver settings (kata_teacher_desc.retarget, kata_retargeter_create) ---- */
/* How a retargeter solves. Fill with kata_retarget_desc_init, then change fields. */
typedef struct kata_retarget_desc {
  uint32_t struct_size;        /* sizeof(kata_retarget_desc) */
  const char* joint_set;       /* the joints solved: "cmu" (default) or "gpd" (see Retargeting) */
  double gradient_tolerance;   /* stop when |grad| <= this x sqrt(sum pi delta^2). Default 3e-5;
                                  warm frames stop at 3x this (their quasi-Newton steps start from
                                  the previous frame's; docs/retarget/README.md) */
  uint32_t max_iterations;     /* SPG iteration cap per frame. Default 200 */
  int32_t warm_start;          /* 1 (default): start from the previous frame's solution */
  int32_t restore_bone_lengths;/* 1 (default): reset every bone to the student's exact length */
} kata_retarget_desc;

/* Fills the first struct_size bytes of desc with the defaults above and sets desc->struct_size
 * to the smaller of struct_size and sizeof(kata_retarget_desc): nothing past the caller's own struct is
 * written, so a caller built against an older kata.h (a smaller struct) is safe with a
 * newer library, which then reads only that much (the later fields keep their defaults).
 * struct_size below 4 writes nothing. Bindings that declare the struct themselves (ctypes,
 * P/Invoke) pass their own size. [any thread] */
KATA_API void kata_retarget_desc_init_sized(kata_retarget_desc* desc, uint32_t struct_size);
/* Fills *desc with the defaults for the caller's own struct: kata_retarget_desc_init_sized(desc, sizeof *desc). */
#define kata_retarget_desc_init(desc) kata_retarget_desc_init_sized((desc), (uint32_t)sizeof *(desc))


/* ##############################################################################################
 * Task 4 - retarget: a teacher's posture on a student's body, frame by frame
 *
 * kata_retargeter rt;  kata_retargeter_create(ctx, student_skeleton, NULL, &rt);
 * float ghost[3 * 64];  kata_retarget_info info;  info.struct_size = sizeof info;
 * kata_retargeter_solve(rt, teacher_xyz, teacher_joints, ghost, 3 * 64, &info);
 * kata_retargeter_place(rt, student_xyz, student_joints, ghost, 3 * 64);
 * kata_retargeter_destroy(rt);
 * ############################################################################################ */

/* ==== Retargeting ========================================================================= */
/* Puts a teacher's posture onto a student's body, frame after frame (skeleton-independent
 * distance matrices + a warm-started non-monotone spectral gradient solve, then exact bone
 * lengths). The student is a skeleton with rest offsets (its bone lengths); teacher frames come
 * in the same skeleton layout (same joints, same order: e.g. two CMU subjects) with their own
 * bone lengths. The retargeter works on a subset of the joints, its joint set (desc.joint_set):
 *   "cmu" (default): every joint that carries a bone; joints with a zero offset, sitting on their
 *         parent, are dropped (CMU BVH: 31 -> 21 joints);
 *   "gpd": the 16 GPD joints, read through the "cmu" layout.
 * Units: positions in the student skeleton's units (teacher frames must use the same unit),
 * +Y up. Memory: kata_retargeter_create allocates everything; the per-frame calls never do.
 * Threads: a retargeter is used by one thread at a time (different retargeters in parallel). */

/* Per-student retargeting state (warm start, buffers). */
typedef struct kata_retargeter_s* kata_retargeter;

/* What one kata_retargeter_solve did. */
typedef struct kata_retarget_info {
  uint32_t struct_size;         /* set by the caller: sizeof(kata_retarget_info) */
  uint32_t iterations;          /* SPG iterations this frame */
  int32_t converged;            /* 1 when the gradient tolerance was met (else the cap) */
  int32_t warm;                 /* 1 when warm-started from the previous frame */
  double stress;                /* the paper's stress at the SPG optimum, units^2 */
  double max_bone_error_solved; /* largest relative bone-length error at the optimum (0.01 = 1%) */
  double max_bone_error;        /* the same for the returned ghost (after the restoring step) */
} kata_retarget_info;

/* Creates a retargeter for the student `student` (a skeleton with rest offsets; copied, may be
 * destroyed afterwards). desc may be NULL for the defaults; else desc->struct_size is 1.0's
 * size or more (see Versions). Errors (unknown joint set, missing
 * joint, no rest pose, zero bone length) are reported on the context. [any thread] */
KATA_API kata_status kata_retargeter_create(kata_context context, kata_skeleton student,
                                            const kata_retarget_desc* desc, kata_retargeter* out);
/* The same with a stream's skeleton as the student (its rest offsets give the bone lengths).
 * A stream whose skeleton has no rest pose uses its estimated GPD bone lengths
 * (kata_stream_bone_lengths; KATA_E_STATE until they are ready) on the 16 GPD joints (as
 * kata_retargeter_create_across with the stream's own layout as the teacher's). The retargeter
 * is independent of the stream afterwards. [stream owner] */
KATA_API kata_status kata_retargeter_create_for_stream(kata_context context, kata_stream student,
                                                       const kata_retarget_desc* desc, kata_retargeter* out);
/* Across layouts: a teacher on another skeleton (e.g. a CMU BVH) onto the student stream's
 * layout (e.g. MediaPipe). solve() then takes frames of `teacher` (teacher_layout names its layout,
 * e.g. "cmu"; read in teacher_up_axis unless the layout fixes its axes; its units do not matter)
 * and works on the 16 GPD joints both layouts map: the ghost is the 16 GPD joints (GPD order) in
 * the student stream's axes and units, root (Hip) at the origin until kata_retargeter_place puts
 * it over the student; kata_retargeter_joint_source gives the student joint each stands for (-1
 * for a synthesised one). The student's bone lengths come from its rest pose, or else from the
 * stream's estimate (KATA_E_STATE until kata_stream_bone_lengths has them). desc may be NULL
 * (its joint_set is ignored). [stream owner] */
KATA_API kata_status kata_retargeter_create_across(kata_context context, kata_stream student, kata_skeleton teacher,
                                                   const char* teacher_layout, kata_up_axis teacher_up_axis,
                                                   const kata_retarget_desc* desc, kata_retargeter* out);
/* Releases a retargeter. NULL is ignored. [retargeter owner] */
KATA_API void kata_retargeter_destroy(kata_retargeter retargeter);
/* The message of the last failed call on this retargeter, or "". Valid until the next call on
 * it. [retargeter owner] */
KATA_API const char* kata_retargeter_last_error(kata_retargeter retargeter);
/* Number of joints the retargeter outputs (21 for "cmu" on CMU, 16 for "gpd"); 0 for NULL.
 * [retargeter owner] */
KATA_API uint32_t kata_retargeter_joint_count(kata_retargeter retargeter);
/* The skeleton joint that output joint i stands for (an index into the student skeleton), or
 * -1 when out of range. [retargeter owner] */
KATA_API int32_t kata_retargeter_joint_source(kata_retargeter retargeter, uint32_t i);

/* Retargets one teacher frame. teacher: every joint of the skeleton (teacher_joint_count x 3
 * floats, x, y, z interleaved, student units; across layouts: every joint of the teacher
 * skeleton, its own units, and the ghost's root (Hip) is at the origin). ghost (capacity floats) receives
 * kata_retargeter_joint_count() x 3 floats: the posture on the student's bones, root on the
 * teacher's root, oriented like the teacher. info (may be NULL; set info->struct_size) receives
 * the solve's figures. KATA_E_WRONG_JOINT_COUNT, KATA_E_NON_FINITE, KATA_E_BUFFER_TOO_SMALL and
 * KATA_E_NULL_POINTER leave the state unchanged. Does not allocate. [retargeter owner] */
KATA_API kata_status kata_retargeter_solve(kata_retargeter retargeter, const float* teacher,
                                           uint32_t teacher_joint_count, float* ghost, size_t capacity,
                                           kata_retarget_info* info);
/* Places a ghost from kata_retargeter_solve (in/out, joint_count() x 3 floats) over the
 * student's current posture (student: every skeleton joint, student_joint_count x 3 floats):
 * root on the student's root, turned about +Y (a proper rotation, never a mirror) to face like
 * the student. Does not allocate. [retargeter owner] */
KATA_API kata_status kata_retargeter_place(kata_retargeter retargeter, const float* student,
                                           uint32_t student_joint_count, float* ghost, size_t capacity);
/* Forgets the previous frame: the next solve starts cold (forward-kinematics baseline: the
 * student's bone lengths laid along the teacher's bone directions). Call at a cut in the
 * teacher's motion. [retargeter owner] */
KATA_API kata_status kata_retargeter_reset(kata_retargeter retargeter);

/* ---- The ghost as local rotations (what a game engine animates) ----
 * For a student skeleton with a rest pose (kata_retargeter_create, or _create_for_stream /
 * _create_across on a stream whose skeleton has rest offsets): per joint of the student's whole
 * hierarchy a rotation relative to its parent, and the root's position, whose forward kinematics
 *   G_root = R_root, X_root = root_position;  G_j = G_parent R_j,  X_j = X_parent + G_parent offset_j
 * (offset_j from kata_skeleton_joint_offset; quaternions act on column vectors) put every ghost
 * joint on the ghost's position. Each joint turns its bone onto the ghost's bone with the
 * smallest rotation added to its parent's (a swing; the twist about a bone is the parent's); a
 * joint carrying several bones takes the rotation that best turns all of them (least squares).
 * Exact (to float rounding) when every joint with a bone is a ghost joint and each joint carries
 * at most one bone, branches going through zero-offset joints (a CMU BVH with the "cmu" joint
 * set); where a joint carries several bones (a game rig's hips) they move rigidly, so the ghost is
 * reproduced as closely as a rotation can: *residual says how far. */

/* Joints of the student hierarchy the rotations cover (kata_skeleton_joint_count of the
 * student); 0 when the retargeter has no rest pose to rotate (or NULL). [retargeter owner] */
KATA_API uint32_t kata_retargeter_rotation_joint_count(kata_retargeter retargeter);
/* ghost: a ghost from kata_retargeter_solve (placed or not), ghost_count = 3 x
 * kata_retargeter_joint_count() floats. rotations (rotation_capacity >= 4 x
 * kata_retargeter_rotation_joint_count() floats) receives unit quaternions (x, y, z, w), w >= 0,
 * one per student joint in skeleton order, each relative to its parent (the root's: world);
 * root_position[3] the root's position. positions (may be NULL; 3 x joints floats) receives every
 * joint's forward-kinematics position; residual (may be NULL) the largest distance between a
 * ghost joint and its FK position (student units). KATA_E_STATE without a rest pose;
 * KATA_E_WRONG_JOINT_COUNT, KATA_E_BUFFER_TOO_SMALL, KATA_E_NON_FINITE as for solve. Does not
 * allocate. [retargeter owner] */
KATA_API kata_status kata_retargeter_local_rotations(kata_retargeter retargeter, const float* ghost,
                                                     size_t ghost_count, float* rotations,
                                                     size_t rotation_capacity, float* root_position,
                                                     float* positions, size_t position_capacity,
                                                     double* residual);

#ifdef __cplusplus
}
#endif

#endif /* KATA_RETARGET_H */
