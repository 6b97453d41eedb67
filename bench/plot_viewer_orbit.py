#!/usr/bin/python3
"""Plots a `volcl bench view --csv` (or `volcl view --headless --stats`) CSV: frame time per frame against
the target, the transport (upload) time, and the rendered image edge.
Usage: plot_viewer_orbit.py FRAMES.csv TARGET_MS OUT.png"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    path, target, out = sys.argv[1], float(sys.argv[2]), sys.argv[3]
    rows = list(csv.DictReader(open(path)))
    frame = [int(r["frame"]) for r in rows]
    ms = [float(r["frame_ms"]) for r in rows]
    inter = [r["interactive"] == "1" for r in rows]
    edge = [int(r["width"]) for r in rows]
    step = [float(r["step"]) for r in rows]
    im = sorted(m for m, i in zip(ms, inter) if i)
    med = im[len(im) // 2] if len(im) % 2 else 0.5 * (im[len(im) // 2 - 1] + im[len(im) // 2])
    pos = 0.9 * (len(im) - 1)
    lo = int(pos)
    p90 = im[lo] + (im[min(lo + 1, len(im) - 1)] - im[lo]) * (pos - lo)

    fig, ax = plt.subplots(figsize=(9, 4.8))
    ax.semilogy([f for f, i in zip(frame, inter) if i], [m for m, i in zip(ms, inter) if i], "o-", ms=3,
                label=f"interactive frames (median {med:.0f} ms, p90 {p90:.0f} ms)")
    ax.semilogy([f for f, i in zip(frame, inter) if not i], [m for m, i in zip(ms, inter) if not i], "s",
                color="C3", label="full-quality frames (512x512, scene step)")
    if "upload_ms" in rows[0]:
        up = [float(r["upload_ms"]) for r in rows]
        ax.semilogy(frame, up, ".", color="C4", ms=3, label="of which transport (PBO upload + glFinish)")
    ax.axhline(target, color="k", ls="--", lw=1, label=f"target {target:.0f} ms")
    ax.axhline(1.1 * target, color="k", ls=":", lw=1, label="target + 10 %")
    ax.set_xlabel("frame")
    ax.set_ylabel("frame time, ms (render + upload + draw)")
    ax2 = ax.twinx()
    ax2.plot(frame, edge, color="C2", lw=1, alpha=0.7, label="rendered edge (pixels)")
    ax2.set_ylabel("rendered image edge, pixels")
    ax2.set_ylim(0, max(edge) * 1.05)
    lines = ax.get_legend_handles_labels()
    lines2 = ax2.get_legend_handles_labels()
    ax.legend(lines[0] + lines2[0], lines[1] + lines2[1], loc="upper center", fontsize=8)
    ax.set_title(f"Orbiting the 180x216x180 MRI at 512x512 with adaptive quality "
                 f"(interactive step x{max(step) / min(step):.0f})", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    main()
