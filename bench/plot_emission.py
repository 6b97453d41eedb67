#!/usr/bin/env python3
"""Error vs time of the emission-only mode's step knob beside unlit dvr (volcl bench render --csv).

Usage: /usr/bin/python3 bench/plot_emission.py EMISSION.csv DVR.csv OUT.png
Takes the rows without pre-integration and without skipping (emission drops both).
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def rows(path):
    with open(path) as f:
        return [r for r in csv.DictReader(line for line in f if not line.startswith("#"))
                if r["preintegration"] == "none" and r["skipping"] == "0"]


def main():
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for path, label, marker in ((sys.argv[1], "emission", "o"), (sys.argv[2], "dvr (unlit)", "s")):
        r = rows(path)
        ax.loglog([float(x["ms_per_frame"]) for x in r], [float(x["rmse_rgb"]) for x in r], marker=marker,
                  label=label)
        for x in r:
            ax.annotate(x["step"], (float(x["ms_per_frame"]), float(x["rmse_rgb"])), fontsize=7,
                        textcoords="offset points", xytext=(4, 2))
    ax.set_xlabel("ms per frame (median of 5, one core)")
    ax.set_ylabel("RMSE of RGB against the double reference")
    ax.set_title("Step knob (labels: step in voxels), HeadMRVolume 128x128")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(sys.argv[3], dpi=110)


if __name__ == "__main__":
    main()
