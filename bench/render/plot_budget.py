#!/usr/bin/python3
"""Plots `volcl bench render --budgets --budget-csv` output: the achieved frame time against the budget (with
the +-20% band) and the measured and expected RMSE against the budget, each point marked by the knob chosen,
one colour per run.
Usage: plot_budget.py out.png label=budget.csv [label=budget.csv ...]"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

MARKERS = {"render.step": ("s", "ray marched, single scattering (step)"),
           "effects.scattering.samples": ("o", "path traced, multiple scattering (samples)")}


def main(png_path, inputs):
    fig, (ax_t, ax_e) = plt.subplots(1, 2, figsize=(11, 4.5))
    runs = [(label, [r for r in csv.DictReader(open(path)) if r["knob"] != "refused"]) for label, path in inputs]
    budgets = [float(r["budget_ms"]) for _, rows in runs for r in rows]
    lo, hi = min(budgets) / 1.5, max(budgets) * 1.5
    ax_t.fill_between([lo, hi], [0.8 * lo, 0.8 * hi], [1.2 * lo, 1.2 * hi], color="0.9", label="budget +-20%")
    ax_t.loglog([lo, hi], [lo, hi], "k:", linewidth=1)
    for (label, rows), color in zip(runs, ["tab:blue", "tab:red", "tab:green", "tab:purple"]):
        for knob, (marker, name) in MARKERS.items():
            sel = [r for r in rows if r["knob"] == knob]
            if not sel:
                continue
            b = [float(r["budget_ms"]) for r in sel]
            ax_t.loglog(b, [float(r["achieved_ms"]) for r in sel], marker, color=color, markersize=8,
                        label=f"{label}: {name}")
            ax_e.loglog(b, [float(r["rmse"]) for r in sel], marker, color=color, markersize=8,
                        label=f"{label}: measured, {name}")
            ax_e.loglog(b, [float(r["expected_rmse"]) for r in sel], marker, color=color, markersize=8,
                        fillstyle="none", label=f"{label}: expected")
    ax_t.set_xlabel("budget (ms/frame)")
    ax_t.set_ylabel("achieved (ms/frame, median of interleaved frames)")
    ax_t.set_title("frame time against the budget")
    ax_t.legend(fontsize=7)
    ax_e.set_xlabel("budget (ms/frame)")
    ax_e.set_ylabel("RMSE against the converged reference")
    ax_e.set_title("error of the choice (filled: measured, open: expected)")
    ax_e.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110, metadata={"Software": None})


if __name__ == "__main__":
    main(sys.argv[1], [a.split("=", 1) for a in sys.argv[2:]])
