#!/usr/bin/env python3
"""Plot of the visibility-sort measurements (volcl bench mesh --csv) for docs/meshes.md: the share of ray pairs
each method misorders against its time per sort, per mesh. Usage: plot_sort.py [csv, default
bench/results/meshes/sort-methods.csv] [image, default docs/images/sort-methods.png]"""
import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

src = Path(sys.argv[1] if len(sys.argv) > 1 else "bench/results/meshes/sort-methods.csv")
out = Path(sys.argv[2] if len(sys.argv) > 2 else "docs/images/sort-methods.png")
with open(src) as f:
    rows = list(csv.DictReader(f))

markers = {"centroid": "o", "mpvo": "s", "convexified": "^"}
colours = {}
fig, ax = plt.subplots(figsize=(6.4, 4.2))
for r in rows:
    mesh = Path(r["mesh"]).name
    colour = colours.setdefault(mesh, f"C{len(colours)}")
    pairs = float(r["oracle_pairs"])
    share = 100.0 * float(r["oracle_violations"]) / pairs if pairs else 0.0
    ax.scatter(float(r["median_ms"]), share, marker=markers[r["method"]], color=colour, s=50)
for mesh, colour in colours.items():
    ax.scatter([], [], color=colour, marker="o", label=mesh)
for method, marker in markers.items():
    ax.scatter([], [], color="grey", marker=marker, label=method)
ax.set_xscale("log")
ax.set_yscale("symlog", linthresh=0.1)
ax.set_xlabel("ms per sort (median, one loaded core)")
ax.set_ylabel("ray pairs misordered (%)")
ax.set_title("Visibility sorts: error against time")
ax.grid(True, which="both", alpha=0.3)
ax.set_ylim(-0.02, 20)
ax.legend(fontsize=8, loc="lower left")
fig.tight_layout()
out.parent.mkdir(parents=True, exist_ok=True)
fig.savefig(out, dpi=110)
print(out)
