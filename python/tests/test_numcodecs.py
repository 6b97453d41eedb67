"""The volcl numcodecs codec in a chunked zarr 2 array: exact when lossless, within the bound when lossy."""
from __future__ import annotations

import numcodecs
import numpy as np
import pytest

import volcl
import volcl.numcodecs

zarr = pytest.importorskip("zarr")
if int(zarr.__version__.split(".")[0]) >= 3:
    pytest.skip(f"zarr {zarr.__version__}: these are zarr 2's tests (zarr 3's are test_zarr3.py)",
                allow_module_level=True)


def test_codec_is_registered_and_configurable():
    codec = numcodecs.get_codec({"id": "volcl", "max_error": 0.5})
    assert isinstance(codec, volcl.numcodecs.Volcl) and codec.max_error == 0.5
    assert numcodecs.get_codec(codec.get_config()) == codec


def test_zarr_lossless_round_trip_is_exact(tmp_path, mri):
    z = zarr.open_array(str(tmp_path / "mri.zarr"), mode="w", shape=mri.shape, chunks=(64, 50, 70),
                        dtype=mri.dtype, compressor=volcl.numcodecs.Volcl())
    z[:] = mri
    back = zarr.open_array(str(tmp_path / "mri.zarr"), mode="r")
    assert np.array_equal(back[:], mri)
    assert np.array_equal(back[10:20, 100:150, 33], mri[10:20, 100:150, 33])
    assert back.nbytes_stored < mri.nbytes / 2


@pytest.mark.parametrize("dtype,bound", [(np.float32, 0.02), (np.uint16, 3)])
def test_zarr_lossy_round_trip_is_within_the_bound(tmp_path, smooth_float, dtype, bound):
    a = smooth_float if dtype == np.float32 else (smooth_float * 5000 + 20000).astype(dtype)
    z = zarr.open_array(str(tmp_path / "a.zarr"), mode="w", shape=a.shape, chunks=(16, 16, 16), dtype=dtype,
                        compressor=volcl.numcodecs.Volcl(max_error=bound))
    z[:] = a
    err = np.abs(zarr.open_array(str(tmp_path / "a.zarr"), mode="r")[:].astype(np.float64) - a).max()
    assert err <= bound


def test_chunks_of_other_ranks_and_refused_dtypes():
    codec = volcl.numcodecs.Volcl()
    for shape in ((1000,), (30, 40), (2, 3, 8, 9)):
        a = np.arange(np.prod(shape), dtype=np.int16).reshape(shape)
        out = np.empty_like(a)
        codec.decode(codec.encode(a), out=out)
        assert np.array_equal(out, a)
    # float64 chunks stay float64, bit for bit (NaN, -0 and values beyond float32's range included).
    f = np.linspace(-1e300, 1e300, 4 * 5 * 6).reshape(4, 5, 6)
    f[0, 0, :3] = (np.nan, -0.0, 1e-310)
    back = codec.decode(codec.encode(f))
    assert back.dtype == np.float64 and np.array_equal(back.view(np.uint64), f.view(np.uint64))
    bounded = volcl.numcodecs.Volcl(pw_rel_error=1e-3)
    g = np.exp(np.linspace(-30, 30, 8 * 8 * 8)).reshape(8, 8, 8)
    assert np.all(np.abs(bounded.decode(bounded.encode(g)) - g) <= 1e-3 * g)
