"""DICOM series made with pydicom from NIfTI volumes, read back through the volcl CLI and checked with nibabel.

Usage: dicom_series.py VOLCL_EXE WORK_DIR [SHARED_DATA_DIR]
Each series is written slice by slice from a NIfTI volume (its RAS affine turned into DICOM's LPS Image
Position/Orientation (Patient)); `volcl convert` of the series to NIfTI must give the same voxels, type,
spacing, origin and direction (affine within 1e-5 mm: DS values carry 16 characters). Hard cases are
refused with one line naming the offending file and exit 1. Exits 77 (skipped) when pydicom or nibabel is
missing; the real volumes (../shared/data/timevarying/functional.nii.gz, mricron's ch2.nii.gz) are skipped
with a message when absent.
"""
import json
import os
import shutil
import sys

import numpy as np

try:
    import nibabel as nib
    import pydicom
    from pydicom.dataset import FileDataset, FileMetaDataset
    from pydicom.encaps import encapsulate
    from pydicom.uid import ExplicitVRLittleEndian, generate_uid
    from pydicom.valuerep import format_number_as_ds
except ImportError as e:
    print(f"skipped: {e} (apt-get install python3-pydicom python3-nibabel)")
    sys.exit(77)

from cli_checks import SHARED, WORK, check, finish, run, volcl  # noqa: E402

MRI = "/usr/share/mricron/templates/ch2.nii.gz"  # a real T1 MRI, 181x217x181 uint8 (mricron-data)
AFFINE_TOL = 1e-5
MR_STORAGE = "1.2.840.10008.5.1.4.1.1.4"


def path(*names):
    return os.path.join(WORK, *names)


def ds_list(values):
    return [format_number_as_ds(float(v)) for v in values]


def slice_dataset(pixels, ipp, iop, spacing, series_uid, number, slope=1.0, inter=0.0, description=""):
    """One MR slice (Part 10, explicit VR little endian) holding `pixels` (rows = y, columns = x)."""
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = MR_STORAGE
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = FileDataset(None, {}, file_meta=meta, preamble=b"\0" * 128)
    ds.is_little_endian = True
    ds.is_implicit_VR = False
    ds.SOPClassUID = MR_STORAGE
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.Modality = "MR"
    ds.StudyInstanceUID = "1.2.826.0.1.3680043.8.498.1"
    ds.SeriesInstanceUID = series_uid
    ds.SeriesDescription = description
    ds.InstanceNumber = number
    ds.ImagePositionPatient = ds_list(ipp)
    ds.ImageOrientationPatient = ds_list(iop)
    ds.PixelSpacing = ds_list(spacing)
    ds.SliceThickness = format_number_as_ds(1.0)
    if slope != 1.0 or inter != 0.0:
        ds.RescaleSlope = format_number_as_ds(float(slope))
        ds.RescaleIntercept = format_number_as_ds(float(inter))
    ds.SamplesPerPixel = 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    ds.Rows, ds.Columns = pixels.shape
    ds.BitsAllocated = ds.BitsStored = pixels.dtype.itemsize * 8
    ds.HighBit = ds.BitsStored - 1
    ds.PixelRepresentation = 1 if pixels.dtype.kind == "i" else 0
    ds.PixelData = np.ascontiguousarray(pixels).astype(pixels.dtype.newbyteorder("<")).tobytes()
    return ds


def write_series(folder, data, affine, uid=None, slope=1.0, inter=0.0, names=None, description=""):
    """Writes data[x, y, z] with RAS `affine` as one file per z slice; returns the series UID and the files."""
    os.makedirs(folder, exist_ok=True)
    uid = uid or generate_uid()
    lps = np.diag([-1.0, -1.0, 1.0, 1.0]) @ affine
    sx, sy = np.linalg.norm(lps[:3, 0]), np.linalg.norm(lps[:3, 1])
    iop = np.concatenate([lps[:3, 0] / sx, lps[:3, 1] / sy])
    files = []
    for k in range(data.shape[2]):
        ipp = (lps @ np.array([0.0, 0.0, k, 1.0]))[:3]
        ds = slice_dataset(data[:, :, k].T, ipp, iop, (sy, sx), uid, k + 1, slope, inter, description)
        name = names[k] if names else f"slice{k:04d}.dcm"
        ds.save_as(os.path.join(folder, name), write_like_original=False)
        files.append(os.path.join(folder, name))
    return uid, files


def nifti_of(input_path, out_name, *extra):
    out = path(out_name)
    volcl("convert", input_path, "-o", out, *extra)
    return nib.load(out)


def compare(img, data, affine, what, dtype=None, rtol=0.0):
    back = np.asanyarray(img.dataobj)
    same = back.shape == data.shape and (np.allclose(back, data, rtol=rtol, atol=0) if rtol else
                                         np.array_equal(back, data))
    check(same, f"{what}: same voxels {data.shape}" + (f" (relative {rtol})" if rtol else ""))
    if dtype is not None:
        check(img.get_data_dtype() == dtype, f"{what}: type {img.get_data_dtype()} == {np.dtype(dtype)}")
    err = np.abs(img.affine - affine).max()
    check(err <= AFFINE_TOL, f"{what}: affine (spacing, origin, direction) within {AFFINE_TOL} (max {err:.2e})")


def refused(args, folder_or_file, words, what):
    r = run(*args)
    msg = r.stderr.strip()
    ok = r.returncode == 1 and msg.count("\n") == 0 and folder_or_file in msg and all(w in msg for w in words)
    check(ok, f"{what}: exit {r.returncode}, one line naming {os.path.basename(folder_or_file)}: {msg}")
    return msg


def rotation(ax, ay, az):
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def synthetic(shape=(11, 9, 7), dtype=np.int16):
    rng = np.random.default_rng(39)
    x, y, z = np.meshgrid(*[np.arange(n) for n in shape], indexing="ij")
    return (31 * x - 7 * y * y + 13 * z * x + rng.integers(-200, 200, shape)).astype(dtype)


def affine_of(rot, spacing, origin):
    a = np.eye(4)
    a[:3, :3] = rot * np.asarray(spacing)[None, :]
    a[:3, 3] = origin
    return a


def stored_values(img):
    """The voxels in the file's own integer type (nibabel gives float64 for a NaN scl_slope)."""
    data = np.asanyarray(img.dataobj)
    typed = data.astype(img.get_data_dtype())
    assert np.array_equal(typed, data)
    return typed


def real_volumes():
    real = os.path.join(SHARED, "timevarying", "functional.nii.gz") if SHARED else ""
    if os.path.exists(real):
        # A real fMRI volume: int16 scaled by scl_slope/scl_inter (data units float32) and LAS (x mirrored).
        # Stored as DICOM with the same Rescale Slope/Intercept; DS keeps 16 characters of them, so values
        # agree to float32 rounding (relative 1e-6). Its slice axis runs against row x column, so the
        # series reads back with z reversed: the same voxels at the same world positions.
        src = nib.load(real)
        stored = src.dataobj.get_unscaled()[..., 0]
        slope, inter = float(src.dataobj.slope), float(src.dataobj.inter)
        write_series(path("functional"), stored, src.affine, slope=slope, inter=inter)
        img = nifti_of(path("functional"), "functional.nii.gz")
        flipped = src.affine.copy()
        flipped[:3, 2] = -src.affine[:3, 2]
        flipped[:3, 3] = (src.affine @ np.array([0, 0, stored.shape[2] - 1, 1.0]))[:3]
        units = np.asanyarray(src.dataobj)[..., 0].astype(np.float32)
        compare(img, units[:, :, ::-1], flipped, "functional.nii.gz frame 0 (real fMRI, scaled int16, LAS)",
                np.float32, rtol=1e-6)
        volcl("convert", real, "--frame", "0", "-o", path("functional_nifti_read.nii"))
        # volcl's NIfTI output keeps the stored integers and the scale; in float32 data units they equal
        # the DICOM's bit for bit (the 16-character slope did not move any rounding here).
        own = np.asanyarray(nib.load(path("functional_nifti_read.nii")).dataobj).astype(np.float32)
        back = np.asanyarray(img.dataobj)
        check(np.array_equal(back, own[:, :, ::-1]),
              "functional.nii.gz: the DICOM's float32 values equal volcl's read of the NIfTI bit for bit")
    else:
        print("skipping the real fMRI: ../shared/data/timevarying/functional.nii.gz is absent")
    if os.path.exists(MRI):
        src = nib.load(MRI)
        data = stored_values(src)
        uid, files = write_series(path("ch2"), data, src.affine)
        compare(nifti_of(path("ch2"), "ch2.nii.gz"), data, src.affine, "ch2 T1 MRI (real, uint8)", np.uint8)
        # One slice file names its series: the same volume.
        compare(nifti_of(files[90], "ch2_from_slice.nii.gz"), data, src.affine, "ch2 from one slice file")
        vcz = path("ch2.vcz")
        volcl("encode", path("ch2"), "--lossless", "-o", vcz)
        volcl("decode", vcz, "-o", path("ch2_decoded.nii.gz"))
        compare(nib.load(path("ch2_decoded.nii.gz")), data, src.affine, "ch2 encode --lossless/decode")
        info = json.loads(volcl("info", path("ch2"), "--json"))
        check(info.get("dims") == [181, 217, 181], f"info --json of the folder: dims {info.get('dims')}")
    else:
        print(f"skipping the real MRI: {MRI} is absent (apt-get install mricron-data)")


def geometry_cases():
    data = synthetic()
    axial = affine_of(np.eye(3), (0.8, 0.8, 2.5), (-40.0, 25.0, 12.5))
    write_series(path("axial"), data, axial)
    compare(nifti_of(path("axial"), "axial.nii"), data, axial, "axial, anisotropic 0.8x0.8x2.5", np.int16)
    oblique = affine_of(rotation(0.35, -0.2, 0.6), (0.7, 0.9, 1.3), (12.25, -7.5, 33.0))
    write_series(path("oblique"), data, oblique)
    compare(nifti_of(path("oblique"), "oblique.nii"), data, oblique, "oblique (rotated orientation)", np.int16)
    r = run("render", "--volume", path("oblique"), "--width", "32", "--height", "32", "-o", path("oblique.png"))
    check(r.returncode == 0 and os.path.getsize(path("oblique.png")) > 0, f"render of a DICOM folder: {r.stderr.strip()}")
    # Shuffled names: the file order says nothing, Image Position (Patient) orders the slices.
    order = np.random.default_rng(7).permutation(data.shape[2])
    names = [f"img_{int(p):02d}_{chr(97 + int(p))}" for p in order]
    write_series(path("shuffled"), data, oblique, names=names)
    compare(nifti_of(path("shuffled"), "shuffled.nii"), data, oblique, "shuffled file order, no extension")
    # A glob of slice files is one series.
    compare(nifti_of(path("oblique", "slice*.dcm"), "glob.nii"), data, oblique, "a glob pattern of slices")
    # A non-DICOM file in the folder is skipped.
    with open(path("axial", "README.txt"), "w") as f:
        f.write("notes\n" * 40)
    compare(nifti_of(path("axial"), "axial_readme.nii"), data, axial, "folder with a non-DICOM file")
    # One slice: spacing from Slice Thickness (1 here).
    write_series(path("one"), data[:, :, 3:4], axial)
    one = affine_of(np.eye(3), (0.8, 0.8, 1.0), (-40.0, 25.0, 12.5))
    compare(nifti_of(path("one"), "one.nii"), data[:, :, 3:4], one, "one-slice series")


def rescale_cases():
    data = synthetic()
    axial = affine_of(np.eye(3), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
    write_series(path("ct"), data, axial, slope=1.0, inter=-1024.0)
    compare(nifti_of(path("ct"), "ct.nii"), data.astype(np.int32) - 1024, axial, "slope 1, intercept -1024: int16",
            np.int16)
    write_series(path("scaled"), data, axial, slope=0.5, inter=3.0)
    img = nifti_of(path("scaled"), "scaled.nii")
    expected = (data.astype(np.float64) * 0.5 + 3.0).astype(np.float32)
    compare(img, expected, axial, "slope 0.5, intercept 3: float32", np.float32)
    big = synthetic(dtype=np.uint16) + np.uint16(1000)
    write_series(path("wide"), big, axial, slope=1.0, inter=-40000.0)
    compare(nifti_of(path("wide"), "wide.nii"), big.astype(np.float32) - 40000, axial,
            "uint16, intercept -40000: beyond int16, float32", np.float32)


def two_series():
    data = synthetic()
    axial = affine_of(np.eye(3), (1.0, 1.0, 2.0), (5.0, 5.0, 5.0))
    a, _ = write_series(path("two"), data, axial, description="first")
    b, _ = write_series(path("two"), data[::-1].copy(), axial, names=[f"b{k}.dcm" for k in range(7)],
                        description="second")
    refused(["convert", path("two"), "-o", path("two.nii")], path("two"), [a, b, "--series"], "two series, no choice")
    check(not os.path.exists(path("two.nii")), "two series: no partial output")
    compare(nifti_of(path("two"), "two_a.nii", "--series", a), data, axial, "two series: --series picks the first")
    compare(nifti_of(path("two"), "two_b.nii", "--series", b), data[::-1], axial, "two series: --series picks the second")
    refused(["info", path("two"), "--series", "1.2.3.4"], path("two"), ["1.2.3.4", a], "an unknown --series")


def hard_cases():
    data = synthetic()
    axial = affine_of(np.eye(3), (1.0, 1.0, 2.0), (0.0, 0.0, 0.0))

    def copy_of(name):
        folder = path(name)
        shutil.rmtree(folder, ignore_errors=True)
        _, files = write_series(folder, data, axial)
        return folder, files

    folder, files = copy_of("gap")
    os.remove(files[3])
    refused(["info", folder], files[4], ["gaps"], "a missing slice (gap)")
    folder, files = copy_of("nonuniform")
    ds = pydicom.dcmread(files[6])
    ds.ImagePositionPatient = ds_list([0, 0, 12.5])
    ds.save_as(files[6])
    refused(["convert", folder, "-o", path("nonuniform.nii")], files[6], ["non-uniform"], "non-uniform spacing")
    check(not os.path.exists(path("nonuniform.nii")), "non-uniform spacing: no partial output")
    folder, files = copy_of("duplicate")
    ds = pydicom.dcmread(files[2])
    ds.ImagePositionPatient = ds_list([0, 0, 2.0])
    ds.save_as(files[2])
    refused(["info", folder], files[2], ["same slice position"], "duplicated positions")
    folder, files = copy_of("mixed_size")
    ds = pydicom.dcmread(files[5])
    ds.Rows, ds.Columns = 5, 4
    ds.PixelData = np.zeros((5, 4), np.int16).tobytes()
    ds.save_as(files[5])
    refused(["info", folder], files[5], ["4x5"], "mixed rows/columns")
    folder, files = copy_of("mixed_orientation")
    ds = pydicom.dcmread(files[1])
    ds.ImageOrientationPatient = ds_list([1, 0, 0, 0, 0, -1])
    ds.save_as(files[1])
    refused(["info", folder], files[1], ["orientation"], "mixed orientation")
    folder, files = copy_of("tilted")
    for k, f in enumerate(files):
        ds = pydicom.dcmread(f)
        ds.ImagePositionPatient = ds_list([0, -0.5 * k, 2.0 * k])  # a gantry tilt: y drifts with z
        ds.save_as(f)
    refused(["info", folder], files[1], ["sheared"], "tilted stack")
    folder, files = copy_of("no_pixels")
    ds = pydicom.dcmread(files[4])
    del ds.PixelData
    ds.save_as(files[4])
    refused(["info", folder], files[4], ["no pixel data"], "missing pixel data")
    folder, files = copy_of("mpeg2")
    ds = pydicom.dcmread(files[0])
    ds.file_meta.TransferSyntaxUID = "1.2.840.10008.1.2.4.100"  # MPEG2 Main Profile: GDCM has no decoder
    ds.PixelData = encapsulate([b"\0\0\1\xb3" + bytes(60)])
    ds["PixelData"].VR = "OB"
    ds["PixelData"].is_undefined_length = True
    ds.save_as(files[0], write_like_original=False)
    refused(["info", folder], files[0], ["cannot decode"], "a transfer syntax GDCM cannot decode")
    # A file GDCM fails an assertion on (the fuzz regression): read in a child process, refused by name.
    here = os.path.dirname(os.path.abspath(__file__))
    forged = os.path.join(here, "..", "..", "fuzz", "regressions", "fuzz_read_dicom", "gdcm_assertion_in_meta_header.dcm")
    os.makedirs(path("forged"), exist_ok=True)
    shutil.copy(forged, path("forged", "forged.dcm"))
    refused(["info", path("forged", "forged.dcm")], path("forged", "forged.dcm"), ["not a readable DICOM file"],
            "a malformed file that makes GDCM abort")
    os.makedirs(path("empty"), exist_ok=True)
    with open(path("empty", "notes.txt"), "w") as f:
        f.write("no images here\n")
    refused(["info", path("empty")], path("empty"), ["no DICOM image"], "a folder without DICOM files")


shutil.rmtree(WORK, ignore_errors=True)  # series UIDs are fresh each run: no stale slices
os.makedirs(WORK)
geometry_cases()
rescale_cases()
two_series()
hard_cases()
real_volumes()
finish()
