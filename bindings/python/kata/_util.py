"""Conversions shared by the modules (not public): bytes <-> str, numpy arrays -> C pointers."""
import ctypes
import functools
import inspect
import numbers
import typing
import warnings
from typing import Any, Callable, Dict, Optional, Tuple, TypeVar
import numpy as np


def _text(b: Optional[bytes]) -> Optional[str]:
    return b.decode("utf-8", "replace") if b is not None else None  # a message is never lost to its bytes


def _utf8(s: Any) -> Optional[bytes]:
    return None if s is None else (s if isinstance(s, bytes) else str(s).encode("utf-8"))



_addressof = ctypes.addressof
_c_char_from_buffer = ctypes.c_char.from_buffer


def _address(a: np.ndarray) -> int:
    """The data pointer of a C-contiguous array: 3x cheaper than a.ctypes.data (measured 0.7 vs
    2.0 us), which also fills numpy's ctypes caches; read-only arrays take the slow path."""
    try:
        return _addressof(_c_char_from_buffer(a))  # type: ignore[arg-type]  # numpy arrays export buffers
    except (TypeError, ValueError):
        return a.ctypes.data


def _positions_f32(positions: Any, joints: Optional[int] = None) -> np.ndarray:
    """positions as a C-contiguous float32 array (no copy when it already is one)."""
    a = np.ascontiguousarray(positions, dtype=np.float32)
    if joints is not None and a.size != 3 * joints:
        raise ValueError("expected %d joints x 3 floats, got %d floats" % (joints, a.size))
    return a


def _time_units_code(units: str) -> int:
    if units == "s":
        return 0  # KATA_TIME_SECONDS
    if units == "ms":
        return 1  # KATA_TIME_MILLISECONDS
    raise ValueError('time_units must be "s" or "ms" (or "auto" for a whole recording), not %r' % (units,))


def _type_error(function: Callable[..., Any], args: Tuple[Any, ...], kwargs: Dict[str, Any],
                error: Exception) -> TypeError:
    """A ctypes.ArgumentError turned into the TypeError a Python caller expects, naming the
    argument: the first one annotated as a number (float, int) that is not one, else ctypes' text.
    Only on the error path: the calls themselves pay nothing."""
    name = getattr(function, "__qualname__", getattr(function, "__name__", "?"))
    try:
        bound = inspect.signature(function).bind(*args, **kwargs)
        hints = typing.get_type_hints(function)
    except (TypeError, NameError):
        return TypeError("%s: %s" % (name, error))
    for param, value in bound.arguments.items():
        hint = hints.get(param)
        if hint in (float, int) and not isinstance(value, numbers.Real) or \
                hint is float and isinstance(value, bool):
            return TypeError("%s: %s must be a %s, not %s" % (name, param, "number" if hint is float else "integer",
                                                              type(value).__name__))
    return TypeError("%s: %s" % (name, error))


_F = TypeVar("_F", bound=Callable[..., Any])


def _typed(function: _F) -> _F:
    """Wraps a method whose C call may get a wrong Python type: ctypes.ArgumentError becomes a
    TypeError naming the argument (see _type_error). Not for the per-frame pushes, which catch it
    inline (a wrapper costs a call frame)."""
    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return function(*args, **kwargs)
        except ctypes.ArgumentError as e:
            raise _type_error(function, args, kwargs, e) from None
    return wrapper  # type: ignore[return-value]
