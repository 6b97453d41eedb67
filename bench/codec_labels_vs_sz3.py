#!/usr/bin/env python3
"""Piecewise-constant volumes (label atlases, a tissue map): volcl's `encode --psnr P` against SZ3 at equal PSNR.

For each label volume present (Debian's mricron atlases and the shared frog tissue map), encodes it with
`volcl encode --psnr P` and default options (the whole file's bytes, level-of-detail statistics included)
and `volcl encode` lossless, and SZ3 (pysz) in its PSNR mode at the same P on the voxels as float32, its
output rounded and clipped to the voxel type as an integer reader would. PSNR is over the input's value
range, in double, for both. Prints one row per cell, the ratio volcl bytes / SZ3 bytes, and the time of one
volcl encode (wall, as run: state the machine's load with it).

Usage: bench/codec_labels_vs_sz3.py path/to/volcl [--psnr 40 50 60] [--csv out.csv]   (numpy and pysz 1.1.0)
"""
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import pysz

from codec_vs_sperr import psnr_bench_args

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.normpath(os.path.join(HERE, "..", "..", "shared", "data"))
MRICRON = "/usr/share/mricron/templates"
VOLUMES = [
    ("aal", os.path.join(MRICRON, "aal.nii.gz")),
    ("harvard-oxford-cort", os.path.join(MRICRON, "HarvardOxford-cort-maxprob-thr0-1mm.nii.gz")),
    ("jhu-wm-labels", os.path.join(MRICRON, "JHU-WhiteMatter-labels-1mm.nii.gz")),
    ("brodmann", os.path.join(MRICRON, "brodmann.nii.gz")),
    ("frogtissue", os.path.join(DATA, "regular", "froggy", "frogtissue.mhd")),
]


def psnr(a, b):
    a = a.astype(np.float64)
    b = b.astype(np.float64)
    mse = float(np.mean((a - b) ** 2))
    rng = float(a.max() - a.min())
    if mse == 0:
        return math.inf
    return 20 * math.log10(rng / math.sqrt(mse)) if rng > 0 else -math.inf


def sz3(a, target):
    c = pysz.szConfig()
    c.errorBoundMode = pysz.szErrorBoundMode.PSNR
    c.psnrErrorBound = target
    comp, _ = pysz.sz.compress(np.ascontiguousarray(a.astype(np.float32)), c)
    out, _ = pysz.sz.decompress(comp, np.float32, a.shape)
    if np.issubdtype(a.dtype, np.integer):
        info = np.iinfo(a.dtype)
        out = np.clip(np.rint(out), info.min, info.max).astype(a.dtype)
    return comp.nbytes, psnr(a, out)


def main():
    a = psnr_bench_args(__doc__)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, path in VOLUMES:
            if not os.path.exists(path):
                print(f"skipping {name}: {path} is absent", file=sys.stderr)
                continue
            npy = os.path.join(tmp, name + ".npy")
            subprocess.run([a.volcl, "convert", path, "-o", npy], check=True, capture_output=True)
            vol = np.load(npy)
            out = os.path.join(tmp, "out.vcz")
            subprocess.run([a.volcl, "encode", npy, "-o", out], check=True, capture_output=True)
            lossless = os.path.getsize(out)
            print(f"{name}: {vol.shape[::-1]} {vol.dtype}, {len(np.unique(vol))} values, "
                  f"volcl lossless {lossless} B", flush=True)
            for target in a.psnr:
                t0 = time.perf_counter()
                run = subprocess.run([a.volcl, "encode", npy, "-o", out, "--psnr", str(target)],
                                     capture_output=True, text=True)
                seconds = time.perf_counter() - t0
                if run.returncode != 0:
                    sys.exit(f"{name} at {target} dB: {run.stderr.strip()}")
                dec = os.path.join(tmp, "dec.npy")
                subprocess.run([a.volcl, "decode", out, "-o", dec], check=True, capture_output=True)
                ours_psnr = psnr(vol, np.load(dec))
                ours = os.path.getsize(out)
                peer, peer_psnr = sz3(vol, target)
                rows.append((name, target, ours, ours_psnr, peer, peer_psnr, ours / peer, lossless, seconds))
                print(f"{name:20s} {target:4.0f} dB: volcl {ours:8d} B (PSNR {ours_psnr:.2f}), "
                      f"SZ3 {peer:8d} B (PSNR {peer_psnr:.2f}), volcl/SZ3 {ours / peer:.3f}, "
                      f"lossless {lossless} B, volcl encode {seconds:.2f} s", flush=True)
    if rows:
        gm = math.exp(sum(math.log(r[6]) for r in rows) / len(rows))
        print(f"cells {len(rows)}, above 1.0x SZ3: {sum(r[6] > 1 for r in rows)}, geometric mean {gm:.3f}, "
              f"worst {max(r[6] for r in rows):.3f}; files above lossless: {sum(r[2] > r[7] for r in rows)}")
    if a.csv:
        with open(a.csv, "w") as f:
            f.write("volume,target_db,volcl_bytes,volcl_psnr_db,sz3_bytes,sz3_psnr_db,ratio,volcl_lossless_bytes,"
                    "volcl_encode_s\n")
            for r in rows:
                f.write(",".join(str(v) for v in r) + "\n")


if __name__ == "__main__":
    main()
