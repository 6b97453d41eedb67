#!/usr/bin/python3
"""VTK peer for `volcl bench render`: vtkFixedPointVolumeRayCastMapper on the job's volume, TF, camera and step.

Reads a JSON job written by volcl (volume as raw float32, TF samples (s, r, g, b, opacity per unit length),
camera, image size, sample distance, runs, and "shade": Blinn-Phong coefficients under VTK's head light, or
null); writes the median ms per frame and the last image as float32
RGBA, top row first, colour over a black background (that is, associated colour). Run under xvfb-run.
"""
import json
import statistics
import sys
import time

import numpy as np
import vtk
from vtk.util import numpy_support


def main(job_path):
    job = json.load(open(job_path))
    nx, ny, nz = job["dims"]
    data = np.fromfile(job["volume"], dtype=np.float32)
    image = vtk.vtkImageData()
    image.SetDimensions(nx, ny, nz)
    image.SetSpacing(*job["spacing"])
    image.SetOrigin(*job["origin"])
    image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(data, deep=True, array_type=vtk.VTK_FLOAT))

    color = vtk.vtkColorTransferFunction()
    opacity = vtk.vtkPiecewiseFunction()
    for s, r, g, b, a in job["tf"]:
        color.AddRGBPoint(s, r, g, b)
        opacity.AddPoint(s, a)
    prop = vtk.vtkVolumeProperty()
    prop.SetColor(color)
    prop.SetScalarOpacity(opacity)
    prop.SetScalarOpacityUnitDistance(1.0)  # opacities are per unit world length, as volcl's tau
    prop.SetInterpolationTypeToLinear()
    shade = job.get("shade")
    if shade:
        prop.ShadeOn()
        prop.SetAmbient(shade["ambient"])
        prop.SetDiffuse(shade["diffuse"])
        prop.SetSpecular(shade["specular"])
        prop.SetSpecularPower(shade["specular_power"])
    else:
        prop.ShadeOff()

    mapper = vtk.vtkFixedPointVolumeRayCastMapper()
    mapper.SetInputData(image)
    mapper.SetAutoAdjustSampleDistances(0)
    mapper.SetSampleDistance(job["step"])
    mapper.SetImageSampleDistance(1.0)
    mapper.SetLockSampleDistanceToInputSpacing(0)

    volume = vtk.vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)

    renderer = vtk.vtkRenderer()
    renderer.AddVolume(volume)
    renderer.SetBackground(0, 0, 0)
    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.AddRenderer(renderer)
    w, h = job["width"], job["height"]
    window.SetSize(w, h)

    cam = renderer.GetActiveCamera()
    c = job["camera"]
    cam.SetPosition(*c["eye"])
    cam.SetFocalPoint(*c["target"])
    cam.SetViewUp(*c["up"])
    if c["perspective"]:
        cam.ParallelProjectionOff()
        cam.SetViewAngle(c["fov_y_deg"])
    else:
        cam.ParallelProjectionOn()
        cam.SetParallelScale(c["height"] / 2.0)
    renderer.ResetCameraClippingRange()

    window.Render()  # warm-up: builds the mapper's internal copies of the volume
    times = []
    for _ in range(max(1, job["runs"])):
        cam.Modified()
        t0 = time.perf_counter()
        window.Render()
        times.append((time.perf_counter() - t0) * 1000.0)

    pixels = vtk.vtkFloatArray()
    window.GetRGBAPixelData(0, 0, w - 1, h - 1, 1, pixels)
    rgba = numpy_support.vtk_to_numpy(pixels).reshape(h, w, 4)[::-1].astype(np.float32)  # top row first
    rgba.tofile(job["image"])
    json.dump({"median_ms": statistics.median(times), "times_ms": times,
               "vtk_version": vtk.vtkVersion.GetVTKVersion(),
               "threads": mapper.GetNumberOfThreads()}, open(job["result"], "w"))


if __name__ == "__main__":
    main(sys.argv[1])
