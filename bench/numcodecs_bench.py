#!/usr/bin/env python3
"""Benchmarks volcl's numcodecs codec against numcodecs' Blosc and zfp on real volumes cut into zarr chunks.

For each volume every codec encodes and decodes every chunk (what zarr does per chunk); the rounds are
interleaved (each round runs every codec once, in a rotated order) and the table shows medians. Ratio and
MB/s count the volume's own bytes. zfp has no 8/16-bit integer mode: integer volumes reach it as float32
(its ratio still counts the original bytes). Lossy rows bound the error by E = 1e-3 of the value range (at least 1 on integer volumes).
Usage: build/venv/bin/python bench/numcodecs_bench.py [--rounds N] [--chunk C] [--csv out.csv]
"""
from __future__ import annotations

import argparse
import importlib.metadata
import gzip
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import numcodecs
import zfpy
from numcodecs import Blosc
from numcodecs.compat import ensure_ndarray
from numcodecs.zfpy import ZFPY

import volcl
import volcl.numcodecs

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def volumes():
    """(name, array) of the real volumes present."""
    mri = DATA / "regular" / "t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz"
    if mri.exists():
        raw = gzip.decompress(mri.read_bytes())
        yield "BrainWeb T1 MRI 180x216x180 uint8", np.frombuffer(raw, np.uint8).reshape(180, 216, 180)
    walnut = DATA / "regular" / "walnut.vvd"
    if walnut.exists():
        yield "walnut CT 128x96x114 uint16", volcl.read(walnut).array
    fingers = DATA / "timevarying" / "viscousfingers" / "020_density_020_064_2.0.vti"
    if fingers.exists():
        yield "viscous fingers 64^3 float32", volcl.read(fingers).array
    isabel = DATA / "timevarying" / "isabel" / "isabel_30.vti"
    if isabel.exists():
        yield "Isabel wind 125x125x25 float32", volcl.read(isabel).array


def chunks(a, c):
    return [np.ascontiguousarray(a[z:z + c, y:y + c, x:x + c]) for z in range(0, a.shape[0], c)
            for y in range(0, a.shape[1], c) for x in range(0, a.shape[2], c)]


def codecs_for(a):
    """(label, codec, feed) per codec; feed converts a chunk to what the codec takes."""
    e = 1e-3 * float(a.max() - a.min())
    if np.issubdtype(a.dtype, np.integer):
        e = max(e, 1.0)  # below 1 an integer bound is lossless
    same = lambda c: c  # noqa: E731
    as_f32 = lambda c: c.astype(np.float32)  # noqa: E731
    zfp_feed = same if a.dtype == np.float32 else as_f32
    return e, [
        ("volcl lossless (dense)", volcl.numcodecs.Volcl(), same),
        ("volcl lossless (fast)", volcl.numcodecs.Volcl(entropy="fast"), same),
        ("Blosc zstd-5 bitshuffle", Blosc("zstd", 5, Blosc.BITSHUFFLE), same),
        ("Blosc lz4-5 shuffle", Blosc("lz4", 5, Blosc.SHUFFLE), same),
        (f"volcl max_error E", volcl.numcodecs.Volcl(max_error=e), same),
        (f"zfp fixed accuracy E", ZFPY(mode=zfpy.mode_fixed_accuracy, tolerance=e), zfp_feed),
    ]


def run(codec, feed, parts):
    fed = [feed(p) for p in parts]
    t0 = time.perf_counter()
    enc = [codec.encode(p) for p in fed]
    t1 = time.perf_counter()
    dec = [ensure_ndarray(codec.decode(b)).view(p.dtype).reshape(p.shape) for b, p in zip(enc, fed)]
    t2 = time.perf_counter()
    size = sum(len(b) for b in enc)
    err = max(float(np.abs(d.astype(np.float64) - p.astype(np.float64)).max()) for d, p in zip(dec, parts))
    return t1 - t0, t2 - t1, size, err


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--chunk", type=int, default=64)
    ap.add_argument("--csv", default="")
    args = ap.parse_args()
    print(f"# volcl {volcl.__version__}, numcodecs {numcodecs.__version__}, zfpy {importlib.metadata.version('zfpy')}, "
          f"device {volcl.devices()[0]['name']}, load {os.getloadavg()[0]:.1f} (1-min)", flush=True)
    print(f"# chunks {args.chunk}^3, medians of {args.rounds} interleaved rounds", flush=True)
    rows = []
    for name, a in volumes():
        parts = chunks(a, args.chunk)
        e, cs = codecs_for(a)
        times = {label: ([], []) for label, _, _ in cs}
        sizes, errs = {}, {}
        for r in range(args.rounds):
            order = cs[r % len(cs):] + cs[:r % len(cs)]
            for label, codec, feed in order:
                te, td, size, err = run(codec, feed, parts)
                times[label][0].append(te)
                times[label][1].append(td)
                sizes[label], errs[label] = size, err
        mb = a.nbytes / 1e6
        print(f"\n## {name} ({mb:.1f} MB, E = {e:.4g})")
        print("| codec | ratio | encode MB/s | decode MB/s | max error |")
        print("|---|---:|---:|---:|---:|")
        for label, _, _ in cs:
            enc_s, dec_s = statistics.median(times[label][0]), statistics.median(times[label][1])
            row = (name, label.replace(" E", f" {e:.4g}"), a.nbytes / sizes[label], mb / enc_s, mb / dec_s,
                   errs[label])
            rows.append(row)
            print(f"| {row[1]} | {row[2]:.2f} | {row[3]:.1f} | {row[4]:.1f} | {row[5]:.4g} |", flush=True)
    print(f"\n# load after: {os.getloadavg()[0]:.1f} (1-min)")
    if args.csv:
        with open(args.csv, "w") as f:
            f.write("volume,codec,ratio,encode_MBps,decode_MBps,max_error\n")
            for r in rows:
                f.write(f"{r[0]},{r[1]},{r[2]:.4f},{r[3]:.2f},{r[4]:.2f},{r[5]:.6g}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
