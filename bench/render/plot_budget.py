#!/usr/bin/python3
"""Plots `volcl bench render --budgets --budget-csv` output: the achieved frame time against the budget (with
the +-20% band) and the measured and expected RMSE against the budget, each point marked by the knob chosen.
Usage: plot_budget.py out.png budget.csv [label]"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

MARKERS = {"render.step": ("s", "ray marched, single scattering (step)"),
           "effects.scattering.samples": ("o", "path traced, multiple scattering (samples)")}


def main(png_path, csv_path, label):
    rows = [r for r in csv.DictReader(open(csv_path)) if r["knob"] != "refused"]
    fig, (ax_t, ax_e) = plt.subplots(1, 2, figsize=(11, 4.5))
    budgets = [float(r["budget_ms"]) for r in rows]
    lo, hi = min(budgets) / 1.5, max(budgets) * 1.5
    ax_t.fill_between([lo, hi], [0.8 * lo, 0.8 * hi], [1.2 * lo, 1.2 * hi], color="0.9", label="budget +-20%")
    ax_t.loglog([lo, hi], [lo, hi], "k:", linewidth=1)
    for knob, (marker, name) in MARKERS.items():
        sel = [r for r in rows if r["knob"] == knob]
        if not sel:
            continue
        b = [float(r["budget_ms"]) for r in sel]
        ax_t.loglog(b, [float(r["achieved_ms"]) for r in sel], marker, color="tab:blue", markersize=8, label=name)
        ax_e.loglog(b, [float(r["rmse"]) for r in sel], marker, color="tab:red", markersize=8,
                    label=f"measured, {name}")
        ax_e.loglog(b, [float(r["expected_rmse"]) for r in sel], marker, color="tab:red", markersize=8,
                    fillstyle="none", label=f"expected, {name}")
    ax_t.set_xlabel("budget (ms/frame)")
    ax_t.set_ylabel("achieved (ms/frame, median of interleaved frames)")
    ax_t.set_title(f"{label}: frame time")
    ax_t.legend(fontsize=8)
    ax_e.set_xlabel("budget (ms/frame)")
    ax_e.set_ylabel("RMSE against the converged reference")
    ax_e.set_title(f"{label}: error of the choice")
    ax_e.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110, metadata={"Software": None})


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else "scene")
