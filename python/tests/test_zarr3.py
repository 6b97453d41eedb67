"""zarr 3 with the volcl codec: volcl.zarr3.Volcl in zarr_format 3 arrays, volcl.numcodecs.Volcl in zarr_format 2."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import volcl

zarr = pytest.importorskip("zarr")
if int(zarr.__version__.split(".")[0]) < 3:
    pytest.skip(f"zarr {zarr.__version__}: these are zarr 3's tests (zarr 2's are test_numcodecs.py)",
                allow_module_level=True)

import volcl.numcodecs  # noqa: E402
import volcl.zarr3  # noqa: E402


def field(shape, dtype):
    """An analytic field with an edge, varying along every axis (a field constant along z codes losslessly in
    fewer bytes than any lossy mode, and the codec then keeps it exact), scaled to fill most of an integer
    type's range."""
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n) for n in shape), indexing="ij")
    f = np.sin(5 * x) * np.cos(3 * y) * np.cos(4 * z + x) + 2.0 * (x * x + y * y + z * z < 0.4)
    if np.dtype(dtype).kind == "f":
        return f.astype(dtype)
    info = np.iinfo(dtype)
    lo, hi = max(info.min, -20000), min(info.max, 60000)
    return (lo + (f - f.min()) / (f.max() - f.min()) * (hi - lo)).round().astype(dtype)


def test_lossless_round_trip_is_exact_and_the_codec_is_found_by_name(tmp_path):
    arrays = {np.dtype(t).name: field((20, 18, 21), t) for t in (np.uint8, np.int16, np.uint16, np.float32)}
    for name, a in arrays.items():  # chunks of 16 leave partial edge chunks on every axis
        z = zarr.create_array(str(tmp_path / f"{name}.zarr"), shape=a.shape, chunks=(16, 16, 16), dtype=a.dtype,
                              compressors=[volcl.zarr3.Volcl()])
        z[:] = a
        meta = json.loads((tmp_path / f"{name}.zarr" / "zarr.json").read_text())
        assert [c["name"] for c in meta["codecs"]] == ["bytes", "volcl"]
    # A new process that never imports volcl opens them: zarr loads the codec through the entry point.
    code = ("import sys, numpy as np, zarr\n"
            "for name in sys.argv[2:]:\n"
            "    np.save(f'{sys.argv[1]}/{name}.npy', zarr.open_array(f'{sys.argv[1]}/{name}.zarr', mode='r')[:])\n")
    subprocess.run([sys.executable, "-c", code, str(tmp_path), *arrays], check=True)
    for name, a in arrays.items():
        back = np.load(tmp_path / f"{name}.npy")
        assert back.dtype == a.dtype and back.tobytes() == a.tobytes(), name


@pytest.mark.parametrize("dtype,bound", [(np.float32, 0.01), (np.uint16, 4)])
def test_lossy_round_trip_is_within_the_bound(tmp_path, dtype, bound):
    a = field((40, 36, 33), dtype)
    z = zarr.create_array(str(tmp_path / "a.zarr"), shape=a.shape, chunks=(32, 32, 32), dtype=a.dtype,
                          compressors=[volcl.zarr3.Volcl(max_error=bound)])
    z[:] = a
    back = zarr.open_array(str(tmp_path / "a.zarr"), mode="r")
    err = np.abs(back[:].astype(np.float64) - a).max()
    assert 0 < err <= bound  # lossy (not silently lossless) and bounded
    assert np.array_equal(back[5:9, 30, ::3], back[:][5:9, 30, ::3])
    assert back.nbytes_stored() < a.nbytes / 2


def test_codec_metadata_round_trips_and_bad_configurations_are_refused():
    codec = volcl.zarr3.Volcl(psnr=45.0, levels=3, brick=32)
    d = codec.to_dict()
    assert d == {"name": "volcl", "configuration": {"psnr": 45.0, "levels": 3, "brick": 32, "entropy": "dense",
                                                    "threads": 2}}
    assert volcl.zarr3.Volcl.from_dict(d) == codec
    with pytest.raises(ValueError, match="unknown parameter"):
        volcl.zarr3.Volcl.from_dict({"name": "volcl", "configuration": {"max_eror": 1}})
    # float64 arrays stay float64: lossless bit for bit, a relative bound on every voxel in double.
    a = np.exp(np.linspace(-30, 30, 8 * 8 * 8)).reshape(8, 8, 8) * np.where(np.arange(8) % 2, -1, 1)
    for codec, check in ((volcl.zarr3.Volcl(), lambda b: np.array_equal(b.view(np.uint64), a.view(np.uint64))),
                         (volcl.zarr3.Volcl(pw_rel_error=1e-3), lambda b: np.all(np.abs(b - a) <= 1e-3 * np.abs(a)))):
        z = zarr.create_array(zarr.storage.MemoryStore(), shape=(8, 8, 8), chunks=(8, 8, 8), dtype=np.float64,
                              compressors=[codec])
        z[:] = a
        back = z[:]
        assert back.dtype == np.float64 and check(back)


def test_zarr_format_2_arrays_take_the_numcodecs_codec(tmp_path):
    a = field((20, 24, 28), np.int16)
    z = zarr.create_array(str(tmp_path / "v2.zarr"), shape=a.shape, chunks=(16, 16, 16), dtype=a.dtype,
                          zarr_format=2, compressors=volcl.numcodecs.Volcl())
    z[:] = a
    back = zarr.open_array(str(tmp_path / "v2.zarr"), mode="r")
    assert back.metadata.zarr_format == 2 and np.array_equal(back[:], a)
