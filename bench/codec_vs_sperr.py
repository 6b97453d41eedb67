#!/usr/bin/env python3
"""volcl's default `encode --psnr P` against SPERR's measured rate-distortion curves.

For each shared volume with a curve in ../shared/peers/sperr-curves (SPERR 0.8.5, single thread), encodes it
with `volcl encode --psnr P` and default options, takes the file's bits per voxel (everything in the file) and
the PSNR volcl reports, and divides by SPERR's bits at that PSNR: log(bits) interpolated linearly in PSNR on the
Pareto front of SPERR's points (its --psnr and --bpp sweeps). Prints one row per cell and the geometric mean.

Usage: bench/codec_vs_sperr.py path/to/volcl [--psnr 40 50 60] [--csv out.csv]
"""
import argparse
import gzip
import json
import math
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
SHARED = os.path.normpath(os.path.join(HERE, "..", "..", "shared"))
CURVES = os.path.join(SHARED, "peers", "sperr-curves")
DATA = os.path.join(SHARED, "data")
MRICRON = "/usr/share/mricron/templates"


def inputs(tmp):
    """(curve name, input path, voxels) for every volume whose input is present."""
    r, t = os.path.join(DATA, "regular"), os.path.join(DATA, "timevarying")
    brainweb = os.path.join(tmp, "brainweb_180x216x180_uint8.raw")
    gz = os.path.join(r, "t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz")
    if os.path.exists(gz):
        with gzip.open(gz) as f, open(brainweb, "wb") as out:
            out.write(f.read())
    return [
        ("ch2", os.path.join(MRICRON, "ch2.nii.gz"), 181 * 217 * 181),
        ("ch2better", os.path.join(MRICRON, "ch2better.nii.gz"), 301 * 370 * 316),
        ("brainweb", brainweb, 180 * 216 * 180),
        ("walnut", os.path.join(r, "walnut.vvd"), 128 * 96 * 114),
        ("hydrogen", os.path.join(r, "hydrogenatom.dat"), 128 ** 3),
        ("isabel30", os.path.join(t, "isabel", "isabel_30.vti"), 125 * 125 * 25),
        ("viscous010", os.path.join(t, "viscousfingers", "010_density_010_064_2.0.vti"), 64 ** 3),
    ]


def pareto(points):
    """SPERR's points that no other point beats (higher or equal PSNR for fewer or equal bits), by PSNR."""
    pts = sorted((p, b) for p, b, _ in points)
    front = []
    for p, b in pts:
        if any(q >= p and c <= b and (q, c) != (p, b) for q, c in pts):
            continue
        front.append((p, b))
    return front


def sperr_bits(front, psnr):
    """log(bits) interpolated linearly in PSNR; None outside the front's PSNR span."""
    for (p0, b0), (p1, b1) in zip(front, front[1:]):
        if p0 <= psnr <= p1:
            f = (psnr - p0) / (p1 - p0) if p1 > p0 else 0.0
            return math.exp(math.log(b0) + f * (math.log(b1) - math.log(b0)))
    return None


def psnr_bench_args(doc):
    """The arguments of the equal-PSNR benchmarks: path to volcl, the PSNR targets, an optional CSV."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("volcl")
    ap.add_argument("--psnr", type=float, nargs="+", default=[40.0, 50.0, 60.0])
    ap.add_argument("--csv")
    return ap.parse_args()


def main():
    a = psnr_bench_args(__doc__)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, path, voxels in inputs(tmp):
            curve = os.path.join(CURVES, name + ".json")
            if not os.path.exists(path) or not os.path.exists(curve):
                print(f"skipping {name}: {path if not os.path.exists(path) else curve} is absent", file=sys.stderr)
                continue
            with open(curve) as f:
                c = json.load(f)
            front = pareto(c["sperr"] + c["sperr_bpp"])
            for target in a.psnr:
                out = os.path.join(tmp, "out.vcz")
                run = subprocess.run([a.volcl, "encode", path, "-o", out, "--psnr", str(target)],
                                     capture_output=True, text=True)
                if run.returncode != 0:
                    sys.exit(f"{name} at {target} dB: {run.stderr.strip()}")
                psnr = float(re.search(r"PSNR ([0-9.]+|inf) dB", run.stderr).group(1))
                bits = 8.0 * os.path.getsize(out) / voxels
                peer = sperr_bits(front, psnr)
                rows.append((name, target, psnr, os.path.getsize(out), bits, peer, bits / peer if peer else None))
                print(f"{name:11s} {target:4.0f} dB: PSNR {psnr:6.2f}, {os.path.getsize(out):9d} B, "
                      f"{bits:.4f} bpv, SPERR {peer if peer else float('nan'):.4f} bpv, "
                      f"ratio {rows[-1][6] if peer else float('nan'):.3f}", flush=True)
    ratios = [r[6] for r in rows if r[6]]
    if ratios:
        gm = math.exp(sum(math.log(x) for x in ratios) / len(ratios))
        print(f"cells {len(ratios)}, above 1.0x SPERR: {sum(x > 1 for x in ratios)}, "
              f"geometric mean {gm:.3f}, worst {max(ratios):.3f}")
    if a.csv:
        with open(a.csv, "w") as f:
            f.write("volume,target_db,psnr_db,bytes,bits_per_voxel,sperr_bits_per_voxel,ratio\n")
            for r in rows:
                f.write(",".join("" if v is None else str(v) for v in r) + "\n")


if __name__ == "__main__":
    main()
