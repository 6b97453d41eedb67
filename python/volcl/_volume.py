"""The Volume type of the Python API and volume files: read and write."""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _arrays, _volcl

PathLike = Union[str, "os.PathLike[str]"]


@dataclass
class Volume:
    """A dense node-centred scalar grid: voxel ``array[z, y, x]`` sits at world position
    ``origin + (x * sx, y * sy, z * sz)``.

    Attributes:
        array: the voxels, ``a[z, y, x]`` (x varies fastest in memory), or ``a[t, z, y, x]`` for a time
            series of several frames on one grid. dtype uint8, uint16, int16 or float32.
        spacing: world distance between neighbouring samples along x, y, z (note: the reverse of the
            array's axis order, as in the file formats).
        origin: world position of sample (0, 0, 0), x, y, z.
        metadata: what the reader knows besides the grid: ``format`` (the file format read) and, for a
            series, ``times``; a .vcz adds its stored key/value metadata. An oriented file adds
            ``direction`` (its index axes in world axes, a 3x3 matrix row by row; world is patient RAS
            when ``anatomical``), which :func:`volcl.render` frames views with.
    """

    array: np.ndarray
    spacing: Tuple[float, float, float] = (1.0, 1.0, 1.0)
    origin: Tuple[float, float, float] = (0.0, 0.0, 0.0)
    metadata: Dict[str, Any] = field(default_factory=dict)

    @property
    def frames(self) -> int:
        """Number of frames: 1 for a 3D array, ``array.shape[0]`` for a 4D one."""
        return 1 if self.array.ndim == 3 else int(self.array.shape[0])

    def frame(self, k: int) -> np.ndarray:
        """Frame ``k`` (0-based) as a 3D array ``a[z, y, x]``."""
        if self.array.ndim == 3:
            if k != 0:
                raise _volcl.UsageError(f"frame {k} out of range (the volume has 1 frame)")
            return self.array
        if not 0 <= k < self.array.shape[0]:
            raise _volcl.UsageError(f"frame {k} out of range (the volume has {self.array.shape[0]} frames)")
        return self.array[k]


def read(path: PathLike, *, device: Optional[str] = None) -> Volume:
    """Reads a volume file with the readers of ``volcl`` (NRRD, NIfTI, MetaImage, VTK, raw with the size in
    its name, SLC, VDB, Inviwo .dat, Voreen .vvd, a ParaView .pvd series, a quoted glob, and .vcz).

    A file of one frame gives a 3D ``array[z, y, x]``, a series a 4D ``array[t, z, y, x]``. The array owns
    the reader's buffer (no copy). Errors raise :class:`volcl.IoError` (an OSError) /
    :class:`volcl.DataError` with the command line's message; a path that does not exist raises
    :class:`volcl.FileNotFoundError` (also the builtin FileNotFoundError).

    Example::

        vol = volcl.read("mri.nii.gz")
        print(vol.array.shape, vol.array.dtype, vol.spacing)
    """
    p = _arrays.fspath(path)
    ctx = _arrays.context(device) if p.lower().endswith(".vcz") else None
    with _arrays.missing_file_check(p):
        r = _volcl.read(p, ctx)
    frames: List[np.ndarray] = r["frames"]
    array = frames[0] if len(frames) == 1 else np.stack(frames)
    metadata: Dict[str, Any] = {"format": r["format"]}
    if r["times"]:
        metadata["times"] = list(r["times"])
    if r["anatomical"] or tuple(r["direction"]) != (1, 0, 0, 0, 1, 0, 0, 0, 1):
        metadata["direction"] = tuple(r["direction"])  # index axes in world (RAS) axes, row by row
        metadata["anatomical"] = bool(r["anatomical"])
    return Volume(array, tuple(r["spacing"]), tuple(r["origin"]), metadata)


def write(path: PathLike, volume: Union[Volume, np.ndarray], *, spacing: Optional[Sequence[float]] = None,
          origin: Optional[Sequence[float]] = None, compress: bool = True) -> None:
    """Writes one volume (a :class:`Volume` or a 3D array ``a[z, y, x]``); the format follows the extension
    (.raw, .nrrd, .nhdr + .raw, .nii, .nii.gz, .vti, .vdb, .npy: what ``volcl decode -o`` writes). The file is written
    atomically: a failed write leaves nothing behind. ``spacing``/``origin`` (x, y, z) override the
    volume's. ``compress``: gzip for NRRD, Blosc/zip for VDB.
    """
    if isinstance(volume, Volume):
        array = volume.array
        spacing = volume.spacing if spacing is None else spacing
        origin = volume.origin if origin is None else origin
    else:
        array = volume
    a = _arrays.volume_array(array)
    if a.ndim != 3:
        raise _volcl.UsageError(f"write takes one 3D volume a[z, y, x]; this array has {a.ndim} dimensions")
    _volcl.write(_arrays.fspath(path), a, _arrays.triple(spacing, 1.0, "spacing"),
                 _arrays.triple(origin, 0.0, "origin"), compress)


def read_image(path: PathLike) -> Tuple[np.ndarray, List[str]]:
    """An image file (EXR from ``volcl render`` or ``volcl preint``, PNG, ...) as float32 pixels
    [height, width, channels] and the channel names, e.g. ``(img, ["R", "G", "B", "A"])``."""
    p = _arrays.fspath(path)
    with _arrays.missing_file_check(p):
        pixels, channels = _volcl.read_image(p)
    return pixels, list(channels)
