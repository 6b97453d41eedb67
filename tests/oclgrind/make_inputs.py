"""Writes the tiny inputs of run_kernels.sh: a blob volume, a moving-blob series, a tetrahedral mesh, a fog scene."""
import json
import math
import sys
from pathlib import Path

out = Path(sys.argv[1])
out.mkdir(parents=True, exist_ok=True)
NX, NY, NZ = 16, 12, 8


def blob(cx, cy, cz):
    """uint8 Gaussian blob centred at (cx, cy, cz), x fastest, plus a ramp so no region is constant."""
    data = bytearray()
    for z in range(NZ):
        for y in range(NY):
            for x in range(NX):
                r2 = (x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2
                data.append(min(255, int(200 * math.exp(-r2 / 10.0) + 3 * x + y)))
    return bytes(data)


(out / f"blob_{NX}x{NY}x{NZ}_uint8.raw").write_bytes(blob(7.5, 5.5, 3.5))
# Three frames of a blob moving one voxel along x per frame: P and B frames find the motion.
for k in range(3):
    (out / f"frame{k}_{NX}x{NY}x{NZ}_uint8.raw").write_bytes(blob(5.0 + k, 5.5, 3.5))

# A 2 x 2 x 2 block of unit cubes, each split into six tetrahedra around its main diagonal, scalar x + y + z.
n = 3
points = [(x, y, z) for z in range(n) for y in range(n) for x in range(n)]
index = {p: i for i, p in enumerate(points)}
tets = []
for z in range(n - 1):
    for y in range(n - 1):
        for x in range(n - 1):
            c = [index[(x + (i & 1), y + (i >> 1 & 1), z + (i >> 2))] for i in range(8)]
            for a, b in ((1, 3), (3, 2), (2, 6), (6, 4), (4, 5), (5, 1)):
                tets.append((c[0], c[a], c[b], c[7]))


def write_vtk(path, points, tets, scalar):
    """An ASCII legacy VTK unstructured grid of tetrahedra with one point scalar."""
    lines = ["# vtk DataFile Version 2.0", path.stem, "ASCII", "DATASET UNSTRUCTURED_GRID",
             f"POINTS {len(points)} float"]
    lines += [f"{x} {y} {z}" for x, y, z in points]
    lines.append(f"CELLS {len(tets)} {5 * len(tets)}")
    lines += ["4 " + " ".join(map(str, t)) for t in tets]
    lines.append(f"CELL_TYPES {len(tets)}")
    lines += ["10"] * len(tets)
    lines += [f"POINT_DATA {len(points)}", "SCALARS s float 1", "LOOKUP_TABLE default"]
    lines += [f"{scalar(x, y, z)}" for x, y, z in points]
    path.write_text("\n".join(lines) + "\n")


write_vtk(out / "cubes.vtk", points, tets, lambda x, y, z: (x + y + z) / 6.0)

# Two of those blocks in one file, the second shifted by (1.1, 0.7, 0.4) cell widths: they share no point or
# face, and their boxes overlap, so the cell caster takes its path for meshes whose tets may overlap
# (MESH_OVERLAPS: the union of the tets' intervals). Scalar x + y + z on both, so they agree where they overlap.
shift = (1.1, 0.7, 0.4)
both_points = points + [(x + shift[0], y + shift[1], z + shift[2]) for x, y, z in points]
both_tets = tets + [tuple(v + len(points) for v in t) for t in tets]
write_vtk(out / "overlapping_blocks.vtk", both_points, both_tets, lambda x, y, z: (x + y + z) / 8.5)

# Height fog over the Marschner-Lobb volume (9^3 voxels): a base below the box, falling off upwards.
scene = {"effects": {"fog": {"density": 0.2, "base": -2, "falloff": 3, "color": [0.75, 0.8, 0.9],
                             "up": [0, 1, 0], "box": [[-2, -2, -2], [10, 10, 10]]}}}
(out / "fog_scene.json").write_text(json.dumps(scene))
