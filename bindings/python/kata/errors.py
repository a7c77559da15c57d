"""Statuses and errors: every failed C call raises KataError with .status (Status) and .message
(the C library's last error of the handle the call was made on); results lost to a full ring are
reported by ResultsDroppedWarning or ResultsDroppedError (Stream.on_drop)."""
import enum
from typing import Any, Union

from . import _native as _n

__all__ = ["Status", "KataError", "ResultsDroppedWarning", "ResultsDroppedError"]


class Status(enum.IntEnum):
    OK = 0
    NO_DATA = 1
    E_INVALID_ARGUMENT = 2
    E_NULL_POINTER = 3
    E_WRONG_JOINT_COUNT = 4
    E_NON_FINITE = 5
    E_TIMESTAMP_NOT_INCREASING = 6
    E_PARSE = 7
    E_IO = 8
    E_MODEL = 9
    E_NOT_FOUND = 10
    E_OUT_OF_MEMORY = 11
    E_BUFFER_TOO_SMALL = 12
    E_INTERNAL = 13
    E_STATE = 14
    #: not an error: the frame was accepted without features (too many joints missing)
    TRACKING_LOST = 15
    E_STOPPED = 16
    E_QUEUE_FULL = 17
    E_NO_CLIP_TEACHER = 18


class KataError(Exception):
    """A failed C call: .status (Status, or the raw int for a status this binding does not know)
    and .message (kata_*_last_error of the handle the call was made on)."""

    status: Union[Status, int]

    def __init__(self, status: int, message: Any, call: str = "") -> None:
        try:
            self.status = Status(status)
        except ValueError:
            self.status = status
        self.message = message
        self.call = call
        name = _n.status_string(int(status)).decode("utf-8", "replace")
        super().__init__("%s%s: %s" % (call + ": " if call else "", name, message))


class ResultsDroppedWarning(UserWarning):
    """Results were overwritten unread (the stream's result ring was full) before a read: .count of
    them. Read more often, give open_stream a larger result_capacity, or use Stream.push_and_read
    for a recording. Stream.on_drop = "raise" makes it an error, "count" silences it (the count
    stays in Results.dropped and Stream.results_dropped)."""

    def __init__(self, count: int, message: str) -> None:
        super().__init__(message)
        self.count = count


class ResultsDroppedError(Exception):
    """Stream.on_drop = "raise": results were overwritten unread before this read. .count of them
    were lost; .results holds what the read did move (nothing more is lost by the raise)."""

    def __init__(self, count: int, message: str, results: Any = None) -> None:
        super().__init__(message)
        self.count = count
        self.results = results
