#!/usr/bin/python3
"""Plots `volcl bench codec --json` output: rate-distortion curves (PSNR vs bits/voxel, ours vs zfp),
lossless ratios against zstd/xz, and throughput bars; prints the markdown tables for docs/codec.md.

Usage: /usr/bin/python3 bench/plot_codec.py bench-codec.json docs/images/
       (a saved stderr log of the bench, *.log, works too: it lacks the zstd rows)
"""
import json
import math
import re
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def num(v):
    if isinstance(v, str):
        return math.inf if v == "inf" else math.nan
    return v


def parse_log(path):
    """Rows from the progress lines `volcl bench codec` prints on stderr."""
    rows, transforms, ds = [], [], None
    f = r"([-+0-9.eE]+|inf|nan)"
    for line in open(path):
        line = line.rstrip()
        m = re.match(r"== (\S+) ", line)
        if m:
            ds = m.group(1)
            continue
        m = re.match(rf"  (volcl-\w+) (\S+): ratio {f} bpv {f} PSNR {f} maxerr {f} enc {f} MB/s dec {f} MB/s", line)
        if m:
            rows.append(dict(dataset=ds, codec=m.group(1), mode=m.group(2), ratio=float(m.group(3)),
                             bits_per_voxel=float(m.group(4)), psnr_db=m.group(5) if m.group(5) == "inf" else float(m.group(5)),
                             max_abs_error=float(m.group(6)), encode_MBps=float(m.group(7)), decode_MBps=float(m.group(8))))
            continue
        m = re.match(rf"  zfp reversible: ratio {f} enc {f} dec {f}", line)
        if m:
            rows.append(dict(dataset=ds, codec="zfp", mode="lossless", ratio=float(m.group(1)), bits_per_voxel=math.nan,
                             psnr_db="inf", max_abs_error=0.0, encode_MBps=float(m.group(2)), decode_MBps=float(m.group(3))))
            continue
        m = re.match(rf"  xz -9: ratio {f}", line)
        if m:
            rows.append(dict(dataset=ds, codec="xz-9", mode="lossless", ratio=float(m.group(1)), bits_per_voxel=math.nan,
                             psnr_db="inf", max_abs_error=0.0, encode_MBps=math.nan, decode_MBps=math.nan))
            continue
        m = re.match(rf"  zfp (psnr\d+): bpv {f} PSNR {f}", line)
        if m:
            rows.append(dict(dataset=ds, codec="zfp", mode=m.group(1), ratio=math.nan, bits_per_voxel=float(m.group(2)),
                             psnr_db=float(m.group(3)), max_abs_error=math.nan, encode_MBps=math.nan, decode_MBps=math.nan))
            continue
        m = re.match(rf"  transform (.+?), (\S+): {f} Gvoxel/s, {f} GB/s of pass traffic = {f}% of the copy kernel "
                     rf"\({f} GB/s\)", line)
        if m:
            transforms.append(dict(dataset=ds, transform=m.group(1) + " 3D", kernel=m.group(2),
                                   gvoxel_per_s=float(m.group(3)), gb_per_s=float(m.group(4)),
                                   copy_gb_per_s=float(m.group(6)), fraction_of_copy=float(m.group(5)) / 100))
    return dict(rows=rows, transforms=transforms)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    data = parse_log(sys.argv[1]) if sys.argv[1].endswith(".log") else json.load(open(sys.argv[1]))
    out = sys.argv[2].rstrip("/")
    rows = data["rows"]
    sets = list(dict.fromkeys(r["dataset"] for r in rows))

    # Rate-distortion: one panel per data set.
    cols = 3
    nrows = math.ceil(len(sets) / cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(5 * cols, 3.8 * nrows), squeeze=False)
    for ax, ds in zip(axes.flat, sets):
        for codec, style in (("volcl-dense", "o-"), ("zfp", "s--")):
            pts = sorted((r["bits_per_voxel"], num(r["psnr_db"])) for r in rows
                         if r["dataset"] == ds and r["codec"] == codec and r["mode"].startswith("psnr"))
            if pts:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], style, label=codec)
        ax.set_title(ds)
        ax.set_xlabel("bits / voxel")
        ax.set_ylabel("PSNR (dB)")
        ax.set_xscale("log")
        ax.grid(True, alpha=0.3)
        ax.legend()
    for ax in list(axes.flat)[len(sets):]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(f"{out}/codec-rate-distortion.png", dpi=90)

    # Throughput bars: lossless encode/decode MB/s per codec.
    codecs = ["volcl-dense", "volcl-fast", "zfp", "zstd-3", "zstd-19"]
    fig, axes = plt.subplots(1, 2, figsize=(15, 4.5))
    width = 0.8 / len(codecs)
    for k, key in enumerate(("encode_MBps", "decode_MBps")):
        ax = axes[k]
        for i, c in enumerate(codecs):
            vals = []
            for ds in sets:
                m = [r[key] for r in rows if r["dataset"] == ds and r["codec"] == c and r["mode"] == "lossless"]
                vals.append(m[0] if m else 0)
            ax.bar([j + i * width for j in range(len(sets))], vals, width, label=c)
        ax.set_xticks([j + 0.4 - width / 2 for j in range(len(sets))])
        ax.set_xticklabels(sets, rotation=30, ha="right")
        goal = 100 if key == "encode_MBps" else 200  # the lossless speed goal
        ax.axhline(goal, color="k", linestyle=":", linewidth=1, label=f"goal {goal} MB/s")
        ax.set_ylabel("MB/s of original voxels")
        ax.set_yscale("log")
        ax.set_title("lossless " + key.split("_")[0])
        ax.grid(True, axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(f"{out}/codec-throughput.png", dpi=90)

    # Markdown tables.
    by = defaultdict(dict)
    for r in rows:
        by[(r["dataset"], r["mode"])][r["codec"]] = r
    print("| data set | volcl dense | volcl fast | zfp reversible | zstd -3 | zstd -19 | xz -9 | dense enc / dec MB/s | fast enc / dec MB/s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for ds in sets:
        m = by[(ds, "lossless")]
        cell = lambda c: f"{m[c]['ratio']:.2f}" if c in m else "-"  # noqa: E731
        speed = lambda c: f"{m[c]['encode_MBps']:.0f} / {m[c]['decode_MBps']:.0f}" if c in m else "-"  # noqa: E731
        print(f"| {ds} | {cell('volcl-dense')} | {cell('volcl-fast')} | {cell('zfp')} | {cell('zstd-3')} | "
              f"{cell('zstd-19')} | {cell('xz-9')} | {speed('volcl-dense')} | {speed('volcl-fast')} |")
    print()
    print("| data set | target | volcl bpv | volcl PSNR | zfp bpv | zfp PSNR | volcl/zfp bits | volcl enc MB/s | volcl dec MB/s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for ds in sets:
        for mode in sorted({r["mode"] for r in rows if r["dataset"] == ds and r["mode"].startswith("psnr")},
                           key=lambda s: float(s[4:])):
            m = by[(ds, mode)]
            if "volcl-dense" not in m or "zfp" not in m:
                continue
            a, z = m["volcl-dense"], m["zfp"]
            print(f"| {ds} | {mode[4:]} dB | {a['bits_per_voxel']:.3f} | {num(a['psnr_db']):.2f} | "
                  f"{z['bits_per_voxel']:.3f} | {num(z['psnr_db']):.2f} | {a['bits_per_voxel'] / z['bits_per_voxel']:.2f} | "
                  f"{a['encode_MBps']:.0f} | {a['decode_MBps']:.0f} |")
    print()
    print("| data set | mode | coder | bpv | PSNR | max error | enc MB/s | dec MB/s |")
    print("|---|---|---|---|---|---|---|---|")
    for ds in sets:
        for mode in ("bpv1", "bpv2", "maxerr0.5%"):
            for codec in ("volcl-dense", "volcl-fast"):
                a = by[(ds, mode)].get(codec)
                if a:
                    print(f"| {ds} | {mode} | {codec[6:]} | {a['bits_per_voxel']:.3f} | {num(a['psnr_db']):.2f} | "
                          f"{a['max_abs_error']:.4g} | {a['encode_MBps']:.0f} | {a['decode_MBps']:.0f} |")
    print()
    print("| data set | transform | kernel | Gvoxel/s | GB/s | copy GB/s | fraction of copy |")
    print("|---|---|---|---|---|---|---|")
    for t in data.get("transforms", []):
        print(f"| {t['dataset']} | {t['transform']} | {t.get('kernel', '-')} | {t['gvoxel_per_s']:.3f} | "
              f"{t['gb_per_s']:.1f} | {t['copy_gb_per_s']:.1f} | {t['fraction_of_copy']:.2f} |")


if __name__ == "__main__":
    main()
