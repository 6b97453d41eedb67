"""Sizes of the relative bounds against SZ3 (pysz) and of the two ways to code the point-wise bound.

Usage: python bench/relative_bounds_peers.py VOLCL DATA_DIR WORK_DIR   (numpy and pysz installed)
Prints, for Isabel step 30 and viscous fingering step 10: `--pw-rel-error R` as built (correction list), the
log route estimated (ln|x| coded with `--max-error ln(1 + R)` plus an xz-compressed zero map; zeros filled
with the smallest logarithm), SZ3's ABS mode on the same logarithms plus the zero map, and `--rel-error R`
against SZ3's REL mode (with the largest error SZ3 left, relative to the range).
"""
import lzma
import os
import subprocess
import sys

import numpy as np
import pysz

VOLUMES = {"isabel-30": "timevarying/isabel/isabel_30.vti",
           "viscous-010": "timevarying/viscousfingers/010_density_010_064_2.0.vti"}


def sz3(a, mode, bound):
    c = pysz.szConfig()
    c.errorBoundMode = getattr(pysz.szErrorBoundMode, mode)
    if mode == "REL":
        c.relErrorBound = bound
    else:
        c.absErrorBound = bound
    comp, _ = pysz.sz.compress(np.ascontiguousarray(a), c)
    out, _ = pysz.sz.decompress(comp, a.dtype, a.shape)
    return comp.nbytes, out


def volcl_bytes(volcl, src, out, *flags):
    subprocess.run([volcl, "encode", src, "-o", out, "--no-lod-stats", *flags], check=True, capture_output=True)
    return os.path.getsize(out)


def main():
    volcl, data, work = sys.argv[1:4]
    os.makedirs(work, exist_ok=True)
    for name, rel in VOLUMES.items():
        npy = os.path.join(work, name + ".npy")
        subprocess.run([volcl, "convert", os.path.join(data, rel), "-o", npy], check=True, capture_output=True)
        a = np.load(npy)
        nz = a != 0
        lg = np.zeros(a.shape, np.float64)
        np.log(np.abs(a), where=nz, out=lg)
        lg[~nz] = lg[nz].min()
        lg = lg.astype(np.float32)
        log_npy = os.path.join(work, name + "_log.npy")
        np.save(log_npy, lg)
        zero_map = len(lzma.compress(np.packbits(nz).tobytes(), preset=9))
        vcz = os.path.join(work, "out.vcz")
        for r in (1e-2, 1e-3):
            e = np.log1p(r) * 0.999
            built = volcl_bytes(volcl, npy, vcz, "--pw-rel-error", str(r))
            log_route = volcl_bytes(volcl, log_npy, vcz, "--max-error", str(e)) + zero_map
            sz_log = sz3(lg, "ABS", float(e))[0] + zero_map
            print(f"{name} voxels {a.size} pw-rel {r}: correction list {built} B, log route {log_route} B "
                  f"(zero map {zero_map} B), SZ3 ABS on ln|x| + zero map {sz_log} B")
        for r in (1e-3, 1e-4):
            ours = volcl_bytes(volcl, npy, vcz, "--rel-error", str(r))
            sz_bytes, out = sz3(a, "REL", r)
            worst = np.abs(out.astype(np.float64) - a).max() / (float(a.max()) - float(a.min()))
            print(f"{name} rel {r}: volcl {ours} B, SZ3 REL {sz_bytes} B (SZ3 max error / range {worst:.6g})")


if __name__ == "__main__":
    main()
