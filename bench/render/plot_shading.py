#!/usr/bin/python3
"""Plots `volcl bench render --shading-sweep --shading-csv` output: RMSE against the double reference versus
milliseconds per frame for the plain frame, each gradient kind of the shaded frame, the iso layer and, when
the CSV has them, VTK's fixed-point ray caster shaded and plain.
Usage: plot_shading.py out.png file.csv"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def main(png_path, csv_path):
    lines = [l for l in open(csv_path) if not l.startswith("#")]
    load = [l for l in open(csv_path) if l.startswith("# load")]
    rows = list(csv.DictReader(lines))
    fig, ax = plt.subplots(figsize=(7.5, 5))
    markers = "os^vDPX*"
    for r, m in zip(rows, markers * 2):
        color = "tab:red" if r["variant"].startswith("vtk") else "tab:blue"
        ax.loglog([float(r["ms_per_frame"])], [float(r["rmse_reference"])], m, color=color, markersize=9,
                  label=f"{r['variant']}: {float(r['ms_per_frame']):.0f} ms, {float(r['ratio_to_plain']):.2f}x plain")
    ax.set_xlabel("ms per frame (kernel; VTK: Render() wall time)")
    ax.set_ylabel("RMSE of RGB against the double reference")
    title = "shading: error against time"
    if load:
        title += f" ({load[0][2:].strip()})"
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
