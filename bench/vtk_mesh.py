#!/usr/bin/python3
"""VTK peers for `volcl bench render` on a tetrahedral mesh: Bunyk's ray caster
(vtkUnstructuredGridVolumeRayCastMapper), projected tetrahedra (vtkProjectedTetrahedraMapper, OpenGL) and
ZSweep (vtkUnstructuredGridVolumeZSweepMapper) on the job's mesh, TF, camera and image size.

Reads a JSON job written by volcl: the mesh as raw files (points float64 x 3, tets int64 x 4, point scalars
float32), TF samples (s, r, g, b, opacity 1 - exp(-tau) of a unit length), camera, image size, runs and the mappers to run.
Writes, per mapper, the median ms per frame and the last image as float32 RGBA, top row first, colour over a
black background (associated colour). Run under xvfb-run.
"""
import json
import math
import statistics
import sys
import time

import numpy as np
import vtk
from vtk.util import numpy_support


def vtk_scalar_opacity(opacity_per_unit_length):
    """The value VTK's unstructured-grid mappers need in the scalar opacity function for a job sample.

    The job carries the opacity of a unit length, 1 - exp(-tau) (what the grid mappers read), but
    vtkUnstructuredGridPartialPreIntegration (Bunyk's default integrator) and vtkProjectedTetrahedraMapper read
    the scalar opacity function as the attenuation coefficient per unit distance (divided by the unit distance):
    the partial pre-integration's colours hold opacity / unit_distance as extinction, and the projected
    tetrahedra's fragment shader takes 1 - exp(-attenuation * thickness). So the extinction tau goes in."""
    a = min(max(float(opacity_per_unit_length), 0.0), 1.0 - 1e-15)
    return -math.log1p(-a)


def make_grid(job):
    pts = np.fromfile(job["points"], dtype=np.float64).reshape(-1, 3)
    tets = np.fromfile(job["tets"], dtype=np.int64).reshape(-1, 4)
    scalars = np.fromfile(job["scalars"], dtype=np.float32)
    grid = vtk.vtkUnstructuredGrid()
    points = vtk.vtkPoints()
    points.SetData(numpy_support.numpy_to_vtk(pts, deep=True))
    grid.SetPoints(points)
    cells = vtk.vtkCellArray()
    offsets = numpy_support.numpy_to_vtkIdTypeArray(np.arange(0, 4 * len(tets) + 1, 4, dtype=np.int64), deep=True)
    conn = numpy_support.numpy_to_vtkIdTypeArray(tets.reshape(-1).astype(np.int64), deep=True)
    cells.SetData(offsets, conn)
    grid.SetCells(vtk.VTK_TETRA, cells)
    arr = numpy_support.numpy_to_vtk(scalars, deep=True, array_type=vtk.VTK_FLOAT)
    arr.SetName("s")
    grid.GetPointData().SetScalars(arr)
    return grid


def make_mapper(name, grid):
    if name == "bunyk":
        m = vtk.vtkUnstructuredGridVolumeRayCastMapper()
        m.SetAutoAdjustSampleDistances(0)
        m.SetImageSampleDistance(1.0)
    elif name == "projected_tetrahedra":
        m = vtk.vtkProjectedTetrahedraMapper()
    elif name == "zsweep":
        m = vtk.vtkUnstructuredGridVolumeZSweepMapper()
        m.SetAutoAdjustSampleDistances(0)
        m.SetImageSampleDistance(1.0)
    else:
        raise SystemExit("unknown mapper " + name)
    m.SetInputData(grid)
    return m


def run(name, grid, job, prop):
    mapper = make_mapper(name, grid)
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
    t0 = time.perf_counter()
    window.Render()  # warm-up: the mappers build their cell and face structures here
    first_ms = (time.perf_counter() - t0) * 1000.0
    times = []
    for _ in range(max(1, job.get("mapper_runs", {}).get(name, job["runs"]))):
        cam.Modified()
        t0 = time.perf_counter()
        window.Render()
        times.append((time.perf_counter() - t0) * 1000.0)
    pixels = vtk.vtkFloatArray()
    window.GetRGBAPixelData(0, 0, w - 1, h - 1, 1, pixels)
    rgba = numpy_support.vtk_to_numpy(pixels).reshape(h, w, 4)[::-1].astype(np.float32)
    path = job["image_prefix"] + name + ".f32"
    rgba.tofile(path)
    info = {"median_ms": statistics.median(times), "times_ms": times, "first_frame_ms": first_ms,
            "image": path, "class": mapper.GetClassName()}
    if name == "bunyk":
        integ = mapper.GetRayIntegrator()
        info["integrator"] = integ.GetClassName() if integ is not None else "default"
    return info


def main(job_path):
    job = json.load(open(job_path))
    grid = make_grid(job)
    color = vtk.vtkColorTransferFunction()
    opacity = vtk.vtkPiecewiseFunction()
    for s, r, g, b, a in job["tf"]:
        color.AddRGBPoint(s, r, g, b)
        opacity.AddPoint(s, vtk_scalar_opacity(a))
    prop = vtk.vtkVolumeProperty()
    prop.SetColor(color)
    prop.SetScalarOpacity(opacity)
    prop.SetScalarOpacityUnitDistance(1.0)  # extinction per unit world length, as volcl's tau
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOff()
    out = {"vtk_version": vtk.vtkVersion.GetVTKVersion(), "mappers": {}}
    for name in job["mappers"]:
        out["mappers"][name] = run(name, grid, job, prop)
    json.dump(out, open(job["result"], "w"), indent=1)


if __name__ == "__main__":
    main(sys.argv[1])
