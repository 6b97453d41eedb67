#!/usr/bin/env python3
"""Cost of N channels against a plain scalar frame (docs/channels.md, "Cost").

BrainWeb's T1 (180x216x180 uint8, ../shared/data) as 1 to 4 channels of one NRRD (a leading `vector` axis),
rendered by `volcl render` through the channel renderer, against the same volume as a scalar scene through the
grid renderer (its default frame: packets, empty-space skipping, early termination). Every configuration runs
once per round, rounds interleaved; the figure is the median kernel time over the rounds, with its ratio to the
scalar frame of the same run. Run pinned at normal priority: taskset -c 0 python3 bench/channels_cost.py.
Usage: channels_cost.py [VOLCL] [ROUNDS]
"""
import gzip
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VOLCL = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build", "volcl")
ROUNDS = int(sys.argv[2]) if len(sys.argv) > 2 else 5
DATA = os.path.join(ROOT, "..", "shared", "data", "regular",
                    "t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz")
DIMS = (180, 216, 180)
COLOURS = [[1.0, 0.4, 0.2], [0.2, 1.0, 0.4], [0.3, 0.5, 1.0], [1.0, 1.0, 0.3]]


def write_nrrd(path, voxels, channels):
    """`channels` copies of the uint8 voxels, interleaved under a leading vector axis (plain 3D for one)."""
    if channels == 1:
        header = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: %d %d %d\nencoding: raw\n\n" % DIMS
        payload = voxels
    else:
        header = ("NRRD0004\ntype: uchar\ndimension: 4\nsizes: %d %d %d %d\nkinds: vector domain domain domain\n"
                  "encoding: raw\n\n" % ((channels,) + DIMS))
        out = bytearray(len(voxels) * channels)
        for c in range(channels):
            out[c::channels] = voxels
        payload = bytes(out)
    with open(path, "wb") as f:
        f.write(header.encode())
        f.write(payload)


def kernel_ms(scene, out):
    r = subprocess.run([VOLCL, "render", "--scene", scene, "-o", out], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("volcl render failed: " + r.stderr.strip())
    m = re.search(r"([0-9.]+) ms kernel", r.stderr)
    if not m:
        sys.exit("no kernel time in: " + r.stderr.strip())
    return float(m.group(1))


def main():
    if not os.path.exists(DATA):
        sys.exit("BrainWeb T1 not found at ../shared/data: nothing to measure")
    voxels = gzip.open(DATA).read()
    with tempfile.TemporaryDirectory() as work:
        scenes = {}
        for k in range(1, 5):
            write_nrrd(os.path.join(work, "t1_%d.nrrd" % k), voxels, k)
        for c in range(4):
            with open(os.path.join(work, "tf%d.json" % c), "w") as f:
                json.dump({"color": [[0] + COLOURS[c], [255] + COLOURS[c]],
                           "extinction": [[0, 0.0], [60, 0.0], [120, 0.05], [255, 0.2]]}, f)
        image = {"width": 512, "height": 512}
        scalar = {"volume": os.path.join(work, "t1_1.nrrd"), "tf": os.path.join(work, "tf0.json"), "image": image}
        scenes["scalar frame (grid renderer)"] = scalar
        for k in range(1, 5):
            scenes["%d channel%s (channel renderer)" % (k, "s" if k > 1 else "")] = {
                "volume": os.path.join(work, "t1_%d.nrrd" % k),
                "channels": [{"tf": os.path.join(work, "tf%d.json" % c)} for c in range(k)],
                "image": image}
        paths = {}
        for name, scene in scenes.items():
            paths[name] = os.path.join(work, re.sub(r"[^a-z0-9]+", "_", name) + ".json")
            with open(paths[name], "w") as f:
                json.dump(scene, f)
        times = {name: [] for name in scenes}
        out = os.path.join(work, "out.exr")
        for _ in range(ROUNDS):
            for name in scenes:
                times[name].append(kernel_ms(paths[name], out))
        load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
        base = statistics.median(times["scalar frame (grid renderer)"])
        print("BrainWeb T1 180x216x180 uint8, 512x512, step 0.5 vox, %d interleaved rounds; load: %s" % (ROUNDS, load))
        print("%-34s %12s %10s" % ("configuration", "median ms", "vs scalar"))
        for name in scenes:
            med = statistics.median(times[name])
            print("%-34s %12.1f %9.2fx" % (name, med, med / base))


if __name__ == "__main__":
    main()
