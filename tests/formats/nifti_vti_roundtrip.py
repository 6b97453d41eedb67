"""NIfTI and VTI outputs of the volcl CLI opened by nibabel and VTK: same voxels, spacing and orientation.

Usage: nifti_vti_roundtrip.py VOLCL_EXE WORK_DIR [SHARED_DATA_DIR]
Exits 77 (skipped) when nibabel, VTK or the NIfTI sample volumes are missing.
"""
import os
import subprocess
import sys

import numpy as np

try:
    import nibabel as nib
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader
except ImportError as e:
    print(f"skipped: {e} (apt-get install python3-nibabel python3-vtk9)")
    sys.exit(77)

VOLCL, WORK = sys.argv[1], sys.argv[2]
SHARED = sys.argv[3] if len(sys.argv) > 3 else ""
# A small real template with a flipped x axis (LAS), qform/sform code 2 and units mm/s.
LAS = "/usr/share/mricron/templates/AICHAmc.nii.gz"
failures = []


def volcl(*args):
    r = subprocess.run([VOLCL, "--quiet", *args], capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"volcl {' '.join(args)} failed ({r.returncode}): {r.stderr.strip()}")


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def same_header(a, b, what, fields=("qform_code", "sform_code", "xyzt_units", "intent_code", "intent_p1",
                                    "intent_p2", "intent_p3", "intent_name", "descrip")):
    for f in fields:
        check(np.array_equal(a.header[f], b.header[f]), f"{what}: {f} {a.header[f]} == {b.header[f]}")


def vti(path):
    r = vtkXMLImageDataReader()
    r.SetFileName(path)
    r.Update()
    img = r.GetOutput()
    nx, ny, nz = img.GetDimensions()
    values = vtk_to_numpy(img.GetPointData().GetScalars()).reshape(nz, ny, nx).transpose(2, 1, 0)
    direction = np.array([[img.GetDirectionMatrix().GetElement(i, j) for j in range(3)] for i in range(3)])
    affine = np.eye(4)
    affine[:3, :3] = direction * np.array(img.GetSpacing())[None, :]
    affine[:3, 3] = img.GetOrigin()
    return values, affine


def las_template():
    if not os.path.exists(LAS):
        print(f"skipped: {LAS} is absent (apt-get install mricron-data)")
        sys.exit(77)
    src = nib.load(LAS)
    data = np.asanyarray(src.dataobj)

    # convert keeps voxels, type, both transforms and the other header fields.
    out = os.path.join(WORK, "las.nii.gz")
    volcl("convert", LAS, "-o", out)
    back = nib.load(out)
    check(np.array_equal(np.asanyarray(back.dataobj), data), "convert .nii.gz: same voxels")
    check(back.get_data_dtype() == src.get_data_dtype(), "convert .nii.gz: same data type")
    check(np.allclose(back.get_qform(), src.get_qform(), atol=1e-5), "convert .nii.gz: same qform")
    check(np.allclose(back.get_sform(), src.get_sform(), atol=1e-5), "convert .nii.gz: same sform")
    check(nib.aff2axcodes(back.affine) == nib.aff2axcodes(src.affine), "convert .nii.gz: same axis codes (LAS)")
    same_header(back, src, "convert .nii.gz")

    # encode (lossless) -> decode keeps all of it through the .vcz.
    vcz = os.path.join(WORK, "las.vcz")
    volcl("encode", LAS, "--lossless", "-o", vcz)
    dec = os.path.join(WORK, "las_decoded.nii")
    volcl("decode", vcz, "-o", dec)
    d = nib.load(dec)
    check(np.array_equal(np.asanyarray(d.dataobj), data), "encode/decode .nii: same voxels")
    check(np.allclose(d.affine, src.affine, atol=1e-5), "encode/decode .nii: same affine")
    same_header(d, src, "encode/decode .nii")

    # A region decode sits where its voxels sat in the source.
    reg = os.path.join(WORK, "las_region.nii.gz")
    volcl("decode", vcz, "--region", "10,20,30:50,60,70", "-o", reg)
    r = nib.load(reg)
    check(np.array_equal(np.asanyarray(r.dataobj), data[10:50, 20:60, 30:70]), "region decode: same voxels")
    shifted = src.affine @ np.array([[1, 0, 0, 10], [0, 1, 0, 20], [0, 0, 1, 30], [0, 0, 0, 1]])
    check(np.allclose(r.affine, shifted, atol=1e-4), "region decode: affine moved by the region's corner")

    # VTI: VTK sees the same voxels at the same world positions (direction from the NIfTI transform).
    vti_path = os.path.join(WORK, "las.vti")
    volcl("convert", LAS, "-o", vti_path)
    values, affine = vti(vti_path)
    check(np.array_equal(values, data), "convert .vti: VTK reads the same voxels")
    check(np.allclose(affine, src.affine, atol=1e-5), "convert .vti: VTK origin, spacing and direction = NIfTI affine")


def scaled_with_intent():
    # An int16 file with scl_slope/scl_inter and an intent, written by nibabel: volcl keeps all of it.
    rng = np.random.default_rng(3)
    stored = rng.integers(-2000, 2000, size=(9, 7, 5), dtype=np.int16)
    affine = np.array([[0, -1.5, 0, 30], [2.0, 0, 0, -20], [0, 0, 1.25, 5], [0, 0, 0, 1]])
    img = nib.Nifti1Image(stored, affine)
    img.header.set_slope_inter(0.25, -100.0)
    img.header.set_intent("t test", (12.0,), name="tstat")
    img.header.set_xyzt_units("mm", "sec")
    img.header.set_qform(affine, code=1)
    img.header.set_sform(affine, code=3)
    src_path = os.path.join(WORK, "scaled.nii")
    nib.save(img, src_path)
    src = nib.load(src_path)

    out = os.path.join(WORK, "scaled_out.nii.gz")
    volcl("convert", src_path, "-o", out)
    back = nib.load(out)
    check(back.get_data_dtype() == np.int16, "scaled: stored type int16 kept")
    check(np.array_equal(np.asanyarray(back.dataobj.get_unscaled()), stored), "scaled: same stored integers")
    check(back.dataobj.slope == 0.25 and back.dataobj.inter == -100.0, "scaled: scl_slope/scl_inter kept")
    check(np.array_equal(back.get_fdata(), src.get_fdata()), "scaled: same data units")
    check(np.allclose(back.affine, src.affine, atol=1e-6), "scaled: same affine (rotated axes)")
    same_header(back, src, "scaled")

    vcz = os.path.join(WORK, "scaled.vcz")
    volcl("encode", src_path, "--max-error", "0.5", "-o", vcz)
    lossy = os.path.join(WORK, "scaled_lossy.nii")
    volcl("decode", vcz, "-o", lossy)
    l = nib.load(lossy)
    check(np.max(np.abs(l.get_fdata() - src.get_fdata())) <= 0.5 + 1e-6, "lossy decode: within --max-error 0.5")
    check(np.allclose(l.affine, src.affine, atol=1e-6), "lossy decode: same affine")
    same_header(l, src, "lossy decode")


def refused_outputs():
    # Bad outputs are one-line errors naming the file, exit 1, and leave nothing behind.
    vcz = os.path.join(WORK, "las.vcz")
    missing = os.path.join(WORK, "no_such_dir", "x.nii.gz")
    r = subprocess.run([VOLCL, "decode", vcz, "-o", missing], capture_output=True, text=True)
    lines = r.stderr.strip().splitlines()
    check(r.returncode == 1 and len(lines) == 1 and missing in lines[0], f"decode to a missing directory: exit 1, one line ({r.stderr.strip()})")
    check(not os.path.exists(os.path.dirname(missing)), "decode to a missing directory: nothing created")
    src = os.path.join(WORK, "las.nii.gz")
    before = open(src, "rb").read()
    r = subprocess.run([VOLCL, "convert", src, "-o", src], capture_output=True, text=True)
    check(r.returncode != 0 and len(r.stderr.strip().splitlines()) == 1, f"convert onto its input: refused ({r.stderr.strip()})")
    check(open(src, "rb").read() == before, "convert onto its input: input untouched")
    wide = os.path.join(WORK, "wide_4x4x40000_uint8.raw")
    with open(wide, "wb") as f:
        f.write(bytes(4 * 4 * 40000))
    out = os.path.join(WORK, "wide.nii")
    r = subprocess.run([VOLCL, "convert", wide, "-o", out], capture_output=True, text=True)
    check(r.returncode != 0 and "32767" in r.stderr and not os.path.exists(out), f"convert a 40000-slice volume to NIfTI-1: refused ({r.stderr.strip()})")


def functional_series():
    path = os.path.join(SHARED, "timevarying", "functional.nii.gz") if SHARED else ""
    if not os.path.exists(path):
        print("skipping the 4D series check: ../shared/data/timevarying/functional.nii.gz is absent")
        return
    src = nib.load(path)
    vcz = os.path.join(WORK, "functional.vcz")
    volcl("encode", path, "--lossless", "-o", vcz)
    out = os.path.join(WORK, "functional_f7.nii.gz")
    volcl("decode", vcz, "--frame", "7", "-o", out)
    f = nib.load(out)
    check(np.array_equal(np.asanyarray(f.dataobj), np.asanyarray(src.dataobj)[..., 7]), "4D series: frame 7 voxels")
    check(np.allclose(f.affine, src.affine, atol=1e-5), "4D series: frame 7 affine")
    check(np.allclose(f.header.get_zooms()[:3], src.header.get_zooms()[:3]), "4D series: frame 7 spacing")


os.makedirs(WORK, exist_ok=True)
las_template()
scaled_with_intent()
refused_outputs()
functional_series()
if failures:
    print(f"{len(failures)} check(s) failed")
    sys.exit(1)
