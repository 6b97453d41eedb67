"""The wavelet codec: encode arrays into .vcz bytes, decode them (whole, a region, a level, a frame), and
random access to .vcz files (:class:`VczFile`)."""
from __future__ import annotations

import os
from typing import Any, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _arrays, _volcl
from ._volume import Volume

Region = Union[str, Tuple[slice, slice, slice]]


def _rate(lossless: Optional[bool], max_error: Optional[float], psnr: Optional[float],
          bpv: Optional[float]) -> Tuple[str, float]:
    chosen = [(name, value) for name, value in
              (("max_error", max_error), ("psnr", psnr), ("bpv", bpv)) if value is not None]
    if lossless:
        chosen.insert(0, ("lossless", 0.0))
    if len(chosen) > 1:
        raise _volcl.UsageError("choose one of --lossless, --max-error, --psnr, --bpv")
    if not chosen:
        if lossless is False:
            raise _volcl.UsageError("lossless=False needs a lossy mode (max_error, psnr or bpv)")
        return "lossless", 0.0
    return chosen[0][0], float(chosen[0][1])


def encode(data: Union[np.ndarray, Volume, Sequence[np.ndarray]], *, lossless: Optional[bool] = None,
           max_error: Optional[float] = None, psnr: Optional[float] = None, bpv: Optional[float] = None,
           step: Optional[float] = None, wavelet: Optional[str] = None, levels: int = 4,
           brick: Union[int, Sequence[int]] = 64, entropy: str = "dense", threads: int = 2,
           spacing: Optional[Sequence[float]] = None, origin: Optional[Sequence[float]] = None,
           metadata: Optional[Dict[str, str]] = None, gop: int = 10, b_frames: int = 0, motion: str = "block",
           global_shift: bool = True, lod_stats: bool = False, device: Optional[str] = None,
           report: Optional[Dict[str, Any]] = None) -> bytes:
    """Compresses a volume (3D ``a[z, y, x]``), a series (4D ``a[t, z, y, x]`` or a list of 3D arrays) or a
    :class:`Volume` into .vcz bytes, as ``volcl encode`` does.

    Rate (at most one; default lossless):
        lossless: every voxel bit-exact (float NaN/Inf bit patterns included).
        max_error: every voxel within E of the input (guaranteed).
        psnr: PSNR in dB over the input's value range, met within 0.5 dB.
        bpv: at most R bits per voxel, file overhead included.
    Other knobs are those of ``volcl encode``: ``step`` (lossy: fixed base quantiser step), ``wavelet``
    (cdf53 | cdf97 | haar | cdf26), ``levels``, ``brick`` (B or (x, y, z), multiples of 2^levels),
    ``entropy`` (dense | fast), ``threads``. ``metadata`` (str -> str) is stored in the file.
    Series, as ``volcl encode``: ``gop`` (frames per group, each starting with an I frame), ``b_frames``
    (B frames between two I/P frames), ``motion`` (block: motion-compensated P/B frames; none: I frames only),
    ``global_shift`` (False: P frames use block motion alone).
    ``lod_stats``: add the per-brick, per-level error statistics renderers use for ``--lod auto``, which
    ``volcl encode`` adds unless given ``--no-lod-stats``; with the same options and statistics the bytes
    equal the command line's.
    ``report``, when a dict is given, receives what the encoder measured (bytes, bits_per_voxel, psnr,
    max_error, corrections, step, milliseconds) for a single volume.

    float64 input is converted to float32 first. The GIL is released while the encoder runs.

    Example::

        vcz = volcl.encode(vol.array, psnr=50, spacing=vol.spacing)
        print(vol.array.nbytes / len(vcz), ":1")
    """
    if isinstance(data, Volume):
        spacing = data.spacing if spacing is None else spacing
        origin = data.origin if origin is None else origin
        data = data.array
    if isinstance(data, np.ndarray) or not isinstance(data, (list, tuple)):
        a = _arrays.volume_array(data)
        if a.ndim == 4:
            frames = [a[k] for k in range(a.shape[0])]
        elif a.ndim == 3:
            frames = [a]
        else:
            raise _volcl.UsageError(
                f"encode takes a 3D volume a[z, y, x] or a 4D series a[t, z, y, x]; this array has {a.ndim} "
                "dimensions")
    else:
        frames = [_arrays.volume_array(f) for f in data]
    rate, target = _rate(lossless, max_error, psnr, bpv)
    out, measured = _volcl.encode(_arrays.context(device), frames, _arrays.triple(spacing, 1.0, "spacing"),
                                  _arrays.triple(origin, 0.0, "origin"), rate, target,
                                  None if step is None else float(step), wavelet, int(levels),
                                  _arrays.triple(brick, 64, "brick", int),
                                  entropy, int(threads), {str(k): str(v) for k, v in (metadata or {}).items()},
                                  str(motion), int(gop), int(b_frames), bool(global_shift), bool(lod_stats))
    if report is not None:
        report.update(measured)
    return out


def _bytes_view(data: Any) -> np.ndarray:
    """Any bytes-like object as a 1D uint8 array over the same memory."""
    if isinstance(data, np.ndarray):
        return np.ascontiguousarray(data).reshape(-1).view(np.uint8)
    return np.frombuffer(memoryview(data), dtype=np.uint8)


def _region_corners(region: Optional[Region], shape: Tuple[int, int, int]
                    ) -> Tuple[Optional[Tuple[int, int, int]], Optional[Tuple[int, int, int]]]:
    """(lo, hi) in (x, y, z) full-resolution voxel indices, half-open, or (None, None) for the whole volume.

    ``region``: the command line's "x0,y0,z0:x1,y1,z1", or numpy slices in array order (z, y, x), e.g.
    ``np.s_[10:20, :, 5:50]`` (steps other than 1 are refused)."""
    if region is None:
        return None, None
    if isinstance(region, str):
        try:
            lo_text, hi_text = region.split(":")
            lo = tuple(int(v) for v in lo_text.split(","))
            hi = tuple(int(v) for v in hi_text.split(","))
            if len(lo) != 3 or len(hi) != 3:
                raise ValueError
        except ValueError:
            raise _volcl.UsageError(f"region '{region}': expected x0,y0,z0:x1,y1,z1") from None
        return lo, hi  # type: ignore[return-value]
    if not isinstance(region, tuple) or len(region) != 3:
        raise _volcl.UsageError("region must be 'x0,y0,z0:x1,y1,z1' or 3 slices (z, y, x)")
    lo_zyx, hi_zyx = [], []
    for axis, (s, n) in enumerate(zip(region, shape)):
        if isinstance(s, (int, np.integer)):
            s = slice(int(s), int(s) + 1)
        if not isinstance(s, slice):
            raise _volcl.UsageError(f"region axis {axis}: expected a slice or an index")
        start, stop, stride = s.indices(n)
        if stride != 1:
            raise _volcl.UsageError(f"region axis {axis}: slices with a step are not decoded (use level=)")
        lo_zyx.append(start)
        hi_zyx.append(max(start, stop))
    return (lo_zyx[2], lo_zyx[1], lo_zyx[0]), (hi_zyx[2], hi_zyx[1], hi_zyx[0])


class VczFile:
    """A .vcz file (or .vcz bytes) opened for random access: the header and brick index are read and
    checked at once, bricks and frames are decoded only when asked for.

    Example::

        f = volcl.VczFile("mri.vcz")
        print(f.shape, f.dtype, f.frames, f.brick_grid)
        sub = f[40:60, :, 10:100]            # a region of frame 0, full resolution
        coarse = f.read(level=2)             # a 4x-downsampled approximation
        b = f.brick(5)                       # one brick; f.brick_box(5) tells where it lies
    """

    def __init__(self, source: Union[str, "os.PathLike[str]", bytes, bytearray, memoryview, np.ndarray], *,
                 device: Optional[str] = None, stored_values: bool = False) -> None:
        if isinstance(source, (bytes, bytearray, memoryview, np.ndarray)):
            self._vcz = _volcl.Vcz(_bytes_view(source), "input")
        else:
            self._vcz = _volcl.Vcz.open(os.fspath(source))
        self._device = device
        self._stored = bool(stored_values)
        self.header: Dict[str, Any] = self._vcz.header

    @property
    def shape(self) -> Tuple[int, int, int]:
        """Full-resolution shape of one frame, (z, y, x)."""
        return tuple(self.header["shape"])  # type: ignore[return-value]

    @property
    def dtype(self) -> np.dtype:
        """numpy dtype of the voxels reads give: float32 data units for a scaled NIfTI's stored integers
        (unless opened with ``stored_values=True``), else the stored type."""
        if self.stored_scale is not None and not self._stored:
            return np.dtype(np.float32)
        return np.dtype(self.header["dtype"])

    @property
    def stored_scale(self) -> Optional[Tuple[float, float]]:
        """(scl_slope, scl_inter) when the file holds a scaled NIfTI's stored integers (``volcl encode`` of
        such a NIfTI keeps them exactly), else None. Reads give data units ``stored * slope + inter`` as
        float32, as ``volcl.read`` of the .nii and ``volcl decode`` to formats other than NIfTI do; open the
        file with ``stored_values=True`` for the integers."""
        scale = self._vcz.stored_scale
        return None if scale is None else (float(scale[0]), float(scale[1]))

    @property
    def spacing(self) -> Tuple[float, float, float]:
        """World distance between samples along x, y, z (full resolution)."""
        return tuple(self.header["spacing"])  # type: ignore[return-value]

    @property
    def origin(self) -> Tuple[float, float, float]:
        """World position of voxel (0, 0, 0), x, y, z."""
        return tuple(self.header["origin"])  # type: ignore[return-value]

    @property
    def frames(self) -> int:
        """Number of frames (1 for a single volume)."""
        return len(self.header["times"])

    @property
    def levels(self) -> int:
        """Transform levels: ``read(level=k)`` accepts k = 0..levels."""
        return int(self.header["levels"])

    @property
    def brick_shape(self) -> Tuple[int, int, int]:
        """Brick size (z, y, x) at full resolution."""
        return tuple(self.header["brick"])  # type: ignore[return-value]

    @property
    def brick_grid(self) -> Tuple[int, int, int]:
        """Bricks per axis, (z, y, x); brick indices run x fastest."""
        return tuple(self.header["brick_grid"])  # type: ignore[return-value]

    @property
    def brick_count(self) -> int:
        """Bricks per frame."""
        z, y, x = self.brick_grid
        return z * y * x

    @property
    def metadata(self) -> Dict[str, Union[str, bytes]]:
        """The key/value metadata stored at encoding: text values as str; a value that is not UTF-8 as bytes
        (``volcl:lod``, the level-of-detail statistics ``volcl encode`` stores, is binary)."""
        return dict(self.header["metadata"])

    @property
    def nbytes(self) -> int:
        """Size of the compressed file in bytes."""
        return int(self._vcz.file_size)

    def __len__(self) -> int:
        return self.frames

    def read(self, *, frame: int = 0, level: int = 0, region: Optional[Region] = None,
             threads: int = 2) -> Volume:
        """Frame ``frame`` decoded whole or over ``region``, at full resolution or the 2^level-downsampled
        approximation, as a :class:`Volume` (its spacing grows by 2^level, its origin moves to the first
        kept sample). The same voxels as ``volcl decode --frame K --level L --region ...``."""
        lo, hi = _region_corners(region, self.shape)
        array, spacing, origin = self._vcz.decode(_arrays.context(self._device), lo, hi, int(level), int(frame),
                                                  int(threads), self._stored)
        return Volume(array, tuple(spacing), tuple(origin), {"format": "vcz", **self.metadata})

    def __getitem__(self, key: Any) -> np.ndarray:
        """``f[z0:z1, y0:y1, x0:x1]`` decodes that region of frame 0; ``f[k, ...]`` with four indices picks
        frame k; ``f[k]`` is frame k whole."""
        if isinstance(key, (int, np.integer)):
            return self.read(frame=int(key)).array
        if not isinstance(key, tuple):
            key = (key,)
        frame = 0
        if len(key) == 4:
            if not isinstance(key[0], (int, np.integer)):
                raise _volcl.UsageError("the frame index of f[k, z, y, x] must be an integer")
            frame, key = int(key[0]), key[1:]
        key = tuple(key) + (slice(None),) * (3 - len(key))
        return self.read(frame=frame, region=key).array  # type: ignore[arg-type]

    def brick(self, index: int, *, frame: int = 0, level: int = 0) -> np.ndarray:
        """Brick ``index`` of ``frame`` at ``level``, decoded alone (its checksum is checked first)."""
        array, _, _ = self._vcz.decode_brick(_arrays.context(self._device), int(frame), int(index), int(level),
                                             self._stored)
        return array

    def brick_box(self, index: int) -> Tuple[slice, slice, slice]:
        """Where brick ``index`` lies in the full-resolution frame, as slices (z, y, x)."""
        lo, hi = self._vcz.brick_box(int(index))
        return tuple(slice(a, b) for a, b in zip(lo, hi))  # type: ignore[return-value]

    def bricks(self, *, frame: int = 0) -> Iterator[Tuple[int, Tuple[slice, slice, slice], np.ndarray]]:
        """Every brick of ``frame`` at full resolution, one at a time: (index, slices, voxels)."""
        for i in range(self.brick_count):
            yield i, self.brick_box(i), self.brick(i, frame=frame)


def decode(data: Any, *, region: Optional[Region] = None, level: int = 0, frame: int = 0, threads: int = 2,
           device: Optional[str] = None, stored_values: bool = False) -> np.ndarray:
    """Decodes .vcz bytes (any bytes-like object) into an array ``a[z, y, x]``, as ``volcl decode`` does:
    the whole frame, a ``region`` ("x0,y0,z0:x1,y1,z1" or slices (z, y, x)), a coarser ``level``
    (2^level-downsampled, no finer detail decoded), a ``frame`` of a series. The array owns the decoder's
    output (no copy); the GIL is released while the decoder runs. Use :class:`VczFile` for the grid and
    repeated access. A scaled NIfTI's stored integers come back in float32 data units unless
    ``stored_values`` (see :attr:`VczFile.stored_scale`)."""
    return VczFile(data, device=device, stored_values=stored_values).read(frame=frame, level=level, region=region,
                                                                          threads=threads).array
