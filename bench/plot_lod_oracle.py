#!/usr/bin/env python3
"""Plots docs/images/multires-oracle.png: RMSE against the lod full render versus voxels decoded (top) and versus frame
time (bottom), for lod auto's estimate and the measured oracle, one column per view.
Usage: plot_lod_oracle.py OUT.png BENCH.csv[,BENCH.csv...] LABEL=LOG[,LOG...] [LABEL=LOG[,LOG...] ...]
Each LABEL's logs come from volcl-bench-lod-oracle on one scene and view; where several give an estimate
line for the same lod_error, the last one counts. BENCH.csv files come from bench/bricks_bench.sh (medians of
kernel + decode ms per lod_error, matched by scene and camera height)."""
import csv, re, statistics, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

est_re = re.compile(r"estimate lod_error ([0-9.e-]+): RMSE ([0-9.e+-]+), voxels (\d+) \(([0-9.]+)x fewer\)")
ora_re = re.compile(r"oracle target ([0-9.e+-]+): predicted RMSE [0-9.e+-]+, measured RMSE ([0-9.e+-]+), "
                    r"voxels (\d+) \(([0-9.]+)x fewer\)")
zoom_re = re.compile(r"zoom: ([0-9.]+) \(camera height ([0-9.]+)")
foot_re = re.compile(r"footprint: visible pixels span (\d+) x (\d+)")

bench = {}
for path in sys.argv[2].split(","):
    for r in csv.DictReader(open(path)):
        key = (r["scene"], float(r["view_height"]), r["lod"], float(r["lod_error"]), float(r["cache_mb"]))
        bench.setdefault(key, []).append(float(r["kernel_ms"]) + float(r["decode_ms"]))

runs = []
for arg in sys.argv[3:]:
    label, paths = arg.split("=", 1)
    est, ora, zoom, height, span, scene = {}, [], None, None, None, None
    for path in paths.split(","):
        for line in open(path):
            if line.startswith("file:") or line.startswith("scene:"):
                continue
            m = zoom_re.search(line)
            if m: zoom, height = float(m.group(1)), float(m.group(2))
            m = foot_re.search(line)
            if m: span = f"{m.group(1)}x{m.group(2)} px"
            m = est_re.search(line)
            if m: est[float(m.group(1))] = (float(m.group(2)), float(m.group(4)))
            m = ora_re.search(line)
            if m: ora.append((float(m.group(1)), float(m.group(2)), float(m.group(4))))
    scene = "mri_sharp" if "sharp" in label else "mri"
    runs.append((label, scene, zoom, height, span, est, sorted(ora)))

zooms = sorted({r[2] for r in runs}, reverse=True)
fig, ax = plt.subplots(2, len(zooms), figsize=(5.5 * len(zooms), 8.4), squeeze=False)
colors = {"mri": "tab:blue", "mri_sharp": "tab:red"}
for col, z in enumerate(zooms):
    top, bottom = ax[0][col], ax[1][col]
    for label, scene, zoom, height, span, est, ora in runs:
        if zoom != z:
            continue
        column_height, span_txt = height, span
        c = colors[scene]
        e = sorted(est.items())
        top.plot([v[1] for _, v in e], [max(v[0], 1e-6) for _, v in e], marker="o", color=c,
                 label=f"{label}: lod auto (lod_error {e[0][0]:g}-{e[-1][0]:g})")
        if ora:
            top.plot([o[2] for o in ora], [o[1] for o in ora], marker="s", ls="--", color=c,
                     label=f"{label}: oracle (measured per-brick errors)")
        times = []
        for le, (rmse, _) in e:
            t = bench.get((scene, height, "auto", le, 512.0))
            if t: times.append((statistics.median(t), max(rmse, 1e-6), le))
        if times:
            bottom.plot([t[0] for t in times], [t[1] for t in times], marker="o", color=c, label=f"{label}: lod auto")
            for t in times:
                bottom.annotate(f"{t[2]:g}", (t[0], t[1]), textcoords="offset points", xytext=(4, 3), fontsize=7)
        full = bench.get((scene, height, "full", 0.0, 512.0))
        if full:
            bottom.axvline(statistics.median(full), color=c, ls=":", lw=1, label=f"{label}: lod full")
    top.axhline(1e-3, color="grey", ls="--", lw=0.8)
    top.axvline(3.0, color="grey", ls=":", lw=0.8)
    top.set_xscale("log")
    top.set_yscale("log")
    top.set_xlabel("voxels decoded: times fewer than lod full")
    top.set_ylabel("RMSE against lod full (RGBA, all pixels; 0 drawn at 1e-6)")
    top.set_title(f"512^2, camera height {column_height:g} (zoomed out {z:g}x): volume spans {span_txt}", fontsize=9)
    top.legend(fontsize=7)
    bottom.axhline(1e-3, color="grey", ls="--", lw=0.8)
    bottom.set_yscale("log")
    bottom.set_xlabel("kernel + decode ms per frame (median of cold runs; labels: lod_error)")
    bottom.set_ylabel("RMSE against lod full (0 drawn at 1e-6)")
    bottom.set_title("accuracy against time", fontsize=9)
    bottom.legend(fontsize=7)
fig.tight_layout()
fig.savefig(sys.argv[1], dpi=100)
