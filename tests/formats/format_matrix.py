"""The format round-trip matrix: every volcl output format and voxel type, there and back through the CLI.

Usage: format_matrix.py VOLCL_EXE WORK_DIR
A non-symmetric volume (7x5x4, anisotropic spacing, non-zero origin) is written by nibabel for each voxel
type, converted by `volcl convert` (or `volcl encode` for .vcz) to each format and back to NIfTI, and read
by nibabel: values, dims, type, spacing, origin and frames must be kept as the table below says, or the
conversion must be refused in one line naming the file (exit 2) with no output left.
Exits 77 (skipped) when nibabel is missing.
"""
import glob
import os
import subprocess
import sys

import numpy as np

try:
    import nibabel as nib
except ImportError as e:
    print(f"skipped: {e} (apt-get install python3-nibabel)")
    sys.exit(77)

VOLCL, WORK = sys.argv[1], sys.argv[2]
failures = []
SHAPE = (7, 5, 4)
AFFINE = np.array([[0.5, 0, 0, 3.0], [0, 1.25, 0, -4.0], [0, 0, 2.0, 5.5], [0, 0, 0, 1]])

# Output format: (file name template, keeps spacing and origin, holds several frames). A raw file keeps
# values, dims (in its name) and type only, a numpy .npy values, dims and type; every other format keeps
# the grid too; NIfTI, NRRD, .vcz and .npy hold a series.
FORMATS = {
    "raw": ("{n}_7x5x4_{t}.raw", False, False),
    "raw.gz": ("{n}_7x5x4_{t}.raw.gz", False, False),
    "nrrd": ("{n}.nrrd", True, True),
    "nhdr": ("{n}.nhdr", True, True),
    "nii": ("{n}.nii", True, True),
    "nii.gz": ("{n}.nii.gz", True, True),
    "vti": ("{n}.vti", True, False),
    "vdb": ("{n}.vdb", True, False),
    "vcz": ("{n}.vcz", True, True),
    "npy": ("{n}.npy", False, True),
}
# Voxel types of the sources (the volume model's four types) and the scaled int16 source: scl_slope 0.5,
# scl_inter 3. The scaled source keeps its stored int16 and scale in NIfTI and .vcz; every other format
# holds its data units (stored * slope + inter) as float32.
SOURCES = ["uint8", "int16", "uint16", "float32", "int16_scaled"]


def run(*args):
    return subprocess.run([VOLCL, "--quiet", *args], capture_output=True, text=True)


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def path(name):
    return os.path.join(WORK, name)


def make_source(kind, frames=1):
    rng = np.random.default_rng(7)
    t = "int16" if kind == "int16_scaled" else kind
    shape = SHAPE + ((frames,) if frames > 1 else ())
    # 1..199 plus a ramp along x: every voxel distinct from its mirror images and non-zero (a .vdb keeps
    # the active voxels of a grid whose background is 0).
    data = rng.integers(1, 150, size=shape) + np.arange(SHAPE[0]).reshape((-1,) + (1,) * (len(shape) - 1)) * 7
    img = nib.Nifti1Image(data.astype(t), AFFINE)
    img.header.set_qform(AFFINE, 1)
    img.header.set_sform(AFFINE, 1)
    if kind == "int16_scaled":
        img.header.set_slope_inter(0.5, 3.0)
    name = path(f"src_{kind}_{frames}.nii")
    nib.save(img, name)
    return name, nib.load(name)


def to_format(src, fmt, name):
    """src -> fmt with volcl; returns the CompletedProcess."""
    if fmt == "vcz":
        return run("encode", src, "--lossless", "-o", name)
    return run("convert", src, "-o", name)


def back_to_nifti(name, fmt, out):
    return run("decode", name, "-o", out) if fmt == "vcz" else run("convert", name, "-o", out)


def expected_dtype(kind, fmt):
    if kind == "int16_scaled":
        return np.dtype("int16") if fmt in ("nii", "nii.gz", "vcz") else np.dtype("float32")
    return np.dtype(kind)


def volume_case(kind, fmt):
    src_path, src = make_source(kind)
    template, keeps_grid, _ = FORMATS[fmt]
    t = "float32" if kind == "int16_scaled" else kind  # a raw output of the scaled source holds data units
    name = path(template.format(n=f"m_{kind}_{fmt.replace('.', '_')}", t=t))
    r = to_format(src_path, fmt, name)
    what = f"{kind} -> {fmt}"
    if r.returncode != 0:
        check(False, f"{what}: {r.stderr.strip()}")
        return
    if fmt == "npy":  # numpy reads it too: a[z, y, x], the transpose of nibabel's a[x, y, z]
        a = np.load(name)
        check(a.dtype == expected_dtype(kind, fmt) and np.array_equal(a, src.get_fdata().T),
              f"{what}: numpy loads {a.shape} {a.dtype}")
    out = path(f"back_{kind}_{fmt.replace('.', '_')}.nii")
    r = back_to_nifti(name, fmt, out)
    if r.returncode != 0:
        check(False, f"{what} -> nii: {r.stderr.strip()}")
        return
    b = nib.load(out)
    ok = b.shape == src.shape and np.array_equal(b.get_fdata(), src.get_fdata())
    ok = ok and b.get_data_dtype() == expected_dtype(kind, fmt)
    if kind == "int16_scaled" and fmt in ("nii", "nii.gz", "vcz"):
        ok = ok and (b.dataobj.slope, b.dataobj.inter) == (0.5, 3.0)
    grid = AFFINE if keeps_grid else np.eye(4)
    ok = ok and np.allclose(b.affine, grid, atol=1e-6)
    check(ok, f"{what}: values, dims {b.shape}, type {b.get_data_dtype()}, grid "
              f"{np.diag(b.affine)[:3]} + {b.affine[:3, 3]}")


def series_case(fmt):
    """A 4D scaled int16 source: kept whole by NIfTI, NRRD and .vcz, refused by formats that hold one volume."""
    src_path, src = make_source("int16_scaled", frames=3)
    template, keeps_grid, holds_series = FORMATS[fmt]
    stem = f"s4_{fmt.replace('.', '_')}"
    name = path(template.format(n=stem, t="int16"))
    what = f"4D int16_scaled -> {fmt}"
    if fmt == "vcz":  # encode holds the series; the one-volume refusal is decode's
        r = to_format(src_path, fmt, name)
        check(r.returncode == 0, f"{what}: encoded")
        refusal = run("decode", name, "-o", path(f"{stem}.vti"))
        lines = refusal.stderr.strip().splitlines()
        check(refusal.returncode == 2 and len(lines) == 1 and f"{stem}.vti" in lines[0]
              and not os.path.exists(path(f"{stem}.vti")), f"{what}: decode to .vti refused")
    else:
        r = to_format(src_path, fmt, name)
    if not holds_series:
        lines = r.stderr.strip().splitlines()
        left = glob.glob(path(stem + "*"))
        check(r.returncode == 2 and len(lines) == 1 and os.path.basename(name) in lines[0] and not left,
              f"{what}: refused (exit {r.returncode}, {r.stderr.strip()}, left {left})")
        return
    if fmt == "npy":
        a = np.load(name)
        check(a.shape == src.shape[::-1] and np.array_equal(a, src.get_fdata().T),
              f"{what}: numpy loads {a.shape} {a.dtype}")
    out = path(f"back_{stem}.nii")
    back = back_to_nifti(name, fmt, out)
    check(back.returncode == 0, f"{what} -> nii: {back.stderr.strip()}")
    b = nib.load(out)
    same = b.shape == src.shape and np.allclose(b.affine, AFFINE if keeps_grid else np.eye(4), atol=1e-6)
    if fmt in ("nii", "nii.gz", "vcz"):
        check(same and np.array_equal(b.dataobj.get_unscaled(), src.dataobj.get_unscaled())
              and (b.dataobj.slope, b.dataobj.inter) == (0.5, 3.0), f"{what}: frames, stored values, scale and grid kept ({b.shape})")
    else:  # NRRD and .npy have no scale: data units as float32
        check(same and b.get_data_dtype() == np.float32 and np.array_equal(b.get_fdata(), src.get_fdata()),
              f"{what}: frames, data units and grid kept ({b.shape}, {b.get_data_dtype()})")


os.makedirs(WORK, exist_ok=True)
for old in glob.glob(path("*")):
    os.remove(old)
for kind in SOURCES:
    for fmt in FORMATS:
        volume_case(kind, fmt)
for fmt in FORMATS:
    series_case(fmt)
if failures:
    print(f"{len(failures)} check(s) failed")
    sys.exit(1)
