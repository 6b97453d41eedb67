#!/usr/bin/python3
"""VTK peer for `volcl bench preint --vtk`: builds vtkUnstructuredGridPreIntegration tables (incremental and
direct) for a volcl transfer function and table shape, times them and dumps the tables.

Run with Debian's interpreter (python3-vtk9): /usr/bin/python3 bench/vtk_preint_peer.py --tf tf.json ...

Shape mapping. VTK's table is float32 [d][s_b][s_f][RGBA] with lengths d * MaxLength / (L - 1), d = 0..L-1, and
scalar nodes range[0] + i (range[1] - range[0]) / (N - 1): the same node-centred scalar axis as volcl. VTK takes
MaxLength from the largest cell diagonal, so the script builds one tetrahedron whose bounding-box diagonal is
maxLength * (L - 1) / L; VTK's slice d then has length d * maxLength / L, which is volcl's slice d - 1.
Optical model. VTK's partial pre-integration reads the scalar opacity function as attenuation per unit length
(with ScalarOpacityUnitDistance = 1) and emits colour * attenuation: volcl's tau and c, unchanged.
"""
import argparse
import ctypes
import json
import math
import os
import statistics
import sys
import time

import numpy as np
import vtkmodules.vtkCommonCore as vcore
import vtkmodules.vtkCommonDataModel as vdm
import vtkmodules.vtkRenderingCore as vrc
import vtkmodules.vtkRenderingVolume as vrv


def piecewise_points(points):
    """VTK functions keep one value per x: a volcl step (two points at one s) moves the later point up by a
    relative 1e-9 of the domain, which is as close as VTK can represent a discontinuity."""
    out = []
    for p in points:
        s = float(p[0])
        if out and s <= out[-1][0]:
            s = out[-1][0] + 1e-9 * max(1.0, abs(s))
        out.append([s] + [float(v) for v in p[1:]])
    return out


def build_volume(tf, max_length_vtk, workaround=True):
    lo, hi = tf["domain"]
    pts = vcore.vtkPoints()
    pts.SetDataTypeToDouble()
    a = max_length_vtk / math.sqrt(3.0)
    for p in [(0, 0, 0), (a, 0, 0), (0, a, 0), (0, 0, a)]:
        pts.InsertNextPoint(p)
    grid = vdm.vtkUnstructuredGrid()
    grid.SetPoints(pts)
    ids = vcore.vtkIdList()
    for i in range(4):
        ids.InsertNextId(i)
    grid.InsertNextCell(vdm.VTK_TETRA, ids)
    scalars = vcore.vtkDoubleArray()
    scalars.SetName("s")
    for v in [lo, hi, 0.5 * (lo + hi), lo]:
        scalars.InsertNextValue(v)
    grid.GetPointData().SetScalars(scalars)

    ctf = vrc.vtkColorTransferFunction()
    for s, r, g, b in piecewise_points(tf["color"]):
        ctf.AddRGBPoint(s, r, g, b)
    if workaround:
        # vtkPartialPreIntegrationTransferFunction::GetTransferFunction collects the opacity function's control
        # points in a loop that stops at the first one (it tests `function[0] == function_range[0]`), so
        # extinction knots that are not colour knots are ignored and tau is interpolated across them. Adding
        # colour points on the colour function's own line at those knots leaves the TF unchanged and lets VTK
        # see every knot.
        known = {p[0] for p in piecewise_points(tf["color"])}
        for s, _ in piecewise_points(tf["extinction"]):
            if s not in known:
                rgb = [0.0, 0.0, 0.0]
                ctf.GetColor(s, rgb)
                ctf.AddRGBPoint(s, *rgb)
    otf = vcore.vtkPiecewiseFunction() if hasattr(vcore, "vtkPiecewiseFunction") else vdm.vtkPiecewiseFunction()
    for s, tau in piecewise_points(tf["extinction"]):
        otf.AddPoint(s, tau)
    prop = vrc.vtkVolumeProperty()
    prop.SetColor(ctf)
    prop.SetScalarOpacity(otf)
    prop.SetScalarOpacityUnitDistance(1.0)
    mapper = vrv.vtkUnstructuredGridVolumeRayCastMapper()
    mapper.SetInputData(grid)
    volume = vrc.vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)
    return volume, scalars, (ctf, otf, prop, mapper, grid)


def build_table(volume, scalars, n, lengths, incremental):
    integ = vrv.vtkUnstructuredGridPreIntegration()
    integ.SetIntegrationTableScalarResolution(n)
    integ.SetIntegrationTableLengthResolution(lengths)
    integ.SetIncrementalPreIntegration(1 if incremental else 0)
    t0 = time.perf_counter()
    integ.Initialize(volume, scalars)
    ms = (time.perf_counter() - t0) * 1e3
    return integ, ms


def table_array(integ, n, lengths):
    ptr = integ.GetPreIntegrationTable(0)  # "_<hex address>_p_void"
    addr = int(ptr[1:].split("_")[0], 16)
    raw = ctypes.cast(addr, ctypes.POINTER(ctypes.c_float))
    return np.ctypeslib.as_array(raw, shape=(lengths, n, n, 4)).copy()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tf", required=True, help="volcl canonical transfer-function JSON")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--lengths", type=int, default=256)
    ap.add_argument("--max-length", type=float, required=True, help="volcl's largest length D")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--report", required=True)
    ap.add_argument("--as-is", action="store_true",
                    help="do not add colour points at extinction knots (shows VTK's opacity control-point bug)")
    args = ap.parse_args()
    with open(args.tf) as f:
        tf = json.load(f)
    max_length_vtk = args.max_length * (args.lengths - 1) / args.lengths
    volume, scalars, keep = build_volume(tf, max_length_vtk, workaround=not args.as_is)
    report = {"runs": args.runs, "workaround": not args.as_is, "size": args.size, "lengths": args.lengths, "max_length": args.max_length,
              "vtk_version": vcore.vtkVersion.GetVTKVersion()}
    for mode, incremental in (("incremental", True), ("direct", False)):
        build_table(volume, scalars, args.size, args.lengths, incremental)  # warm-up (allocator, caches)
        times = []
        integ = None
        for _ in range(args.runs):
            integ, ms = build_table(volume, scalars, args.size, args.lengths, incremental)
            times.append(ms)
        scale = integ.GetIntegrationTableLengthScale()
        table = table_array(integ, args.size, args.lengths)
        path = os.path.join(args.out_dir, "vtk_%s.f32" % mode)
        table.astype(np.float32).tofile(path)
        report[mode] = {"time_ms": statistics.median(times), "times_ms": times, "table": path,
                        "length_step": 1.0 / scale}
        print("VTK %-11s %dx%dx%d: median %.1f ms over %d runs" % (mode, args.size, args.size, args.lengths,
                                                                  statistics.median(times), args.runs),
              file=sys.stderr)
    with open(args.report, "w") as f:
        json.dump(report, f, indent=1)
    sys.stdout.flush()
    sys.stderr.flush()
    # VTK's volume mapper without a render window crashes in its destructors; the work is done and written.
    os._exit(0)


if __name__ == "__main__":
    main()
