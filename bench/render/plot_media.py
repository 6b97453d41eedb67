#!/usr/bin/python3
"""Plots for docs/media.md (Debian python3-matplotlib).

Usage: /usr/bin/python3 bench/render/plot_media.py bench/results/media/fog-bench-mri.csv \
           bench/results/media/tables-bench-mri.csv docs/images/media-fog-cost.png docs/images/media-tables.png
(a) fog: ms per frame of each variant relative to the plain frame (`volcl bench render --fog --csv`);
(b) tables: RMSE against the double reference versus ms per frame, one point per step, for the shaded
    per-sample path, 2D pre-integration lit at the midpoint and through the pre-integrated lighting table,
    and iso-surfaces by exact roots and by the iso-surface table (`volcl bench render --tables --csv`).
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def fog_plot(src, dst):
    r = rows(src)
    names = [x["variant"] for x in r]
    ratio = [float(x["ratio_to_plain"]) for x in r]
    fig, ax = plt.subplots(figsize=(7.5, 3.2))
    bars = ax.barh(range(len(r)), ratio, color=["#888"] + ["#4a7fb5"] * (len(r) - 1))
    ax.set_yticks(range(len(r)), names)
    ax.invert_yaxis()
    ax.set_xlabel("frame time / plain frame")
    for b, x, row in zip(bars, ratio, r):
        ax.text(b.get_width(), b.get_y() + b.get_height() / 2,
                f" {x:.2f}x, {float(row['ms_per_frame']):.0f} ms, RMSE {float(row['rmse_rgba']):.1e}",
                va="center", fontsize=8)
    ax.set_xlim(0, max(ratio) * 1.6)
    ax.set_title("Fog cost (MRI 180x216x180, 128x128, step 0.5)", fontsize=10)
    fig.tight_layout()
    fig.savefig(dst, dpi=120)


def tables_plot(src, dst):
    r = rows(src)
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for ax, kind, title in ((axes[0], "shaded", "(a) shaded dvr, 1 light"),
                            (axes[1], "iso", "(b) iso-surface")):
        variants = []
        for x in r:
            if x["kind"] == kind and x["variant"] not in variants:
                variants.append(x["variant"])
        for v in variants:
            pts = [x for x in r if x["kind"] == kind and x["variant"] == v]
            ms = [float(x["ms_per_frame"]) for x in pts]
            err = [float(x["rmse_rgba"]) for x in pts]
            ax.plot(ms, err, "o-", label=v)
            for x, m, e in zip(pts, ms, err):
                ax.annotate(f"{float(x['step']):g}", (m, e), fontsize=7, xytext=(3, 3),
                            textcoords="offset points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("ms per frame (labels: step)")
        ax.set_ylabel("RMSE vs reference (RGBA)")
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=7)
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(dst, dpi=120)


if __name__ == "__main__":
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    fog_plot(sys.argv[1], sys.argv[3])
    tables_plot(sys.argv[2], sys.argv[4])
