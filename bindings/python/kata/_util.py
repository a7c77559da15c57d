"""Conversions shared by the modules (not public): bytes <-> str, numpy arrays -> C pointers."""
import ctypes
import warnings
import numpy as np


def _text(b):
    return b.decode("utf-8") if b is not None else None


def _deprecated(old, new):
    warnings.warn("kata.Stream.%s is deprecated since 1.0 and goes in 2.0: use %s" % (old, new),
                  DeprecationWarning, stacklevel=3)


def _utf8(s):
    return None if s is None else (s if isinstance(s, bytes) else str(s).encode("utf-8"))



_addressof = ctypes.addressof
_c_char_from_buffer = ctypes.c_char.from_buffer


def _address(a):
    """The data pointer of a C-contiguous array: 3x cheaper than a.ctypes.data (measured 0.7 vs
    2.0 us), which also fills numpy's ctypes caches; read-only arrays take the slow path."""
    try:
        return _addressof(_c_char_from_buffer(a))
    except (TypeError, ValueError):
        return a.ctypes.data


def _positions_f32(positions, joints=None):
    """positions as a C-contiguous float32 array (no copy when it already is one)."""
    a = np.ascontiguousarray(positions, dtype=np.float32)
    if joints is not None and a.size != 3 * joints:
        raise ValueError("expected %d joints x 3 floats, got %d floats" % (joints, a.size))
    return a


def _time_units_code(units):
    if units == "s":
        return 0  # KATA_TIME_SECONDS
    if units == "ms":
        return 1  # KATA_TIME_MILLISECONDS
    raise ValueError('time_units must be "s" or "ms" (or "auto" for a whole recording), not %r' % (units,))
