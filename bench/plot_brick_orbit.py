#!/usr/bin/env python3
"""Plots an orbit of volcl-bench-brick-orbit (one or more CSVs, one line per cache budget): frame time,
cache hit rate and working set (bricks visited, bricks decoded) per frame.
Usage: plot_brick_orbit.py OUT.png LABEL=ORBIT.csv [LABEL=ORBIT.csv ...]"""
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

runs = []
for arg in sys.argv[2:]:
    label, path = arg.split("=", 1)
    runs.append((label, list(csv.DictReader(open(path)))))
fig, ax = plt.subplots(1, 3, figsize=(14, 4))
for label, rows in runs:
    f = [int(r["frame"]) for r in rows]
    ax[0].plot(f, [float(r["frame_ms"]) for r in rows], marker=".", label=label)
    ax[1].plot(f, [100 * float(r["hit_rate"]) for r in rows], marker=".", label=label)
    ax[2].plot(f, [int(r["visited"]) for r in rows], marker=".", label=label + ": working set")
    ax[2].plot(f, [int(r["decoded"]) for r in rows], linestyle="--", label=label + ": decoded (misses)")
ax[0].set(xlabel="orbit frame", ylabel="frame time (ms, decode + upload + kernel)", title="frame time")
ax[0].set_yscale("log")
ax[1].set(xlabel="orbit frame", ylabel="bricks found in the pool (%)", title="cache hit rate", ylim=(-5, 105))
ax[2].set(xlabel="orbit frame", ylabel="bricks", title="working set and misses per frame")
for a in ax:
    a.grid(alpha=0.3)
    a.legend(fontsize=7)
fig.tight_layout()
fig.savefig(sys.argv[1], dpi=100)
