#!/usr/bin/python3
"""Plots `volcl bench render --tiers --tier-csv` output: RMSE against the double reference versus ms per frame,
the ray marcher at each step as a line (labels: step in voxels) and the preview tiers as points."""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def main(csv_path, png_path, title):
    lines = [line for line in open(csv_path) if not line.startswith("#")]
    rows = list(csv.DictReader(lines))
    fig, ax = plt.subplots(figsize=(7, 5))
    march = [r for r in rows if r["method"] == "raymarch"]
    ms = [float(r["ms_per_frame"]) for r in march]
    err = [float(r["rmse_rgba"]) for r in march]
    ax.plot(ms, err, "-", color="tab:blue", marker="o", label="ray marcher (point sampling)")
    for r, x, y in zip(march, ms, err):
        ax.annotate(f"{float(r['step']):g}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
    for method, color, marker, label in (("shear-warp", "tab:red", "s", "shear-warp"),
                                         ("drc", "tab:green", "^", "discrete ray casting")):
        sel = [r for r in rows if r["method"] == method]
        if sel:
            ax.plot([float(r["ms_per_frame"]) for r in sel], [float(r["rmse_rgba"]) for r in sel], marker,
                    color=color, markersize=9, linestyle="none", label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("ms per frame (median kernel time)")
    ax.set_ylabel("RMSE vs double reference (linear RGBA)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else "preview tiers")
