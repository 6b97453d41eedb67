#!/usr/bin/python3
"""Plots `volcl bench render --scatter-sweep --scatter-csv` output of one or more scenes: RMSE against the
converged path-traced reference versus samples per pixel (with a 1/sqrt(n) line through the first point),
and RMSE versus milliseconds per frame with the single-scattering and octave-approximation points.
Usage: plot_scattering.py out.png name=file.csv [name=file.csv ...]
       plot_scattering.py --panel out.png IMAGE_DIR   (the --scatter-images PNGs side by side)"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def main(png_path, inputs):
    fig, (ax_n, ax_t) = plt.subplots(1, 2, figsize=(12, 5))
    colors = ["tab:blue", "tab:red", "tab:green", "tab:purple"]
    for (name, path), color in zip(inputs, colors):
        rows = list(csv.DictReader(open(path)))
        pt = [r for r in rows if r["variant"].startswith("multiple")]
        n = [int(r["samples"]) for r in pt]
        err = [float(r["rmse"]) for r in pt]
        ms = [float(r["ms"]) for r in pt]
        ax_n.loglog(n, err, "o-", color=color, label=f"{name}: path tracer")
        ax_n.loglog(n, [err[0] / math.sqrt(k / n[0]) for k in n], ":", color=color, label=f"{name}: 1/sqrt(n)")
        ax_t.loglog(ms, err, "o-", color=color, label=f"{name}: path tracer (1, 2, 4, ... spp)")
        for r, marker in zip([r for r in rows if not r["variant"].startswith("multiple")], "sD^vP"):
            ax_t.loglog([float(r["ms"])], [float(r["rmse"])], marker, color=color, markersize=8,
                        label=f"{name}: {r['variant']}")
    ax_n.set_xlabel("samples per pixel")
    ax_n.set_ylabel("RMSE against the converged reference")
    ax_n.set_title("Monte Carlo convergence")
    ax_n.grid(True, which="both", alpha=0.3)
    ax_n.legend(fontsize=8)
    ax_t.set_xlabel("ms per frame (kernel)")
    ax_t.set_ylabel("RMSE against the converged reference")
    ax_t.set_title("error against time")
    ax_t.grid(True, which="both", alpha=0.3)
    ax_t.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


def panel(png_path, image_dir):
    import glob
    import os
    names = [("plain", "plain (emission-absorption)"), ("single", "single scattering"),
             ("octaves4", "single + 4 octaves"), ("multiple_1spp", "path tracer, 1 spp"),
             ("multiple_16spp", "path tracer, 16 spp")]
    last = sorted(glob.glob(os.path.join(image_dir, "multiple_*spp.png")),
                  key=lambda p: int(os.path.basename(p)[9:-7]))[-1]
    names.append((os.path.basename(last)[:-4], "path tracer, " + os.path.basename(last)[9:-7] + " spp"))
    names.append(("reference", "reference (converged)"))
    names = [(n, t) for n, t in names if os.path.exists(os.path.join(image_dir, n + ".png"))]
    fig, axes = plt.subplots(1, len(names), figsize=(2.6 * len(names), 2.9))
    for ax, (n, t) in zip(axes, names):
        ax.imshow(plt.imread(os.path.join(image_dir, n + ".png")), interpolation="nearest")
        ax.set_title(t, fontsize=9)
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


if __name__ == "__main__":
    if sys.argv[1] == "--panel":
        panel(sys.argv[2], sys.argv[3])
    else:
        main(sys.argv[1], [tuple(a.split("=", 1)) for a in sys.argv[2:]])
