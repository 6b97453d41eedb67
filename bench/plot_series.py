#!/usr/bin/python3
"""Plots `volcl bench series` JSON: bits/voxel of motion-compensated against intra-only coding per series
and rate target (log scale), and the MC/intra ratio, into one PNG.

Usage: /usr/bin/python3 bench/plot_series.py docs/results/series-bench.json docs/motion-series-bpv.png
"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def main(src, dst):
    rows = json.load(open(src))["rows"]
    series = list(dict.fromkeys(r["series"] for r in rows))
    rates = [r for r in dict.fromkeys(r["rate"] for r in rows) if r != "lossless"]
    bpv = {(r["series"], r["rate"], r["mode"]): r["bits_per_voxel"] for r in rows}
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.5))
    width = 0.8 / len(rates)
    for k, rate in enumerate(rates):
        xs = [i + k * width for i in range(len(series))]
        a.bar(xs, [bpv.get((s, rate, "intra"), 0) for s in series], width * 0.45, label=f"{rate} intra")
        a.bar([x + width * 0.45 for x in xs], [bpv.get((s, rate, "mc"), 0) for s in series], width * 0.45,
              label=f"{rate} MC", hatch="//")
        b.bar(xs, [bpv.get((s, rate, "mc"), 0) / max(bpv.get((s, rate, "intra"), 1e-30), 1e-30) for s in series],
              width * 0.9, label=rate)
    for ax in (a, b):
        ax.set_xticks([i + 0.4 - width / 2 for i in range(len(series))])
        ax.set_xticklabels(series, rotation=20, fontsize=8)
    a.set_yscale("log")
    a.set_ylabel("bits per voxel")
    a.set_title("bits/voxel: intra-only against motion-compensated")
    a.legend(fontsize=6, ncol=2)
    b.axhline(1.0, color="k", lw=0.8)
    b.axhline(0.6, color="g", lw=0.8, ls="--")
    b.axhline(0.8, color="orange", lw=0.8, ls="--")
    b.set_ylabel("MC bits / intra bits")
    b.set_title("ratio (dashed: 0.6 and 0.8)")
    b.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(dst, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
