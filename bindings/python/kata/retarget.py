"""Retargeting (kata_retargeter): a teacher frame solved onto a student's skeleton (the ghost)."""
import ctypes
from typing import Any, Dict, NoReturn, Optional, Tuple

import numpy as np

from . import _native as _n
from ._util import _positions_f32, _text, _utf8
from .errors import KataError
from .objects import _Handle

__all__ = ["Retargeter"]


def _retarget_desc(options: Dict[str, Any]) -> "_n.RetargetDesc":
    d = _n.RetargetDesc()
    _n.retarget_desc_init_sized(ctypes.byref(d), ctypes.sizeof(d))
    for key, value in options.items():
        if key not in ("joint_set", "gradient_tolerance", "max_iterations", "warm_start", "restore_bone_lengths"):
            raise TypeError("unknown retarget option %r" % key)
        setattr(d, key, _utf8(value) if key == "joint_set" else (int(value) if key != "gradient_tolerance" else value))
    return d



class Retargeter(_Handle):
    """Per-student retargeting state (kata_retargeter); one thread at a time."""
    _release = _n.retargeter_destroy
    _student_joints = 0

    def _raise(self, status: int, call: str) -> NoReturn:
        raise KataError(status, _text(_n.retargeter_last_error(self._h)), call)

    @property
    def joint_count(self) -> int:
        return _n.retargeter_joint_count(self.handle)

    @property
    def joint_sources(self) -> np.ndarray:
        h = self.handle
        return np.array([_n.retargeter_joint_source(h, i) for i in range(_n.retargeter_joint_count(h))],
                        dtype=np.int32)

    def solve(self, teacher: Any, out: Optional[np.ndarray] = None) -> Tuple[np.ndarray, Dict[str, Any]]:
        """kata_retargeter_solve: one teacher frame (skeleton joints x 3) -> (ghost (joint_count, 3)
        float32, info dict)."""
        t = _positions_f32(teacher)
        if out is None:
            out = np.empty((self.joint_count, 3), dtype=np.float32)
        info = _n.RetargetInfo()
        info.struct_size = ctypes.sizeof(info)
        status = _n.retargeter_solve(self.handle, t.ctypes.data, t.size // 3, out.ctypes.data, out.size,
                                     ctypes.byref(info))
        if status:
            self._raise(status, "kata_retargeter_solve")
        return out, {name: getattr(info, name) for name, _ in _n.RetargetInfo._fields_[1:]}

    def place(self, student: Any, ghost: np.ndarray) -> np.ndarray:
        """kata_retargeter_place: moves ghost (in place) over the student's posture."""
        s = _positions_f32(student)
        if ghost.dtype != np.float32 or not ghost.flags.c_contiguous:
            raise ValueError("ghost must be a C-contiguous float32 array (from solve)")
        status = _n.retargeter_place(self.handle, s.ctypes.data, s.size // 3, ghost.ctypes.data, ghost.size)
        if status:
            self._raise(status, "kata_retargeter_place")
        return ghost

    @property
    def rotation_joint_count(self) -> int:
        """Joints the local rotations cover (the student skeleton's); 0 without a rest pose."""
        return int(_n.retargeter_rotation_joint_count(self.handle))

    def local_rotations(self, ghost: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """kata_retargeter_local_rotations: the ghost (from solve) as what a game engine animates:
        (rotations (J, 4) float32 unit quaternions x, y, z, w (w >= 0), each relative to its parent,
        the root's world; root_position (3,); positions (J, 3), every joint's forward kinematics;
        residual, the largest ghost-to-FK distance, student units). J = rotation_joint_count.
        E_STATE without a rest pose. [retargeter owner]"""
        g = _positions_f32(ghost)
        j = self.rotation_joint_count
        rotations = np.empty((j, 4), dtype=np.float32)
        root = np.empty(3, dtype=np.float32)
        positions = np.empty((j, 3), dtype=np.float32)
        residual = ctypes.c_double()
        status = _n.retargeter_local_rotations(self.handle, g.ctypes.data, g.size, rotations.ctypes.data,
                                               rotations.size, root.ctypes.data, positions.ctypes.data,
                                               positions.size, ctypes.byref(residual))
        if status:
            self._raise(status, "kata_retargeter_local_rotations")
        return rotations, root, positions, residual.value

    def reset(self) -> None:
        status = _n.retargeter_reset(self.handle)
        if status:
            self._raise(status, "kata_retargeter_reset")
