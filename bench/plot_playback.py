"""Plots decode speed of a motion-compensated 128^3 series from `volcl bench series` JSON: P-frame decode
time over an intra frame's, and playback frames per second, per rate, with the goals (2x, 30 fps); with a
third panel of the process CPU time per played frame when the file has it (bench runs that record it).

Usage: plot_playback.py after.json out.png [before.json]   (before: a run of an earlier build)
"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def rows(path):
    """(rate -> {mode: row}) of the 128^3 MRI series in one bench file."""
    out = {}
    for r in json.load(open(path))["rows"]:
        if r["series"] == "mri-shift":
            out.setdefault(r["rate"], {})[r["mode"]] = r
    return out


def main():
    after = rows(sys.argv[1])
    before = rows(sys.argv[3]) if len(sys.argv) > 3 else {}
    rates = list(after)
    cpu = all("playback_cpu_ms_per_frame" in after[r].get("mc", {}) for r in rates)
    fig, axes = plt.subplots(1, 3 if cpu else 2, figsize=(13.5 if cpu else 9, 3.6))
    a1, a2 = axes[0], axes[1]
    w = 0.38
    xs = range(len(rates))
    for ax, key, goal, label in ((a1, "ratio", 2.0, "P frame / I frame decode time"),
                                 (a2, "playback_fps", 30.0, "playback fps (MC series)")):
        for k, (name, data) in enumerate((("before", before), ("after", after))):
            if not data:
                continue
            vals = []
            for rate in rates:
                d = data.get(rate, {})
                if key == "ratio":
                    vals.append(d["mc"]["frame_decode_ms"] / d["intra"]["frame_decode_ms"] if d else 0)
                else:
                    vals.append(d["mc"]["playback_fps"] if d else 0)
            ax.bar([x + (k - 0.5) * w for x in xs], vals, w, label=name)
        if key == "playback_fps":
            ax.bar([x + 1.5 * w for x in xs], [after[r]["intra"]["playback_fps"] for r in rates], w * 0.6,
                   label="intra-only (after run)", color="grey")
        ax.axhline(goal, color="k", ls="--", lw=1, label=f"goal {goal:g}")
        ax.set_xticks(list(xs), rates)
        ax.set_title(label, fontsize=10)
        ax.legend(fontsize=8)
    if cpu:
        a3 = axes[2]
        for k, mode in enumerate(("intra", "mc")):
            a3.bar([x + (k - 0.5) * w for x in xs], [after[r][mode]["playback_cpu_ms_per_frame"] for r in rates], w,
                   label="intra-only" if mode == "intra" else "MC", color="grey" if mode == "intra" else None)
        # 30 fps on 2 cores, both kept busy: at most 2 x 33.3 ms of CPU time per frame.
        a3.axhline(2000 / 30, color="k", ls="--", lw=1, label="30 fps on 2 busy cores")
        a3.set_xticks(list(xs), rates)
        a3.set_title("process CPU ms per played frame (after run)", fontsize=10)
        a3.legend(fontsize=8)
    fig.suptitle("128^3 MRI series, 10 frames (1 I + 9 P), 2 cores, PoCL", fontsize=10)
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=110)


if __name__ == "__main__":
    main()
