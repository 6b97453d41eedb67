#!/usr/bin/env python3
"""SZ3 in 4D (PyPI pysz) on the series `volcl bench series --export DIR` wrote, at the rates of a series bench.

Each series is one 4D float32 array (frame, z, y, x) compressed by SZ3 whole, with its default predictor
(interpolation + Lorenzo). Rates:
- psnrP: SZ3's absolute error bound is searched (bisection on its logarithm) for the largest bound whose
  lowest frame PSNR reaches the lowest frame PSNR volcl's motion-compensated coding reached on that row
  ("equal PSNR"), and separately reaches P - 0.5 dB (the floor volcl's --psnr P guarantees). PSNR is per
  frame over the frame's own value range, as volcl measures it.
- maxerrX%: the absolute bound X % of the series' value range, as volcl's row.
Bits/voxel count SZ3's compressed bytes over every voxel of every frame.

Usage: build/sz3-venv/bin/python bench/sz3_series.py EXPORT_DIR SERIES_BENCH.json OUT.json
(make the venv with: bash scripts/sz3-venv.sh)
"""
import importlib.metadata
import json
import math
import os
import sys
import time

import numpy as np
from pysz import sz, szConfig, szErrorBoundMode


def frame_psnrs(orig, rec):
    out = []
    for f, g in zip(orig, rec):
        e = float(np.sqrt(np.mean((f.astype(np.float64) - g.astype(np.float64)) ** 2)))
        r = float(f.max()) - float(f.min())
        out.append(math.inf if e == 0 else 20 * math.log10(r / e))
    return out


def run(a, eb):
    conf = szConfig()
    conf.errorBoundMode = szErrorBoundMode.ABS
    conf.absErrorBound = eb
    t0 = time.perf_counter()
    comp, _ = sz.compress(a, conf)
    t1 = time.perf_counter()
    rec, _ = sz.decompress(comp, np.float32, a.shape)
    t2 = time.perf_counter()
    p = frame_psnrs(a, rec)
    return {"error_bound": eb, "bytes": int(comp.size), "bits_per_voxel": 8.0 * comp.size / a.size,
            "min_frame_psnr_db": min(p), "frame_psnr_db": p,
            "max_error": float(np.max(np.abs(rec.astype(np.float64) - a))),
            "encode_ms": (t1 - t0) * 1e3, "decode_ms": (t2 - t1) * 1e3}


def search(a, target, tol=0.05):
    """The largest absolute bound whose lowest frame PSNR is >= target (within `tol` dB above it)."""
    span = float(a.max() - a.min())
    lo, hi = math.log(span * 1e-9), math.log(span)  # log bounds: lo meets the target, hi does not
    best = None
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        r = run(a, math.exp(mid))
        if r["min_frame_psnr_db"] >= target:
            lo, best = mid, r
            if r["min_frame_psnr_db"] <= target + tol:
                break
        else:
            hi = mid
        if hi - lo < 1e-4:
            break
    return best if best else run(a, math.exp(lo))


def main(export_dir, bench_json, out_json):
    rows = json.load(open(bench_json))["rows"]
    out = []
    for meta_name in sorted(f for f in os.listdir(export_dir) if f.endswith(".json")):
        meta = json.load(open(os.path.join(export_dir, meta_name)))
        nx, ny, nz = meta["dims"]
        a = np.fromfile(os.path.join(export_dir, meta["series"] + ".f32"), np.float32)
        a = a.reshape(meta["frames"], nz, ny, nx)
        mine = [r for r in rows if r["series"] == meta["series"] and r["mode"] == "mc"]
        for r in mine:
            rate = r["rate"]
            row = {"series": meta["series"], "rate": rate, "mode": "sz3-4d"}
            if rate.startswith("psnr"):
                mc_min = r["min_frame_psnr_db"]
                equal = search(a, float(mc_min))
                floor = search(a, float(rate[4:]) - 0.5)
                row.update(equal)
                row["target_min_frame_psnr_db"] = mc_min
                row["at_floor"] = {k: floor[k] for k in ("error_bound", "bytes", "bits_per_voxel",
                                                           "min_frame_psnr_db")}
            elif rate.startswith("maxerr"):
                span = float(a.max() - a.min())
                row.update(run(a, float(rate[6:-1]) / 100 * span))
            else:
                continue  # SZ3 is not lossless
            print(f"{meta['series']:>14} {rate:>9}: SZ3-4D {row['bits_per_voxel']:.4f} bpv "
                  f"(min frame PSNR {row['min_frame_psnr_db']:.2f}), volcl MC {r['bits_per_voxel']:.4f} "
                  f"(min {r['min_frame_psnr_db']})", file=sys.stderr, flush=True)
            out.append(row)
    json.dump({"pysz": importlib.metadata.version("pysz"), "load": os.getloadavg()[0], "rows": out},
              open(out_json, "w"), indent=1)


if __name__ == "__main__":
    main(*sys.argv[1:4])
