"""A numcodecs codec (``id: "volcl"``), so zarr 2 arrays (and zarr 3 arrays of ``zarr_format=2``) compress
their chunks with the volcl wavelet codec; zarr 3's own format takes :class:`volcl.zarr3.Volcl`.

Example::

    import zarr, volcl.numcodecs
    z = zarr.open_array("mri.zarr", mode="w", shape=vol.array.shape, chunks=(64, 64, 64),
                        dtype=vol.array.dtype, compressor=volcl.numcodecs.Volcl(max_error=0.5))
    z[:] = vol.array

Each chunk becomes one .vcz (one volume: chunks of fewer than three dimensions are treated as thin
volumes, extra leading dimensions are stacked along z). Lossless by default; ``max_error`` bounds every
voxel, ``rel_error`` every voxel by R x the value range of its chunk (the range zarr hands the codec),
``pw_rel_error`` every voxel by R x its magnitude, ``psnr`` and ``bpv`` set a quality or a size. The dtype must be a volume type (uint8, uint16,
int16, float32, float64): a float64 chunk decodes as float64, bit for bit when lossless and within the bound
(checked in double) otherwise; ``bpv`` is refused for float64, as it would bound no voxel.
"""
from __future__ import annotations

from typing import Any, Optional

import numpy as np
from numcodecs.abc import Codec
from numcodecs.compat import ensure_contiguous_ndarray, ndarray_copy
from numcodecs.registry import register_codec

from ._codec import chunk_volume, decode, encode


class Volcl(Codec):
    """volcl's wavelet codec for numcodecs/zarr. Parameters are those of :func:`volcl.encode`."""

    codec_id = "volcl"

    def __init__(self, max_error: Optional[float] = None, psnr: Optional[float] = None,
                 bpv: Optional[float] = None, wavelet: Optional[str] = None, levels: int = 4, brick: int = 64,
                 entropy: str = "dense", threads: int = 2, device: Optional[str] = None,
                 rel_error: Optional[float] = None, pw_rel_error: Optional[float] = None) -> None:
        self.max_error = max_error
        self.rel_error = rel_error
        self.pw_rel_error = pw_rel_error
        self.psnr = psnr
        self.bpv = bpv
        self.wavelet = wavelet
        self.levels = levels
        self.brick = brick
        self.entropy = entropy
        self.threads = threads
        self.device = device

    def encode(self, buf: Any) -> bytes:
        a = chunk_volume(np.asarray(buf))
        return encode(a, max_error=self.max_error, rel_error=self.rel_error, pw_rel_error=self.pw_rel_error,
                      psnr=self.psnr, bpv=self.bpv, wavelet=self.wavelet,
                      levels=self.levels, brick=self.brick, entropy=self.entropy, threads=self.threads,
                      device=self.device)

    def decode(self, buf: Any, out: Any = None) -> Any:
        a = decode(ensure_contiguous_ndarray(buf), threads=self.threads, device=self.device)
        if out is not None:
            return ndarray_copy(a, out)
        return a

    def __repr__(self) -> str:
        mode = next((f"{k}={v}" for k, v in (("max_error", self.max_error), ("rel_error", self.rel_error),
                                              ("pw_rel_error", self.pw_rel_error), ("psnr", self.psnr),
                                              ("bpv", self.bpv)) if v is not None), "lossless")
        return f"Volcl({mode}, levels={self.levels}, brick={self.brick}, entropy={self.entropy!r})"


register_codec(Volcl)
