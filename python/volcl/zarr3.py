"""The volcl wavelet codec for zarr 3 arrays (``zarr_format=3``): a BytesBytesCodec named ``volcl``.

Example::

    import zarr, volcl.zarr3
    z = zarr.create_array("mri.zarr", shape=vol.array.shape, chunks=(64, 64, 64), dtype=vol.array.dtype,
                          compressors=[volcl.zarr3.Volcl(max_error=0.5)])
    z[:] = vol.array

zarr finds the codec by name when it opens such an array (the ``zarr.codecs`` entry point ``volcl``, also
registered on import of this module). Each chunk becomes one .vcz, as with :class:`volcl.numcodecs.Volcl`:
the chunk's shape and dtype come from zarr's chunk spec, its bytes from the ``bytes`` codec before it,
whose little-endian default the codec reads them in (a big-endian ``bytes`` codec still round-trips, but
the lossy bounds would then apply to byte-swapped values). float64 arrays stay float64 (lossless bit for
bit, a bound checked in double; ``bpv`` refused).
"""
from __future__ import annotations

import asyncio
from dataclasses import dataclass
from typing import Any, Dict, Optional

import numpy as np
from zarr.abc.codec import BytesBytesCodec
from zarr.registry import register_codec

from ._codec import chunk_volume, decode, encode

_PARAMETERS = ("max_error", "rel_error", "pw_rel_error", "psnr", "bpv", "wavelet", "levels", "brick", "entropy", "threads", "device")


def _chunk_dtype(spec: Any) -> np.dtype:
    """The chunk's numpy dtype, little-endian (what zarr's ``bytes`` codec writes by default)."""
    dtype = spec.dtype
    native = dtype.to_native_dtype() if hasattr(dtype, "to_native_dtype") else np.dtype(dtype)
    return np.dtype(native).newbyteorder("<")


@dataclass(frozen=True)
class Volcl(BytesBytesCodec):
    """volcl's wavelet codec as a zarr 3 compressor. Parameters are those of :func:`volcl.encode`; none of
    ``max_error``, ``rel_error`` (R x each chunk's value range), ``pw_rel_error``, ``psnr``, ``bpv`` means
    lossless."""

    is_fixed_size = False

    max_error: Optional[float] = None
    rel_error: Optional[float] = None
    pw_rel_error: Optional[float] = None
    psnr: Optional[float] = None
    bpv: Optional[float] = None
    wavelet: Optional[str] = None
    levels: int = 4
    brick: int = 64
    entropy: str = "dense"
    threads: int = 2
    device: Optional[str] = None

    @classmethod
    def from_dict(cls, data: Dict[str, Any]) -> "Volcl":
        if data.get("name") != "volcl":
            raise ValueError(f"expected the codec 'volcl', got {data.get('name')!r}")
        config = dict(data.get("configuration") or {})
        unknown = sorted(set(config) - set(_PARAMETERS))
        if unknown:
            raise ValueError(f"codec 'volcl': unknown parameter(s) {', '.join(unknown)}")
        return cls(**config)

    def to_dict(self) -> Dict[str, Any]:
        config = {k: getattr(self, k) for k in _PARAMETERS if getattr(self, k) is not None}
        config.pop("device", None)  # a device is this process's choice, not the array's
        return {"name": "volcl", "configuration": config}

    def _encode_sync(self, chunk_bytes: Any, chunk_spec: Any) -> Any:
        a = np.frombuffer(chunk_bytes.to_bytes(), dtype=_chunk_dtype(chunk_spec)).reshape(chunk_spec.shape)
        vcz = encode(chunk_volume(a), max_error=self.max_error, rel_error=self.rel_error,
                     pw_rel_error=self.pw_rel_error, psnr=self.psnr, bpv=self.bpv,
                     wavelet=self.wavelet, levels=self.levels, brick=self.brick, entropy=self.entropy,
                     threads=self.threads, device=self.device)
        return chunk_spec.prototype.buffer.from_bytes(vcz)

    def _decode_sync(self, chunk_bytes: Any, chunk_spec: Any) -> Any:
        a = decode(chunk_bytes.as_numpy_array(), threads=self.threads, device=self.device)
        raw = np.ascontiguousarray(a, dtype=_chunk_dtype(chunk_spec)).tobytes()
        return chunk_spec.prototype.buffer.from_bytes(raw)

    async def _encode_single(self, chunk_bytes: Any, chunk_spec: Any) -> Any:
        return await asyncio.to_thread(self._encode_sync, chunk_bytes, chunk_spec)

    async def _decode_single(self, chunk_bytes: Any, chunk_spec: Any) -> Any:
        return await asyncio.to_thread(self._decode_sync, chunk_bytes, chunk_spec)

    def compute_encoded_size(self, input_byte_length: int, chunk_spec: Any) -> int:
        raise NotImplementedError  # variable-size output


register_codec("volcl", Volcl)
