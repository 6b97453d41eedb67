#!/usr/bin/env python3
"""Plots of the k-buffer measurements (bench/kbuffer_sweep.sh) for docs/meshes.md: RMSE and frame time
against k per mesh, error against frame work per face order (render.sort), and the level-of-detail
controller's trace. Usage: plot_kbuffer.py [results-dir, default bench/results/meshes] [image-dir, default docs/images]"""
import csv
import sys
from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

res = Path(sys.argv[1] if len(sys.argv) > 1 else "bench/results/meshes")
docs = Path(sys.argv[2] if len(sys.argv) > 2 else "docs/images")


def rows(name):
    p = res / name
    if not p.exists():
        return []
    with open(p) as f:
        return [r for r in csv.DictReader(line for line in f if not line.startswith("#") and not line.startswith("lod,"))]


sweep = rows("kbuffer-k-sweep.csv") + rows("kbuffer-ml64.csv")
by = defaultdict(list)
for r in sweep:
    by[r["mesh"]].append(r)

fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
for mesh, rs in by.items():
    rs.sort(key=lambda r: int(r["k"]))
    ks = [int(r["k"]) for r in rs]
    a.semilogy(ks, [max(float(r["rmse"]), 1e-6) for r in rs], "o-", label=f"{mesh} ({int(rs[0]['tets']):,} tets)")
    b.semilogy(ks, [float(r["cpu_ms"]) for r in rs], "o-", label=mesh)
a.axhline(0.01, color="grey", ls="--", lw=1)
a.text(2.05, 0.011, "goal at k = 6: 0.01", color="grey", fontsize=8)
a.set_xlabel("k (k-buffer entries per pixel)")
a.set_ylabel("RMSE vs exact double reference (linear RGBA)")
a.set_title("k-buffer error against k, 512x512")
a.legend(fontsize=7)
b.set_xlabel("k")
b.set_ylabel("CPU ms per frame (both cores, whole frame)")
b.set_title("what accuracy costs: frame work against k")
fig.tight_layout()
fig.savefig(docs / "meshes-kbuffer-k.png", dpi=110)

order = rows("kbuffer-order.csv")
if order:
    fig, ax = plt.subplots(figsize=(7.5, 4.6))
    markers = {"centroid": "o", "mpvo": "^", "convexified": "s"}
    colours = {}
    for r in order:
        mesh = r["mesh"]
        colours.setdefault(mesh, f"C{len(colours)}")
        ax.loglog(float(r["cpu_ms"]), max(float(r["rmse"]), 1e-6), markers.get(r["sort"], "x"),
                  color=colours[mesh], fillstyle="full" if r["sort"] == "centroid" else "none", ms=7)
        ax.annotate(f"k{r['k']}", (float(r["cpu_ms"]), max(float(r["rmse"]), 1e-6)), fontsize=6,
                    xytext=(3, 2), textcoords="offset points")
    for mesh, c in colours.items():
        ax.plot([], [], "-", color=c, label=mesh)
    for name, m in markers.items():
        ax.plot([], [], m, color="grey", fillstyle="full" if name == "centroid" else "none", label=f"sort {name}")
    ax.set_xlabel("CPU ms per frame (whole process, 512x512)")
    ax.set_ylabel("RMSE vs exact double reference (linear RGBA)")
    ax.set_title("k-buffer face order: error against frame work")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(docs / "meshes-kbuffer-order.png", dpi=110)

lod = []
p = res / "kbuffer-lod.csv"
if p.exists():
    with open(p) as f:
        for line in f:
            if line.startswith("lod,"):
                parts = line.strip().split(",")
                lod.append((int(parts[2]), float(parts[4]), float(parts[6]), float(parts[7])))
if lod:
    fig, ax = plt.subplots(figsize=(7, 3.6))
    fr = [x[0] for x in lod]
    ax.plot(fr, [x[2] for x in lod], "o-", label="frame time (wall, ms)")
    ax.axhline(lod[0][3], color="grey", ls="--", lw=1, label="target")
    ax.set_xlabel("frame (camera orbits 4 degrees per frame)")
    ax.set_ylabel("ms")
    ax2 = ax.twinx()
    ax2.plot(fr, [100 * x[1] for x in lod], "s-", color="tab:orange", label="internal faces drawn (%)")
    ax2.set_ylabel("internal faces drawn (%)")
    ax.legend(loc="upper right", fontsize=8)
    ax2.legend(loc="center right", fontsize=8)
    ax.set_title("dynamic level of detail: controller holds the frame time")
    fig.tight_layout()
    fig.savefig(docs / "meshes-kbuffer-lod.png", dpi=110)
print("plots written to", docs)
