# pvbatch script: a volume representation with a 2D transfer function of three boxes (two apart, one
# overlapping), saved as a ParaView state, and ParaView's own function of those boxes
# (vtkPVTransferFunction2D::GetFunction) sampled at its texels: one line "s g r g b a" per texel.
# Usage: pvbatch tf2d_state.py OUT_DIR   (writes OUT_DIR/state.pvsm and OUT_DIR/function.txt)
import sys

from paraview.simple import (ColorBy, CreateView, GetColorTransferFunction, GetTransferFunction2D, SaveState,
                             Show, Wavelet)

out = sys.argv[1]
view = CreateView("RenderView")
display = Show(Wavelet(), view)
display.SetRepresentationType("Volume")
ColorBy(display, ("POINTS", "RTData"))
GetColorTransferFunction("RTData")
tf2d = GetTransferFunction2D("RTData")
# x, y, width, height (value and gradient magnitude), r, g, b, opacity
tf2d.Boxes = [60, 4, 50, 12, 1.0, 0.5, 0.25, 0.8,
              150, 20, 60, 24, 0.2, 0.9, 0.4, 0.35,
              190, 30, 50, 20, 0.3, 0.3, 1.0, 1.0]
tf2d.Range = [37, 277, 0, 60]
tf2d.OutputDimensions = [256, 256]
display.UseTransfer2D = 1
display.ScalarOpacityUnitDistance = 2.5
SaveState(out + "/state.pvsm")

tf2d.UpdateVTKObjects()
function = tf2d.GetClientSideObject()
function.Build()
image = function.GetFunction()
nx, ny, _ = image.GetDimensions()
ox, oy, _ = image.GetOrigin()
dx, dy, _ = image.GetSpacing()
scalars = image.GetPointData().GetScalars()
with open(out + "/function.txt", "w") as f:
    for j in range(ny):
        for i in range(nx):
            r, g, b, a = scalars.GetTuple4(i + nx * j)
            f.write("%.9g %.9g %.9g %.9g %.9g %.9g\n" % (ox + i * dx, oy + j * dy, r, g, b, a))
