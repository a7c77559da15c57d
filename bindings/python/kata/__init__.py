"""kata: real-time 3D human pose: GPD v1 features, a learned score against a teacher, the
teacher's pose retargeted onto the student (the "ghost"), from Python over libkata's C ABI.

    import kata, numpy as np
    teacher = kata.find_data("data/cmu/05_18.bvh")          # a clip kata installs
    with kata.Context() as ctx, ctx.load_model(kata.default_model_path()) as model, \\
         ctx.load_clip(teacher) as clip, clip.skeleton() as skeleton, \\
         ctx.open_stream(skeleton, layout="cmu", stencil=model.stencil) as stream:
        stream.attach_teacher(model, clip=clip, first_frame=1)
        frames = clip.all_positions(1)                       # (n, joints, 3) float32
        r = stream.push_and_read(1 + np.arange(len(frames)) * clip.frame_time, frames)
        print(len(r), r.scores["score"].mean())              # every result: nothing dropped

Modules, whose public names are re-exported here: errors (Status, KataError, the dropped-results
warning), objects (Context, Skeleton, Clip, Model, Landmarks, the enums, find_data), stream
(Stream, Results, gpd_joint_name / gpd_joint_part / body_part_name / gpd_joint_words), retarget
(Retargeter), people (People: identity of unlabeled multi-person poses), messages (Subscriber,
read_message, write_skeleton / write_frame / write_practice), runtime (Runtime), humanoid
(HumanoidRig: the student and the ghost as VRM bone rotations), vmc (vmc_write_pose, VmcReader:
the VMC protocol). Not re-exported: mediapipe
(MediaPipe Pose recordings and live feeds scored against a BVH teacher; `import kata.mediapipe`).
_native holds every ctypes declaration. The C header kata.h is the manual: units, ownership and
thread rules are its.

Results are never lost in silence: a stream keeps result_capacity results (64) until read; a
read after some were overwritten says so (Results.dropped, and a ResultsDroppedWarning by default;
Stream.on_drop = "raise" or "count"). push_and_read reads as it pushes and loses nothing.
Arrays: positions are float32 (joints, 3), passed without a copy when C-contiguous float32.
Errors: a failed C call raises KataError (.status, .message); a wrong argument type, TypeError.
Handles: every object has close() and is a context manager; a Context closes what was made from
it before it is destroyed (kata.h requires that order).
"""
import os

from .errors import KataError, ResultsDroppedError, ResultsDroppedWarning, Status
from .objects import (GPD_DIMS, GPD_JOINTS, BodyPart, Clip, Context, CueAction, Landmarks, Model, ScoreState, Skeleton, Stencil,
                      Teacher, UpAxis,
                      default_model_path, find_data, library_path, layouts, version)
from .stream import (DROP_POLICIES, RESULT_DTYPE, ResultBuffer, Results,
                     ScoreRecord, Stream, body_part_name, cue_text, detect_time_units, gpd_joint_name,
                     gpd_joint_part, gpd_joint_words)
from .retarget import Retargeter
from .messages import (PracticeSection, ResultMessage, Subscriber, read_message, write_frame, write_frame_batch, write_practice,
                       write_skeleton)
from .messages import ROM_JOINTS, Repetition, read_repetition, write_repetition
from .runtime import Runtime, shard_of
from .humanoid import (BONE_COUNT, BONE_NAMES, BONE_PARENTS, Bone, HumanoidFrame, HumanoidPose, HumanoidRig, bone_find,
                       bone_name, bone_parent)
from .people import People, people_stream_id, write_people_frame
from .vmc import VMC_DEFAULT_MAX_PACKET, VMC_JOINTS, VMC_PORT, VmcCounters, VmcReader, vmc_write_pose
from . import mediapipe  # kata.mediapipe after a plain `import kata` (it reads the names above at call time)

#: The loaded libkata's version as "MAJOR.MINOR.PATCH" (the package is versioned with it).
__version__ = "%d.%d.%d" % version

__all__ = ["Context", "Skeleton", "Clip", "Model", "Teacher", "Landmarks", "Stream", "Retargeter", "Runtime", "Subscriber",
           "Results", "ResultBuffer", "ScoreRecord", "ResultMessage", "PracticeSection",
           "KataError", "ResultsDroppedWarning", "ResultsDroppedError", "Status", "Stencil", "UpAxis", "ScoreState",
           "BodyPart", "CueAction", "cue_text", "gpd_joint_name", "gpd_joint_part", "body_part_name",
           "gpd_joint_words", "read_message", "write_skeleton", "write_frame", "write_frame_batch",
           "write_practice", "shard_of", "detect_time_units", "default_model_path", "find_data", "layouts",
           "version", "library_path", "GPD_DIMS", "GPD_JOINTS", "RESULT_DTYPE", "DROP_POLICIES",
           "HumanoidRig", "HumanoidPose", "HumanoidFrame", "Bone", "BONE_COUNT", "BONE_NAMES", "BONE_PARENTS",
           "bone_name", "bone_parent", "bone_find"]
__all__ += ["People", "people_stream_id", "write_people_frame"]
__all__ += ["Repetition", "read_repetition", "write_repetition", "ROM_JOINTS"]
__all__ += ["vmc_write_pose", "VmcReader", "VmcCounters", "VMC_PORT", "VMC_JOINTS", "VMC_DEFAULT_MAX_PACKET"]

# kata.fb: the readers flatc generates from schemas/*.fbs (kata.fb.Result, ...) ship inside the
# installed package; used from a checkout, they are the build's (<repo>/build/python/kata/fb).
if not os.path.isdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), "fb")):
    _build_fb = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..",
                                              "build", "python", "kata"))
    if os.path.isdir(os.path.join(_build_fb, "fb")):
        __path__.append(_build_fb)
del os
