#!/usr/bin/python3
"""Plots `volcl bench motion --json` output: prediction PSNR against search time per data set (one
marker per block size, full vs hierarchical), and prints the markdown tables for docs/motion.md.

Usage: /usr/bin/python3 bench/plot_motion.py bench-motion.json docs/images/
"""
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def num(v):
    return math.inf if isinstance(v, str) else v


def main():
    data = json.load(open(sys.argv[1]))
    out = sys.argv[2] if len(sys.argv) > 2 else "."
    rows = data["rows"]
    sets = sorted({r["dataset"] for r in rows})
    fig, axes = plt.subplots(1, len(sets), figsize=(5.2 * len(sets), 4.2), squeeze=False)
    markers = {4: "o", 8: "s", 16: "^"}
    for ax, ds in zip(axes[0], sets):
        sub = [r for r in rows if r["dataset"] == ds]
        for method, colour in (("full", "tab:blue"), ("hierarchical", "tab:orange")):
            for b, mk in markers.items():
                pts = sorted((r["search_ms"], num(r["prediction_psnr_db"]), r["radius"]) for r in sub
                             if r["method"] == method and r["block"] == b)
                if not pts:
                    continue
                ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=mk, color=colour, ls="-" if method == "full" else "--",
                        label=f"{method} B={b}")
                for x, y, rad in pts:
                    ax.annotate(f"R{rad}", (x, y), fontsize=7, xytext=(3, 2), textcoords="offset points")
        zero = num(sub[0]["zero_motion_psnr_db"])
        ax.axhline(zero, color="grey", lw=0.8, ls=":", label="no motion")
        ax.set_xscale("log")
        ax.set_xlabel("search kernel time (ms, log)")
        ax.set_ylabel("prediction PSNR (dB)")
        ax.set_title(ds)
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.suptitle(f"Motion search: accuracy against time ({data['device']})")
    fig.tight_layout()
    fig.savefig(f"{out}/motion-search-time-psnr.png", dpi=110)
    print("| data set | B | R | method | search ms | prediction PSNR dB | no-motion PSNR dB | inter blocks | vector bytes |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['dataset']} | {r['block']} | {r['radius']} | {r['method']} | {r['search_ms']:.1f} | "
              f"{num(r['prediction_psnr_db']):.2f} | {num(r['zero_motion_psnr_db']):.2f} | "
              f"{r['inter_blocks']}/{r['blocks']} | {r['motion_bytes']} |")
    print()
    print("| data set | what | kernel ms | kernel wall ms | C++ reference ms | reference / kernel wall | identical |")
    print("|---|---|---|---|---|---|---|")
    for s in data["kernel_vs_reference"]:
        ident = "-" if s["identical"] is None else ("yes" if s["identical"] else "NO")
        print(f"| {s['dataset']} | {s['what']} | {s['kernel_ms']:.1f} | {s['kernel_wall_ms']:.1f} | "
              f"{s['reference_ms']:.1f} | {s['reference_ms'] / s['kernel_wall_ms']:.1f}x | {ident} |")


if __name__ == "__main__":
    main()
