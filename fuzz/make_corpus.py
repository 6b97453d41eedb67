#!/usr/bin/env python3
"""Writes the fuzz seed corpora into fuzz/corpus/<target>/: a few small valid inputs per target.

Text headers and small binary files are built here; .vcz seeds (both entropy coders, every transform)
come from `volcl encode`, the EXR strip from oiiotool. Usage: fuzz/make_corpus.py path/to/volcl
"""
import gzip
import os
import struct
import subprocess
import sys
import tempfile
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "corpus")


def put(target, name, data):
    d = os.path.join(CORPUS, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def ramp(n, mod=251):
    return bytes((i * 7) % mod for i in range(n))


def nrrd_seeds():
    data = ramp(4 * 3 * 2)
    put("fuzz_read_nrrd", "raw.nrrd",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 3 2\nspacings: 1 1.5 2\nencoding: raw\n\n" + data)
    put("fuzz_read_nrrd", "gzip16.nrrd",
        b"NRRD0005\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: big\nencoding: gzip\n"
        b"space dimension: 3\nspace directions: (1,0,0) (0,2,0) (0,0,3)\nspace origin: (1,2,3)\n\n" +
        gzip.compress(struct.pack(">24h", *range(-12, 12))))
    put("fuzz_read_nrrd", "ascii4d.nrrd",
        "NRRD0004\ntype: float\ndimension: 4\nsizes: 2 2 1 2\nencoding: ascii\naxis mins: 0 0 0 0\n\n"
        "1 2 3 4\n5.5 6 7e1 -8\n")
    put("fuzz_read_nhdr", "single.nhdr",
        b"NRRD0004\ntype: ushort\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n"
        b"data file: data.raw\n\0" + struct.pack("<24H", *range(24)))
    put("fuzz_read_nhdr", "skip.nhdr",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 3 2\nencoding: raw\nbyte skip: -1\n"
        b"data file: data.raw\n\0" + b"junk" + data)
    put("fuzz_read_nhdr", "list.nhdr",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 3 2\nencoding: raw\ndata file: LIST\n"
        b"data.raw\ndata.raw\n\0" + data[:12])


def meta_seeds():
    data = ramp(4 * 3 * 2)
    put("fuzz_read_mha", "local.mha",
        b"ObjectType = Image\nNDims = 3\nDimSize = 4 3 2\nElementSpacing = 1 1 2\nOffset = 0 1 2\n"
        b"ElementType = MET_UCHAR\nElementDataFile = LOCAL\n" + data)
    put("fuzz_read_mha", "zlib16.mha",
        b"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nElementByteOrderMSB = True\n"
        b"CompressedData = True\nElementDataFile = LOCAL\n" + zlib.compress(struct.pack(">24h", *range(24))))
    put("fuzz_read_mhd", "raw.mhd",
        b"NDims = 3\nDimSize = 4 3 2\nElementType = MET_FLOAT\nHeaderSize = 0\nElementDataFile = data.raw\n\0" +
        struct.pack("<24f", *[i * 0.5 for i in range(24)]))
    put("fuzz_read_mhd", "pattern4d.mhd",
        b"NDims = 4\nDimSize = 2 2 1 2\nElementType = MET_UCHAR\nElementDataFile = data.r%d 1 2 1\n\0" +
        data[:8])


def nifti_header(datatype, bitpix, dims, slope=1.0, inter=0.0, sform=True):
    h = bytearray(352)
    struct.pack_into("<i", h, 0, 348)
    struct.pack_into("<8h", h, 40, len(dims), *dims, *([1] * (7 - len(dims))))
    struct.pack_into("<hh", h, 70, datatype, bitpix)
    struct.pack_into("<8f", h, 76, 1, 1.5, 1, 2, 1, 1, 1, 1)
    struct.pack_into("<fff", h, 108, 352.0, slope, inter)
    struct.pack_into("<hh", h, 252, 0, 1 if sform else 0)
    struct.pack_into("<12f", h, 280, 1.5, 0, 0, 10, 0, 1, 0, 20, 0, 0, 2, 30)
    h[344:348] = b"n+1\0"
    return bytes(h)


def nifti_seeds():
    put("fuzz_read_nifti", "u8.nii", nifti_header(2, 8, [4, 3, 2]) + ramp(24))
    put("fuzz_read_nifti", "i16_scaled.nii", nifti_header(4, 16, [4, 3, 2], 0.5, 3) + struct.pack("<24h", *range(24)))
    put("fuzz_read_nifti", "f32_4d.nii", nifti_header(16, 32, [2, 2, 1, 2], sform=False) +
        struct.pack("<8f", *range(8)))
    put("fuzz_read_nifti_gz", "u8.nii.gz", gzip.compress(nifti_header(2, 8, [4, 3, 2]) + ramp(24)))


def vtk_seeds():
    put("fuzz_read_vtk", "ascii.vtk",
        "# vtk DataFile Version 3.0\nseed\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 3 2 2\n"
        "SPACING 1 2 3\nORIGIN 0 0 0\nPOINT_DATA 12\nSCALARS density float 1\nLOOKUP_TABLE default\n"
        "0 1 2 3 4 5 6 7 8 9 10 11\n")
    put("fuzz_read_vtk", "binary.vtk",
        b"# vtk DataFile Version 3.0\nseed\nBINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS 3 2 2\n"
        b"ASPECT_RATIO 1 1 1\nORIGIN 1 1 1\nPOINT_DATA 12\nSCALARS s short\nLOOKUP_TABLE default\n" +
        struct.pack(">12h", *range(12)) + b"\n")
    raw = struct.pack("<12f", *range(12))
    put("fuzz_read_vti", "ascii.vti",
        '<?xml version="1.0"?>\n<VTKFile type="ImageData" version="0.1" byte_order="LittleEndian">\n'
        '<ImageData WholeExtent="0 2 0 1 0 1" Origin="0 0 0" Spacing="1 1 1">\n'
        '<Piece Extent="0 2 0 1 0 1"><PointData Scalars="s">\n'
        '<DataArray type="Float32" Name="s" format="ascii">0 1 2 3 4 5 6 7 8 9 10 11</DataArray>\n'
        '</PointData></Piece></ImageData></VTKFile>\n')
    put("fuzz_read_vti", "appended.vti",
        b'<?xml version="1.0"?>\n<VTKFile type="ImageData" version="0.1" byte_order="LittleEndian" '
        b'header_type="UInt32">\n<ImageData WholeExtent="0 2 0 1 0 1" Origin="0 0 0" Spacing="1 2 1">\n'
        b'<Piece Extent="0 2 0 1 0 1"><PointData Scalars="s">\n'
        b'<DataArray type="Float32" Name="s" format="appended" offset="0"/>\n'
        b'</PointData></Piece></ImageData>\n<AppendedData encoding="raw">\n_' +
        struct.pack("<I", len(raw)) + raw + b"\n</AppendedData></VTKFile>\n")


def slc_seeds():
    # VolVis SLC: magic, sizes, bits, voxel sizes, unit/source/modification, compression, icon, data.
    head = b"11111\n4 3 2 8\n1.0 1.0 2.0\n0 0 0 0\n2 2\n"
    icon = bytes(3 * 4)
    put("fuzz_read_slc", "plain.slc", head + b"X" + icon + b"X" + ramp(24))
    runs = b"".join(bytes([0x80 | 12]) + ramp(12) for _ in range(2)) + b"\x00"
    put("fuzz_read_slc", "rle.slc", b"11111\n4 3 2 8\n1.0 1.0 2.0\n0 0 0 1\n2 2\n" + b"X" + icon + b"X" + runs)


def sidecar_seeds():
    put("fuzz_read_dat", "u8.dat",
        b"ObjectFileName: data.raw\nResolution: 4 3 2\nSliceThickness: 1 1 2\nFormat: UCHAR\n\0" + ramp(24))
    put("fuzz_read_dat", "u16_seq.dat",
        b"ObjectFileName: data.raw\nResolution: 2 2 1\nFormat: USHORT\nByteOrder: BigEndian\nSequences: 2\n"
        b"ByteOffset: 2\n\0" + b"\0\0" + struct.pack(">8H", *range(8)))
    put("fuzz_read_vvd", "u8.vvd",
        b'<?xml version="1.0" ?>\n<VoreenData version="1">\n<Volumes><Volume>\n'
        b'<RawData filename="data.raw" format="uint8" x="4" y="3" z="2" />\n'
        b'<MetaData><MetaItem name="Spacing" type="Vec3MetaData"><value x="1" y="1" z="2" /></MetaItem>'
        b'<MetaItem name="Offset" type="Vec3MetaData"><value x="0" y="0" z="0" /></MetaItem></MetaData>\n'
        b'</Volume></Volumes>\n</VoreenData>\n\0' + ramp(24))


def raw_seeds():
    put("fuzz_read_raw_gz", "ramp.raw.gz", gzip.compress(struct.pack("<64H", *range(64))))
    put("fuzz_read_raw_gz", "members.raw.gz",
        gzip.compress(struct.pack("<32H", *range(32))) + gzip.compress(struct.pack("<32H", *range(32))))


def json_seeds():
    put("fuzz_tf_json", "canonical.json",
        '{"domain": [0, 255], "color": [[0, 0, 0, 0], [128, 1, 0.6, 0.2], [255, 1, 1, 1]],\n'
        ' "extinction": [[0, 0], [60, 0], [80, 0.8], [255, 0.05]], "name": "seed"}')
    put("fuzz_tf_json", "step.json",
        '{"domain": [0, 1], "color": [[0, 1, 0, 0], [0.5, 1, 0, 0], [0.5, 0, 0, 1], [1, 0, 0, 1]],'
        ' "extinction": [[0, 0], [0.5, 0], [0.5, 50], [1, 50]]}')
    put("fuzz_tf_json", "paraview.json",
        '[{"Name": "seed", "ColorSpace": "RGB", "RGBPoints": [0, 0, 0, 1, 0.5, 1, 1, 1, 1, 1, 0, 0],'
        ' "Points": [0, 0, 0.5, 0, 0.5, 0.2, 0.5, 0, 1, 1, 0.5, 0]}]')
    put("fuzz_scene_json", "dvr.json",
        '{"volume": "v_8x8x8_uint8.raw", "tf": "tf.json",\n'
        ' "camera": {"projection": "orthographic", "eye": [4, 4, -20], "target": [4, 4, 4], "up": [0, 1, 0],'
        ' "height": 10},\n "image": {"width": 32, "height": 24, "background": [0, 0, 0, 1]},\n'
        ' "render": {"mode": "dvr", "step": 0.5, "preintegration": "3d", "table_size": 64,'
        ' "table_lengths": 8},\n "lights": [{"type": "directional", "direction": [0, 0, 1], "intensity": 1}],\n'
        ' "effects": {"shading": {"ambient": 0.2, "diffuse": 0.7, "specular": 0.3, "shininess": 20},'
        ' "shadows": true, "shadow_step": 1, "gradient": "sobel"}}')
    put("fuzz_scene_json", "iso.json",
        '{"volume": "v.nrrd", "render": {"mode": "iso", "step": 0.25},'
        ' "camera": {"projection": "perspective", "eye": [0, 0, -30], "target": [0, 0, 0], "up": [0, 1, 0],'
        ' "fov_y_deg": 40},'
        ' "effects": {"isosurfaces": [{"value": 100, "color": [1, 0.5, 0, 1]}],'
        ' "clip_planes": [{"normal": [1, 0, 0], "offset": 2}], "scattering": {"albedo": 0.5, "g": 0.3}}}')


def png_strip(width):
    rows = b"".join(b"\0" + bytes(c for x in range(width) for c in (x * 30 % 256, 128, 255 - x * 20 % 256, x * 16 % 256))
                    for _ in range(1))
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xffffffff)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, 1, 8, 6, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def strip_seeds():
    put("fuzz_tf_png", "strip8.png", png_strip(8))
    put("fuzz_tf_png", "strip2.png", png_strip(2))
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "strip.exr")
        subprocess.run(["oiiotool", "--pattern", "fill:left=0,0,0,0:right=1,0.5,0.2,1", "8x1", "4",
                        "-d", "float", "-o", out], check=True)
        with open(out, "rb") as f:
            put("fuzz_tf_exr", "strip8.exr", f.read())
        out = os.path.join(tmp, "half.exr")
        subprocess.run(["oiiotool", "--pattern", "constant:color=1,0.5,0.25,0.5", "4x1", "4",
                        "-d", "half", "--compression", "zip", "-o", out], check=True)
        with open(out, "rb") as f:
            put("fuzz_tf_exr", "half4.exr", f.read())


def vcz_and_vdb_seeds(volcl):
    with tempfile.TemporaryDirectory() as tmp:
        u8 = os.path.join(tmp, "v_12x10x8_uint8.raw")
        with open(u8, "wb") as f:
            f.write(bytes((x * 3 + y * 5 + z * 7) % 256 for z in range(8) for y in range(10) for x in range(12)))
        f32 = os.path.join(tmp, "v_8x8x8_float32.raw")
        with open(f32, "wb") as f:
            f.write(struct.pack("<512f", *[((i * 37) % 101) * 0.25 - 3 for i in range(512)]))
        runs = [
            ("lossless_dense_cdf53.vcz", u8, ["--lossless", "--brick", "8", "--levels", "2"]),
            ("lossless_fast_haar.vcz", u8, ["--lossless", "--entropy", "fast", "--wavelet", "haar", "--brick", "8", "--levels", "3"]),
            ("lossless_cdf26_levels1.vcz", u8, ["--lossless", "--wavelet", "cdf26", "--levels", "1", "--brick", "4"]),
            ("lossy_cdf97_dense.vcz", f32, ["--max-error", "0.1", "--brick", "8", "--levels", "2"]),
            ("lossy_cdf53_fast.vcz", u8, ["--psnr", "40", "--wavelet", "cdf53", "--entropy", "fast", "--brick", "8", "--levels", "2"]),
            ("rawbits_float.vcz", f32, ["--lossless", "--brick", "8", "--levels", "1"]),
        ]
        # Voxel-coded bricks (version 7): labels in few values (palette, u8 indices), uint16 labels in more than
        # 256 values (u16 indices) in a lossy file, noise (raw byte planes).
        labels = os.path.join(tmp, "l_16x16x16_uint8.raw")
        with open(labels, "wb") as f:
            f.write(bytes((x // 5 + 3 * (y // 6) + 7 * (z // 4)) % 9 for z in range(16) for y in range(16)
                          for x in range(16)))
        labels16 = os.path.join(tmp, "l_32x32x8_uint16.raw")
        with open(labels16, "wb") as f:
            f.write(struct.pack("<8192H", *[(x // 2 + 16 * (y // 2) + 256 * (z // 2)) * 37 % 700 for z in range(8)
                                            for y in range(32) for x in range(32)]))
        noise = os.path.join(tmp, "n_16x16x8_uint8.raw")
        with open(noise, "wb") as f:
            f.write(bytes((i * 2654435761 >> 13) % 256 for i in range(2048)))
        runs += [
            ("voxel_palette_u8.vcz", labels, ["--lossless", "--brick", "8", "--levels", "2", "--no-lod-stats"]),
            ("voxel_palette_u16_psnr.vcz", labels16, ["--psnr", "50", "--brick", "32", "--levels", "2", "--no-lod-stats"]),
            ("voxel_raw_noise.vcz", noise, ["--lossless", "--brick", "8", "--levels", "2", "--no-lod-stats"]),
        ]
        for name, src, flags in runs:
            out = os.path.join(tmp, name)
            subprocess.run([volcl, "-q", "encode", src, "-o", out, *flags], check=True)
            with open(out, "rb") as f:
                put("fuzz_vcz", name, f.read())
        # A motion-compensated series (I, B, I, P frames with their motion blocks): P/B decoding paths in the
        # version 6 container. Seeds of the older layouts were written by earlier encoders and are kept as
        # they are (nothing writes them now; tests/test_motion_codec.cpp decodes them): v3_*.vcz, the single
        # volumes above in version 3; motion_v4_* and motion_v5_*, these frames in versions 4 and 5.
        for f in range(4):
            frame = bytes(((x + f) * 7 + y * 3 + z * 5) % 200 if (x + f) % 8 < 5 else 20
                          for z in range(8) for y in range(8) for x in range(8))
            with open(os.path.join(tmp, "s%d_8x8x8_uint8.raw" % f), "wb") as fh:
                fh.write(frame)
        out = os.path.join(tmp, "motion.vcz")
        subprocess.run([volcl, "-q", "encode", os.path.join(tmp, "s*_8x8x8_uint8.raw"), "-o", out, "--lossless",
                        "--gop", "4", "--b-frames", "1", "--brick", "8", "--levels", "1"], check=True)
        with open(out, "rb") as f:
            put("fuzz_vcz", "motion_lossless_gop4_b1.vcz", f.read())
        out = os.path.join(tmp, "v.vdb")
        subprocess.run([volcl, "-q", "convert", f32, "-o", out], check=True)
        with open(out, "rb") as f:
            put("fuzz_read_vdb", "float.vdb", f.read())


def mesh_seeds():
    # One tetrahedron (VTK cell type 10) and one hexahedron (12), with a point scalar.
    put("fuzz_mesh_vtk", "tet_ascii.vtk",
        "# vtk DataFile Version 2.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n"
        "0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 4\n"
        "SCALARS s float 1\nLOOKUP_TABLE default\n0 1 2 3\n")
    cube = [(x, y, z) for z in (0, 1) for y in (0, 1) for x in (0, 1)]
    hexa = [0, 1, 3, 2, 4, 5, 7, 6]
    put("fuzz_mesh_vtk", "hex_binary51.vtk",
        b"# vtk DataFile Version 5.1\nh\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 8 float\n" +
        struct.pack(">24f", *[c for p in cube for c in p]) +
        b"\nCELLS 2 8\nOFFSETS vtktypeint64\n" + struct.pack(">2q", 0, 8) +
        b"\nCONNECTIVITY vtktypeint64\n" + struct.pack(">8q", *hexa) +
        b"\nCELL_TYPES 1\n" + struct.pack(">i", 12) +
        b"\nPOINT_DATA 8\nSCALARS s double 1\nLOOKUP_TABLE default\n" + struct.pack(">8d", *range(8)) + b"\n")

    def vtu(arrays, appended=b""):
        head = ('<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" '
                'byte_order="LittleEndian" header_type="UInt32">\n<UnstructuredGrid>\n'
                '<Piece NumberOfPoints="%d" NumberOfCells="%d">\n' % arrays["counts"])
        body = ('<PointData Scalars="s">%s</PointData>\n<Points>%s</Points>\n<Cells>%s</Cells>\n'
                '</Piece></UnstructuredGrid>\n' % (arrays["s"], arrays["points"], arrays["cells"]))
        tail = (b'<AppendedData encoding="raw">\n_' + appended + b"\n</AppendedData>\n") if appended else b""
        return head.encode() + body.encode() + tail + b"</VTKFile>\n"

    put("fuzz_mesh_vtu", "tet_ascii.vtu", vtu({
        "counts": (4, 1),
        "s": '<DataArray type="Float32" Name="s" format="ascii">0 1 2 3</DataArray>',
        "points": '<DataArray type="Float32" NumberOfComponents="3" format="ascii">0 0 0 1 0 0 0 1 0 0 0 1'
                  '</DataArray>',
        "cells": '<DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 3</DataArray>'
                 '<DataArray type="Int32" Name="offsets" format="ascii">4</DataArray>'
                 '<DataArray type="UInt8" Name="types" format="ascii">10</DataArray>'}))
    blocks = [struct.pack("<8f", *range(8)), struct.pack("<24f", *[c for p in cube for c in p]),
              struct.pack("<8q", *hexa), struct.pack("<q", 8), struct.pack("<B", 12)]
    offsets, data = [], b""
    for b in blocks:
        offsets.append(len(data))
        data += struct.pack("<I", len(b)) + b
    put("fuzz_mesh_vtu", "hex_appended.vtu", vtu({
        "counts": (8, 1),
        "s": '<DataArray type="Float32" Name="s" format="appended" offset="%d"/>' % offsets[0],
        "points": '<DataArray type="Float32" NumberOfComponents="3" format="appended" offset="%d"/>' % offsets[1],
        "cells": ('<DataArray type="Int64" Name="connectivity" format="appended" offset="%d"/>'
                  '<DataArray type="Int64" Name="offsets" format="appended" offset="%d"/>'
                  '<DataArray type="UInt8" Name="types" format="appended" offset="%d"/>') % tuple(offsets[2:])},
        data))

    # PLOT3D: a 2x2x2 grid (one hexahedron) and its q file, as "grid length (2 bytes LE), grid, q".
    def plot3d(endian, real, markers, iblank):
        def record(payload):
            return (struct.pack(endian + "i", len(payload)) + payload + struct.pack(endian + "i", len(payload))
                    if markers else payload)
        dims = struct.pack(endian + "3i", 2, 2, 2)
        coords = struct.pack(endian + "24" + real, *[p[a] for a in range(3) for p in cube])
        grid = record(dims) + record(coords + (struct.pack(endian + "8i", *[1] * 8) if iblank else b""))
        q = (record(dims) + record(struct.pack(endian + "4" + real, 0.5, 0.0, 1e6, 0.0)) +
             record(struct.pack(endian + "40" + real, *[1.0 + 0.1 * i for i in range(40)])))
        return struct.pack("<H", len(grid)) + grid + q

    put("fuzz_mesh_plot3d", "plain_le_f32.xyz", plot3d("<", "f", False, False))
    put("fuzz_mesh_plot3d", "records_be_f64_iblank.xyz", plot3d(">", "d", True, True))


def vcm_seeds(volcl):
    # .vcm meshes encoded by volcl from the mesh seeds: a tet lossless, split hexahedra at 16 and 3 bits,
    # and a two-component mesh (a second tet apart from the hexahedron) whose border empties midway.
    with tempfile.TemporaryDirectory() as tmp:
        def encode(seed_dir, seed, name, args):
            src = os.path.join(tmp, seed)
            with open(os.path.join(HERE, "corpus", seed_dir, seed), "rb") as f, open(src, "wb") as g:
                g.write(f.read())
            out = os.path.join(tmp, name)
            subprocess.run([volcl, "--quiet", "encode", src, "-o", out] + args, check=True)
            with open(out, "rb") as f:
                put("fuzz_mesh_vcm", name, f.read())
        encode("fuzz_mesh_vtu", "tet_ascii.vtu", "tet_lossless.vcm", ["--lossless"])
        encode("fuzz_mesh_vtu", "hex_appended.vtu", "hex_16bits.vcm", [])
        encode("fuzz_mesh_vtu", "hex_appended.vtu", "hex_3bits.vcm", ["--bits", "3"])
        two = os.path.join(tmp, "two.vtk")
        with open(two, "w") as f:
            f.write("# vtk DataFile Version 2.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 8 float\n"
                    "0 0 0 1 0 0 0 1 0 0 0 1 5 5 5 6 5 5 5 6 5 5 5 6\nCELLS 2 10\n4 0 1 2 3\n4 4 5 6 7\n"
                    "CELL_TYPES 2\n10\n10\nPOINT_DATA 8\nSCALARS s float 1\nLOOKUP_TABLE default\n"
                    "0 1 2 3 4 5 6 7\n")
        out = os.path.join(tmp, "two_components.vcm")
        subprocess.run([volcl, "--quiet", "encode", two, "-o", out], check=True)
        with open(out, "rb") as f:
            put("fuzz_mesh_vcm", "two_components.vcm", f.read())


def series_seeds():
    # A .pvd, a NUL byte, then the "frame.nrrd" its data sets name.
    frame = (b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 3 2\nencoding: raw\n\n" + ramp(24))
    put("fuzz_series_pvd", "two_steps.pvd",
        b'<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n<Collection>\n'
        b'<DataSet timestep="0.5" group="" part="0" file="frame.nrrd"/>\n'
        b'<DataSet timestep="0" group="" part="0" file="frame.nrrd"/>\n</Collection>\n</VTKFile>\n\0' + frame)
    frame4d = (b"NRRD0004\ntype: short\ndimension: 4\nsizes: 2 2 1 3\nendian: little\nencoding: raw\n\n" +
               struct.pack("<12h", *range(12)))
    put("fuzz_series_pvd", "one_4d_file.pvd",
        b'<VTKFile type="Collection"><Collection><DataSet timestep="1" file="./frame.nrrd"/>'
        b'</Collection></VTKFile>\0' + frame4d)


def dicom_element(group, element, vr, value):
    """One explicit-VR little-endian data element; values padded to even length as DICOM requires."""
    if isinstance(value, str):
        value = value.encode()
    if len(value) % 2:
        value += b"\0" if vr in (b"UI", b"OB") else b" "
    if vr in (b"OB", b"OW", b"UN", b"SQ", b"UT"):
        return struct.pack("<HH2sHI", group, element, vr, 0, len(value)) + value
    return struct.pack("<HH2sH", group, element, vr, len(value)) + value


def dicom_file(rows, columns, pixels, bits, signed, extra=b"", ts="1.2.840.10008.1.2.1"):
    """A DICOM Part 10 MR slice: preamble, "DICM", the meta group, then the data set in tag order."""
    meta = (dicom_element(0x0002, 0x0001, b"OB", b"\0\1") +
            dicom_element(0x0002, 0x0002, b"UI", "1.2.840.10008.5.1.4.1.1.4") +
            dicom_element(0x0002, 0x0003, b"UI", "1.2.3.4.5.6") + dicom_element(0x0002, 0x0010, b"UI", ts))
    meta = dicom_element(0x0002, 0x0000, b"UL", struct.pack("<I", len(meta))) + meta
    body = (dicom_element(0x0008, 0x0016, b"UI", "1.2.840.10008.5.1.4.1.1.4") +
            dicom_element(0x0008, 0x0018, b"UI", "1.2.3.4.5.6") + dicom_element(0x0008, 0x0060, b"CS", "MR") +
            dicom_element(0x0018, 0x0050, b"DS", "2.5") +
            dicom_element(0x0020, 0x000E, b"UI", "1.2.3.4.7") +
            dicom_element(0x0020, 0x0032, b"DS", "-10\\20.5\\3") +
            dicom_element(0x0020, 0x0037, b"DS", "1\\0\\0\\0\\0.8\\-0.6") +
            dicom_element(0x0028, 0x0002, b"US", struct.pack("<H", 1)) +
            dicom_element(0x0028, 0x0004, b"CS", "MONOCHROME2") +
            dicom_element(0x0028, 0x0010, b"US", struct.pack("<H", rows)) +
            dicom_element(0x0028, 0x0011, b"US", struct.pack("<H", columns)) +
            dicom_element(0x0028, 0x0030, b"DS", "0.5\\0.75") +
            dicom_element(0x0028, 0x0100, b"US", struct.pack("<H", bits)) +
            dicom_element(0x0028, 0x0101, b"US", struct.pack("<H", bits)) +
            dicom_element(0x0028, 0x0102, b"US", struct.pack("<H", bits - 1)) +
            dicom_element(0x0028, 0x0103, b"US", struct.pack("<H", 1 if signed else 0)) + extra +
            dicom_element(0x7FE0, 0x0010, b"OW" if bits > 8 else b"OB", pixels))
    return bytes(128) + b"DICM" + meta + body


def dicom_seeds():
    put("fuzz_read_dicom", "i16.dcm", dicom_file(3, 4, struct.pack("<12h", *range(-6, 6)), 16, True))
    put("fuzz_read_dicom", "u8.dcm", dicom_file(3, 4, ramp(12), 8, False))
    rescale = dicom_element(0x0028, 0x1052, b"DS", "-1024") + dicom_element(0x0028, 0x1053, b"DS", "0.5")
    put("fuzz_read_dicom", "u16_rescaled.dcm", dicom_file(2, 2, struct.pack("<4H", 0, 1, 4000, 65535), 16, False,
                                                           rescale))


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: make_corpus.py path/to/volcl")
    nrrd_seeds()
    meta_seeds()
    nifti_seeds()
    vtk_seeds()
    slc_seeds()
    sidecar_seeds()
    raw_seeds()
    json_seeds()
    strip_seeds()
    mesh_seeds()
    series_seeds()
    dicom_seeds()
    vcz_and_vdb_seeds(sys.argv[1])
    vcm_seeds(sys.argv[1])


if __name__ == "__main__":
    main()
