# Checks of the pvbatch reader test (run with /usr/bin/python3: numpy and matplotlib):
#   check_render.py bricks REPORT.json N0,N1,...   each rank decoded exactly N_r bricks, over disjoint z slabs
#                                                  that tile the volume
#   check_render.py images A.png B.png             B equals A within the compositing tolerance below
#   check_render.py frames REPORT.json T0,T1,.. F L   the reader gave those time steps, and every rank
#                                                     decoded frame F at level L
import json
import sys

import numpy as np
from matplotlib import image

# Sort-last compositing: each rank ray-casts its own slab, so samples start at the slab's boundary instead of
# continuing from the slab before, and the ranks' images are blended afterwards. Colours then move by a few
# levels in scattered pixels, and by more only on single pixels along silhouettes and the slab boundary
# (measured on the field of pvbatch_render.sh: mean 0.18/255, 1.2 % of pixels above 4/255, max 34/255).
# A missing or misplaced slab moves the mean by tens of levels.
MAX_FRACTION_ABOVE, LEVEL, MAX_ANY, MAX_MEAN = 0.03, 4 / 255, 64 / 255, 0.5 / 255


def bricks(report_path, expected):
    report = json.load(open(report_path))
    pieces = report["pieces"]
    want = [int(n) for n in expected.split(",")]
    got = [int(p["bricks"]) for p in pieces]
    print("%s: ranks %d, bricks per rank %s (expected %s), z slabs %s" %
          (report_path, report["ranks"], got, want, [p["z"] for p in pieces]))
    if report["ranks"] != len(want) or got != want:
        sys.exit("%s: bricks per rank %s, expected %s" % (report_path, got, want))
    z = [p["z"] for p in pieces]
    if z[0][0] != 0 or any(a[1] != b[0] for a, b in zip(z, z[1:])):
        sys.exit("%s: the z slabs %s do not tile the volume" % (report_path, z))


def difference(a_path, b_path):
    a = image.imread(a_path)[..., :3].astype(np.float64)
    b = image.imread(b_path)[..., :3].astype(np.float64)
    if a.shape != b.shape:
        sys.exit("%s and %s differ in size" % (a_path, b_path))
    d = np.abs(a - b)
    return a, d, float(np.mean(np.max(d, axis=2) > LEVEL))


def frames(report_path, steps, frame, level):
    report = json.load(open(report_path))
    want = [float(t) for t in steps.split(",")]
    got = [(p["frame"], p["level"]) for p in report["pieces"]]
    print("%s: time steps %s, (frame, level) per rank %s" % (report_path, report["time_steps"], got))
    if report["time_steps"] != want or any(g != (int(frame), int(level)) for g in got):
        sys.exit("%s: time steps %s, (frame, level) per rank %s; expected %s, frame %s, level %s" %
                 (report_path, report["time_steps"], got, want, frame, level))


def images(a_path, b_path):
    a, d, above = difference(a_path, b_path)
    lit = float(np.mean(np.max(a, axis=2) > 8 / 255))
    print("%s vs %s: max %.1f/255, mean %.3f/255, %.3f %% of pixels above %.0f/255 (%.0f %% of pixels lit)" %
          (b_path, a_path, 255 * d.max(), 255 * d.mean(), 100 * above, 255 * LEVEL, 100 * lit))
    if lit < 0.05:
        sys.exit("%s: the render is nearly empty (%.1f %% lit)" % (a_path, 100 * lit))
    if above > MAX_FRACTION_ABOVE or d.max() > MAX_ANY or d.mean() > MAX_MEAN:
        sys.exit("%s differs from %s beyond the compositing tolerance" % (b_path, a_path))


if __name__ == "__main__":
    {"bricks": bricks, "images": images, "frames": frames}[sys.argv[1]](*sys.argv[2:])
