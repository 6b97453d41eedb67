#!/usr/bin/env python3
"""A volume larger than the memory limit, end to end: a raw uint8 volume of FACTOR x LIMIT bytes is encoded
(streamed), listed by `info`, rendered with `render --lod auto` and drawn by `view --headless --lod auto`,
each command's peak resident set (getrusage of the finished child, os.wait4) asserted under LIMIT.

The limit is measured, not imposed: RLIMIT_AS counts PoCL's address-space reservations, not memory used.
With --over-baseline the limit applies to what each command holds above the same command on a 64^3
volume (the process with the OpenCL platform, its compiler and Mesa loaded: about 215 MiB for render,
250 MiB for view), so a short form can use a small volume.

Usage: out_of_core.py VOLCL WORK_DIR [--limit-mb 320] [--factor 4] [--cache-mb 64] [--over-baseline]
                      [--log FILE]
Exit 0 when every command succeeds within the limit; 77 (skipped) when the disk cannot hold the volume.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time


def write_volume(path, n):
    """A ball of radially falling density with a small voxel pattern, n^3 uint8, written slice by slice:
    each slice translates one template of squared in-plane radii through a per-slice table, at C speed."""
    c = (n - 1) / 2.0
    radius = 0.45 * n
    scale = 65535.0 / (2 * c * c)  # squared radius in the plane -> 16 bits
    template = bytearray(2 * n * n)
    for y in range(n):
        dy2 = (y - c) ** 2
        row = bytearray(2 * n)
        for x in range(n):
            q = min(65535, int(((x - c) ** 2 + dy2) * scale))
            row[2 * x] = q >> 8
            row[2 * x + 1] = (x * 7 + y * 13) % 5  # a little texture so bricks are not constant
        template[2 * y * n:2 * (y + 1) * n] = row
    high = bytes(template[0::2])
    low = bytes(template[1::2])
    with open(path, "wb") as f:
        for z in range(n):
            dz2 = (z - c) ** 2
            table = bytearray(256)
            for h in range(256):
                r = math.sqrt((h + 0.5) * 256 / scale + dz2)
                table[h] = max(0, min(250, int(250 * (1 - r / radius)))) if r < radius else 0
            sl = high.translate(bytes(table))
            if z % 2 == 0:  # the texture on alternate slices, added where the ball is
                sl = _add_texture(sl, low)
            f.write(sl)


def _add_texture(sl, low):
    # 0..4 added inside the ball (values <= 250: no carry between bytes), whole slices as one integer
    a = int.from_bytes(sl, "little")
    mask_bytes = sl.translate(bytes([0] + [0xFF] * 255))
    t = int.from_bytes(low, "little") & int.from_bytes(mask_bytes, "little")
    return (a + t).to_bytes(len(sl), "little")


def run(cmd):
    """Runs cmd; returns (exit code, its rusage, wall seconds, stdout, stderr)."""
    t0 = time.monotonic()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        p = subprocess.Popen(cmd, stdout=out, stderr=err)
        _, status, usage = os.wait4(p.pid, 0)  # this child's own peak RSS
        wall = time.monotonic() - t0
        out.seek(0)
        err.seek(0)
        return (os.waitstatus_to_exitcode(status), usage, wall, out.read().decode(errors="replace"),
                err.read().decode(errors="replace"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("volcl")
    ap.add_argument("work")
    ap.add_argument("--limit-mb", type=int, default=320)
    ap.add_argument("--over-baseline", action="store_true")
    ap.add_argument("--factor", type=int, default=4)
    ap.add_argument("--cache-mb", type=int, default=64)
    ap.add_argument("--size", type=int, default=512, help="image width and height")
    ap.add_argument("--log")
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    n = round((a.factor * a.limit_mb * 2**20) ** (1 / 3))
    volume_bytes = n ** 3
    if shutil.disk_usage(a.work).free < volume_bytes * 1.2:
        print(f"skipped: {a.work} cannot hold a {volume_bytes >> 20} MiB volume")
        return 77
    raw = os.path.join(a.work, f"ball_{n}x{n}x{n}_uint8.raw")
    vcz = os.path.join(a.work, "ball.vcz")
    tf = os.path.join(a.work, "tf.json")
    with open(tf, "w") as f:
        json.dump({"domain": [0, 255], "color": [[0, 0.2, 0.4, 0.9], [128, 1, 0.6, 0.2], [255, 1, 1, 1]],
                   "extinction": [[0, 0], [20, 0], [120, 0.05], [255, 0.3]]}, f)
    lines = []

    def say(s):
        print(s, flush=True)
        lines.append(s)

    say(f"load: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}")
    t0 = time.monotonic()
    write_volume(raw, n)
    say(f"volume {n}x{n}x{n} uint8 = {volume_bytes / 2**20:.0f} MiB, limit {a.limit_mb} MiB "
        f"({volume_bytes / (a.limit_mb * 2**20):.2f}x), written in {time.monotonic() - t0:.1f} s")
    cam = ["--tf", tf, "--width", str(a.size), "--height", str(a.size), "--orbit", "30,25"]

    def steps(raw, vcz):
        return [
            ("encode", [a.volcl, "encode", "--stream", raw, "-o", vcz]),
            ("info", [a.volcl, "info", vcz]),
            ("render", [a.volcl, "render", "--volume", vcz, *cam, "--lod", "auto", "--cache-mb",
                        str(a.cache_mb), "--stats", "-o", os.path.join(a.work, "render.png")]),
            ("view", [a.volcl, "view", "--headless", vcz, *cam, "--lod", "auto", "--cache-mb", str(a.cache_mb),
                      "--frames", "3", "--spin", "10", "--stats", os.path.join(a.work, "view.csv"),
                      "-o", os.path.join(a.work, "view.png")]),
        ]

    baseline = {}
    if a.over_baseline:
        small = os.path.join(a.work, "small_64x64x64_uint8.raw")
        write_volume(small, 64)
        for name, cmd in steps(small, os.path.join(a.work, "small.vcz")):
            code, usage, _, _, err = run(cmd)
            if code != 0:
                say(f"baseline {name} failed: {err.strip()}")
                return 1
            baseline[name] = usage.ru_maxrss / 1024
        say("baseline peak RSS on 64^3 (MiB): " + ", ".join(f"{k} {v:.0f}" for k, v in baseline.items()))
        os.remove(small)
    failed = False
    for name, cmd in steps(raw, vcz):
        code, usage, wall, out, err = run(cmd)
        peak = usage.ru_maxrss / 1024
        held = peak - baseline.get(name, 0)
        ok = code == 0 and held < a.limit_mb
        failed |= not ok
        over = f", {held:.0f} MiB over the baseline" if a.over_baseline else ""
        say(f"{name}: exit {code}, peak RSS {peak:.0f} MiB{over} (limit {a.limit_mb}), wall {wall:.1f} s"
            f"{'' if ok else '  <-- FAILED'}")
        for line in (err + out).splitlines():
            if name != "info" or "bricks" in line or "dims" in line.lower():
                say("  " + line)
        if code != 0:
            break
    if os.path.exists(os.path.join(a.work, "view.csv")):
        with open(os.path.join(a.work, "view.csv")) as f:
            for line in f:
                say("  view.csv: " + line.rstrip())
    say(f"vcz {os.path.getsize(vcz) if os.path.exists(vcz) else 0} bytes")
    os.remove(raw)
    if a.log:
        with open(a.log, "w") as f:
            f.write("\n".join(lines) + "\n")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
