"""Argument conversions shared by the volcl API: volume arrays, grids, counts, device contexts, missing files."""
from __future__ import annotations

import builtins
import contextlib
import errno
import glob
import operator
import os
import threading
from typing import Any, Callable, Iterator, Optional, Tuple

import numpy as np

from . import _volcl

#: numpy dtypes a volume can hold (float64 is kept as float64; renderers sample it as float32).
VOLUME_DTYPES = (np.dtype(np.uint8), np.dtype(np.uint16), np.dtype(np.int16), np.dtype(np.float32),
                 np.dtype(np.float64))

_contexts: dict = {}
_contexts_lock = threading.Lock()


def context(device: Optional[str] = None) -> "_volcl.Context":
    """The shared OpenCL context for `device` (None or '': $VOLCL_DEVICE, else the first device).

    Contexts are created once per selector and reused: creating one costs a device query and, on first
    use of a kernel, its build (cached on disk afterwards)."""
    selector = "" if device is None else str(device)
    with _contexts_lock:
        ctx = _contexts.get(selector)
        if ctx is None:
            ctx = _volcl.Context(selector)
            _contexts[selector] = ctx
        return ctx


def volume_array(array: Any) -> np.ndarray:
    """`array` as a C-contiguous, native-byte-order numpy array of a volume dtype (no copy when it is one)."""
    a = np.asarray(array)
    if a.dtype.byteorder not in ("=", "|"):
        a = a.astype(a.dtype.newbyteorder("="))
    if a.dtype not in VOLUME_DTYPES:
        raise TypeError(f"array dtype {a.dtype} is not a volume type (uint8, uint16, int16, float32, float64)")
    return np.ascontiguousarray(a)


def triple(value: Any, default: Any, name: str, kind: Callable[[Any], Any] = float) -> Tuple[Any, Any, Any]:
    """A per-axis (x, y, z) triple of `kind` (float, or int for brick sizes); a scalar applies to all three
    axes, None gives `default` on each."""
    if value is None:
        return (kind(default),) * 3
    if np.isscalar(value):
        return (kind(value),) * 3
    values = tuple(kind(v) for v in value)
    if len(values) != 3:
        raise _volcl.UsageError(f"{name} must be one number or 3 (x, y, z), got {len(values)}")
    return values  # type: ignore[return-value]


def sizes(value: Any, default: int, name: str) -> Tuple[int, int, int]:
    """A per-axis (x, y, z) triple of positive integers (brick sizes): one applies to all three axes."""
    values = triple(value, default, name, lambda v: count(v, name, minimum=1))
    return values


def count(value: Any, name: str, *, minimum: int = 0) -> int:
    """`value` as a Python int of at least `minimum`: TypeError for a non-integer (a float, a string),
    volcl.UsageError (a ValueError) below the minimum, naming the keyword `name`."""
    try:
        n = operator.index(value)
    except TypeError:
        raise TypeError(f"{name}= must be an integer, not {type(value).__name__}") from None
    if n < minimum:
        raise _volcl.UsageError(f"{name}={n} must be at least {minimum}")
    return n


def fspath(path: Any) -> str:
    return os.fspath(path)


class FileNotFoundError(_volcl.IoError, builtins.FileNotFoundError):  # noqa: A001 (volcl.FileNotFoundError)
    """A file volcl was asked to read does not exist: both a :class:`volcl.IoError` and the builtin
    FileNotFoundError (``errno`` ENOENT, ``filename`` the path). The message is the command line's."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


@contextlib.contextmanager
def missing_file_check(path: str) -> Iterator[None]:
    """Turns the IoError a read of `path` raises into volcl.FileNotFoundError when `path` does not exist
    (and is not a glob pattern, whose files are matched later), keeping the message."""
    try:
        yield
    except _volcl.IoError as e:
        if isinstance(e, FileNotFoundError) or os.path.lexists(path) or glob.has_magic(path):
            raise
        missing = FileNotFoundError(str(e))
        missing.errno, missing.strerror, missing.filename = errno.ENOENT, os.strerror(errno.ENOENT), path
        raise missing from None
