"""The humanoid (VRM) rig (kata/humanoid.h): a layout's joints as the local rotations of the VRM
humanoid bones relative to a T-pose, and the hips' position: what a game engine animates and the
VMC protocol sends, for a student and a stream's ghost.

    with kata.Context() as ctx, ctx.load_clip(path) as clip, clip.skeleton() as sk, \\
         kata.HumanoidRig.create(ctx, sk, layout="cmu") as rig:
        pose = rig.pose(clip.positions(10), frame=kata.HumanoidFrame.UNITY)
        pose.rotation[kata.Bone.LEFT_UPPER_ARM]     # x, y, z, w relative to the T-pose

The header is the manual: what is exact (every placed joint by forward kinematics of the rotations
over the pose's offsets), what is chosen (the twist about a bone the input says nothing of), the
frames (the rig's right-handed Y-up metres; Unity's left-handed mirror)."""
import ctypes
import enum
from typing import Any, List, Optional

import numpy as np

from . import _native as _n
from ._util import _positions_f32, _text, _utf8
from .errors import KataError
from .objects import Context, Skeleton, UpAxis, _Handle

__all__ = ["HumanoidRig", "HumanoidPose", "HumanoidFrame", "Bone", "BONE_COUNT", "BONE_NAMES", "BONE_PARENTS",
           "bone_name", "bone_parent", "bone_find"]

#: The number of VRM bones (KATA_BONE_COUNT).
BONE_COUNT = _n.HUMANOID_BONES


class HumanoidFrame(enum.IntEnum):
    """The axes a pose's numbers are in (kata_humanoid_frame)."""
    RIGHT_HANDED = 0  #: the rig's own: +Y up, right-handed, metres; the T-pose faces +Z
    UNITY = 1         #: Unity's left-handed Y-up (x mirrored), as VMC sends


class Bone(enum.IntEnum):
    """The VRM humanoid bones (kata_humanoid_bone), in the C ABI's order."""
    HIPS = 0
    SPINE = 1
    CHEST = 2
    UPPER_CHEST = 3
    NECK = 4
    HEAD = 5
    LEFT_SHOULDER = 6
    LEFT_UPPER_ARM = 7
    LEFT_LOWER_ARM = 8
    LEFT_HAND = 9
    RIGHT_SHOULDER = 10
    RIGHT_UPPER_ARM = 11
    RIGHT_LOWER_ARM = 12
    RIGHT_HAND = 13
    LEFT_UPPER_LEG = 14
    LEFT_LOWER_LEG = 15
    LEFT_FOOT = 16
    LEFT_TOES = 17
    RIGHT_UPPER_LEG = 18
    RIGHT_LOWER_LEG = 19
    RIGHT_FOOT = 20
    RIGHT_TOES = 21


def bone_name(bone: int) -> Optional[str]:
    """kata_humanoid_bone_name: "Hips", "LeftUpperArm", ... (Unity's HumanBodyBones, as VMC sends);
    None out of range."""
    return _text(_n.humanoid_bone_name(int(bone)))


def bone_parent(bone: int) -> int:
    """kata_humanoid_bone_parent: the VRM parent; -1 for the hips, -2 out of range."""
    return int(_n.humanoid_bone_parent(int(bone)))


def bone_find(name: str) -> int:
    """kata_humanoid_bone_find: the bone named `name` (exact), or -1."""
    return int(_n.humanoid_bone_find(_utf8(name)))


#: Every bone's name, in bone order.
BONE_NAMES: List[str] = [bone_name(b) or "" for b in range(BONE_COUNT)]
#: Every bone's parent (-1 for the hips), in bone order.
BONE_PARENTS: List[int] = [bone_parent(b) for b in range(BONE_COUNT)]


class HumanoidPose:
    """One frame of a humanoid (kata_humanoid_pose), as numpy copies: frame (HumanoidFrame), placed
    and degenerate (bit masks by bone), hips_position (3,), rotation (BONE_COUNT, 4) x y z w local
    rotations relative to the T-pose, offset (BONE_COUNT, 3) each bone joint's offset from its
    parent's in the parent's frame (metres). Forward kinematics of rotation over offset places the
    joints (joints())."""

    def __init__(self, c: "_n.HumanoidPose") -> None:
        self._c = c
        self.frame = HumanoidFrame(c.frame)
        self.placed = int(c.placed)
        self.degenerate = int(c.degenerate)
        self.hips_position = np.array(c.hips_position[:], dtype=np.float32)
        self.rotation = np.ctypeslib.as_array(c.rotation).copy()
        self.offset = np.ctypeslib.as_array(c.offset).copy()

    def is_placed(self, bone: int) -> bool:
        return bool(self.placed >> int(bone) & 1)

    def joints(self) -> np.ndarray:
        """kata_humanoid_pose_joints: every bone joint's position (BONE_COUNT, 3) float32, metres, in
        the pose's frame (an unplaced bone's is its parent's)."""
        out = np.empty((BONE_COUNT, 3), dtype=np.float32)
        status = _n.humanoid_pose_joints(ctypes.byref(self._c), out.ctypes.data, out.size, None, 0)
        if status:
            raise KataError(status, "cannot compute the pose's joints", "kata_humanoid_pose_joints")
        return out

    def converted(self, frame: int) -> "HumanoidPose":
        """kata_humanoid_pose_convert: the same pose in another frame (a mirror through YZ)."""
        c = _n.HumanoidPose()
        ctypes.memmove(ctypes.byref(c), ctypes.byref(self._c), ctypes.sizeof(c))
        status = _n.humanoid_pose_convert(ctypes.byref(c), int(frame))
        if status:
            raise KataError(status, "unknown frame %r" % (frame,), "kata_humanoid_pose_convert")
        return HumanoidPose(c)


def _desc(layout: Optional[str], up_axis: int, metres_per_unit: float) -> "_n.HumanoidDesc":
    d = _n.HumanoidDesc()
    _n.humanoid_desc_init_sized(ctypes.byref(d), ctypes.sizeof(d))
    d.layout = _utf8(layout) if layout is not None else None
    d.up_axis = int(up_axis)
    d.metres_per_unit = float(metres_per_unit)
    return d


class HumanoidRig(_Handle):
    """A layout's joints on the VRM bones with the student's bone lengths (kata_humanoid_rig);
    one thread at a time. Make one with HumanoidRig.create (a skeleton and its layout) or
    HumanoidRig.for_stream (a stream: its layout, and its ghost when a teacher with a ghost is
    attached first)."""
    _release = _n.humanoid_rig_destroy

    @classmethod
    def create(cls, context: Context, skeleton: Skeleton, layout: str = "cmu", up_axis: int = UpAxis.Y,
               metres_per_unit: float = 0.0) -> "HumanoidRig":
        """kata_humanoid_rig_create: frames of `skeleton` read through `layout` (a built-in layout's
        name) in `up_axis`; metres_per_unit 0 takes the layout's (CMU 0.056444, azure-kinect 0.001,
        else 1). A skeleton without a rest pose is measured by calibrate() or the first frame."""
        d = _desc(layout, up_axis, metres_per_unit)
        return context._make(cls, "kata_humanoid_rig_create", _n.humanoid_rig_create, skeleton.handle, ctypes.byref(d))

    @classmethod
    def for_stream(cls, context: Context, stream: Any, metres_per_unit: float = 0.0) -> "HumanoidRig":
        """kata_humanoid_rig_create_for_stream: the stream's skeleton, layout and axes, and its ghost."""
        d = _desc(None, UpAxis.Y, metres_per_unit)
        return context._make(cls, "kata_humanoid_rig_create_for_stream", _n.humanoid_rig_create_for_stream,
                             stream.handle, ctypes.byref(d))

    def _raise(self, status: int, call: str) -> None:
        raise KataError(status, _text(_n.humanoid_rig_last_error(self._h)) or call, call)

    @property
    def joint_count(self) -> int:
        return int(_n.humanoid_rig_joint_count(self.handle))

    @property
    def ghost_joint_count(self) -> int:
        return int(_n.humanoid_rig_ghost_joint_count(self.handle))

    @property
    def placed(self) -> int:
        """The bones the layout places, a bit mask by bone."""
        return int(_n.humanoid_rig_placed(self.handle))

    @property
    def metres_per_unit(self) -> float:
        return float(_n.humanoid_rig_metres_per_unit(self.handle))

    @property
    def calibrated(self) -> bool:
        return bool(_n.humanoid_rig_calibrated(self.handle))

    def bone_source(self, bone: int) -> int:
        """The input joint the bone's joint is, or -1 (synthesised, on another bone's joint, unplaced)."""
        return int(_n.humanoid_rig_bone_source(self.handle, int(bone)))

    def calibrate(self, frames: Any) -> None:
        """kata_humanoid_rig_calibrate: the rest bone lengths as medians over frames (n, joints, 3)."""
        f = np.ascontiguousarray(frames, dtype=np.float32)
        if f.ndim == 2:
            f = f[None]
        if f.ndim != 3 or f.shape[2] != 3:
            raise ValueError("frames must be (n, joints, 3)")
        status = _n.humanoid_rig_calibrate(self.handle, f.ctypes.data, f.shape[1], f.shape[0])
        if status:
            self._raise(status, "kata_humanoid_rig_calibrate")

    def _pose(self, fn: Any, call: str, positions: Any, frame: int) -> HumanoidPose:
        p = _positions_f32(positions)
        c = _n.HumanoidPose()
        c.struct_size = ctypes.sizeof(c)
        status = fn(self.handle, p.ctypes.data, p.size // 3, int(frame), ctypes.byref(c))
        if status:
            self._raise(status, call)
        return HumanoidPose(c)

    def pose(self, positions: Any, frame: int = HumanoidFrame.RIGHT_HANDED) -> HumanoidPose:
        """kata_humanoid_rig_pose: one frame (joints x 3, input units and axes) as a HumanoidPose."""
        return self._pose(_n.humanoid_rig_pose, "kata_humanoid_rig_pose", positions, frame)

    def pose_ghost(self, ghost: Any, frame: int = HumanoidFrame.RIGHT_HANDED) -> HumanoidPose:
        """kata_humanoid_rig_pose_ghost: a ghost of the rig's stream (ghost joints x 3) as a HumanoidPose."""
        return self._pose(_n.humanoid_rig_pose_ghost, "kata_humanoid_rig_pose_ghost", ghost, frame)

    def rest_pose(self, frame: int = HumanoidFrame.RIGHT_HANDED) -> HumanoidPose:
        """kata_humanoid_rig_rest_pose: the T-pose (identity rotations, rest offsets)."""
        c = _n.HumanoidPose()
        c.struct_size = ctypes.sizeof(c)
        status = _n.humanoid_rig_rest_pose(self.handle, int(frame), ctypes.byref(c))
        if status:
            self._raise(status, "kata_humanoid_rig_rest_pose")
        return HumanoidPose(c)
