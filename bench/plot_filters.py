#!/usr/bin/python3
"""Plots for `volcl bench render --filters --no-sweep --csv bench/results/rendering/rendering-filters.csv` (python3-matplotlib).

Usage: /usr/bin/python3 bench/plot_filters.py bench/results/rendering/rendering-filters.csv docs/images/rendering-filters.png
Panel (a): mean normal error on the 8-bit sphere against kernel time per frame, one point per filter.
Panel (b): shading roughness (the terrace measure) on the scene against kernel time per frame.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(src, out):
    with open(src, newline="") as f:
        rows = list(csv.DictReader(f))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    panels = (("sphere", "normal_error_deg", "mean normal error (degrees)",
               "(a) 8-bit sphere, 1 level/voxel: error vs time"),
              ("scene", "roughness", "shading roughness (mean |Laplacian|)",
               "(b) 8-bit MRI iso-surface: terraces vs time"))
    for ax, (dataset, key, ylabel, title) in zip(axes, panels):
        sel = [r for r in rows if r["dataset"] == dataset and r[key] != ""]
        for r in sel:
            x, y = float(r["ms_per_frame"]), float(r[key])
            colour = "tab:blue" if r["filter"].startswith("linear") else (
                "tab:red" if r["filter"].startswith("cubic") else "tab:green")
            ax.plot([x], [y], "o", color=colour)
            ax.annotate(r["filter"], (x, y), textcoords="offset points", xytext=(5, 4), fontsize=8)
        ax.set_xlabel("kernel time per frame (ms, median of interleaved runs)")
        ax.set_ylabel(ylabel)
        ax.set_yscale("log")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
