#!/usr/bin/env python3
"""Edge coverage of a fuzz target's own parser files, from libFuzzer's -print_coverage=1 output.

  fuzz_target -runs=0 -print_coverage=1 CORPUS 2>&1 | scripts/fuzz_coverage.py TARGET

libFuzzer lists every instrumented function with its covered and total edges (COVERED_FUNC /
UNCOVERED_FUNC: "edges: a/b NAME FILE:LINE"). libFuzzer's own cov figure counts edges anywhere in
libvolcl; this sums only the files that hold the target's parser, so "how much of the NRRD reader did the
corpus reach" has an answer. Prints one line per file and a last line "TARGET total covered/total pct".
"""
import re
import sys

# The files that hold each target's parser (paths relative to the repository), shared helpers included.
IO = ["host/io/IoDetail.cpp", "host/io/VolumeIo.cpp"]
PARSER_FILES = {
    "fuzz_read_nrrd": ["host/io/NrrdFormat.cpp"] + IO,
    "fuzz_read_nhdr": ["host/io/NrrdFormat.cpp"] + IO,
    "fuzz_read_mha": ["host/io/MetaImageFormat.cpp"] + IO,
    "fuzz_read_mhd": ["host/io/MetaImageFormat.cpp"] + IO,
    "fuzz_read_nifti": ["host/io/NiftiFormat.cpp", "host/io/NiftiMetadata.cpp"] + IO,
    "fuzz_read_nifti_gz": ["host/io/NiftiFormat.cpp", "host/io/NiftiMetadata.cpp"] + IO,
    "fuzz_read_vtk": ["host/io/VtkLegacyFormat.cpp"] + IO,
    "fuzz_read_vti": ["host/io/VtkXmlFormat.cpp", "host/io/VtkXmlArrays.cpp", "host/io/XmlDocument.cpp"] + IO,
    "fuzz_read_slc": ["host/io/SlcFormat.cpp"] + IO,
    "fuzz_read_vdb": ["host/io/VdbFormat.cpp"] + IO,
    "fuzz_read_dat": ["host/io/SidecarFormats.cpp"] + IO,
    "fuzz_read_vvd": ["host/io/SidecarFormats.cpp", "host/io/XmlDocument.cpp"] + IO,
    "fuzz_read_raw_gz": ["host/io/RawFormat.cpp"] + IO,
    "fuzz_vcz": ["wavelet/container/VczFormat.cpp", "wavelet/FrameDecoder.cpp", "wavelet/Codec.cpp",
                 "wavelet/payload/BrickPayload.cpp", "wavelet/quantise/Corrections.cpp",
                 "wavelet/entropy/EntropyCoder.cpp", "wavelet/entropy/DenseDecoder.cpp",
                 "wavelet/entropy/FastCoder.cpp", "wavelet/entropy/Rans.cpp"],
    "fuzz_vcz_bricks": ["wavelet/container/VczFormat.cpp", "wavelet/FrameDecoder.cpp",
                        "wavelet/payload/BrickPayload.cpp", "wavelet/quantise/Corrections.cpp",
                        "wavelet/entropy/EntropyCoder.cpp", "wavelet/entropy/DenseDecoder.cpp",
                        "wavelet/entropy/FastCoder.cpp", "wavelet/entropy/Rans.cpp"],
    "fuzz_tf_json": ["host/tf/TransferFunction.cpp", "host/tf/ColorSpaces.cpp"],
    "fuzz_tf_png": ["host/tf/TransferFunction.cpp", "host/image/ImageIo.cpp"],
    "fuzz_tf_exr": ["host/image/ExrHeaderCheck.cpp", "host/tf/TransferFunction.cpp", "host/image/ImageIo.cpp"],
    "fuzz_scene_json": ["render/Scene.cpp"],
    "fuzz_mesh_vtk": ["host/mesh/VtkLegacyReader.cpp", "host/mesh/MeshIo.cpp", "host/mesh/CellSplit.cpp",
                      "host/mesh/TetMesh.cpp"],
    "fuzz_mesh_vtu": ["host/mesh/VtuReader.cpp", "host/io/VtkXmlArrays.cpp", "host/io/XmlDocument.cpp",
                      "host/mesh/MeshIo.cpp", "host/mesh/CellSplit.cpp", "host/mesh/TetMesh.cpp"],
    "fuzz_mesh_plot3d": ["host/mesh/Plot3dReader.cpp", "host/mesh/MeshIo.cpp", "host/mesh/CellSplit.cpp",
                         "host/mesh/TetMesh.cpp"],
    "fuzz_series_pvd": ["host/io/Series.cpp"] + IO,
}

LINE = re.compile(r"^(?:UN)?COVERED_FUNC: hits: \d+ edges: (\d+)/(\d+) .* (\S+):\d+$")


def main():
    if len(sys.argv) != 2 or sys.argv[1] not in PARSER_FILES:
        sys.exit("usage: fuzz_coverage.py TARGET < print_coverage output (targets: %s)" % " ".join(PARSER_FILES))
    target = sys.argv[1]
    files = PARSER_FILES[target]
    per_file = {f: [0, 0] for f in files}
    for line in sys.stdin:
        m = LINE.match(line.rstrip("\n"))
        if not m:
            continue
        path = m.group(3)
        for f in files:
            # Paths are as the compiler saw them (build-dir/../host/io/X.cpp), or the bare file name in a build
            # without debug information: match the repository-relative tail, or the name (unique in the tree).
            if path.endswith("/" + f) or path == f.rsplit("/", 1)[-1]:
                per_file[f][0] += int(m.group(1))
                per_file[f][1] += int(m.group(2))
    covered = total = 0
    for f in files:
        c, t = per_file[f]
        if t == 0:
            continue  # a file this build has no functions of (not instrumented or not reached by the linker)
        print("%s %s %d/%d %.1f%%" % (target, f, c, t, 100.0 * c / t))
        covered += c
        total += t
    print("%s total %d/%d %.1f%%" % (target, covered, total, 100.0 * covered / total if total else 0.0))


if __name__ == "__main__":
    main()
