# pvbatch script: loads the VolclReader plugin, reads a .vcz, volume-renders it and writes the image and the
# reader's per-rank decode report (JSON). The same script runs on 1 rank and under mpiexec on several.
# Usage: pvbatch [--mpi] pvbatch_render.py PLUGIN VCZ OUT.png OUT.json [--level L] [--time T] [--size W H]
#        [--bench K]
# --bench K: afterwards K rounds of decoding at the next level and back (kernels built, file read) and a
# render from a moved camera, each timed, for docs/scaleout.md.
# Exit 1 with one line naming the file when the reader fails (for example on a corrupt file).
import json
import sys
import time

from paraview import servermanager
from paraview.simple import (ColorBy, CreateView, GetColorTransferFunction, GetOpacityTransferFunction,
                             LoadPlugin, Render, SaveScreenshot, Show)

args = sys.argv[1:]
plugin, vcz, png, report_path = args[:4]
level, size, bench, when = 0, [320, 240], 0, None
rest = args[4:]
while rest:
    if rest[0] == "--level":
        level, rest = int(rest[1]), rest[2:]
    elif rest[0] == "--time":
        when, rest = float(rest[1]), rest[2:]
    elif rest[0] == "--bench":
        bench, rest = int(rest[1]), rest[2:]
    elif rest[0] == "--size":
        size, rest = [int(rest[1]), int(rest[2])], rest[3:]
    else:
        sys.exit("pvbatch_render.py: unknown argument " + rest[0])

ranks = servermanager.vtkProcessModule.GetProcessModule().GetNumberOfLocalPartitions()
LoadPlugin(plugin, ns=globals())
t0 = time.perf_counter()
reader = VolclVczReader(FileName=vcz)  # noqa: F821 (defined by the plugin)
reader.Level = level  # after creation: the level's domain default would override a constructor argument
if when is None:
    reader.UpdatePipeline()
else:
    reader.UpdatePipeline(when)
t_read = time.perf_counter() - t0
reader.UpdatePropertyInformation()
info = reader.GetDataInformation()
report = json.loads(reader.GetProperty("DecodeReport").GetElement(0) or "[]")
if info.GetNumberOfPoints() == 0 or not report or not all(r["ok"] for r in report):
    print("pvbatch_render.py: %s: the reader produced no data" % vcz, file=sys.stderr)
    sys.exit(1)

view = CreateView("RenderView")
view.ViewSize = size
if when is not None:
    view.ViewTime = when
view.OrientationAxesVisibility = 0
view.Background = [0.0, 0.0, 0.0]
try:  # ParaView 5.10+: the background is taken from the palette unless told otherwise
    view.UseColorPaletteForBackground = 0
except AttributeError:
    pass
display = Show(reader, view)
display.Representation = "Volume"
ColorBy(display, ("POINTS", "values"))
lo, hi = info.GetPointDataInformation().GetArrayInformation("values").GetComponentRange(0)
lut = GetColorTransferFunction("values")
lut.ApplyPreset("Cool to Warm", True)
lut.RescaleTransferFunction(lo, hi)
opacity = GetOpacityTransferFunction("values")
opacity.Points = [lo, 0.0, 0.5, 0.0, hi, 0.6, 0.5, 0.0]
# A fixed oblique camera from the data bounds (the same on any number of ranks: bounds are global).
b = info.GetBounds()
centre = [(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2]
extent = max(b[1] - b[0], b[3] - b[2], b[5] - b[4])
view.CameraFocalPoint = centre
view.CameraPosition = [centre[0] + 1.6 * extent, centre[1] - 1.2 * extent, centre[2] + 0.9 * extent]
view.CameraViewUp = [0.0, 0.0, 1.0]
view.CameraParallelProjection = 0
t1 = time.perf_counter()
Render(view)
t_render = time.perf_counter() - t1
SaveScreenshot(png, view, ImageResolution=size)

warm = []
for k in range(bench):
    for lv in (level + 1, level):
        t0 = time.perf_counter()
        reader.Level = lv
        reader.UpdatePipeline()
        t_update = time.perf_counter() - t0
        reader.UpdatePropertyInformation()
        pieces = json.loads(reader.GetProperty("DecodeReport").GetElement(0))
        view.CameraPosition = [centre[0] + 1.6 * extent, centre[1] - (1.2 + 0.01 * (k + 1)) * extent,
                               centre[2] + 0.9 * extent]
        t1 = time.perf_counter()
        Render(view)
        warm.append({"level": lv, "update_s": t_update, "render_s": time.perf_counter() - t1, "pieces": pieces})

steps = reader.TimestepValues
with open(report_path, "w") as f:
    json.dump({"ranks": ranks, "points": info.GetNumberOfPoints(), "bounds": list(b), "level": level,
               "time_steps": list(steps) if hasattr(steps, "__len__") else [steps], "time": when,
               "update_s": t_read, "first_render_s": t_render, "pieces": report, "warm": warm}, f, indent=1)
