"""ctypes declarations of the C ABI (sdk/include/kata/kata.h), one per C function, and the search
for libkata. Nothing here is Pythonic on purpose: the package's modules (errors,
objects, stream, retarget, messages, runtime) build the objects on top; every C declaration stays
here, in one place.

Library search order (like pylsl): $KATA_LIBRARY (a file), the package folder (a libkata.so
dropped next to this file), the install prefix recorded by `cmake --install` (_install_paths.py),
a build tree above the source package (<repo>/build/lib), then the system loader (ld.so paths).
"""
import ctypes
import ctypes.util
import os
import sys
from typing import Any, Iterator, List, Tuple

# The C ABI major version this binding is written against (kata.h KATA_VERSION_MAJOR), and the
# oldest minor that has every function declared below (1.1: the message writers, the joint and
# part vocabulary, direct ingest, landmark recordings).
EXPECTED_MAJOR = 1
MINIMUM_MINOR = 1

GPD_DIMS = 1683
GPD_JOINTS = 16
PART_COUNT = 5

c_float_p = ctypes.POINTER(ctypes.c_float)

#: kata_progress_callback (kata/teacher.h, 1.1): (user, done, frames) as a teacher loads.
ProgressCallback = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_uint32, ctypes.c_uint32)


def _library_file_names() -> List[str]:
    if sys.platform == "win32":
        return ["kata.dll"]
    if sys.platform == "darwin":
        return ["libkata.dylib"]
    return ["libkata.so", "libkata.so.%d" % EXPECTED_MAJOR]


def _candidates() -> Iterator[Tuple[str, str]]:
    """Where libkata is looked for, in order, as (how it was found, path)."""
    env = os.environ.get("KATA_LIBRARY")
    if env:
        yield "KATA_LIBRARY", env
        return  # an explicit choice is never silently replaced by another library
    here = os.path.dirname(os.path.abspath(__file__))
    for name in _library_file_names():
        yield "package folder", os.path.join(here, name)
    try:
        from . import _install_paths  # type: ignore[attr-defined]  # written by `cmake --install`
        for name in _library_file_names():
            yield "install prefix", os.path.normpath(os.path.join(here, _install_paths.LIBDIR_FROM_PACKAGE, name))
    except ImportError:
        pass
    # Used from a source checkout: bindings/python/kata -> <repo>/build/lib.
    repo = os.path.normpath(os.path.join(here, "..", "..", ".."))
    for name in _library_file_names():
        yield "build tree", os.path.join(repo, "build", "lib", name)
    found = ctypes.util.find_library("kata")
    if found:
        yield "system", found


def _open_library() -> Tuple[ctypes.CDLL, str, str]:
    tried = []
    for how, path in _candidates():
        if how != "system" and not os.path.exists(path):
            tried.append(path)
            continue
        try:
            return ctypes.CDLL(path), path, how
        except OSError as e:
            tried.append("%s (%s)" % (path, e))
    raise ImportError("kata: libkata not found; set KATA_LIBRARY to its path. Tried: " + "; ".join(tried))


lib, library_path, found_by = _open_library()


def _check_version() -> Tuple[int, int, int]:
    lib.kata_version.restype = ctypes.c_uint32
    lib.kata_version.argtypes = []
    v = lib.kata_version()
    major, minor, patch = v // 10000, (v // 100) % 100, v % 100
    if major != EXPECTED_MAJOR or minor < MINIMUM_MINOR:
        raise ImportError("kata: %s is version %d.%d.%d; this binding needs %d.x with x >= %d "
                          "(major versions differ in their ABI). Point KATA_LIBRARY at a matching libkata."
                          % (library_path, major, minor, patch, EXPECTED_MAJOR, MINIMUM_MINOR))
    return major, minor, patch


version = _check_version()


# ---- structs (layouts as in kata.h; struct_size is set from ctypes.sizeof) ----------------------

class StreamDesc(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("layout", ctypes.c_char_p), ("name_map_path", ctypes.c_char_p),
                ("stencil", ctypes.c_int), ("up_axis", ctypes.c_int), ("max_gap", ctypes.c_double),
                ("history_capacity", ctypes.c_uint32), ("body_height", ctypes.c_double),
                ("calibration_frames", ctypes.c_uint32), ("result_capacity", ctypes.c_uint32),
                ("keep_features", ctypes.c_int32)]


class RetargetDesc(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("joint_set", ctypes.c_char_p), ("gradient_tolerance", ctypes.c_double),
                ("max_iterations", ctypes.c_uint32), ("warm_start", ctypes.c_int32),
                ("restore_bone_lengths", ctypes.c_int32)]


class RetargetInfo(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("iterations", ctypes.c_uint32), ("converged", ctypes.c_int32),
                ("warm", ctypes.c_int32), ("stress", ctypes.c_double), ("max_bone_error_solved", ctypes.c_double),
                ("max_bone_error", ctypes.c_double)]


class TeacherDesc(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("model", ctypes.c_void_p), ("clip", ctypes.c_void_p),
                ("skeleton", ctypes.c_void_p), ("positions", ctypes.c_void_p), ("frames", ctypes.c_uint32),
                ("frame_time", ctypes.c_double), ("layout", ctypes.c_char_p), ("first_frame", ctypes.c_uint32),
                ("pose_frame", ctypes.c_int32), ("ghost", ctypes.c_int32),
                ("retarget", ctypes.POINTER(RetargetDesc)),
                ("features", ctypes.c_void_p), ("joints", ctypes.c_void_p), ("body_height", ctypes.c_double),
                # 1.1
                ("ghost_across", ctypes.c_int32), ("alignment_window", ctypes.c_double),
                ("on_progress", ProgressCallback), ("on_progress_user", ctypes.c_void_p),
                # 1.1
                ("tolerance", ctypes.c_char_p)]


class PeopleDesc(ctypes.Structure):
    """kata_people_desc (kata/people.h, 1.1)."""
    _fields_ = [("struct_size", ctypes.c_uint32), ("joint_count", ctypes.c_uint32), ("max_people", ctypes.c_uint32),
                ("max_poses", ctypes.c_uint32), ("forget_seconds", ctypes.c_double), ("coast_seconds", ctypes.c_double),
                ("gate", ctypes.c_double), ("gate_growth", ctypes.c_double), ("size_gate", ctypes.c_double),
                ("shape_weight", ctypes.c_double), ("min_confidence", ctypes.c_double)]


class PeopleFrameMessage(ctypes.Structure):
    """kata_people_frame_message (kata/people.h, 1.1)."""
    _fields_ = [("struct_size", ctypes.c_uint32), ("joint_count", ctypes.c_uint32), ("stream_id", ctypes.c_uint64),
                ("sequence", ctypes.c_uint64), ("capture_time", ctypes.c_double), ("pose_count", ctypes.c_uint32),
                ("reserved", ctypes.c_uint32), ("positions", ctypes.c_void_p), ("confidences", ctypes.c_void_p)]


class PeopleCounters(ctypes.Structure):
    """kata_people_counters (kata/people.h, 1.1)."""
    _fields_ = [("struct_size", ctypes.c_uint32), ("open_streams", ctypes.c_uint32)] + [
        (name, ctypes.c_uint64) for name in (
            "frames", "empty_frames", "refused_frames", "poses", "assigned", "opened", "closed",
            "refused_non_finite", "refused_out_of_range", "refused_few_joints", "refused_too_many_poses",
            "refused_table_full")]


class ResultRecord(ctypes.Structure):
    """kata_result_record (kata/result.h): every result a stream, a message or a plugin gives."""
    _fields_ = [("struct_size", ctypes.c_uint32), ("scored", ctypes.c_int32),
                ("stream_id", ctypes.c_uint64), ("result_sequence", ctypes.c_uint64),
                ("frame_sequence", ctypes.c_uint64), ("frame_index", ctypes.c_int64),
                ("capture_time", ctypes.c_double), ("arrival_ns", ctypes.c_int64), ("computed_ns", ctypes.c_int64),
                ("published_ns", ctypes.c_int64), ("matched_teacher_frame", ctypes.c_int32),
                ("state", ctypes.c_int32), ("matched_teacher_time", ctypes.c_double),
                ("distance", ctypes.c_float), ("score", ctypes.c_float), ("parts", ctypes.c_float * PART_COUNT),
                ("part_scores", ctypes.c_float * PART_COUNT), ("part_to_fix", ctypes.c_int32),
                ("ghost_joint_count", ctypes.c_uint32),
                # const float* ghost, as an address: numpy dtypes take no ctypes pointer
                ("ghost", ctypes.c_size_t),
                ("has_practice", ctypes.c_int32), ("practice_revision", ctypes.c_uint32),
                ("practice_start_time", ctypes.c_double), ("practice_end_time", ctypes.c_double),
                ("practice_loop", ctypes.c_int32), ("reserved0", ctypes.c_uint32),
                # added with the correction cue (after reserved0) (kata.h "Score calibration and feedback")
                ("cue_joint", ctypes.c_int32), ("cue_degrees", ctypes.c_float), ("cue_action", ctypes.c_int32),
                ("reserved1", ctypes.c_uint32),
                # 1.1: repetitions
                ("repetition", ctypes.c_int32), ("repetition_progress", ctypes.c_float)]


ROM_JOINT_COUNT = 8


class Repetition(ctypes.Structure):
    """kata_repetition (kata/result.h, 1.1): one repetition of the teacher's section."""
    _fields_ = [("struct_size", ctypes.c_uint32), ("index", ctypes.c_int32), ("stream_id", ctypes.c_uint64),
                ("start_time", ctypes.c_double), ("end_time", ctypes.c_double), ("tempo", ctypes.c_double),
                ("score", ctypes.c_float), ("partial", ctypes.c_int32), ("part_to_fix", ctypes.c_int32),
                ("cue_joint", ctypes.c_int32), ("cue_degrees", ctypes.c_float), ("cue_action", ctypes.c_int32),
                ("range", ctypes.c_float * ROM_JOINT_COUNT), ("teacher_range", ctypes.c_float * ROM_JOINT_COUNT),
                ("coverage", ctypes.c_float), ("reserved0", ctypes.c_uint32)]


class RuntimeDesc(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("workers", ctypes.c_uint32), ("max_streams", ctypes.c_uint32),
                ("max_joints", ctypes.c_uint32), ("queue_capacity", ctypes.c_uint32),
                ("publish_endpoints", ctypes.c_char_p), ("send_hwm", ctypes.c_int32),
                ("ingest_endpoints", ctypes.c_char_p), ("ingest_pull", ctypes.c_int32),
                ("max_message_bytes", ctypes.c_uint32), ("skeleton_resend_seconds", ctypes.c_double),
                # since 1.0 (kata.h: who may send what). Filled by kata_runtime_desc_init_sized
                # with this struct's own size: the library writes nothing past it.
                ("key_file", ctypes.c_char_p), ("client_keys_dir", ctypes.c_char_p),
                ("ingest_server_key_file", ctypes.c_char_p), ("max_streams_per_sender", ctypes.c_uint32),
                ("max_connections", ctypes.c_uint32), ("max_frame_age_seconds", ctypes.c_double),
                ("idle_stream_seconds", ctypes.c_double),
                # 1.1: on_result (a kata_result_callback, left NULL here) and its user, direct_ingest
                ("on_result", ctypes.c_void_p), ("on_result_user", ctypes.c_void_p),
                ("direct_ingest", ctypes.c_int32),
                # 1.1: on_stream_open (a kata_stream_open_callback) and its user, stream_stencil
                ("on_stream_open", ctypes.c_void_p), ("on_stream_open_user", ctypes.c_void_p),
                ("stream_stencil", ctypes.c_int)]


class StreamOpenInfo(ctypes.Structure):
    """kata_stream_open_info (since 1.1): what a skeleton definition says of the stream it opens."""
    _fields_ = [("struct_size", ctypes.c_uint32), ("joint_count", ctypes.c_uint32), ("stream_id", ctypes.c_uint64),
                ("revision", ctypes.c_uint32), ("has_rest_pose", ctypes.c_int32), ("layout", ctypes.c_char_p),
                ("frame_rate", ctypes.c_double), ("skeleton", ctypes.c_void_p)]


#: kata_stream_open_callback (kata/runtime.h, 1.1): (user, info, stream) -> kata_status.
StreamOpenCallback = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.POINTER(StreamOpenInfo), ctypes.c_void_p)


class RuntimeCounters(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("streams", ctypes.c_uint32)] + [
        (name, ctypes.c_uint64) for name in ("frames_in", "queue_full", "refused", "results", "results_dropped",
                                             "published", "ingest_received", "ingest_dropped",
                                             "ingest_sequence_gaps", "ingest_restarts",
                                             # since 1.0: who may send what, then practice messages
                                             "ingest_not_owner", "ingest_refused_limit", "ingest_out_of_window",
                                             "ingest_stale", "closed_streams", "ingest_practices",
                                             "ingest_practice_bad_values", "ingest_practice_outside_clip",
                                             "ingest_practice_no_clip", "ingest_practice_queue_full",
                                             # since 1.1
                                             "streams_refused_by_app", "ingest_frames", "ingest_skeletons",
                                             "ingest_repeated_skeletons", "ingest_closes",
                                             "ingest_repeated_practices", "ingest_other_shard", "ingest_batches",
                                             "ingest_batch_frames", "ingest_malformed", "ingest_refused_skeletons",
                                             "ingest_unknown_stream", "ingest_wrong_joint_count",
                                             "ingest_out_of_order", "ingest_other_kind", "ingest_connections",
                                             "ingest_disconnections", "ingest_connections_refused",
                                             "ingest_handshake_failures", "ingest_last_handshake_error",
                                             "pipeline_dropped", "result_queue_full", "send_failed",
                                             # since 1.1: people frames (kata/people.h)
                                             "people_frames", "people_empty_frames", "people_refused_frames",
                                             "people_poses", "people_poses_tracked", "people_refused_non_finite",
                                             "people_refused_out_of_range", "people_refused_few_joints",
                                             "people_refused_too_many_poses", "people_refused_table_full",
                                             "people_streams_opened", "people_streams_closed",
                                             "people_streams_refused", "people_poses_unopened")]


class SkeletonMessage(ctypes.Structure):
    """kata_skeleton_message (since 1.1): a stream's skeleton definition for kata_message_write_skeleton."""
    _fields_ = [("struct_size", ctypes.c_uint32), ("revision", ctypes.c_uint32), ("stream_id", ctypes.c_uint64),
                ("skeleton", ctypes.c_void_p), ("layout", ctypes.c_char_p), ("name_map", ctypes.POINTER(ctypes.c_char_p)),
                ("up_axis", ctypes.c_int), ("metres_per_unit", ctypes.c_float), ("frame_rate", ctypes.c_float),
                ("closed", ctypes.c_int32)]


class FrameMessage(ctypes.Structure):
    """kata_frame_message (since 1.1): one frame for kata_message_write_frame."""
    _fields_ = [("struct_size", ctypes.c_uint32), ("joint_count", ctypes.c_uint32), ("stream_id", ctypes.c_uint64),
                ("sequence", ctypes.c_uint64), ("capture_time", ctypes.c_double), ("positions", ctypes.c_void_p),
                ("confidences", ctypes.c_void_p), ("presences", ctypes.c_void_p)]


class PracticeMessage(ctypes.Structure):
    """kata_practice_message (since 1.1): a practice setting for kata_message_write_practice."""
    _fields_ = [("struct_size", ctypes.c_uint32), ("revision", ctypes.c_uint32), ("stream_id", ctypes.c_uint64),
                ("teacher_start", ctypes.c_double), ("loop", ctypes.c_int32), ("loop_start", ctypes.c_double),
                ("loop_end", ctypes.c_double)]


class HumanoidDesc(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("layout", ctypes.c_char_p), ("up_axis", ctypes.c_int),
                ("metres_per_unit", ctypes.c_double)]


HUMANOID_BONES = 22  # KATA_BONE_COUNT


class HumanoidPose(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("placed", ctypes.c_uint32), ("frame", ctypes.c_int32),
                ("hips_position", ctypes.c_float * 3), ("rotation", (ctypes.c_float * 4) * HUMANOID_BONES),
                ("offset", (ctypes.c_float * 3) * HUMANOID_BONES), ("degenerate", ctypes.c_uint32),
                ("reserved", ctypes.c_uint32)]


class VmcCounters(ctypes.Structure):
    """kata_vmc_counters (kata/vmc.h, 1.1)."""
    _fields_ = [("struct_size", ctypes.c_uint32), ("reserved", ctypes.c_uint32)] + [
        (name, ctypes.c_uint64) for name in (
            "packets", "frames", "malformed", "oversized", "wrong_type", "unknown_bone", "bad_value",
            "out_of_order", "ignored")]


VMC_JOINTS = 22  # KATA_VMC_JOINTS


# ---- functions -------------------------------------------------------------------------------------

_u32, _i32, _i64, _u64 = ctypes.c_uint32, ctypes.c_int32, ctypes.c_int64, ctypes.c_uint64
_p, _s, _d, _sz, _st = ctypes.c_void_p, ctypes.c_char_p, ctypes.c_double, ctypes.c_size_t, ctypes.c_int
_pp = ctypes.POINTER(ctypes.c_void_p)

_SIGNATURES = {
    # name: (restype, argtypes)
    "kata_status_string": (_s, [_st]),
    "kata_context_create": (_st, [_pp]),
    "kata_context_destroy": (None, [_p]),
    "kata_context_last_error": (_s, [_p]),
    "kata_skeleton_create": (_st, [_p, _u32, ctypes.POINTER(_s), _p, _p, _pp]),
    "kata_skeleton_load_bvh": (_st, [_p, _s, _pp]),
    "kata_skeleton_destroy": (None, [_p]),
    "kata_skeleton_joint_count": (_u32, [_p]),
    "kata_skeleton_joint_name": (_s, [_p, _u32]),
    "kata_skeleton_joint_parent": (_i32, [_p, _u32]),
    "kata_clip_load_bvh": (_st, [_p, _s, _pp]),
    "kata_clip_destroy": (None, [_p]),
    "kata_clip_frame_count": (_u32, [_p]),
    "kata_clip_frame_time": (_d, [_p]),
    "kata_clip_skeleton": (_st, [_p, _pp]),
    "kata_clip_positions": (_st, [_p, _u32, _p, _sz]),
    "kata_stream_desc_init_sized": (None, [ctypes.POINTER(StreamDesc), _u32]),
    "kata_stream_open": (_st, [_p, _p, ctypes.POINTER(StreamDesc), _pp]),
    "kata_stream_destroy": (None, [_p]),
    "kata_stream_last_error": (_s, [_p]),
    "kata_stream_push": (_st, [_p, _d, _p, _u32]),
    "kata_stream_push_many": (_st, [_p, _p, _p, _p, _u32, _u32, ctypes.POINTER(_u32), ctypes.POINTER(_u32)]),
    "kata_stream_push_landmarks": (_st, [_p, _d, ctypes.c_int, _p, _u32, _u32]),
    "kata_time_units_detect": (_st, [_p, _sz, ctypes.POINTER(ctypes.c_int)]),
    "kata_stream_flush": (_st, [_p]),
    "kata_stream_reset": (_st, [_p]),
    "kata_stream_features": (_st, [_p, _p, _sz, ctypes.POINTER(_d), ctypes.POINTER(_i64)]),
    "kata_stream_feature_count": (_i64, [_p]),
    "kata_stream_body_height": (_d, [_p]),
    "kata_model_load": (_st, [_p, _s, _pp]),
    "kata_model_load_memory": (_st, [_p, _p, _sz, _pp]),
    "kata_model_destroy": (None, [_p]),
    "kata_model_rank": (_u32, [_p]),
    "kata_model_delta_star": (_d, [_p]),
    "kata_model_stencil": (_st, [_p]),
    "kata_model_metadata": (_s, [_p, _s]),
    "kata_retarget_desc_init_sized": (None, [ctypes.POINTER(RetargetDesc), _u32]),
    "kata_retargeter_create": (_st, [_p, _p, ctypes.POINTER(RetargetDesc), _pp]),
    "kata_retargeter_create_for_stream": (_st, [_p, _p, ctypes.POINTER(RetargetDesc), _pp]),
    "kata_retargeter_destroy": (None, [_p]),
    "kata_retargeter_last_error": (_s, [_p]),
    "kata_retargeter_joint_count": (_u32, [_p]),
    "kata_retargeter_joint_source": (_i32, [_p, _u32]),
    "kata_retargeter_solve": (_st, [_p, _p, _u32, _p, _sz, ctypes.POINTER(RetargetInfo)]),
    "kata_retargeter_place": (_st, [_p, _p, _u32, _p, _sz]),
    "kata_retargeter_reset": (_st, [_p]),
    "kata_teacher_desc_init_sized": (None, [ctypes.POINTER(TeacherDesc), _u32]),
    "kata_stream_attach_teacher": (_st, [_p, ctypes.POINTER(TeacherDesc)]),
    "kata_teacher_create": (_st, [_p, ctypes.POINTER(TeacherDesc), _pp]),
    "kata_teacher_destroy": (None, [_p]),
    "kata_teacher_frame_count": (_u32, [_p]),
    "kata_teacher_frame_time": (_d, [_p]),
    "kata_teacher_memory_bytes": (_u64, [_p]),
    "kata_stream_attach_shared_teacher": (_st, [_p, _p, ctypes.POINTER(TeacherDesc)]),
    "kata_stream_detach_teacher": (_st, [_p]),
    "kata_stream_restart_teacher": (_st, [_p]),
    "kata_stream_read_newest": (_st, [_p, _p, _p, _sz, _p, _sz]),
    "kata_stream_read_results": (_st, [_p, _p, _p, _sz, _p, _sz, _u32, ctypes.POINTER(_u32)]),
    "kata_stream_results_dropped": (_u64, [_p]),
    "kata_stream_results_pending": (_u32, [_p]),
    "kata_stream_ghost_joint_count": (_u32, [_p]),
    "kata_stream_ghost_joint_source": (_i32, [_p, _u32]),
    # layouts, confidence, smoothing, bone lengths
    "kata_layout_name": (_s, [_u32]),
    "kata_skeleton_create_layout": (_st, [_p, _s, _pp]),
    "kata_skeleton_joint_offset": (_st, [_p, _u32, ctypes.POINTER(_d)]),
    "kata_stream_open_name_map": (_st, [_p, _p, ctypes.POINTER(StreamDesc), _s, _pp]),
    "kata_stream_push_confidence": (_st, [_p, _d, _p, _p, _u32]),
    "kata_stream_set_confidence_gate": (_st, [_p, ctypes.c_float, _d, _d]),
    "kata_stream_set_smoothing": (_st, [_p, _i32, _d, _d, _d]),
    "kata_stream_lost_frames": (_i64, [_p]),
    "kata_stream_bone_lengths": (_st, [_p, _p, _p, _sz]),
    # local rotations
    "kata_retargeter_rotation_joint_count": (_u32, [_p]),
    "kata_retargeter_local_rotations": (_st, [_p, _p, _sz, _p, _sz, _p, _p, _sz, ctypes.POINTER(_d)]),
    # messages
    "kata_message_read_result": (_st, [_p, _sz, ctypes.POINTER(ResultRecord)]),
    # since 1.1: repetitions
    "kata_message_read_repetition": (_st, [_p, _sz, ctypes.POINTER(Repetition)]),
    "kata_message_write_repetition": (_st, [ctypes.POINTER(Repetition), _p, _sz, ctypes.POINTER(_sz)]),
    "kata_stream_read_repetitions": (_st, [_p, ctypes.POINTER(Repetition), _u32, ctypes.POINTER(_u32)]),
    "kata_stream_set_practice_section": (_st, [_p, _i32, _i32, _i32]),
    "kata_message_read_refusal": (_st, [_p, _sz, ctypes.POINTER(ctypes.c_uint64), _p, _sz]),  # 1.1
    # since 1.1: the ingest message writers
    "kata_skeleton_message_init_sized": (None, [ctypes.POINTER(SkeletonMessage), _u32]),
    "kata_frame_message_init_sized": (None, [ctypes.POINTER(FrameMessage), _u32]),
    "kata_practice_message_init_sized": (None, [ctypes.POINTER(PracticeMessage), _u32]),
    "kata_message_write_skeleton": (_st, [ctypes.POINTER(SkeletonMessage), _p, _sz, ctypes.POINTER(_sz)]),
    "kata_message_write_frame": (_st, [ctypes.POINTER(FrameMessage), _p, _sz, ctypes.POINTER(_sz)]),
    "kata_message_write_frame_batch": (_st, [ctypes.POINTER(ctypes.POINTER(FrameMessage)), _sz, _p, _sz, ctypes.POINTER(_sz)]),
    "kata_message_write_practice": (_st, [ctypes.POINTER(PracticeMessage), _p, _sz, ctypes.POINTER(_sz)]),
    "kata_shard_of": (_u32, [_u64, _u32]),
    # the runtime
    "kata_runtime_desc_init_sized": (None, [ctypes.POINTER(RuntimeDesc), _u32]),
    "kata_runtime_create": (_st, [_p, ctypes.POINTER(RuntimeDesc), _pp]),
    "kata_runtime_destroy": (None, [_p]),
    "kata_runtime_add_stream": (_st, [_p, _u64, _pp, _s, _i32]),
    "kata_runtime_push": (_st, [_p, _u64, _u64, _d, _p, _u32]),
    "kata_runtime_push_confidence": (_st, [_p, _u64, _u64, _d, _p, _p, _u32]),
    "kata_runtime_stop": (_st, [_p]),
    "kata_runtime_set_practice": (_st, [_p, _u64, _u32, _d, _i32, _d, _d]),
    "kata_runtime_get_counters": (_st, [_p, ctypes.POINTER(RuntimeCounters)]),
    "kata_runtime_publish_endpoint": (_s, [_p]),
    "kata_runtime_ingest_endpoint": (_s, [_p]),
    # the correction cue
    "kata_gpd_joint_name": (_s, [_i32]),
    "kata_cue_text": (_sz, [ctypes.POINTER(ResultRecord), _p, _sz]),
    # since 1.1: the vocabulary of joints and parts, a runtime's latency and direct ingest
    "kata_stream_gpd_joint_source": (_i32, [_p, _u32]),
    "kata_gpd_joint_part": (_i32, [_i32]),
    "kata_body_part_name": (_s, [_i32]),
    "kata_gpd_joint_words": (_s, [_i32]),
    "kata_runtime_latency_percentile": (_d, [_p, _d]),
    "kata_runtime_offer": (_st, [_p, _p, _sz]),
    # since 1.1: landmark recordings
    "kata_landmarks_load": (_st, [_p, _s, _s, _d, _i32, _pp]),
    "kata_landmarks_destroy": (None, [_p]),
    "kata_landmarks_frame_count": (_u32, [_p]),
    "kata_landmarks_joint_count": (_u32, [_p]),
    "kata_landmarks_frame_time": (_d, [_p]),
    "kata_landmarks_capture_time": (_d, [_p, _u32]),
    "kata_landmarks_positions": (_p, [_p]),
    # the humanoid (VRM) rig, kata/humanoid.h
    "kata_humanoid_bone_name": (_s, [ctypes.c_int]),
    "kata_humanoid_bone_find": (ctypes.c_int, [_s]),
    "kata_humanoid_bone_parent": (ctypes.c_int, [ctypes.c_int]),
    "kata_humanoid_desc_init_sized": (None, [ctypes.POINTER(HumanoidDesc), _u32]),
    "kata_humanoid_rig_create": (_st, [_p, _p, ctypes.POINTER(HumanoidDesc), _pp]),
    "kata_humanoid_rig_create_for_stream": (_st, [_p, _p, ctypes.POINTER(HumanoidDesc), _pp]),
    "kata_humanoid_rig_destroy": (None, [_p]),
    "kata_humanoid_rig_last_error": (_s, [_p]),
    "kata_humanoid_rig_joint_count": (_u32, [_p]),
    "kata_humanoid_rig_ghost_joint_count": (_u32, [_p]),
    "kata_humanoid_rig_placed": (_u32, [_p]),
    "kata_humanoid_rig_metres_per_unit": (_d, [_p]),
    "kata_humanoid_rig_bone_source": (_i32, [_p, _i32]),
    "kata_humanoid_rig_calibrate": (_st, [_p, _p, _u32, _u32]),
    "kata_humanoid_rig_calibrated": (_i32, [_p]),
    "kata_humanoid_rig_rest_pose": (_st, [_p, _i32, ctypes.POINTER(HumanoidPose)]),
    "kata_humanoid_rig_pose": (_st, [_p, _p, _u32, _i32, ctypes.POINTER(HumanoidPose)]),
    "kata_humanoid_rig_pose_ghost": (_st, [_p, _p, _u32, _i32, ctypes.POINTER(HumanoidPose)]),
    "kata_humanoid_pose_convert": (_st, [ctypes.POINTER(HumanoidPose), _i32]),
    "kata_humanoid_pose_joints": (_st, [ctypes.POINTER(HumanoidPose), _p, _sz, _p, _sz]),
    # since 1.1: the people tracker
    "kata_people_desc_init_sized": (None, [ctypes.POINTER(PeopleDesc), _u32]),
    "kata_people_create": (_st, [_p, ctypes.POINTER(PeopleDesc), _pp]),
    "kata_people_destroy": (None, [_p]),
    "kata_people_last_error": (_s, [_p]),
    "kata_people_track": (_st, [_p, _d, _p, _p, _u32, _p, _sz]),
    "kata_people_opened": (_st, [_p, _p, _sz, ctypes.POINTER(_u32)]),
    "kata_people_closed": (_st, [_p, _p, _sz, ctypes.POINTER(_u32)]),
    "kata_people_streams": (_st, [_p, _p, _sz, ctypes.POINTER(_u32)]),
    "kata_people_predicted": (_st, [_p, _u32, _d, _p]),
    "kata_people_get_counters": (_st, [_p, ctypes.POINTER(PeopleCounters)]),
    "kata_people_frame_message_init_sized": (None, [ctypes.POINTER(PeopleFrameMessage), _u32]),
    "kata_message_write_people_frame": (_st, [ctypes.POINTER(PeopleFrameMessage), _p, _sz, ctypes.POINTER(_sz)]),
    "kata_people_stream_id": (_u64, [_u64, _u32]),
    # since 1.1: the VMC protocol, kata/vmc.h
    "kata_vmc_write_pose": (_st, [ctypes.POINTER(HumanoidPose), _d, ctypes.c_float, _p, _sz, ctypes.POINTER(_sz)]),
    "kata_vmc_reader_create": (_st, [_p, _u32, _pp]),
    "kata_vmc_reader_destroy": (None, [_p]),
    "kata_vmc_reader_read": (_st, [_p, _p, _sz, _d, ctypes.POINTER(_i32)]),
    "kata_vmc_reader_positions": (_st, [_p, _p, _sz, ctypes.POINTER(_d)]),
    "kata_vmc_reader_get_counters": (_st, [_p, ctypes.POINTER(VmcCounters)]),
    "kata_vmc_reader_last_error": (_s, [_p]),
}

for _name, (_restype, _argtypes) in _SIGNATURES.items():
    _f = getattr(lib, _name)
    _f.restype = _restype
    _f.argtypes = _argtypes
    globals()[_name[len("kata_"):]] = _f


def cue_phrase(rec: ResultRecord) -> str:
    """kata_cue_text of a record: "left knee: bend 30 deg more", "" without a cue."""
    buf = ctypes.create_string_buffer(64)
    globals()["cue_text"](ctypes.byref(rec), buf, len(buf))  # set by the loop above
    return buf.value.decode("utf-8", "replace")


def __getattr__(name: str) -> Any:
    """For type checkers: every C function above is set in globals() by the loop, so a name that
    reaches here is not one (PEP 562)."""
    raise AttributeError("kata._native has no C function %r" % name)
