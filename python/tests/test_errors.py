"""Errors from Python: the command line's one-line messages, as volcl exception classes."""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

import volcl
from conftest import cli_message, run_cli


def test_missing_file_raises_io_error_with_the_cli_message(tmp_path):
    missing = tmp_path / "missing.nrrd"
    with pytest.raises(volcl.IoError) as e:
        volcl.read(missing)
    assert str(e.value) == cli_message("info", str(missing))
    with pytest.raises(volcl.IoError) as e:
        volcl.VczFile(tmp_path / "missing.vcz")
    assert str(e.value) == cli_message("decode", str(tmp_path / "missing.vcz"), "-o", str(tmp_path / "o.raw"))


def test_two_rate_modes_raise_usage_error_with_the_cli_message_in_keywords(tmp_path):
    src = tmp_path / "v.raw"
    volcl.write(src, np.zeros((4, 4, 4), np.uint8))
    with pytest.raises(volcl.UsageError) as e:
        volcl.encode(np.zeros((4, 4, 4), np.uint8), max_error=1, psnr=40)
    cli = cli_message("encode", str(src), "--dims", "4,4,4", "--type", "uint8", "--max-error", "1", "--psnr", "40",
                      "-o", str(tmp_path / "o.vcz"))
    assert cli == "choose one of --lossless, --max-error, --rel-error, --pw-rel-error, --psnr, --bpv"
    assert str(e.value) == "choose one of lossless=True, max_error=, rel_error=, pw_rel_error=, psnr=, bpv="


def test_corrupted_vcz_raises_io_error_and_no_crash(tmp_path):
    vcz = bytearray(volcl.encode(np.arange(32768, dtype=np.uint16).reshape(32, 32, 32)))
    vcz[len(vcz) // 2] ^= 0xFF
    (tmp_path / "bad.vcz").write_bytes(bytes(vcz))
    with pytest.raises(volcl.IoError) as e:
        volcl.decode(bytes(vcz))
    assert "checksum" in str(e.value) or "corrupt" in str(e.value)
    with pytest.raises(volcl.IoError):
        volcl.decode(b"not a vcz at all")
    assert isinstance(e.value, volcl.Error) and "\n" not in str(e.value)


def test_bad_arguments_are_usage_errors():
    a = np.zeros((8, 8, 8), np.uint8)
    with pytest.raises(TypeError, match="not a volume type"):
        volcl.encode(a.astype(np.int64))
    with pytest.raises(volcl.UsageError, match="3D"):
        volcl.encode(np.zeros((8, 8), np.uint8))
    with pytest.raises(volcl.UsageError, match="wavelet"):
        volcl.encode(a, wavelet="nope")
    # NaN is no error for lossy coding either: kept exactly.
    assert np.isnan(volcl.decode(volcl.encode(np.full((8, 8, 8), np.nan, np.float32), max_error=0.1))).all()
    with pytest.raises(volcl.UsageError, match="no brick 99"):
        volcl.VczFile(volcl.encode(a)).brick(99)
    with pytest.raises(volcl.UsageError):
        volcl.decode(volcl.encode(a), level=9)
    # No transform level: the library refuses it as the command line does (no unreadable file).
    for rate in ({}, {"max_error": 0.5}):
        with pytest.raises(volcl.UsageError, match="levels"):
            volcl.encode(a, levels=0, **rate)


def test_write_refuses_unknown_format_and_leaves_nothing(tmp_path):
    with pytest.raises(volcl.UsageError):
        volcl.write(tmp_path / "v.unknown", np.zeros((2, 2, 2), np.uint8))
    assert list(tmp_path.iterdir()) == []


def test_python_m_volcl_is_the_command_line():
    version = subprocess.run([sys.executable, "-m", "volcl", "--version"], capture_output=True, text=True)
    assert version.returncode == 0 and version.stdout.strip().endswith(volcl.__version__)
    unknown = run_cli("frobnicate", check=False)
    assert unknown.returncode == 2 and "unknown subcommand 'frobnicate'" in unknown.stderr
    helped = run_cli("encode", "--help")
    assert "--max-error" in helped.stdout


def test_degenerate_sizes_and_refused_inputs():
    tf = {"domain": [0, 1], "color": [[0, 1, 1, 1]], "extinction": [[0, 1]]}
    for shape in ((1, 1, 1), (1, 1, 7), (3, 1, 1)):
        a = np.arange(np.prod(shape), dtype=np.float32).reshape(shape)
        assert np.array_equal(volcl.decode(volcl.encode(a)), a)
        assert np.abs(volcl.decode(volcl.encode(a, max_error=0.1)) - a).max() <= 0.1
    with pytest.raises(volcl.DataError, match="dimensions must be positive"):
        volcl.encode(np.zeros((0, 4, 4), np.uint8))
    with pytest.raises(volcl.IoError, match="not a .vcz"):
        volcl.decode(b"")
    with pytest.raises(volcl.UsageError, match="image size"):
        volcl.render(np.zeros((4, 4, 4), np.uint8), tf, width=0, height=4)
    with pytest.raises(volcl.UsageError, match="render.step"):
        volcl.render(np.zeros((4, 4, 4), np.uint8), tf, step=0, width=4, height=4)
    # NaN voxels are no error: they take the NaN colour, transparent unless nan_color says otherwise.
    nan = np.full((4, 4, 4), np.nan, np.float32)
    assert not volcl.render(nan, tf, width=4, height=4)[..., 3].any()
    red = volcl.render(nan, tf, width=4, height=4, options={"nan_color": [1, 0, 0, 1]})
    assert red[2, 2, 3] > 0.99 and red[2, 2, 0] > 0.99 and red[2, 2, 1] == 0
    with pytest.raises(volcl.UsageError, match="table size"):
        volcl.preintegration_table(tf, size=1, step=1.0)


def test_non_regular_inputs_and_bad_geometry_are_refused(tmp_path):
    # A FIFO blocked read() and VczFile forever; the subprocess guard turns a regression into a failure.
    fifo = tmp_path / "fifo.nrrd"
    os.mkfifo(fifo)
    code = ("import sys, volcl\n"
            "for call in (volcl.read, volcl.VczFile):\n"
            "    try:\n"
            "        call(sys.argv[1])\n"
            "    except volcl.IoError as e:\n"
            "        assert sys.argv[1] in str(e) and '\\n' not in str(e), str(e)\n"
            "    else:\n"
            "        raise SystemExit('accepted')\n")
    done = subprocess.run([sys.executable, "-c", code, str(fifo)], timeout=20, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    # Spacing and origin as every reader requires them: positive finite spacing, finite origin.
    a = np.zeros((4, 4, 4), np.uint8)
    for spacing in [(float("nan"), 1, 1), (0, 1, 1), (1, -1, 1), (1, 1, float("inf"))]:
        with pytest.raises(volcl.UsageError, match="spacing"):
            volcl.write(tmp_path / "v.nrrd", a, spacing=spacing)
        with pytest.raises(volcl.UsageError, match="spacing"):
            volcl.encode(a, spacing=spacing)
    with pytest.raises(volcl.UsageError, match="origin"):
        volcl.encode(a, origin=(0, float("nan"), 0))
    assert not (tmp_path / "v.nrrd").exists()
