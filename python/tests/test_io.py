"""Volume files from Python: .vdb written and read by the installed package (its OpenVDB module and the
reader program beside libvolcl), and a corrupt grid refused with the command line's message."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import volcl
from conftest import cli_message


def test_vdb_round_trip_is_bit_exact(tmp_path):
    a = (np.arange(6 * 5 * 7, dtype=np.int64).reshape(6, 5, 7) * 37 - 600).astype(np.int16)
    volcl.write(tmp_path / "v.vdb", a, spacing=(0.5, 1.0, 2.0), origin=(1.0, -2.0, 3.0))
    back = volcl.read(tmp_path / "v.vdb")
    assert back.array.dtype == np.int16
    np.testing.assert_array_equal(back.array, a)
    assert back.spacing == (0.5, 1.0, 2.0) and back.origin == (1.0, -2.0, 3.0)


def test_corrupt_vdb_grid_raises_io_error_with_the_cli_message():
    # A fuzzing find whose grid data only libopenvdb reads: the reader program's error comes back as
    # volcl.IoError, the same line the command line prints.
    bad = Path(__file__).resolve().parents[2] / "fuzz" / "regressions" / "fuzz_read_vdb" / "forged-buffer-size.vdb"
    with pytest.raises(volcl.IoError) as e:
        volcl.read(bad)
    assert str(e.value) == cli_message("info", str(bad))
    assert "forged-buffer-size.vdb" in str(e.value) and "OpenVDB" in str(e.value)
