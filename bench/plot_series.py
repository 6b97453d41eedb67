#!/usr/bin/python3
"""Plots `volcl bench series` JSON: bits/voxel of motion-compensated against intra-only coding (and SZ3 in
4D, from bench/sz3_series.py's JSON when given) per series and rate target (log scale), and the MC/intra
ratio, into one PNG.

Usage: /usr/bin/python3 bench/plot_series.py bench/results/motion/series-bench.json docs/images/motion-series-bpv.png \
           [bench/results/motion/series-sz3.json]
"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def main(src, dst, sz3=None):
    rows = json.load(open(src))["rows"]
    if sz3:
        rows += json.load(open(sz3))["rows"]
    series = list(dict.fromkeys(r["series"] for r in rows))
    rates = [r for r in dict.fromkeys(r["rate"] for r in rows) if r != "lossless"]
    bpv = {(r["series"], r["rate"], r["mode"]): r["bits_per_voxel"] for r in rows}
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.5))
    width = 0.8 / len(rates)
    modes = ["intra", "mc"] + (["sz3-4d"] if sz3 else [])
    names = {"intra": "intra", "mc": "MC", "sz3-4d": "SZ3-4D"}
    hatches = {"intra": None, "mc": "//", "sz3-4d": ".."}
    bar = width * 0.9 / len(modes)
    for k, rate in enumerate(rates):
        xs = [i + k * width for i in range(len(series))]
        for m, mode in enumerate(modes):
            a.bar([x + m * bar for x in xs], [bpv.get((s, rate, mode), 0) for s in series], bar,
                  label=f"{rate} {names[mode]}", hatch=hatches[mode])
        b.bar(xs, [bpv.get((s, rate, "mc"), 0) / max(bpv.get((s, rate, "intra"), 1e-30), 1e-30) for s in series],
              width * 0.9, label=rate)
    for ax in (a, b):
        ax.set_xticks([i + 0.4 - width / 2 for i in range(len(series))])
        ax.set_xticklabels(series, rotation=20, fontsize=8)
    a.set_yscale("log")
    a.set_ylabel("bits per voxel")
    a.set_title("bits/voxel: intra-only, motion-compensated" + (", SZ3-4D" if sz3 else ""))
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
    main(*sys.argv[1:4])
