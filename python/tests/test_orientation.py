"""volcl.render frames oriented files as the command line does: views in patient (RAS) axes, front by default."""
from __future__ import annotations

import json
import struct

import numpy as np

import volcl
from conftest import run_cli

TF = {"domain": [0, 1], "color": [[0, 1, 1, 1], [1, 1, 1, 1]], "extinction": [[0, 0], [1, 0.6]]}


def anatomy(x, y, z):
    """Blobs at distinct patient sides (RAS millimetres): a nose anterior, an ear on the right, a crown on top."""
    def blob(cx, cy, cz, s):
        return np.exp(-((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / (2 * s * s))
    return (0.3 * blob(9.5, 14, 11, 5) + blob(8, 23, 13, 2.5) + 0.8 * blob(15, 12, 9, 2.5)
            + 0.9 * blob(6, 10, 18, 2.5))


def write_nifti(path, array_zyx, srow):
    """A float32 NIfTI-1 file written byte by byte: sform code 1 = `srow` (3 rows of 4)."""
    nz, ny, nx = array_zyx.shape
    h = bytearray(352)
    struct.pack_into("<i", h, 0, 348)
    struct.pack_into("<8h", h, 40, 3, nx, ny, nz, 1, 1, 1, 1)
    struct.pack_into("<hh", h, 70, 16, 32)
    spacing = [float(np.linalg.norm(np.array(srow)[:, c])) for c in range(3)]
    struct.pack_into("<8f", h, 76, 1, *spacing, 1, 0, 0, 0)
    struct.pack_into("<f", h, 108, 352)
    h[123] = 2
    struct.pack_into("<hh", h, 252, 0, 1)
    for r in range(3):
        struct.pack_into("<4f", h, 280 + 16 * r, *srow[r])
    h[344:348] = b"n+1\0"
    path.write_bytes(bytes(h) + np.ascontiguousarray(array_zyx, dtype="<f4").tobytes())
    return path


def ras_and_lps(tmp_path):
    """The anatomy stored RAS (20x24x16, spacing 1, 1.25, 1.5) and LPS (i and j reversed)."""
    n, sp = (20, 24, 16), (1.0, 1.25, 1.5)
    z, y, x = np.meshgrid(*[np.arange(n[a]) * sp[a] for a in (2, 1, 0)], indexing="ij")
    ras = anatomy(x, y, z)
    ext = [(n[a] - 1) * sp[a] for a in range(3)]
    ras_path = write_nifti(tmp_path / "ras.nii", ras, [[sp[0], 0, 0, 0], [0, sp[1], 0, 0], [0, 0, sp[2], 0]])
    lps_path = write_nifti(tmp_path / "lps.nii", ras[:, ::-1, ::-1],
                           [[-sp[0], 0, 0, ext[0]], [0, -sp[1], 0, ext[1]], [0, 0, sp[2], 0]])
    return ras_path, lps_path


def test_lps_copy_renders_like_the_ras_original_from_the_front(tmp_path):
    ras_path, lps_path = ras_and_lps(tmp_path)
    tf = volcl.TransferFunction.from_json(TF)
    kw = dict(width=48, height=48, step=0.25)
    front = volcl.render(ras_path, tf, view="front", **kw)
    assert front[..., 3].max() > 0.1
    assert np.sqrt(np.mean((volcl.render(lps_path, tf, view="front", **kw) - front) ** 2)) <= 2e-3
    # No view: patient data is framed from the front, as the command line frames it.
    assert np.sqrt(np.mean((volcl.render(lps_path, tf, **kw) - front) ** 2)) <= 2e-3
    back = volcl.render(ras_path, tf, view="back", **kw)
    assert np.sqrt(np.mean((back - front) ** 2)) > 0.02


def test_python_and_cli_frame_an_lps_nifti_alike(tmp_path):
    _, lps_path = ras_and_lps(tmp_path)
    tf_path = tmp_path / "tf.json"
    tf_path.write_text(json.dumps(TF))
    exr = tmp_path / "cli.exr"
    run_cli("render", "--volume", str(lps_path), "--tf", str(tf_path), "--tf-unit-distance", "1", "--step", "0.25",
            "--width", "48", "--height", "48", "-o", str(exr))
    cli, _ = volcl.read_image(exr)
    mine = volcl.render(lps_path, volcl.TransferFunction.from_file(tf_path), width=48, height=48, step=0.25)
    assert np.abs(mine[..., :4] - cli[..., :4]).max() <= 1e-5
