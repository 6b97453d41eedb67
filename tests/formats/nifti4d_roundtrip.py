"""4D and scaled-integer NIfTI through volcl encode/decode/convert, checked with nibabel (an independent reader).

Usage: nifti4d_roundtrip.py VOLCL_EXE WORK_DIR [SHARED_DATA_DIR]
Exits 77 (skipped) when nibabel is missing. The real series (timevarying/functional.nii.gz) is checked
when SHARED_DATA_DIR holds it, else skipped with a message.
"""
import json
import os
import subprocess
import sys
import zlib

import numpy as np

try:
    import nibabel as nib
except ImportError as e:
    print(f"skipped: {e} (apt-get install python3-nibabel)")
    sys.exit(77)

from cli_checks import SHARED, VOLCL, WORK, check, finish, volcl  # noqa: E402


def path(name):
    return os.path.join(WORK, name)


def make_series(name, dtype, slope=None, inter=None):
    """A 9x7x5 volume with 6 frames, no symmetry, anisotropic voxels, a non-zero origin, 2.5 s per frame."""
    rng = np.random.default_rng(41)
    shape = (9, 7, 5, 6)
    x, y, z, t = np.meshgrid(*[np.arange(n) for n in shape], indexing="ij")
    if dtype == np.int16:
        data = (37 * x - 11 * y * y + 5 * z * x + 100 * t + rng.integers(-300, 300, shape)).astype(np.int16)
    else:
        data = (0.75 * x - 0.3 * y * y + 0.01 * z * x + t + rng.standard_normal(shape)).astype(np.float32)
    affine = np.array([[1.5, 0, 0, 10.0], [0, 2.0, 0, -20.0], [0, 0, 3.0, 5.0], [0, 0, 0, 1]])
    img = nib.Nifti1Image(data, affine)
    img.header.set_qform(affine, 1)
    img.header.set_sform(affine, 1)
    img.header.set_xyzt_units("mm", "sec")
    img.header["pixdim"][4] = 2.5
    if slope is not None:
        img.header.set_slope_inter(slope, inter)
    nib.save(img, path(name))
    return nib.load(path(name))


def same_4d(out, src, what, scaled):
    """Shape, frames, datatype, stored values, scale, affine and the time step of `out` against `src`."""
    f = nib.load(path(out))
    check(f.shape == src.shape, f"{what}: shape {f.shape} == {src.shape}")
    if f.shape != src.shape:
        return
    check(f.get_data_dtype() == src.get_data_dtype(), f"{what}: datatype {f.get_data_dtype()}")
    check(np.array_equal(f.dataobj.get_unscaled(), src.dataobj.get_unscaled()), f"{what}: stored values equal")
    check(np.array_equal(f.get_fdata(), src.get_fdata()), f"{what}: data units equal")
    if scaled:
        check((f.dataobj.slope, f.dataobj.inter) == (src.dataobj.slope, src.dataobj.inter),
              f"{what}: scl_slope/scl_inter {f.dataobj.slope}/{f.dataobj.inter}")
    check(np.allclose(f.affine, src.affine, atol=1e-6), f"{what}: affine (spacing, origin)")
    check(f.header.get_zooms() == src.header.get_zooms(), f"{what}: zooms incl. time {f.header.get_zooms()}")
    check(f.header.get_xyzt_units() == src.header.get_xyzt_units(), f"{what}: units")


def refused(args, out, what):
    """One line naming the output, exit 2, no file left."""
    r = subprocess.run([VOLCL, *args], capture_output=True, text=True)
    lines = r.stderr.strip().splitlines()
    check(r.returncode == 2 and len(lines) == 1 and os.path.basename(out) in lines[0] and not os.path.exists(out),
          f"{what}: refused (exit {r.returncode}: {r.stderr.strip()})")


def series_case(tag, dtype, slope=None, inter=None):
    src = make_series(f"{tag}.nii", dtype, slope, inter)
    scaled = slope is not None
    vcz = path(f"{tag}.vcz")
    volcl("encode", path(f"{tag}.nii"), "--lossless", "-o", vcz)
    info = volcl("info", vcz)
    check("(6 frames)" in info, f"{tag}: info of the .vcz reports 6 frames")
    stored_type = "int16" if dtype == np.int16 else "float32"
    check(f"type     {stored_type}" in info, f"{tag}: the .vcz holds {stored_type} voxels")
    check("(6 frames)" in volcl("info", path(f"{tag}.nii")), f"{tag}: info of the 4D NIfTI reports 6 frames")
    if scaled:
        check(f"value = stored * {slope:g} + {inter:g}" in info, f"{tag}: info of the .vcz prints the scale")
    # compare reads both sides in data units and the same frame of the 4D file and of the .vcz.
    for k in (0, 4):
        cmp = json.loads(volcl("compare", path(f"{tag}.nii"), vcz, "--frame", str(k), "--json"))
        check(cmp["max_abs_error"] == 0, f"{tag}: compare .nii .vcz --frame {k}: max error {cmp['max_abs_error']}")
    volcl("decode", vcz, "-o", path(f"{tag}_dec.nii.gz"))
    same_4d(f"{tag}_dec.nii.gz", src, f"{tag}: encode/decode", scaled)
    volcl("convert", path(f"{tag}.nii"), "-o", path(f"{tag}_conv.nii"))
    same_4d(f"{tag}_conv.nii", src, f"{tag}: convert .nii -> .nii", scaled)
    volcl("convert", vcz, "-o", path(f"{tag}_vcz_conv.nii.gz"))
    same_4d(f"{tag}_vcz_conv.nii.gz", src, f"{tag}: convert .vcz -> .nii.gz", scaled)
    # --to-type float32 writes float32 data units, every frame, no scale.
    volcl("convert", path(f"{tag}.nii"), "--to-type", "float32", "-o", path(f"{tag}_f32.nii"))
    f32 = nib.load(path(f"{tag}_f32.nii"))
    check(f32.shape == src.shape and f32.get_data_dtype() == np.float32
          and np.array_equal(f32.get_fdata(), src.get_fdata().astype(np.float32)),
          f"{tag}: convert --to-type float32 gives float32 data units ({f32.get_data_dtype()})")
    # A 4D NRRD holds every frame as data units (NRRD has no scale), back to a 4D NIfTI.
    volcl("decode", vcz, "-o", path(f"{tag}_4d.nrrd"))
    volcl("convert", path(f"{tag}_4d.nrrd"), "-o", path(f"{tag}_4d_back.nii"))
    n4 = nib.load(path(f"{tag}_4d_back.nii"))
    check(n4.shape == src.shape and np.array_equal(n4.get_fdata(), src.get_fdata().astype(np.float32))
          and np.allclose(n4.affine, src.affine, atol=1e-6), f"{tag}: decode to a 4D .nrrd keeps frames and grid")
    # One frame on request: a 3D NIfTI of frame 4.
    volcl("decode", vcz, "--frame", "4", "-o", path(f"{tag}_f4.nii"))
    f4 = nib.load(path(f"{tag}_f4.nii"))
    check(f4.shape == src.shape[:3] and np.array_equal(f4.get_fdata(), src.get_fdata()[..., 4]),
          f"{tag}: decode --frame 4 is frame 4 (3D)")
    # Formats that hold one volume: refused without --frame, one file per frame with a pattern, where
    # the values are data units (stored * slope + inter, nibabel's get_fdata) as float32.
    refused(["decode", vcz, "-o", path(f"{tag}_one.vdb")], path(f"{tag}_one.vdb"), f"{tag}: decode series to .vdb")
    refused(["convert", path(f"{tag}.nii"), "-o", path(f"{tag}_one.vti")], path(f"{tag}_one.vti"),
            f"{tag}: convert series to .vti")
    volcl("decode", vcz, "-o", path(f"{tag}_p%d.nrrd"))
    for k in range(src.shape[3]):
        volcl("convert", path(f"{tag}_p{k}.nrrd"), "-o", path(f"{tag}_p{k}.nii"))
        fk = nib.load(path(f"{tag}_p{k}.nii"))
        check(np.array_equal(np.asarray(fk.dataobj, dtype=np.float64), src.get_fdata()[..., k].astype(np.float32)),
              f"{tag}: pattern frame {k} in data units")
        check(np.allclose(fk.affine, src.affine, atol=1e-6), f"{tag}: pattern frame {k} affine")


def lossy_bound_in_data_units():
    """--max-error is in data units: with scl_slope 2 a bound of 1 allows no error in the stored integers."""
    src = make_series("slope2.nii", np.int16, 2.0, -5.0)
    volcl("encode", path("slope2.nii"), "--max-error", "1", "-o", path("slope2.vcz"))
    volcl("decode", path("slope2.vcz"), "-o", path("slope2_back.nii"))
    err = np.abs(nib.load(path("slope2_back.nii")).get_fdata() - src.get_fdata()).max()
    check(err <= 1, f"scl_slope 2, --max-error 1: data-unit error {err} <= 1")


def png_pixels(name):
    """RGB(A) 8-bit pixels of a non-interlaced PNG (zlib and the five row filters; no imaging library)."""
    data = open(name, "rb").read()
    pos, idat, width, height, channels = 8, b"", 0, 0, 0
    while pos < len(data):
        n = int.from_bytes(data[pos:pos + 4], "big")
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            width, height = int.from_bytes(body[0:4], "big"), int.from_bytes(body[4:8], "big")
            assert body[8] == 8 and body[12] == 0, "8-bit non-interlaced PNG expected"
            channels = {2: 3, 6: 4, 0: 1, 4: 2}[body[9]]
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    stride = width * channels
    out = np.zeros((height, stride), dtype=np.int32)
    for y in range(height):
        f, row = raw[y * (stride + 1)], np.frombuffer(raw, np.uint8, stride, y * (stride + 1) + 1).astype(np.int32)
        up = out[y - 1] if y > 0 else np.zeros(stride, np.int32)
        cur = np.zeros(stride, np.int32)
        for x in range(stride):
            a = cur[x - channels] if x >= channels else 0
            c = up[x - channels] if x >= channels else 0
            b = up[x]
            if f == 0:
                pred = 0
            elif f == 1:
                pred = a
            elif f == 2:
                pred = b
            elif f == 3:
                pred = (a + b) // 2
            else:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[x] = (row[x] + pred) & 0xFF
        out[y] = cur
    return out


def render_in_data_units(tag):
    """A .vcz of stored integers renders and views as its .nii (data units): same --tf-range, same image."""
    args = ["--frame", "0", "--view", "front", "--width", "24", "--height", "20", "--tf", "preset:viridis", "--tf-range", "-40,60"]
    volcl("render", "--volume", path(f"{tag}.nii"), *args, "-o", path(f"{tag}_nii.png"))
    volcl("render", "--volume", path(f"{tag}.vcz"), *args, "-o", path(f"{tag}_vcz.png"))
    a, b = png_pixels(path(f"{tag}_nii.png")), png_pixels(path(f"{tag}_vcz.png"))
    diff = np.abs(a - b).max() if a.shape == b.shape else 255
    check(a.shape == b.shape and diff <= 1 and a.std() > 0, f"{tag}: render of .vcz equals render of .nii (max diff {diff})")
    # view decodes the .vcz whole (not from bricks): data units there too.
    volcl("view", "--volume", path(f"{tag}.nii"), *args, "--headless", "--frames", "2", "-o", path(f"{tag}_nii_view.png"))
    volcl("view", "--volume", path(f"{tag}.vcz"), *args, "--headless", "--frames", "2", "-o", path(f"{tag}_vcz_view.png"))
    a, b = png_pixels(path(f"{tag}_nii_view.png")), png_pixels(path(f"{tag}_vcz_view.png"))
    diff = np.abs(a - b).max() if a.shape == b.shape else 255
    check(a.shape == b.shape and diff <= 1 and a.std() > 0, f"{tag}: view of .vcz equals view of .nii (max diff {diff})")


def functional_series():
    real = os.path.join(SHARED, "timevarying", "functional.nii.gz") if SHARED else ""
    if not os.path.exists(real):
        print("skipping the real series check: ../shared/data/timevarying/functional.nii.gz is absent")
        return
    src = nib.load(real)
    vcz = path("functional.vcz")
    volcl("encode", real, "--lossless", "-o", vcz)
    volcl("decode", vcz, "-o", path("functional_dec.nii.gz"))
    same_4d("functional_dec.nii.gz", src, "functional.nii.gz: encode/decode", True)
    volcl("convert", real, "-o", path("functional_conv.nii.gz"))
    same_4d("functional_conv.nii.gz", src, "functional.nii.gz: convert", True)
    # Stored as its int16 values: no larger than the gzip-compressed source (float32 patterns were 1.7x).
    check(os.path.getsize(vcz) <= os.path.getsize(real),
          f"functional.nii.gz: lossless .vcz {os.path.getsize(vcz)} bytes <= source {os.path.getsize(real)}")


os.makedirs(WORK, exist_ok=True)
series_case("int16_scaled", np.int16, 0.5, 3.0)
render_in_data_units("int16_scaled")
lossy_bound_in_data_units()
series_case("float32", np.float32)
functional_series()
finish()
