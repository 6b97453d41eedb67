#!/usr/bin/python3
"""Plots `volcl bench render --csv` output: RMSE against the reference versus ms per frame, one line per
sampling method (point sampling, 2D and 3D pre-integration), skipping on and off; labels give the step."""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def main(csv_path, png_path, title):
    rows = [r for r in csv.DictReader(line for line in open(csv_path) if not line.startswith("#"))]
    fig, (ax_t, ax_s) = plt.subplots(1, 2, figsize=(12, 5))
    styles = {"none": ("tab:red", "point sampling"), "2d": ("tab:blue", "2D pre-integration"),
              "3d": ("tab:green", "3D pre-integration")}
    for pre, (color, label) in styles.items():
        for skip, ls in (("1", "-"), ("0", "--")):
            sel = [r for r in rows if r["preintegration"] == pre and r["skipping"] == skip]
            if not sel:
                continue
            ms = [float(r["ms_per_frame"]) for r in sel]
            err = [float(r["rmse_rgba"]) for r in sel]
            steps = [float(r["step"]) for r in sel]
            name = f"{label}, skipping {'on' if skip == '1' else 'off'}"
            ax_t.plot(ms, err, ls, color=color, marker="o", label=name)
            if skip == "1":
                for x, y, s in zip(ms, err, steps):
                    ax_t.annotate(f"{s:g}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
                ax_s.plot(steps, err, "-", color=color, marker="o", label=label)
    ax_t.set_xlabel("ms per frame (median)")
    ax_t.set_ylabel("RMSE vs double reference (linear RGBA)")
    ax_t.set_yscale("log")
    ax_t.set_title("error versus time (labels: step in voxels)")
    ax_t.grid(True, which="both", alpha=0.3)
    ax_t.legend(fontsize=8)
    ax_s.set_xlabel("step (voxels)")
    ax_s.set_ylabel("RMSE")
    ax_s.set_xscale("log")
    ax_s.set_yscale("log")
    ax_s.axhline(0.005, color="gray", lw=0.8, ls=":")
    ax_s.set_title("error versus step")
    ax_s.grid(True, which="both", alpha=0.3)
    ax_s.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else "volcl ray marcher")
