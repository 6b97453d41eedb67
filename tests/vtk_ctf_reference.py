#!/usr/bin/python3
"""Colours of a ParaView colour map as VTK's own vtkColorTransferFunction draws them (test reference).

Usage: vtk_ctf_reference.py MAP.json LO HI N
Rescales the map's RGBPoints linearly onto [LO, HI] (as ParaView does when it fits a preset to the data)
and prints N lines "x r g b" at x = LO + i (HI - LO) / (N - 1). Exits 77 when VTK's Python module is
missing, so the calling test can skip with a message.
"""
import json
import sys

try:
    from vtkmodules.vtkRenderingCore import vtkColorTransferFunction
except ImportError:
    sys.exit(77)

path, lo, hi, n = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
cmap = json.load(open(path))
if isinstance(cmap, list):
    cmap = cmap[0]
pts = cmap["RGBPoints"]
xs = pts[0::4]
x0, x1 = min(xs), max(xs)
ctf = vtkColorTransferFunction()
space = cmap.get("ColorSpace", "RGB")
{"RGB": ctf.SetColorSpaceToRGB, "HSV": ctf.SetColorSpaceToHSV, "Lab": ctf.SetColorSpaceToLab,
 "Diverging": ctf.SetColorSpaceToDiverging, "Step": ctf.SetColorSpaceToStep}[space]()
for i in range(0, len(pts), 4):
    x = lo + (pts[i] - x0) * (hi - lo) / (x1 - x0)
    ctf.AddRGBPoint(x, pts[i + 1], pts[i + 2], pts[i + 3])
for i in range(n):
    x = lo + i * (hi - lo) / (n - 1)
    r, g, b = ctf.GetColor(x)
    print(f"{x!r} {r!r} {g!r} {b!r}")
