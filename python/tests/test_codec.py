"""The codec from Python: lossless bit-exact, error bounds, and region/level/frame decodes equal to the CLI's."""
from __future__ import annotations

import numpy as np
import pytest

import volcl
from conftest import DATA, need, read_raw, run_cli


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16, np.float32])
def test_lossless_round_trip_is_bit_exact(dtype, smooth_float):
    rng = np.random.default_rng(7)
    if np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        a = rng.integers(info.min, int(info.max) + 1, size=(17, 23, 29), dtype=dtype)
        a[:8] = np.clip(smooth_float[:8, :23, :29] * 1000, info.min, info.max).astype(dtype)  # a smooth part
    else:
        a = smooth_float.copy()
        a[0, 0, :4] = [np.nan, np.inf, -np.inf, -0.0]  # lossless keeps every bit pattern
    vcz = volcl.encode(a, lossless=True)
    out = volcl.decode(vcz)
    assert out.dtype == a.dtype and out.shape == a.shape
    assert out.tobytes() == a.tobytes()


def test_lossless_real_volumes_are_bit_exact(mri, walnut):
    for a in (mri, walnut.array):
        assert np.array_equal(volcl.decode(volcl.encode(a)), a)


@pytest.mark.parametrize("bound", [0.01, 0.5])
def test_max_error_holds_on_every_voxel(bound, smooth_float, walnut):
    for a, e in ((smooth_float, bound), (walnut.array, 100 * bound)):
        report = {}
        out = volcl.decode(volcl.encode(a, max_error=e, report=report))
        err = np.abs(out.astype(np.float64) - a.astype(np.float64)).max()
        assert err <= e, (err, e)
        assert report["max_error"] <= e and report["bytes"] > 0


def test_psnr_target_is_met_within_half_a_db(mri):
    out = volcl.decode(volcl.encode(mri, psnr=50))
    a, b = mri.astype(np.float64), out.astype(np.float64)
    psnr = 10 * np.log10((a.max() - a.min()) ** 2 / np.mean((a - b) ** 2))
    assert psnr >= 49.5


def _adversarial_float64():
    rng = np.random.default_rng(5)
    z, y, x = np.mgrid[0:13, 0:18, 0:21]
    smooth = np.sin(0.4 * x) * np.cos(0.3 * y) + 0.2 * np.sin(0.5 * z)
    mixed = smooth + 1e-12 * rng.uniform(-1, 1, smooth.shape)  # detail below float32's precision
    wide = np.where(x < 10, -1e300, 1e-300) * (2 + smooth)  # beyond float32's range both ways
    special = 100 * smooth
    r = rng.uniform(-1, 1, smooth.shape)
    special[r > 0.95] = np.inf
    special[r < -0.95] = -np.inf
    special[np.abs(r) < 0.03] = np.frombuffer(np.uint64(0x7FF8000000001234).tobytes(), np.float64)[0]
    special[(np.abs(r) >= 0.03) & (np.abs(r) < 0.06)] = -0.0
    denormal = 1e-310 * (1.5 + smooth)
    return {"mixed": mixed, "wide": wide, "special": special, "denormal": denormal}


def _within(a, b, mode, target):
    """Every voxel of b within the bound of a (NaN/Inf bit for bit, and zeros for the point-wise bound), in double."""
    exact = ~np.isfinite(a) | ((a == 0) if mode == "pw_rel_error" else False)
    assert np.array_equal(a[exact].view(np.uint64), b[exact].view(np.uint64))
    x, d = a[~exact], np.abs(a[~exact] - b[~exact])
    fin = a[np.isfinite(a)]
    if mode == "max_error":
        assert np.all(d <= target)
    elif mode == "rel_error":
        assert np.all(d <= target * fin.max() - target * fin.min())
    elif mode == "pw_rel_error":
        assert np.all(d <= target * np.abs(x))


def test_float64_is_kept_bit_for_bit_and_every_bound_holds_in_double():
    for name, a in _adversarial_float64().items():
        out = volcl.decode(volcl.encode(a, brick=16, levels=3))
        assert out.dtype == np.float64, name
        assert np.array_equal(out.view(np.uint64), a.view(np.uint64)), name
        for mode, target in (("rel_error", 1e-3), ("pw_rel_error", 1e-2)):
            b = volcl.decode(volcl.encode(a, brick=16, levels=3, **{mode: target}))
            assert b.dtype == np.float64
            _within(a, b, mode, target)
    with pytest.raises(volcl.UsageError, match="float64"):
        volcl.encode(_adversarial_float64()["mixed"], bpv=2)


def test_grid_and_metadata_are_kept(walnut):
    vcz = volcl.encode(walnut, max_error=2, metadata={"subject": "walnut"})
    f = volcl.VczFile(vcz)
    assert f.shape == walnut.array.shape and f.dtype == walnut.array.dtype
    assert f.spacing == pytest.approx(walnut.spacing) and f.origin == pytest.approx(walnut.origin)
    assert f.metadata["subject"] == "walnut"
    v = f.read(level=1)
    assert v.spacing == pytest.approx(tuple(2 * s for s in walnut.spacing))


def test_region_level_and_frame_decodes_equal_the_cli(tmp_path, walnut):
    vcz_path = tmp_path / "walnut.vcz"
    vcz_path.write_bytes(volcl.encode(walnut, max_error=4))
    f = volcl.VczFile(vcz_path)
    cases = [("10,20,5:100,90,77", 0), ("0,0,0:128,96,114", 2), ("3,0,50:64,33,51", 1)]
    for region, level in cases:
        out = tmp_path / f"cli_{level}.raw"
        run_cli("decode", str(vcz_path), "--region", region, "--level", str(level), "-o", str(out))
        mine = f.read(region=region, level=level).array
        assert np.array_equal(read_raw(out, mine.shape, mine.dtype), mine), (region, level)
    # numpy slices in array order (z, y, x) name the same box as the CLI's x0,y0,z0:x1,y1,z1.
    assert np.array_equal(f[5:77, 20:90, 10:100], f.read(region="10,20,5:100,90,77").array)


def test_series_frame_decodes_equal_the_cli(tmp_path):
    folder = need(DATA / "timevarying" / "viscousfingers")
    series = volcl.read(str(folder / "00[1-3]_density_*.vti"))
    assert series.array.shape == (3, 64, 64, 64) and series.frames == 3
    vcz_path = tmp_path / "fingers.vcz"
    vcz_path.write_bytes(volcl.encode(series, max_error=0.05))
    f = volcl.VczFile(vcz_path)
    assert len(f) == 3
    for k in range(3):
        out = tmp_path / f"frame{k}.raw"
        run_cli("decode", str(vcz_path), "--frame", str(k), "-o", str(out))
        mine = volcl.decode(vcz_path.read_bytes(), frame=k)
        assert np.array_equal(read_raw(out, mine.shape, mine.dtype), mine)
        assert np.abs(mine - series.array[k]).max() <= 0.05


def test_cli_encoded_file_decodes_the_same_in_python(tmp_path, walnut):
    src = need(DATA / "regular" / "walnut.vvd")
    vcz_path, out = tmp_path / "w.vcz", tmp_path / "w.raw"
    run_cli("encode", str(src), "--psnr", "45", "-o", str(vcz_path))
    run_cli("decode", str(vcz_path), "-o", str(out))
    mine = volcl.read(vcz_path).array
    assert np.array_equal(read_raw(out, mine.shape, mine.dtype), mine)


def test_bricks_are_the_matching_parts_of_the_whole(walnut):
    f = volcl.VczFile(volcl.encode(walnut.array, brick=32))
    whole = f.read().array
    assert f.brick_count == int(np.prod(f.brick_grid)) > 1
    for i, box, voxels in f.bricks():
        assert np.array_equal(voxels, whole[box]), i


def test_outputs_share_the_decoder_buffer():
    a = np.arange(4096, dtype=np.uint16).reshape(16, 16, 16)
    out = volcl.decode(volcl.encode(a))
    assert not out.flags.owndata and out.base is not None and out.flags.c_contiguous and out.flags.writeable
