"""The notebook-style tour in docs/examples runs start to end and draws its figure."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

TOUR = Path(__file__).resolve().parents[2] / "docs" / "examples" / "python_tour.py"
MRI = Path("/usr/share/mricron/templates/ch2better.nii.gz")


def test_python_tour_runs(tmp_path):
    pytest.importorskip("matplotlib")
    if not MRI.exists():
        pytest.skip(f"{MRI} is absent (Debian's mricron-data, scripts/apt-packages.txt)")
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(TOUR), str(tmp_path)], capture_output=True, text=True, env=env,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "PSNR measured here" in proc.stdout
    assert (tmp_path / "python-tour.png").stat().st_size > 10000
