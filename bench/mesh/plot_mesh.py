#!/usr/bin/python3
"""Plots `volcl bench render --csv` output of one or more meshes: RMSE (RGB, against the exact double
reference) versus wall milliseconds per frame, every volcl configuration and VTK peer a point (log-log).

Usage: plot_mesh.py OUT.png TITLE1 CSV1 [TITLE2 CSV2 ...]
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

STYLE = {"cells": ("tab:green", "o"), "kbuffer": ("tab:purple", "s"), "vtk": ("tab:red", "^")}


def panel(ax, title, path):
    rows = list(csv.DictReader(open(path)))
    for r in rows:
        color, marker = STYLE.get(r["method"], ("black", "x"))
        ms, err = float(r["wall_ms"]), float(r["rmse_rgb"])
        ax.scatter(ms, err, color=color, marker=marker, s=40)
        label = r["config"] if r["method"] != "vtk" else "VTK " + r["config"]
        ax.annotate(label, (ms, err), textcoords="offset points", xytext=(5, 3), fontsize=7)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall ms per frame (median), 512 x 512")
    ax.set_ylabel("RMSE of RGB against the exact reference")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    for name, (color, marker) in STYLE.items():
        if any(r["method"] == name for r in rows):
            ax.scatter([], [], color=color, marker=marker, label={"cells": "volcl cells", "kbuffer": "volcl k-buffer",
                                                                   "vtk": "VTK 9.1"}[name])
    ax.legend(fontsize=8, loc="center right")


def main(argv):
    out, pairs = argv[1], argv[2:]
    n = len(pairs) // 2
    fig, axes = plt.subplots(1, n, figsize=(7 * n, 5.5), squeeze=False)
    for i in range(n):
        panel(axes[0][i], pairs[2 * i], pairs[2 * i + 1])
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    main(sys.argv)
