#!/usr/bin/env python3
"""Plots docs/images/multires.png from bench/bricks_bench.sh's CSV and the accuracy log of tests/test_bricks.cpp
(RMSE against the lod full render). Usage: plot_multires.py BENCH.csv ACCURACY.log OUT.png"""
import csv, re, statistics, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

rows = list(csv.DictReader(open(sys.argv[1])))
rmse = {}
for line in open(sys.argv[2]):
    m = re.match(r"mri 512\^2 zoomed out: lod auto, lod_error ([0-9.]+): RMSE ([0-9.e-]+)", line)
    if m: rmse[("auto", float(m.group(1)), 512.0)] = float(m.group(2))
    m = re.match(r"mri 512\^2 zoomed out: lod (\w+), cache ([0-9.]+) MB: RMSE ([0-9.e-]+)", line)
    if m: rmse[(m.group(1), 0.01 if m.group(1) == "auto" else 0.0, float(m.group(2)))] = float(m.group(3))
rmse[("full", 0.0, 512.0)] = 0.0
groups = {}
for r in rows:
    k = (r["lod"], float(r["lod_error"]), float(r["cache_mb"]))
    groups.setdefault(k, []).append(r)
fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
for k, rs in groups.items():
    kern = statistics.median(float(r["kernel_ms"]) for r in rs)
    dec = statistics.median(float(r["decode_ms"]) for r in rs)
    vox = float(rs[0]["voxels"]) / 1e6
    label = "full" if k[0] == "full" and k[2] == 512 else (
        f"auto {k[1]:g}" if k[2] == 512 else f"{k[0]} {k[1]:g}, {k[2]:g} MB" if k[0] == "auto" else f"full, {k[2]:g} MB")
    if k in rmse:
        a.scatter(kern + dec, rmse[k], s=40)
        a.annotate(label, (kern + dec, rmse[k]), textcoords="offset points", xytext=(5, 3), fontsize=8)
    b.bar(label, vox, color="tab:blue")
a.set_xlabel("kernel + decode ms per frame (median of 3 cold runs)")
a.set_ylabel("RMSE against lod full (RGBA)")
a.axhline(1e-3, color="grey", ls="--", lw=0.8)
a.set_title("MRI, 512^2, zoomed out 3x: accuracy vs time")
b.set_ylabel("decoded voxels (millions)")
b.set_title("voxels decoded per frame")
b.tick_params(axis="x", rotation=45, labelsize=8)
fig.tight_layout()
fig.savefig(sys.argv[3], dpi=110)
