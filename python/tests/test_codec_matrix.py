"""Every codec mode x every writer and reader (CLI, Python, HDF5 filter, ParaView reader): same bytes or values.

Writers: `volcl encode` and `volcl.encode` must write the same bytes for the same input and options (the
level-of-detail statistics included); the HDF5 filter's chunk is the same .vcz `volcl.encode` writes for the
chunk's options, after the filter's 40-byte chunk header. Readers: `volcl decode`, `volcl.decode`,
`volcl.VczFile`, `volcl.read`, h5py through the filter and the ParaView reader plugin in pvbatch must give the
same voxels, grid and frames. The HDF5 and ParaView columns run where their programs are installed and built.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import volcl
from conftest import cli_message, run_cli

ROOT = Path(__file__).resolve().parents[2]
BUILD = ROOT / "build"
SHAPE = (22, 19, 27)  # z, y, x: no axis a multiple of the 16-voxel bricks used below
SPACING = (0.5, 0.75, 1.25)
ORIGIN = (-3.0, 2.0, 7.5)
FRAMES = 5

# Rate modes: the command line's flags and volcl.encode's keywords for the same target.
MODES = {
    "lossless": ([], {}),
    "max_error": (["--max-error", "0.02"], {"max_error": 0.02}),
    "psnr": (["--psnr", "42"], {"psnr": 42.0}),
    "bpv": (["--bpv", "1.5"], {"bpv": 1.5}),
    "rel_error": (["--rel-error", "0.002"], {"rel_error": 0.002}),
    "pw_rel_error": (["--pw-rel-error", "0.01"], {"pw_rel_error": 0.01}),
}
# Series frame structures: I frames only, and motion-compensated P and B frames.
STRUCTURES = {
    "I": (["--motion", "none"], {"motion": "none"}),
    "PB": (["--gop", "4", "--b-frames", "1"], {"gop": 4, "b_frames": 1}),
}
# Options every case shares: several bricks per axis, so brick borders are crossed.
COMMON = (["--brick", "16", "--levels", "3"], {"brick": 16, "levels": 3})


def field(dtype, t: float = 0.0) -> np.ndarray:
    """A non-symmetric analytic field with a sharp-edged ball that moves with t, a[z, y, x]."""
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n) for n in SHAPE), indexing="ij")
    v = np.sin(5 * x + 0.4 * t) * np.cos(3 * y) + 2.0 * ((x - 0.15 * t) ** 2 + y * y + z * z < 0.3) + 0.3 * z
    if dtype == np.uint16:
        return np.round((v + 2.5) / 6.0 * 60000).astype(np.uint16)
    if dtype == np.float64:
        return v + 1e-11 * x  # detail float32 cannot hold
    return v.astype(np.float32)


def labels() -> np.ndarray:
    """A piecewise-constant uint16 label volume in 700 values (boxes), whose bricks the encoder codes as voxels."""
    z, y, x = np.meshgrid(*(np.arange(n) for n in SHAPE), indexing="ij")
    return ((x // 4 + 7 * (y // 5) + 31 * (z // 3)) % 700).astype(np.uint16)


def series(dtype) -> np.ndarray:
    return np.stack([field(dtype, t) for t in range(FRAMES)])


def write_inputs(folder: Path, frames: np.ndarray) -> list:
    """Each frame as an NRRD file with the grid (the command line's input)."""
    paths = []
    for k, a in enumerate(frames):
        p = folder / f"in_{k}.nrrd"
        volcl.write(p, volcl.Volume(a, SPACING, ORIGIN))
        paths.append(str(p))
    return paths


def cli_decode(vcz: Path, frame: int, work: Path) -> volcl.Volume:
    out = work / f"cli_{vcz.stem}_{frame}.nrrd"
    run_cli("decode", str(vcz), "--frame", str(frame), "-o", str(out))
    return volcl.read(out)


def assert_same_grid(v: volcl.Volume, what: str):
    assert v.spacing == pytest.approx(SPACING, rel=1e-12), what
    assert v.origin == pytest.approx(ORIGIN, rel=1e-12), what


def check_against_input(out: np.ndarray, a: np.ndarray, mode: str, bound: float, what: str):
    """The rate mode's promise, measured on the decoded voxels (PSNR over the input's value range)."""
    d = out.astype(np.float64) - a.astype(np.float64)
    if mode == "lossless":
        assert out.tobytes() == a.tobytes(), what
    elif mode == "max_error":
        assert np.abs(d).max() <= bound, what
    elif mode == "psnr":  # float64: checked in double without the series' 0.5 dB slack
        span = float(a.max()) - float(a.min())
        slack = 0.0 if a.dtype == np.float64 else 0.5
        assert 10 * np.log10(span * span / np.mean(d * d)) >= 42.0 - slack, what
    elif mode == "rel_error":  # over the frame's finite values
        finite = a[np.isfinite(a)].astype(np.float64)
        assert np.abs(d).max() <= 0.002 * (finite.max() - finite.min()), what
    elif mode == "pw_rel_error":  # zeros exact, signs kept
        assert np.all(np.abs(d) <= 0.01 * np.abs(a.astype(np.float64))), what
        assert np.all(np.sign(out) == np.sign(a)), what


def encode_cases():
    for dtype in (np.float32, np.uint16, np.float64):
        for mode in MODES:
            if dtype == np.float64 and mode == "bpv":
                continue  # refused for float64 (test_float64_bit_budget_is_refused_on_both_sides)
            yield pytest.param(dtype, mode, None, id=f"{np.dtype(dtype).name}-{mode}-volume")
            for structure in STRUCTURES:
                if dtype != np.float32 and mode in ("psnr", "bpv"):
                    continue  # the series structures are covered by float32; the others keep the volume cases
                yield pytest.param(dtype, mode, structure, id=f"{np.dtype(dtype).name}-{mode}-{structure}")


@pytest.mark.parametrize("dtype, mode, structure", list(encode_cases()))
def test_cli_and_python_write_the_same_file_and_every_reader_agrees(tmp_path, dtype, mode, structure):
    frames = series(dtype) if structure else field(dtype)[None]
    inputs = write_inputs(tmp_path, frames)
    cli_flags, py_kwargs = MODES[mode]
    bound = 3.0 if dtype == np.uint16 else 0.02
    if mode == "max_error":
        cli_flags, py_kwargs = ["--max-error", str(bound)], {"max_error": bound}
    cli_flags = cli_flags + COMMON[0] + (STRUCTURES[structure][0] if structure else [])
    py_kwargs = {**py_kwargs, **COMMON[1], **(STRUCTURES[structure][1] if structure else {})}

    # Writers: the command line (which adds the level-of-detail statistics) and Python with the same options.
    cli_vcz = tmp_path / "cli.vcz"
    run_cli("encode", *inputs, "-o", str(cli_vcz), *cli_flags)
    volume = volcl.Volume(frames if structure else frames[0], SPACING, ORIGIN)
    py_bytes = volcl.encode(volume, lod_stats=True, **py_kwargs)
    assert py_bytes == cli_vcz.read_bytes()
    plain = tmp_path / "plain.vcz"
    run_cli("encode", *inputs, "-o", str(plain), "--no-lod-stats", *cli_flags)
    assert volcl.encode(volume, **py_kwargs) == plain.read_bytes()

    # Readers: every one gives the command line's voxels and grid, frame by frame.
    f = volcl.VczFile(cli_vcz)  # the header, metadata included, as Python sees a command-line file
    assert f.frame_shape == SHAPE and f.frames == len(frames) and f.dtype == frames.dtype
    assert f.shape == (frames.shape if len(frames) > 1 else SHAPE)
    assert f.spacing == pytest.approx(SPACING) and f.origin == pytest.approx(ORIGIN)
    assert f.header["rate"] == mode
    assert isinstance(f.metadata["volcl:lod"], bytes)
    types = f.header["frame_types"]
    if structure == "PB":
        # A planned P/B frame falls back to an I frame when that is smaller, and lossless float32 series
        # (raw bit patterns) are I frames; the float32 lossy series here do predict (the point-wise bound's
        # P frames may all fall back: the field's zero crossings need exact voxels wherever they move).
        assert types[0] == "I" and set(types) <= {"I", "P", "B"}, types
        if dtype == np.float32 and mode not in ("lossless", "pw_rel_error"):
            assert set(types) == {"I", "P", "B"}, types
        if dtype == np.float64:  # float64 frames are I frames, each with its float64 layer
            assert set(types) == {"I"}, types
    else:
        assert set(types) == {"I"}, types
    whole = volcl.read(cli_vcz)
    assert_same_grid(whole, "volcl.read")
    for k in range(len(frames)):
        reference = cli_decode(cli_vcz, k, tmp_path)
        assert_same_grid(reference, f"volcl decode frame {k}")
        ref = reference.array
        assert ref.dtype == frames.dtype and ref.shape == SHAPE
        for name, got in (("volcl.decode", volcl.decode(cli_vcz.read_bytes(), frame=k)),
                          ("volcl.decode(python bytes)", volcl.decode(py_bytes, frame=k)),
                          ("VczFile[k]", f[k] if len(frames) > 1 else f[:, :, :]),
                          ("VczFile.read", f.read(frame=k).array),
                          ("volcl.read", whole.frame(k))):
            assert got.dtype == ref.dtype and got.tobytes() == ref.tobytes(), (name, k)
        check_against_input(ref, frames[k], mode, bound, f"frame {k}")
    if mode == "bpv":  # the whole file counts, overhead and level-of-detail statistics included
        assert 8 * cli_vcz.stat().st_size <= 1.5 * frames.size and 8 * plain.stat().st_size <= 1.5 * frames.size


def test_float64_bit_budget_is_refused_on_both_sides(tmp_path):
    inputs = write_inputs(tmp_path, field(np.float64)[None])
    assert "float64" in cli_message("encode", *inputs, "-o", str(tmp_path / "b.vcz"), "--bpv", "2")
    assert run_cli("encode", *inputs, "-o", str(tmp_path / "b.vcz"), "--bpv", "2", check=False).returncode == 2
    assert not (tmp_path / "b.vcz").exists()
    with pytest.raises(volcl.UsageError, match="float64"):
        volcl.encode(field(np.float64), bpv=2)


@pytest.mark.parametrize("mode", list(MODES))
def test_voxel_coded_label_files_read_the_same_everywhere(tmp_path, mode):
    """Labels: the encoder codes bricks as voxels (version 7) in every mode; no file exceeds the lossless one,
    and every reader decodes it to the same voxels, within the mode's promise (HDF5's column:
    test_hdf5_filter_chunks_are_the_python_codec_files)."""
    a = labels()
    inputs = write_inputs(tmp_path, a[None])
    cli_flags, py_kwargs = MODES[mode]
    if mode == "max_error":
        cli_flags, py_kwargs = ["--max-error", "3"], {"max_error": 3.0}
    cli_vcz = tmp_path / "cli.vcz"
    run_cli("encode", *inputs, "-o", str(cli_vcz), *cli_flags, *COMMON[0])
    volume = volcl.Volume(a, SPACING, ORIGIN)
    assert volcl.encode(volume, lod_stats=True, **py_kwargs, **COMMON[1]) == cli_vcz.read_bytes()
    lossless = volcl.encode(volume, lod_stats=True, **COMMON[1])
    data = cli_vcz.read_bytes()
    assert len(data) <= len(lossless)
    assert int.from_bytes(data[8:12], "little") == 7  # voxel-coded bricks
    ref = cli_decode(cli_vcz, 0, tmp_path).array
    for name, got in (("volcl.decode", volcl.decode(data)), ("VczFile", volcl.VczFile(cli_vcz)[:, :, :]),
                      ("volcl.read", volcl.read(cli_vcz).array)):
        assert got.dtype == ref.dtype and got.tobytes() == ref.tobytes(), name
    check_against_input(ref, a, mode, 3.0, f"labels {mode}")


def test_nifti_metadata_of_a_cli_file_reads_in_python(tmp_path):
    """The command line stores a NIfTI source's header fields as text: Python shows them as JSON text."""
    src = tmp_path / "in.nrrd"
    volcl.write(src, volcl.Volume(field(np.uint16), SPACING, ORIGIN))
    nii = tmp_path / "in.nii"
    run_cli("convert", str(src), "-o", str(nii))
    vcz = tmp_path / "n.vcz"
    run_cli("encode", str(nii), "-o", str(vcz))
    f = volcl.VczFile(vcz)
    assert isinstance(json.loads(f.metadata["volcl:nifti"]), dict)
    assert isinstance(f.metadata["volcl:lod"], bytes)
    out = tmp_path / "out.raw"
    run_cli("decode", str(vcz), "-o", str(out))
    assert np.fromfile(out, dtype=np.uint16).tobytes() == volcl.decode(vcz.read_bytes()).tobytes()


# ---- HDF5 filter column: h5py (Debian's python3) writes and reads through the plugin -------------------------

HDF5_PLUGIN_DIR = BUILD / "hdf5-plugins"
SYSTEM_PYTHON = Path("/usr/bin/python3")
HDF5_SCRIPT = r"""
import sys, h5py, numpy as np
sys.path.insert(0, sys.argv[1])
import volcl_hdf5
path, src, rank = sys.argv[2], sys.argv[3], int(sys.argv[4])
a = np.load(src)
cases = {"lossless": {"compression": 420}, "max_error": volcl_hdf5.filter(max_error=float(sys.argv[5])),
         "psnr": volcl_hdf5.filter(psnr=42.0), "bpv": volcl_hdf5.filter(bpv=1.5),
         "rel_error": volcl_hdf5.filter(rel_error=0.002), "pw_rel_error": volcl_hdf5.filter(pw_rel_error=0.01)}
with h5py.File(path, "w") as h:
    for name, kw in cases.items():
        h.create_dataset(name, data=a, chunks=a.shape, **kw)
with h5py.File(path, "r") as h:
    for name in cases:
        d = h[name]
        np.save(path + "." + name + ".values.npy", d[...])
        _, chunk = d.id.read_direct_chunk((0,) * rank)
        open(path + "." + name + ".chunk", "wb").write(chunk)
"""


def hdf5_plugin_dir() -> Path:
    if (HDF5_PLUGIN_DIR / "libH5Zvolcl.so").exists():
        return HDF5_PLUGIN_DIR
    pytest.skip(f"the HDF5 filter plugin is not built under {BUILD} (libhdf5-dev absent)")


def chunk_options(shape3):
    """The options the filter chooses for a chunk of this (z, y, x) shape (docs/scaleout.md)."""
    smallest, levels = min(shape3), 1
    while levels < 6 and (2 << levels) <= smallest:
        levels += 1
    unit = 1 << levels
    brick = tuple((min(n, 256) + unit - 1) // unit * unit for n in reversed(shape3))
    return {"levels": levels, "brick": brick, "threads": 1}


# "labels": one chunk of a label volume, whose bricks are voxel-coded (version 7) inside the filter's chunk.
@pytest.mark.parametrize("dtype, frames", [(np.float32, 1), (np.float32, 3), (np.uint16, 1), (np.uint16, 3),
                                           ("labels", 1)])
def test_hdf5_filter_chunks_are_the_python_codec_files(tmp_path, dtype, frames):
    if not SYSTEM_PYTHON.exists():
        pytest.skip("/usr/bin/python3 (Debian's, with h5py) is absent")
    plugin = hdf5_plugin_dir()
    if dtype == "labels":
        a, dtype = labels(), np.uint16
    else:
        a = series(dtype)[:frames] if frames > 1 else field(dtype)
    np.save(tmp_path / "a.npy", a)
    bound = 0.02 if dtype == np.float32 else 3.0
    env = {**os.environ, "HDF5_PLUGIN_PATH": str(plugin)}
    h5 = tmp_path / "m.h5"
    proc = subprocess.run([str(SYSTEM_PYTHON), "-c", HDF5_SCRIPT, str(ROOT / "plugins" / "hdf5" / "python"),
                           str(h5), str(tmp_path / "a.npy"), str(a.ndim), str(bound)],
                          capture_output=True, text=True, env=env)
    if proc.returncode != 0 and "No module named 'h5py'" in proc.stderr:
        pytest.skip("h5py is not installed for /usr/bin/python3 (python3-h5py)")
    assert proc.returncode == 0, proc.stderr
    options = chunk_options(SHAPE)
    # bpv bounds the stored chunk: the filter's 40-byte chunk header comes out of the codec's budget.
    header_bits = 40 * 8 / float(a.size)
    for name, kwargs in (("lossless", {}), ("max_error", {"max_error": bound}), ("psnr", {"psnr": 42.0}),
                         ("bpv", {"bpv": 1.5 - header_bits}), ("rel_error", {"rel_error": 0.002}),
                         ("pw_rel_error", {"pw_rel_error": 0.01})):
        stored = (tmp_path / f"m.h5.{name}.chunk").read_bytes()
        values = np.load(tmp_path / f"m.h5.{name}.values.npy")
        assert stored[:4] == b"VCZH"
        vcz = stored[40:]
        expected = volcl.encode(a, **options, **kwargs)  # a 4D chunk is a series with the default GOP

        def voxels(b):
            return np.stack([volcl.decode(b, frame=k) for k in range(frames)]) if frames > 1 else volcl.decode(b)

        if name == "psnr" and vcz != expected:
            # The filter holds the target itself on every chunk, without the codec's 0.5 dB slack (a chunk
            # may be an edge chunk's real voxels): it codes again only a chunk whose Python file falls short.
            def worst_psnr(b):
                out = voxels(b) if frames > 1 else voxels(b)[None]
                ins = a if frames > 1 else a[None]
                worst = np.inf
                for o, i in zip(out, ins):
                    span = float(i.max()) - float(i.min())
                    d = o.astype(np.float64) - i.astype(np.float64)
                    worst = min(worst, 10 * np.log10(span * span / np.mean(d * d)))
                return worst

            assert worst_psnr(expected) < 42.0 <= worst_psnr(vcz), name
        else:
            assert vcz == expected, name
        if name == "bpv":
            assert len(stored) * 8 <= 1.5 * a.size
        decoded, inputs = (voxels(vcz), a) if frames > 1 else (voxels(vcz)[None], a[None])
        for k in range(frames):  # each frame keeps the promise (PSNR over the frame's value range)
            check_against_input(decoded[k], inputs[k], name, bound, f"hdf5 {name} frame {k}")
        assert values.dtype == a.dtype and values.tobytes() == voxels(vcz).tobytes(), name


# ---- ParaView column: the reader plugin in pvbatch -----------------------------------------------------------

PARAVIEW_SCRIPT = r"""
import json, sys
import numpy as np
from paraview import servermanager
from paraview.simple import LoadPlugin
from vtkmodules.util.numpy_support import vtk_to_numpy
plugin, vcz, out = sys.argv[1:4]
LoadPlugin(plugin, ns=globals())
reader = VolclVczReader(FileName=vcz)
reader.UpdatePipelineInformation()
times = list(reader.TimestepValues) if len(reader.TimestepValues or []) else [None]
arrays, grids = [], []
for t in times:
    reader.UpdatePipeline() if t is None else reader.UpdatePipeline(t)
    img = servermanager.Fetch(reader)
    pd = img.GetPointData()
    arr = vtk_to_numpy(pd.GetArray(0))
    nx, ny, nz = img.GetDimensions()
    arrays.append(arr.reshape(nz, ny, nx))
    grids.append({"spacing": list(img.GetSpacing()), "origin": list(img.GetOrigin()), "times": times})
np.save(out, np.stack(arrays))
json.dump(grids, open(out + ".json", "w"))
"""


def paraview_paths():
    plugin = next(iter(BUILD.glob("lib/volcl/paraview/VolclReader/VolclReader.so")), None)
    pvpython = BUILD / "paraview-python" / "usr" / "lib" / "python3" / "dist-packages"
    if plugin is None or not (pvpython / "paraview" / "simple.py").exists():
        pytest.skip(f"the ParaView reader plugin is not built under {BUILD} (paraview-dev absent)")
    return plugin, pvpython


@pytest.mark.parametrize("mode", list(MODES))
def test_paraview_reader_gives_the_cli_voxels(tmp_path, mode):
    plugin, pvpython = paraview_paths()
    frames = series(np.float32)[:3]
    inputs = write_inputs(tmp_path, frames)
    vcz = tmp_path / "pv.vcz"
    run_cli("encode", *inputs, "-o", str(vcz), *MODES[mode][0], *COMMON[0], *STRUCTURES["PB"][0])
    out = tmp_path / "pv.npy"
    env = {**os.environ, "PYTHONPATH": str(pvpython), "OMPI_ALLOW_RUN_AS_ROOT": "1",
           "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
    script = tmp_path / "read_vcz.py"
    script.write_text(PARAVIEW_SCRIPT)
    proc = subprocess.run(["pvbatch", str(script), str(plugin), str(vcz), str(out)], capture_output=True,
                          text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    got = np.load(out)
    grids = json.loads(Path(str(out) + ".json").read_text())
    assert got.shape == (3, *SHAPE)
    for k in range(3):
        ref = cli_decode(vcz, k, tmp_path)
        assert got[k].dtype == ref.array.dtype and got[k].tobytes() == ref.array.tobytes(), k
        assert grids[k]["spacing"] == pytest.approx(SPACING) and grids[k]["origin"] == pytest.approx(ORIGIN)


# ---- A scaled int16 NIfTI series: the command line keeps its integers, Python reads data units ---------------

NIFTI_SCRIPT = r"""
import sys, nibabel as nib, numpy as np
out, npy = sys.argv[1:3]
rng = np.random.default_rng(3)
k, j, i, t = np.meshgrid(np.arange(5), np.arange(7), np.arange(9), np.arange(6), indexing="ij")
stored = (200 * np.sin(0.7 * i + 0.3 * t) * np.cos(0.5 * j) + 40 * k + rng.integers(-9, 10, i.shape))
stored = stored.astype(np.int16).transpose(2, 1, 0, 3)  # nibabel's axes: x, y, z, t
img = nib.Nifti1Image(stored, np.diag([0.8, 1.1, 2.5, 1.0]))
img.header.set_slope_inter(0.5, 3.0)
img.header.set_xyzt_units("mm", "sec")
img.header["pixdim"][4] = 2.5
nib.save(img, out)
np.save(npy, np.ascontiguousarray(stored.transpose(3, 2, 1, 0)))  # a[t, z, y, x]
"""


def test_scaled_nifti_series_reads_in_python_as_on_the_command_line(tmp_path):
    if not SYSTEM_PYTHON.exists():
        pytest.skip("/usr/bin/python3 (Debian's, with nibabel) is absent")
    nii, npy = tmp_path / "f.nii.gz", tmp_path / "stored.npy"
    proc = subprocess.run([str(SYSTEM_PYTHON), "-c", NIFTI_SCRIPT, str(nii), str(npy)], capture_output=True,
                          text=True)
    if proc.returncode != 0 and "No module named 'nibabel'" in proc.stderr:
        pytest.skip("nibabel is not installed for /usr/bin/python3 (python3-nibabel)")
    assert proc.returncode == 0, proc.stderr
    stored = np.load(npy)
    units = (stored.astype(np.float64) * 0.5 + 3.0).astype(np.float32)
    vcz = tmp_path / "f.vcz"
    run_cli("encode", str(nii), "-o", str(vcz))
    f = volcl.VczFile(vcz)
    assert len(f) == 6 and f.shape == stored.shape and f.frame_shape == stored.shape[1:]
    assert f.stored_scale == (0.5, 3.0) and f.dtype == np.float32 and f.header["dtype"] == "int16"
    exact = volcl.VczFile(vcz, stored_values=True)
    assert exact.dtype == np.int16
    from_nii = volcl.read(nii).array
    from_vcz = volcl.read(vcz).array
    assert from_vcz.dtype == from_nii.dtype and from_vcz.tobytes() == from_nii.tobytes() == units.tobytes()
    for k in range(6):
        out = tmp_path / f"frame{k}.raw"
        run_cli("decode", str(vcz), "--frame", str(k), "-o", str(out))  # raw: float32 data units
        cli = np.fromfile(out, dtype=np.float32).reshape(stored.shape[1:])
        assert volcl.decode(vcz.read_bytes(), frame=k).tobytes() == cli.tobytes() == units[k].tobytes()
        assert f[k].tobytes() == cli.tobytes()
        assert exact[k].dtype == np.int16 and exact[k].tobytes() == stored[k].tobytes()
        assert volcl.decode(vcz.read_bytes(), frame=k, stored_values=True).tobytes() == stored[k].tobytes()


def test_a_bit_budget_the_statistics_fill_is_refused_naming_the_file(tmp_path):
    inputs = write_inputs(tmp_path, field(np.float32)[None])
    out = tmp_path / "tiny.vcz"
    message = cli_message("encode", *inputs, "-o", str(out), "--bpv", "0.6", *COMMON[0])
    assert message.startswith(str(out)) and "--no-lod-stats" in message, message
    assert not out.exists()
    run_cli("encode", *inputs, "-o", str(out), "--bpv", "0.6", "--no-lod-stats", *COMMON[0])
    assert 8 * out.stat().st_size <= 0.6 * field(np.float32).size


# ---- Relative bounds on adversarial arrays, through every Python writer and reader ----------------------------

def adversarial_arrays():
    """Arrays a relative bound must survive, a[z, y, x] of the matrix's shape, float32 and integer."""
    rng = np.random.default_rng(11)
    smooth = field(np.float32)
    mags = 10.0 ** rng.uniform(-40, 38.4, SHAPE) * np.where(rng.random(SHAPE) < 0.5, -1, 1)
    mags[rng.random(SHAPE) < 0.05] = 0
    nonfinite = (smooth * 100).astype(np.float32)
    r = rng.random(SHAPE)
    nonfinite[r < 0.03] = np.inf
    nonfinite[(r >= 0.03) & (r < 0.06)] = -np.inf
    nonfinite[(r >= 0.06) & (r < 0.09)] = np.frombuffer(np.uint32(0x7FC01234).tobytes(), np.float32)[0]
    nonfinite[(r >= 0.09) & (r < 0.12)] = 0
    half_zero = (smooth + 3).astype(np.float32)
    half_zero[:, :, :12] = 0
    return {
        "zeros": np.zeros(SHAPE, np.float32),
        "constant": np.full(SHAPE, -3.25, np.float32),
        "mixed-signs": smooth,
        "half-zeros": half_zero,
        "denormals": ((smooth + 2.6) * 1e-40).astype(np.float32),
        "dynamic-range": mags.astype(np.float32),
        "nan-inf": nonfinite,
        "uint16": field(np.uint16),
        "int16": (field(np.uint16).astype(np.int32) - 30000).astype(np.int16),
    }


def python_writers():
    """(name, encode(array, **kwargs) -> bytes, decode(bytes) -> array) for each Python writer/reader pair."""
    yield "volcl", lambda a, **kw: volcl.encode(a, **kw), lambda b: volcl.decode(b)
    try:
        import volcl.numcodecs as vnc
    except ImportError:
        return
    yield "numcodecs", lambda a, **kw: vnc.Volcl(**kw).encode(a), lambda b: vnc.Volcl().decode(b)


def check_relative(out: np.ndarray, a: np.ndarray, mode: str, r: float, what: str):
    """Every voxel against the bound, in double; NaN/Inf bit for bit; pw: zeros exact and signs kept."""
    assert out.dtype == a.dtype and out.shape == a.shape, what
    finite = np.isfinite(a)
    if not finite.all():
        assert out[~finite].tobytes() == a[~finite].tobytes(), what
    x, y = a[finite].astype(np.float64), out[finite].astype(np.float64)
    if x.size == 0:
        return
    if mode == "rel_error":
        limit = r * (x.max() - x.min())
    else:
        limit = r * np.abs(x)
        assert np.all((x == 0) == (y == 0)) and np.all(np.signbit(x) == np.signbit(y)), what
    assert np.all(np.abs(y - x) <= limit), what


@pytest.mark.parametrize("mode, r", [("rel_error", 1e-3), ("pw_rel_error", 1e-2), ("pw_rel_error", 1e-5)])
def test_relative_bounds_hold_on_adversarial_arrays_through_every_python_writer(mode, r):
    for name, a in adversarial_arrays().items():
        for writer, enc, dec in python_writers():
            b = enc(a, **{mode: r}, **COMMON[1]) if writer == "volcl" else enc(a, **{mode: r})
            check_relative(dec(b), a, mode, r, f"{name} {writer} {mode}={r}")


def test_relative_bounds_are_refused_when_invalid():
    a = field(np.float32)
    for kwargs in ({"pw_rel_error": 1.0}, {"pw_rel_error": 0.0}, {"rel_error": -1.0},
                   {"rel_error": 1e-3, "max_error": 0.1}):
        with pytest.raises(volcl.UsageError):
            volcl.encode(a, **kwargs)
