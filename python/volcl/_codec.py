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
          bpv: Optional[float], rel_error: Optional[float] = None,
          pw_rel_error: Optional[float] = None) -> Tuple[str, float]:
    chosen = [(name, value) for name, value in
              (("max_error", max_error), ("rel_error", rel_error), ("pw_rel_error", pw_rel_error),
               ("psnr", psnr), ("bpv", bpv)) if value is not None]
    if lossless:
        chosen.insert(0, ("lossless", 0.0))
    if len(chosen) > 1:
        raise _volcl.UsageError("choose one of lossless=True, max_error=, rel_error=, pw_rel_error=, psnr=, bpv=")
    if not chosen:
        if lossless is False:
            raise _volcl.UsageError(
                "lossless=False needs a lossy mode (max_error, rel_error, pw_rel_error, psnr or bpv)")
        return "lossless", 0.0
    return chosen[0][0], float(chosen[0][1])


def encode(data: Union[np.ndarray, Volume, Sequence[np.ndarray]], *, lossless: Optional[bool] = None,
           max_error: Optional[float] = None, psnr: Optional[float] = None, bpv: Optional[float] = None,
           rel_error: Optional[float] = None, pw_rel_error: Optional[float] = None, step: Optional[float] = None, wavelet: Optional[str] = None, levels: int = 4,
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
        rel_error: every finite voxel within R x (max - min) of the finite values (guaranteed).
        pw_rel_error: every voxel within R x |voxel|, 0 < R < 1 (guaranteed; zeros exact, signs kept).
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

    float64 input stays float64 (lossless bit for bit; a bound holds in double on every voxel; a single
    volume, not a series). The GIL is released while the encoder runs.

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
    rate, target = _rate(lossless, max_error, psnr, bpv, rel_error, pw_rel_error)
    out, measured = _volcl.encode(_arrays.context(device), frames, _arrays.triple(spacing, 1.0, "spacing"),
                                  _arrays.triple(origin, 0.0, "origin"), rate, target,
                                  None if step is None else float(step), wavelet,
                                  _arrays.count(levels, "levels"),
                                  _arrays.sizes(brick, 64, "brick"), entropy,
                                  _arrays.count(threads, "threads", minimum=1),
                                  {str(k): str(v) for k, v in (metadata or {}).items()},
                                  str(motion), _arrays.count(gop, "gop", minimum=1),
                                  _arrays.count(b_frames, "b_frames"), bool(global_shift), bool(lod_stats))
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
            path = os.fspath(source)
            with _arrays.missing_file_check(path):
                self._vcz = _volcl.Vcz.open(path)
        self._device = device
        self._stored = bool(stored_values)
        self.header: Dict[str, Any] = self._vcz.header

    @property
    def frame_shape(self) -> Tuple[int, int, int]:
        """Full-resolution shape of one frame, (z, y, x)."""
        return tuple(self.header["shape"])  # type: ignore[return-value]

    @property
    def shape(self) -> Tuple[int, ...]:
        """The array this file holds: (z, y, x) for one volume, (t, z, y, x) for a series of t frames,
        as ``np.asarray(f).shape`` and ``volcl.read(path).array.shape``."""
        return ((self.frames,) if self.frames > 1 else ()) + self.frame_shape

    @property
    def ndim(self) -> int:
        """3 for one volume, 4 for a series."""
        return len(self.shape)

    @property
    def size(self) -> int:
        """Voxels in :attr:`shape`."""
        return int(np.prod(self.shape))

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
        """``shape[0]``, as for a numpy array: z-slices of one volume, frames of a series."""
        return self.shape[0]

    def read(self, *, frame: int = 0, level: int = 0, region: Optional[Region] = None,
             threads: int = 2) -> Volume:
        """Frame ``frame`` decoded whole or over ``region``, at full resolution or the 2^level-downsampled
        approximation, as a :class:`Volume` (its spacing grows by 2^level, its origin moves to the first
        kept sample). The same voxels as ``volcl decode --frame K --level L --region ...``."""
        frame = _arrays.count(frame, "frame")
        if frame >= self.frames:
            raise _volcl.UsageError(f"frame={frame} out of range: the file has {self.frames} frame"
                                    + ("s" if self.frames != 1 else ""))
        lo, hi = _region_corners(region, self.frame_shape)
        array, spacing, origin = self._vcz.decode(_arrays.context(self._device), lo, hi,
                                                  _arrays.count(level, "level"), frame,
                                                  _arrays.count(threads, "threads", minimum=1), self._stored)
        return Volume(array, tuple(spacing), tuple(origin), {"format": "vcz", **self.metadata})

    def frame(self, k: int) -> "VczFrame":
        """Frame ``k`` of a series (negative counts from the end) as a 3D array view ``(z, y, x)`` that
        indexes and converts like :class:`VczFile` and decodes only what an index asks for."""
        k = _arrays.count(k, "frame", minimum=-self.frames)
        if k >= self.frames:
            raise IndexError(f"frame {k} is out of bounds for a file of {self.frames} frames")
        return VczFrame(self, k % self.frames)

    def __getitem__(self, key: Any) -> np.ndarray:
        """numpy indexing over :attr:`shape`: integers (negative from the end), slices with any step,
        ``...`` and ``None``; ``f[90]`` is z-slice 90 of one volume, frame 90 of a series. Only the bricks
        the index touches are decoded (the bounding region of the slices, then stepped); other indices
        (integer or boolean arrays) decode the whole array first."""
        return _index(self, key, self.frames > 1)

    def __array__(self, dtype: Any = None, copy: Optional[bool] = None) -> np.ndarray:
        """The whole array, decoded (``np.asarray(f)``); ``dtype`` converts it. Every call decodes anew:
        a new array (numpy 2's ``copy=`` is accepted either way, no array of the file is kept)."""
        a = self[...]
        return a if dtype is None else a.astype(dtype, copy=False)

    def __repr__(self) -> str:
        return f"VczFile(shape={self.shape}, dtype={self.dtype}, {self.nbytes} bytes)"

    def brick(self, index: int, *, frame: int = 0, level: int = 0) -> np.ndarray:
        """Brick ``index`` of ``frame`` at ``level``, decoded alone (its checksum is checked first)."""
        array, _, _ = self._vcz.decode_brick(_arrays.context(self._device), _arrays.count(frame, "frame"),
                                             _arrays.count(index, "index"), _arrays.count(level, "level"),
                                             self._stored)
        return array

    def brick_box(self, index: int) -> Tuple[slice, slice, slice]:
        """Where brick ``index`` lies in the full-resolution frame, as slices (z, y, x)."""
        lo, hi = self._vcz.brick_box(_arrays.count(index, "index"))
        return tuple(slice(a, b) for a, b in zip(lo, hi))  # type: ignore[return-value]

    def bricks(self, *, frame: int = 0) -> Iterator[Tuple[int, Tuple[slice, slice, slice], np.ndarray]]:
        """Every brick of ``frame`` at full resolution, one at a time: (index, slices, voxels)."""
        for i in range(self.brick_count):
            yield i, self.brick_box(i), self.brick(i, frame=frame)


class VczFrame:
    """Frame ``k`` of a :class:`VczFile` (``f.frame(k)``): a 3D array ``(z, y, x)`` that indexes like
    numpy and decodes only the bricks an index touches; ``np.asarray`` decodes the whole frame."""

    def __init__(self, file: VczFile, k: int) -> None:
        self.file, self.index = file, k

    shape = property(lambda self: self.file.frame_shape, doc="(z, y, x)")
    dtype = property(lambda self: self.file.dtype, doc="numpy dtype of the voxels")
    ndim = property(lambda self: 3, doc="3")
    size = property(lambda self: int(np.prod(self.shape)), doc="voxels in the frame")

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key: Any) -> np.ndarray:
        return _index(self.file, key, False, self.index)

    def __array__(self, dtype: Any = None, copy: Optional[bool] = None) -> np.ndarray:
        a = self[...]
        return a if dtype is None else a.astype(dtype, copy=False)

    def __repr__(self) -> str:
        return f"VczFrame({self.index} of {self.file.frames}, shape={self.shape}, dtype={self.dtype})"


_BASIC_INDEX_MESSAGE = ("only integers, slices (`:`), ellipsis (`...`), numpy.newaxis (`None`) and integer or "
                        "boolean arrays are valid indices")


def _index(f: VczFile, key: Any, series: bool, frame: int = 0) -> np.ndarray:
    """numpy basic indexing of frame `frame` (or, `series`, of the (t, z, y, x) series) of `f`, decoding
    the bounding region of the index's slices only; any other index decodes everything and lets numpy
    apply it."""
    shape = ((f.frames,) if series else ()) + f.frame_shape
    keys = key if isinstance(key, tuple) else (key,)
    basic = all(k is None or k is Ellipsis or isinstance(k, slice) or
                (isinstance(k, (int, np.integer)) and not isinstance(k, (bool, np.bool_))) for k in keys)
    if not basic:
        whole = _index(f, (), series, frame)
        try:
            return whole[key]
        except IndexError:
            raise
        except (TypeError, ValueError):
            raise IndexError(_BASIC_INDEX_MESSAGE) from None
    if sum(k is Ellipsis for k in keys) > 1:
        raise IndexError("an index can only have a single ellipsis ('...')")
    axes_used = sum(k is not None and k is not Ellipsis for k in keys)
    if axes_used > len(shape):
        raise IndexError(f"too many indices for array: array is {len(shape)}-dimensional, but {axes_used} were "
                         "indexed")
    expanded: List[Any] = []
    for k in keys:
        if k is Ellipsis:
            expanded.extend([slice(None)] * (len(shape) - axes_used))
        else:
            expanded.append(k)
    if Ellipsis not in keys:
        expanded.extend([slice(None)] * (len(shape) - axes_used))
    # Per axis: the decoded range [lo, hi) and how to pick from it (an int, or a slice relative to lo).
    bounds: List[Tuple[int, int]] = []
    picks: List[Any] = []
    axis = 0
    for k in expanded:
        if k is None:
            picks.append(None)
            continue
        n = shape[axis]
        if isinstance(k, slice):
            r = range(*k.indices(n))
            if len(r) == 0:
                bounds.append((0, 0))
                picks.append(slice(0, 0))
            else:
                lo, hi = min(r[0], r[-1]), max(r[0], r[-1]) + 1
                stop = r[-1] - lo + (1 if r.step > 0 else -1)
                bounds.append((lo, hi))
                picks.append(slice(r[0] - lo, None if stop < 0 else stop, r.step))
        else:
            i = int(k)
            if not -n <= i < n:
                raise IndexError(f"index {i} is out of bounds for axis {axis} with size {n}")
            i %= n
            bounds.append((i, i + 1))
            picks.append(0)
        axis += 1
    if any(lo == hi for lo, hi in bounds):  # an empty selection decodes nothing
        block = np.zeros([hi - lo for lo, hi in bounds], dtype=f.dtype)
    else:
        spatial = bounds[-3:]
        region = tuple(slice(lo, hi) for lo, hi in spatial)
        if series:
            t0, t1 = bounds[0]
            block = np.stack([f.read(frame=t, region=region).array for t in range(t0, t1)])
        else:
            block = f.read(frame=frame, region=region).array
    return block[tuple(picks)]


def chunk_volume(chunk: np.ndarray) -> np.ndarray:
    """A zarr chunk as the 3D volume the codec compresses: fewer than three dimensions become a thin volume,
    extra leading dimensions are stacked along z."""
    a = _arrays.volume_array(chunk)
    if a.ndim < 3:
        return a.reshape((1,) * (3 - a.ndim) + a.shape)
    if a.ndim > 3:
        return a.reshape((-1,) + a.shape[-2:])
    return a


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
