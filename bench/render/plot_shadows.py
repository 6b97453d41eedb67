#!/usr/bin/python3
"""Plots `volcl bench render --shadow-sweep --shadow-csv` output: RMSE against the secondary-ray reference
versus milliseconds per frame, one marker per method and knob (light-volume cell sizes, shadow-ray steps),
one colour per light, the plain and shaded frames as vertical lines.
Usage: plot_shadows.py out.png shadows.csv"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def main(png_path, csv_path):
    rows = list(csv.DictReader(open(csv_path)))
    fig, ax = plt.subplots(figsize=(7, 5))
    for light, color in (("directional", "tab:blue"), ("head", "tab:red")):
        for method, marker in (("volume", "o-"), ("rays", "s--")):
            pts = [r for r in rows if r["light"] == light and r["method"] == method and float(r["rmse"]) > 0]
            if pts:
                ax.loglog([float(r["ms"]) for r in pts], [float(r["rmse"]) for r in pts], marker, color=color,
                          label=f"{light}: {method}")
                for r in pts:
                    ax.annotate(r["knob"], (float(r["ms"]), float(r["rmse"])), fontsize=7)
        shaded = [r for r in rows if r["light"] == light and r["method"].startswith("shaded")]
        for r in shaded:
            ax.axvline(float(r["ms"]), color=color, linestyle=":", label=f"{light}: shaded, no shadows")
    plain = [r for r in rows if r["method"] == "plain"]
    for r in plain:
        ax.axvline(float(r["ms"]), color="black", linestyle=":", label="plain frame")
    ax.set_xlabel("ms per frame (one core)")
    ax.set_ylabel("RMSE (RGBA) against secondary rays")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
