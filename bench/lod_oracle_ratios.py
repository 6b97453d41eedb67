#!/usr/bin/env python3
"""How lod auto's per-brick estimate compares with the measured error, from volcl-bench-lod-oracle's per-brick
CSVs: for each level, estimate / measured share of the image RMSE (sqrt of the brick's squared error over all
RGBA samples of the image), its quantiles and the rank correlation (Spearman) of the two; then what a bound in
image units built from the same statistics would choose (see docs/multires.md).
Usage: lod_oracle_ratios.py PROBES.csv [ESTIMATE.csv] --voxels-per-pixel V
PROBES.csv has the measurement (sse, rms_share); ESTIMATE.csv, when given, replaces its estimate column (an
estimate-only run of the tool, --probe-size 0, e.g. after the estimate changed)."""
import csv, math, sys

args = [a for a in sys.argv[1:] if not a.startswith("--")]
vpp = float(sys.argv[sys.argv.index("--voxels-per-pixel") + 1])
args = [a for a in args if a != str(vpp) and a != sys.argv[sys.argv.index("--voxels-per-pixel") + 1]]
rows = {(int(r["brick"]), int(r["level"])): r for r in csv.DictReader(open(args[0]))}
if len(args) > 1:
    for r in csv.DictReader(open(args[1])):
        k = (int(r["brick"]), int(r["level"]))
        if k in rows:
            rows[k]["estimate"] = r["estimate"]
pixels = 512 * 512


def ranks(v):
    order = sorted(range(len(v)), key=lambda i: v[i])
    r = [0] * len(v)
    for k, i in enumerate(order):
        r[i] = k
    return r


def spearman(a, b):
    ra, rb = ranks(a), ranks(b)
    n = len(a)
    ma, mb = sum(ra) / n, sum(rb) / n
    c = sum((x - ma) * (y - mb) for x, y in zip(ra, rb))
    return c / math.sqrt(sum((x - ma) ** 2 for x in ra) * sum((y - mb) ** 2 for y in rb))


def q(v, p):
    return v[int(p * (len(v) - 1))]


print(f"{args[0]}" + (f" with estimates of {args[1]}" if len(args) > 1 else ""))
for level in (1, 2, 3):
    r = [x for k, x in rows.items() if k[1] == level and float(x["estimate"]) > 0 and float(x["rms_share"]) > 0]
    ratio = sorted(float(x["estimate"]) / float(x["rms_share"]) for x in r)
    rho = spearman([float(x["estimate"]) for x in r], [float(x["rms_share"]) for x in r])
    zero = sum(1 for k, x in rows.items() if k[1] == level and float(x["rms_share"]) == 0 and float(x["estimate"]) > 0)
    missed = [float(x["rms_share"]) for k, x in rows.items()
              if k[1] == level and float(x["rms_share"]) > 0 and float(x["estimate"]) == 0]
    print(f"level {level}: {len(r)} bricks, estimate / measured share min {ratio[0]:.3g}, p10 {q(ratio, .1):.3g}, "
          f"median {q(ratio, .5):.3g}, p90 {q(ratio, .9):.3g}; Spearman {rho:.2f}; "
          f"{zero} bricks change no pixel but have an estimate > 0; {len(missed)} change pixels but are estimated "
          f"at 0 (largest share {max(missed, default=0):.2e})")

# A bound in image units from the same statistics: the per-segment change E x S accumulated as a random walk
# over the level-l cells along the brick's longest chord (sqrt(chord x 2^l) voxel lengths), times the square
# root of the brick's share of the image's pixels; levels chosen greedily (most voxels saved per squared bound
# added) until the bounds, added in quadrature, reach the target.
bricks = sorted({k[0] for k in rows})
chord = math.sqrt(3) * 32


def bound(b, level):
    if level == 0:
        return 0.0
    x = rows[(b, level)]
    es = float(x["estimate"]) / ((2 ** level) / vpp)  # E x S: the estimate without its cell-pixel factor
    return es * math.sqrt(chord * 2 ** level) * math.sqrt(float(x["pixels"]) / pixels)


ratio = sorted(bound(b, l) / float(rows[(b, l)]["rms_share"]) for b in bricks for l in (1, 2, 3)
               if float(rows[(b, l)]["rms_share"]) > 0)
print(f"image-unit bound / measured share: min {ratio[0]:.3g}, p1 {q(ratio, .01):.3g}, median {q(ratio, .5):.3g}")
vox = {(b, l): float(rows[(b, l)]["voxels"]) for b in bricks for l in (1, 2, 3)}
for b in bricks:
    vox[(b, 0)] = 8 * vox[(b, 1)]
for target in (1e-3, 2e-3, 4e-3, 8e-3):
    level = {b: 0 for b in bricks}
    total = 0.0
    while True:
        best = None
        for b in bricks:
            for l in range(level[b] + 1, 4):
                add = bound(b, l) ** 2 - bound(b, level[b]) ** 2
                if total + add > target ** 2:
                    continue
                gain = (vox[(b, level[b])] - vox[(b, l)]) / (max(add, 0.0) + 1e-30)
                if best is None or gain > best[0]:
                    best = (gain, b, l, add)
        if best is None:
            break
        total += best[3]
        level[best[1]] = best[2]
    fewer = sum(vox[(b, 0)] for b in bricks) / sum(vox[(b, level[b])] for b in bricks)
    measured = math.sqrt(sum(float(rows[(b, level[b])]["rms_share"]) ** 2 for b in bricks if level[b] > 0))
    print(f"bound budget {target:g}: {fewer:.2f}x fewer voxels, measured shares added in quadrature {measured:.2e}")
