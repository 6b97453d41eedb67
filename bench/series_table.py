#!/usr/bin/python3
"""Markdown table of a `volcl bench series` JSON with bench/sz3_series.py's SZ3-4D rows beside it, and
optionally the MC/intra ratio of an earlier bench JSON (the same series and rates) as a "before" column.
"MC/intra at equal PSNR" divides MC's bits by intra-only's bits at MC's lowest frame PSNR, interpolated
(log of bits linear in dB) between the series' intra-only psnrP rows.

Usage: /usr/bin/python3 bench/series_table.py series-bench.json series-sz3.json [before.json] > table.md
"""
import json
import math
import sys


def num(v, digits):
    return "inf" if v == "inf" else f"{v:.{digits}f}"


def intra_at(rows, series, db):
    """Intra-only bits/voxel at `db` dB: log-linear between (or beyond) the two nearest psnrP rows."""
    pts = sorted((r["min_frame_psnr_db"], r["bits_per_voxel"]) for r in rows
                 if r["series"] == series and r["mode"] == "intra" and r["rate"].startswith("psnr"))
    if len(pts) < 2 or db == "inf":
        return None
    k = min(range(len(pts) - 1), key=lambda i: abs((pts[i][0] + pts[i + 1][0]) / 2 - db))
    (p0, b0), (p1, b1) = pts[k], pts[k + 1]
    return math.exp(math.log(b0) + (db - p0) * (math.log(b1) - math.log(b0)) / (p1 - p0))


def main(bench, sz3, before=None):
    rows = json.load(open(bench))["rows"]
    sz = {(r["series"], r["rate"]): r for r in json.load(open(sz3))["rows"]}
    old = {}
    if before:
        b = json.load(open(before))["rows"]
        bpv = {(r["series"], r["rate"], r["mode"]): r["bits_per_voxel"] for r in b}
        old = {(s, rate): bpv[(s, rate, "mc")] / bpv[(s, rate, "intra")]
               for (s, rate, m) in bpv if m == "mc" and (s, rate, "intra") in bpv}
    by = {(r["series"], r["rate"], r["mode"]): r for r in rows}
    head = ["series", "rate", "intra bits/voxel", "MC bits/voxel", "MC/intra", "MC/intra at equal PSNR"]
    if before:
        head.append("MC/intra before")
    head += ["SZ3-4D bits/voxel", "MC/SZ3-4D", "lowest frame PSNR intra / MC / SZ3-4D dB", "P frames",
             "frame decode ms intra / MC", "playback fps intra / MC"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for (s, rate, mode), mc in by.items():
        if mode != "mc":
            continue
        intra = by[(s, rate, "intra")]
        z = sz.get((s, rate))
        cells = [s, rate, num(intra["bits_per_voxel"], 4), num(mc["bits_per_voxel"], 4),
                 f"{mc['bits_per_voxel'] / intra['bits_per_voxel']:.3f}"]
        eq = intra_at(rows, s, mc["min_frame_psnr_db"]) if rate.startswith("psnr") else None
        cells.append(f"{mc['bits_per_voxel'] / eq:.3f}" if eq else "-")
        if before:
            cells.append(f"{old[(s, rate)]:.3f}" if (s, rate) in old else "-")
        cells += [num(z["bits_per_voxel"], 4) if z else "-",
                  f"{mc['bits_per_voxel'] / z['bits_per_voxel']:.3f}" if z else "-",
                  " / ".join([num(intra["min_frame_psnr_db"], 2), num(mc["min_frame_psnr_db"], 2),
                              num(z["min_frame_psnr_db"], 2) if z else "-"]),
                  str(mc["p_frames"]),
                  f"{intra['frame_decode_ms']:.1f} / {mc['frame_decode_ms']:.1f}",
                  f"{intra['playback_fps']:.1f} / {mc['playback_fps']:.1f}"]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(*sys.argv[1:4])
