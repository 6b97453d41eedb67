"""volcl: portable OpenCL volume processing on numpy arrays.

The Python face of the volcl C++ library (the same code the ``volcl`` command runs): volume files,
the wavelet codec (.vcz), transfer functions, pre-integration tables and the ray marcher. Arrays are
``a[z, y, x]`` (x fastest); grids carry spacing and origin in (x, y, z) order. Errors raise
:class:`volcl.Error` subclasses whose message is the command line's one-line message, options named as
keywords; they also derive from the builtin classes (UsageError and DataError from ValueError, IoError
from OSError, volcl.FileNotFoundError from FileNotFoundError). See docs/python.md for a tour.
"""
from ._volcl import ClError, DataError, Error, IoError, UsageError  # noqa: F401
from ._volcl import version as _version
from ._arrays import FileNotFoundError  # noqa: F401,A004 (volcl.FileNotFoundError: also the builtin one)
from ._codec import VczFile, VczFrame, decode, encode  # noqa: F401
from ._render import TF, TransferFunction, composite, preintegration_table, render  # noqa: F401
from ._volume import Volume, read, read_image, write  # noqa: F401
from . import _volcl

__version__ = _version()


def devices() -> list:
    """Every OpenCL device on every platform (what ``volcl devices`` lists), as dicts with index,
    platform, name, vendor, version, driver, type (cpu | gpu | other), compute_units, memory sizes and
    fp64. A call's ``device=`` takes an index or a name substring; the default is $VOLCL_DEVICE, else
    the first device."""
    return list(_volcl.devices())


__all__ = [
    "ClError", "DataError", "Error", "IoError", "UsageError", "TF", "TransferFunction", "VczFile", "VczFrame", "Volume",
    "composite", "decode", "devices", "encode", "preintegration_table", "read", "read_image", "render", "write",
]
