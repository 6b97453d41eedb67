#!/usr/bin/python3
"""Error-versus-time plot for `volcl bench preint --json results.json` (Debian python3-matplotlib).

Usage: /usr/bin/python3 bench/plot_preint.py results.json docs/images/preintegration_error_vs_time.png
Panels: (a) 2D 256x256 tables, (b) 3D 128x128x256 tables (VTK's default shape) with VTK's builders from the
same run, (c) build time versus table size N for every method (2D, float). Errors are the largest absolute
difference from volcl's double-precision reference over every entry (a) and (b) or over a sample (c).
"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLORS = {"exact": "tab:blue", "incremental": "tab:orange", "integral-function": "tab:red",
          "roettger-2d": "tab:purple", "polynomial": "tab:green", "reference": "black",
          "vtk-incremental": "tab:brown", "vtk-direct": "tab:gray"}
FLOOR = 1e-9  # errors of 0 are drawn here on the log axis


def err(r):
    return max(r["max_err"], FLOOR)


def knob_panel(ax, rows, dims, size, lengths, vtk, title):
    sel = [r for r in rows if r["dims"] == dims and r["size"] == size and r["lengths"] == lengths]
    # With one length, incremental, roettger-2d and polynomial reduce to exact: only 3D panels show them.
    sweeps = (("exact", "depth"), ("polynomial", "degree")) if dims == "3D" else (("exact", "depth"),)
    singles = ("incremental", "integral-function", "roettger-2d") if dims == "3D" else ("integral-function",)
    for method, knob in sweeps:
        pts = sorted([r for r in sel if r["method"] == method and r["knob"] == knob], key=lambda r: r["knob_value"])
        if not pts:
            continue
        xs, ys = [r["time_ms"] for r in pts], [err(r) for r in pts]
        ax.plot(xs, ys, "-o", color=COLORS[method], label=method + " (knob sweep)")
        for r in pts:
            ax.annotate("%g" % r["knob_value"], (r["time_ms"], err(r)), textcoords="offset points", xytext=(4, 4),
                        fontsize=7, color=COLORS[method])
    for method in singles:
        pts = [r for r in sel if r["method"] == method and r["knob"] == "" and r["precision"] == "float"]
        if pts:
            ax.plot([pts[-1]["time_ms"]], [err(pts[-1])], "s", color=COLORS[method], label=method)
    for mode in ("incremental", "direct"):
        if vtk and mode in vtk:
            ax.plot([vtk[mode]["time_ms"]], [max(vtk[mode]["max_err"], FLOOR)], "D", color=COLORS["vtk-" + mode],
                    label="VTK " + mode + " (same run)")
    ax.axhline(1e-4, color="k", ls="--", lw=0.8)
    ax.text(0.01, 1.2e-4, "1e-4 target", fontsize=7, va="bottom", transform=ax.get_yaxis_transform())
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("build time, ms (median, kernels built beforehand)")
    ax.set_ylabel("max |table - reference|")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7, loc="center right")


def size_panel(ax, rows):
    for method in ("exact", "integral-function", "reference"):
        pts = sorted([r for r in rows if r["method"] == method and r["dims"] == "2D" and r["knob"] == ""
                      and r["precision"] == "float"], key=lambda r: r["size"])
        if pts:
            ax.plot([r["size"] for r in pts], [r["time_ms"] for r in pts], "-o", color=COLORS[method],
                    label=method + " (wall)")
            if method != "reference":
                ax.plot([r["size"] for r in pts], [max(r["device_ms"], 1e-3) for r in pts], ":", marker=".",
                        color=COLORS[method], label=method + " (kernel only)")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("table size N (2D N x N, float)")
    ax.set_ylabel("time, ms (median)")
    ax.set_title("(c) time versus size, 2D (other methods equal exact in 2D)", fontsize=10)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_preint.py results.json out.png")
    with open(sys.argv[1]) as f:
        data = json.load(f)
    rows, vtk = data["rows"], data.get("vtk")
    fig, axes = plt.subplots(1, 3, figsize=(17, 5.2))
    knob_panel(axes[0], rows, "2D", 256, 1, None, "(a) 2D 256x256, step %g: error vs time" % data["step"])
    knob_panel(axes[1], rows, "3D", 128, 256, vtk,
               "(b) 3D 128x128x256, max length %g: error vs time" % data["max_length"])
    size_panel(axes[2], rows)
    fig.suptitle("volcl pre-integration tables on %s (TF: the documented example)" % data["device"], fontsize=11)
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=110)


if __name__ == "__main__":
    main()
