"""Shared fixtures of the Python tests: the real data folder, the volcl command line, small volumes."""
from __future__ import annotations

import gzip
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import volcl

# The shared data sets sit beside the checkout (../shared/data), as for the C++ tests.
DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
MRI = DATA / "regular" / "t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz"


def need(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f"{path} is absent (the shared data sets are not beside this checkout)")
    return path


def run_cli(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    """`python -m volcl ARGS`: the volcl executable itself, through the package's entry."""
    proc = subprocess.run([sys.executable, "-m", "volcl", "--quiet", *args], capture_output=True, text=True)
    if check and proc.returncode != 0:
        raise AssertionError(f"volcl {' '.join(args)} exited {proc.returncode}: {proc.stderr.strip()}")
    return proc


def cli_message(*args: str) -> str:
    """The one-line error `volcl ARGS` prints, without its "volcl: " prefix."""
    proc = run_cli(*args, check=False)
    assert proc.returncode in (1, 2), proc
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("volcl: ")
    return lines[0][len("volcl: "):]


def read_raw(path: Path, shape, dtype) -> np.ndarray:
    return np.fromfile(path, dtype=dtype).reshape(shape)


@pytest.fixture(scope="session")
def mri() -> np.ndarray:
    """BrainWeb's simulated T1 MRI, 180x216x180 uint8, as a[z, y, x]."""
    raw = gzip.decompress(need(MRI).read_bytes())
    return np.frombuffer(raw, dtype=np.uint8).reshape(180, 216, 180)


@pytest.fixture(scope="session")
def walnut() -> volcl.Volume:
    """Voreen's walnut CT, 128x96x114 uint16 with a spacing and an origin."""
    return volcl.read(need(DATA / "regular" / "walnut.vvd"))


@pytest.fixture
def smooth_float() -> np.ndarray:
    """An analytic float32 field with a sharp edge, 40x36x33 (no axis a multiple of the brick)."""
    z, y, x = np.meshgrid(np.linspace(-1, 1, 40), np.linspace(-1, 1, 36), np.linspace(-1, 1, 33), indexing="ij")
    r = np.sqrt(x * x + y * y + z * z)
    return (np.sin(6 * x) * np.cos(4 * y) + 3 * (r < 0.6)).astype(np.float32)
