"""numpy habits from Python: VczFile indexes like the array it holds, errors are builtin exception kinds."""
from __future__ import annotations

import errno
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import volcl


def volume(shape=(40, 36, 33), dtype=np.uint16):
    """Every voxel distinct (its flat index), so any misplaced voxel shows."""
    return np.arange(np.prod(shape), dtype=np.int64).reshape(shape).astype(dtype)


@pytest.fixture(scope="module")
def single():
    a = volume()
    return a, volcl.VczFile(volcl.encode(a, brick=16))  # 3 x 3 x 3 bricks, partial ones at the far edges


KEYS = [5, -1, -40, 39, np.int64(7), (Ellipsis, 5), (Ellipsis, -1), (..., 3, slice(None)), np.s_[::3],
        np.s_[::-2, 3, 1:30:4], np.s_[2:9, ..., ::-5], np.s_[-3:], np.s_[5:5], np.s_[30:2:-7, -2, -3],
        np.s_[None, 3], np.s_[4, None, ..., 2], np.s_[1, 2, 3], (), Ellipsis, np.s_[[1, 3, 38]],
        np.s_[:, [0, 35]], np.s_[:, :, np.arange(33) % 2 == 0]]


@pytest.mark.parametrize("key", KEYS, ids=[repr(k) for k in KEYS])
def test_vczfile_indexes_as_numpy_indexes_the_array(single, key):
    a, f = single
    got, expected = f[key], a[key]
    assert got.shape == expected.shape and got.dtype == expected.dtype
    assert np.array_equal(got, expected)


def test_vczfile_is_an_array_to_numpy(single):
    a, f = single
    assert f.shape == a.shape == (40, 36, 33) and f.ndim == 3 and len(f) == 40 and f.size == a.size
    assert f.dtype == a.dtype
    assert np.array_equal(np.asarray(f), a)
    as_float = np.asarray(f, dtype=np.float32)
    assert as_float.dtype == np.float32 and np.array_equal(as_float, a.astype(np.float32))
    assert np.array_equal(np.array(f, copy=True), a)
    assert float(np.mean(f[10])) == pytest.approx(float(a[10].mean()))


def test_out_of_range_and_invalid_indices_raise_index_error(single):
    _, f = single
    for key in (40, -41, (0, 0, 0, 0), (..., ...), 1.5, "a", (0, 99)):
        with pytest.raises(IndexError):
            f[key]


def test_only_the_bricks_an_index_touches_are_decoded():
    a = volume((48, 32, 32))
    vcz = bytearray(volcl.encode(a, brick=16))
    clean = volcl.VczFile(bytes(vcz))
    last = clean.brick_count - 1
    # Corrupt the last brick (z 32..48) alone: where its payload lies is where the decoded bytes differ.
    size = len(vcz)
    for at in range(size - 1, 0, -1):
        damaged = bytearray(vcz)
        damaged[at] ^= 0x5A
        try:
            opened = volcl.VczFile(bytes(damaged))  # a damaged header or index fails here: not a brick byte
        except volcl.IoError:
            continue
        try:
            opened.brick(last)
        except volcl.IoError:
            break
    else:
        pytest.fail("no byte of the last brick found")
    f = volcl.VczFile(bytes(damaged))
    assert np.array_equal(f[3], a[3]) and np.array_equal(f[:32, ::5], a[:32, ::5])  # bricks before it
    with pytest.raises(volcl.IoError):
        f[40]
    with pytest.raises(volcl.IoError):
        np.asarray(f)


def test_a_series_is_4d_and_frames_index_alike():
    frames = np.stack([volume((20, 18, 17)) + 1000 * t for t in range(3)]).astype(np.uint16)
    f = volcl.VczFile(volcl.encode(frames, brick=16))
    assert f.shape == frames.shape and f.ndim == 4 and len(f) == 3 and f.frames == 3
    assert f.frame_shape == (20, 18, 17)
    for key in (1, -1, np.s_[1:, 4], np.s_[::-2, ..., 3], np.s_[2, -1, ::2], Ellipsis):
        assert np.array_equal(f[key], frames[key]), key
    assert np.array_equal(np.asarray(f), frames)
    g = f.frame(-1)
    assert g.shape == (20, 18, 17) and np.array_equal(g[5], frames[2, 5])
    assert np.array_equal(np.asarray(g), frames[2]) and np.array_equal(g[..., -1], frames[2, ..., -1])
    with pytest.raises(IndexError):
        f.frame(3)


def test_errors_are_builtin_exception_kinds(tmp_path):
    missing = tmp_path / "missing.nii.gz"
    for call in (volcl.read, volcl.VczFile, volcl.read_image, volcl.TransferFunction.from_file):
        with pytest.raises(FileNotFoundError) as e:
            call(missing)
        assert isinstance(e.value, volcl.IoError) and isinstance(e.value, volcl.Error)
        assert e.value.errno == errno.ENOENT and e.value.filename == str(missing)
        assert str(missing) in str(e.value) and "\n" not in str(e.value)
    assert issubclass(volcl.IoError, OSError) and issubclass(volcl.UsageError, ValueError)
    assert issubclass(volcl.DataError, ValueError)
    a = np.zeros((8, 8, 8), np.uint8)
    with pytest.raises(TypeError, match="dtype int64"):
        volcl.encode(a.astype(np.int64))
    with pytest.raises(ValueError, match="3D"):
        volcl.encode(np.zeros((8, 8), np.uint8))
    with pytest.raises(OSError):
        volcl.decode(b"not a vcz at all")


def test_wrong_types_and_values_never_leak_binding_errors():
    a = np.zeros((16, 16, 16), np.uint8)
    f = volcl.VczFile(volcl.encode(a))
    calls = [lambda: f.read(frame=-1), lambda: f.read(frame=1), lambda: f.read(level=-2), lambda: f.brick(-1),
             lambda: f.read(frame=1.5), lambda: volcl.encode(a, levels=2.5), lambda: volcl.encode(a, threads=-1),
             lambda: volcl.encode(a, brick=-16), lambda: volcl.encode(a, gop="x"), lambda: f.frame("0")]
    for call in calls:
        with pytest.raises((TypeError, ValueError, IndexError)) as e:
            call()
        assert "incompatible function arguments" not in str(e.value)
    with pytest.raises(TypeError, match="levels="):
        volcl.encode(a, levels=2.5)
    with pytest.raises(volcl.UsageError, match="frame=1 out of range"):
        f.read(frame=1)


def test_messages_name_keyword_arguments():
    a = np.zeros((16, 16, 16), np.uint8)
    cases = [(lambda: volcl.encode(a, max_error=1, psnr=40), "max_error="),
             (lambda: volcl.encode(a, levels=0), "levels="),
             (lambda: volcl.encode(a, step=0.5), "step="),
             (lambda: volcl.encode(a, lossless=True, wavelet="cdf97"), "lossless=True"),
             (lambda: volcl.encode(a, bpv=0.0001), "bpv=")]
    for call, name in cases:
        with pytest.raises(volcl.UsageError) as e:
            call()
        assert name in str(e.value) and "--" not in str(e.value), str(e.value)


def test_volcl_console_script_runs_the_command_line():
    script = Path(sys.executable).parent / "volcl"
    assert script.exists(), f"no console script beside {sys.executable}"
    version = subprocess.run([str(script), "--version"], capture_output=True, text=True)
    assert version.returncode == 0 and version.stdout.strip().endswith(volcl.__version__)
    bad = subprocess.run([str(script), "frobnicate"], capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1


NPY_CASES = [("<u1", False, (5, 6, 7)), ("|i1", False, (5, 6, 7)), (">u2", False, (5, 6, 7)),
             ("<i2", True, (5, 6, 7)), ("<f4", True, (3, 5, 6, 7)), (">f8", False, (5, 6, 7)),
             ("<i4", False, (2, 5, 6, 7))]


@pytest.mark.parametrize("descr,fortran,shape", NPY_CASES)
def test_npy_files_read_as_numpy_saved_them(tmp_path, descr, fortran, shape):
    a = (volume(shape, np.int64) % 251 - (100 if descr[1] in "if" else 0)).astype(descr)
    if fortran:
        a = np.asfortranarray(a)
    path = tmp_path / "a.npy"
    np.save(path, a)
    v = volcl.read(path)
    expected = {"u1": np.uint8, "i1": np.int16, "u2": np.uint16, "i2": np.int16, "f8": np.float64}.get(descr[1:],
                                                                                                    np.float32)
    assert v.array.dtype == expected and v.array.shape == shape and v.metadata["format"] == "numpy npy"
    assert np.array_equal(v.array, a.astype(expected))


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16, np.float32])
def test_npy_files_written_load_in_numpy(tmp_path, dtype):
    a = volume((9, 4, 11), dtype)
    volcl.write(tmp_path / "a.npy", a)
    back = np.load(tmp_path / "a.npy")
    assert back.dtype == a.dtype and back.shape == a.shape and np.array_equal(back, a)
    assert np.array_equal(volcl.read(tmp_path / "a.npy").array, a)


def test_npy_files_of_other_types_and_shapes_are_refused_naming_the_file(tmp_path):
    for name, a in (("c.npy", np.zeros((2, 2, 2), np.complex64)), ("b.npy", np.zeros((2, 2, 2), bool)),
                    ("d2.npy", np.zeros((4, 4), np.uint8)), ("h.npy", np.zeros((2, 2, 2), np.float16))):
        np.save(tmp_path / name, a)
        with pytest.raises(volcl.DataError) as e:
            volcl.read(tmp_path / name)
        assert str(tmp_path / name) in str(e.value)
    good = tmp_path / "t.npy"
    np.save(good, np.zeros((4, 4, 4), np.uint8))
    (tmp_path / "short.npy").write_bytes(good.read_bytes()[:-5])
    with pytest.raises(volcl.IoError, match="truncated"):
        volcl.read(tmp_path / "short.npy")
