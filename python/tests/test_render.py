"""Rendering, transfer functions and pre-integration tables from Python, against the command line's output."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

import volcl
from conftest import DATA, need, run_cli

TF = {"domain": [0, 255],
      "color": [[0, 0.0, 0.0, 0.0], [128, 1.0, 0.6, 0.2], [255, 1.0, 1.0, 1.0]],
      "extinction": [[0, 0.0], [60, 0.0], [80, 0.8], [255, 0.05]]}


def render_both(tmp_path, volume_path, tf_path, scene):
    """The CLI's EXR for a scene file, and volcl.render for the same scene."""
    scene_path = tmp_path / "scene.json"
    scene_path.write_text(json.dumps({"volume": str(volume_path), "tf": str(tf_path), **scene}))
    exr = tmp_path / "cli.exr"
    run_cli("render", "--scene", str(scene_path), "-o", str(exr))
    cli, channels = volcl.read_image(exr)
    r = scene.get("render", {})
    mine = volcl.render(volume_path, volcl.TransferFunction.from_file(tf_path), camera=scene.get("camera"),
                        width=scene["image"]["width"], height=scene["image"]["height"],
                        mode=r.get("mode", "dvr"), step=r.get("step", 0.5),
                        preintegration=r.get("preintegration", "none"), effects=scene.get("effects"),
                        lights=scene.get("lights"))
    return cli, channels, mine


@pytest.mark.parametrize("mode,preint", [("dvr", "none"), ("dvr", "2d"), ("mip", "none"), ("xray", "none")])
def test_render_equals_the_cli_exr(tmp_path, mode, preint):
    volume = need(DATA / "regular" / "nucleon.nrrd")
    tf_path = tmp_path / "tf.json"
    tf_path.write_text(json.dumps(TF))
    scene = {"camera": {"projection": "orthographic", "eye": [20, 20, -80], "target": [20, 20, 20],
                        "up": [0, 1, 0], "height": 56.0},
             "image": {"width": 48, "height": 40}, "render": {"mode": mode, "step": 0.5, "preintegration": preint}}
    cli, channels, mine = render_both(tmp_path, volume, tf_path, scene)
    assert channels[:4] == ["R", "G", "B", "A"]
    assert mine.shape == (40, 48, len(channels)) and mine.dtype == np.float32
    assert np.abs(mine - cli).max() <= 1e-6
    assert mine[..., 3].max() > 0.1  # the camera sees the data


def test_render_with_shading_and_perspective_equals_the_cli(tmp_path):
    volume = need(DATA / "regular" / "HeadMRVolume.mhd")
    tf_path = tmp_path / "tf.json"
    tf_path.write_text(json.dumps({"domain": [0, 255], "color": [[0, 1, 1, 1], [255, 1, 0.8, 0.6]],
                                   "extinction": [[0, 0], [40, 0], [90, 0.05], [255, 0.2]]}))
    scene = {"camera": {"projection": "perspective", "eye": [300, 120, -250], "target": [94, 122, 82],
                        "up": [0, 0, 1], "fov_y_deg": 35},
             "image": {"width": 40, "height": 32}, "render": {"mode": "dvr", "step": 1.0},
             "lights": [{"type": "directional", "direction": [0.4, 0.6, -0.7]}], "effects": {"shading": {}}}
    cli, _, mine = render_both(tmp_path, volume, tf_path, scene)
    assert np.abs(mine - cli).max() <= 1e-6


def test_render_takes_arrays_views_and_presets(mri):
    img = volcl.render(volcl.Volume(mri), "preset:viridis", view="front", width=32, height=24)
    assert img.shape == (24, 32, 4) and np.isfinite(img).all() and img[..., 3].max() > 0
    shown = volcl.composite(img, (1, 1, 1, 1))
    assert shown.shape == (24, 32, 4) and 0 <= shown.min() and shown.max() <= 1
    with pytest.raises(volcl.UsageError, match="view"):
        volcl.render(mri, TF, view="sideways", width=8, height=8)


def test_a_float64_array_renders_as_its_float32_narrowing(mri):
    """Renderers sample float32: a float64 volume is narrowed where they take it, nowhere else."""
    wide = mri.astype(np.float64) + 1e-9  # detail float32 cannot hold
    a = volcl.render(volcl.Volume(wide), "preset:viridis", view="front", width=32, height=24)
    b = volcl.render(volcl.Volume(wide.astype(np.float32)), "preset:viridis", view="front", width=32, height=24)
    assert np.array_equal(a, b)


def test_transfer_function_reads_canonical_and_paraview_json():
    tf = volcl.TransferFunction.from_json(TF)
    assert tf.domain == (0, 255) and tf.extinction_at(80) == pytest.approx(0.8)
    assert tf.color_at(64) == pytest.approx((0.5, 0.3, 0.1))
    assert volcl.TransferFunction.from_json(tf.to_json()).to_dict() == tf.to_dict()
    paraview = [{"ColorSpace": "RGB", "Name": "ramp", "RGBPoints": [0, 0, 0, 1, 100, 1, 0, 0],
                 "Points": [0, 0, 0.5, 0, 50, 0.5, 0.5, 0, 100, 1, 0.5, 0]}]
    pv = volcl.TransferFunction.from_json(paraview)
    assert pv.extinction_at(50) == pytest.approx(-math.log(1 - 0.5), rel=1e-6)
    assert pv.extinction_at(100) == pytest.approx(1000.0)  # opacity 1: the documented large finite tau
    assert pv.color_at(100) == pytest.approx((1, 0, 0), abs=1e-4)
    built = volcl.TransferFunction(domain=(0, 1), color=[(0, 1, 0, 0), (1, 0, 0, 1)], extinction=[(0, 0), (1, 2)])
    assert built.extinction_at(0.25) == pytest.approx(0.5)
    assert "viridis" in volcl.TransferFunction.preset_names()
    with pytest.raises(volcl.DataError, match="unknown key"):
        volcl.TransferFunction.from_json({"domain": [0, 1], "colour": []})


def test_preintegration_table_equals_volcl_preint(tmp_path):
    tf_path = tmp_path / "tf.json"
    tf_path.write_text(json.dumps(TF))
    for args, kwargs in ((["--step", "0.5"], {"step": 0.5}),
                         (["--lengths", "4", "--max-length", "2"], {"lengths": 4, "max_length": 2.0})):
        exr = tmp_path / "table.exr"
        run_cli("preint", "--tf", str(tf_path), "--size", "32", *args, "-o", str(exr))
        cli, _ = volcl.read_image(exr)
        table = volcl.preintegration_table(volcl.TF.from_file(tf_path), size=32, **kwargs)
        assert np.abs(table.reshape(cli.shape) - cli).max() <= 1e-6
    table = volcl.preintegration_table(TF, size=16, step=1.0)
    ref = volcl.preintegration_table(TF, size=16, step=1.0, method="reference")
    assert table.shape == (16, 16, 4) and np.abs(table - ref).max() <= 1e-4
    with pytest.raises(volcl.UsageError, match="either step="):
        volcl.preintegration_table(TF, step=1.0, lengths=4)


def test_devices_lists_the_device_the_calls_use():
    devs = volcl.devices()
    assert devs and {"index", "name", "platform", "type"} <= set(devs[0])


@pytest.mark.parametrize("tf", [None, "preset:viridis"])
@pytest.mark.parametrize("name", ["regular/walnut.vvd", "regular/HeadMRVolume.mhd"])
def test_render_defaults_equal_the_cli_without_flags(tmp_path, name, tf):
    # Without a step, a transfer function or a camera, Python renders what `volcl render --volume X` does:
    # half a voxel, ParaView's default TF (or the preset spread over the data range) with the automatic
    # opacity unit distance, the same framing. walnut's spacing is 0.0156, so world-unit defaults differ.
    volume = need(DATA / name)
    exr = tmp_path / "cli.exr"
    run_cli("render", "--volume", str(volume), "--width", "48", "--height", "40", "-o", str(exr),
            *(["--tf", tf] if tf else []))
    cli, _ = volcl.read_image(exr)
    mine = volcl.render(volume, tf, width=48, height=40)
    assert mine[..., 3].max() > 0.05  # visible
    assert np.abs(mine - cli).max() <= 1e-6
