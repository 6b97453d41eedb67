#!/usr/bin/env bash
# Shaded frames from a .vcz's bricks: the gradient cache (trilinear and nearest node) against on-the-fly central
# differences, with the unshaded frame as the peer, on the BrainWeb MRI encoded as bricks_bench.sh encodes it
# (lossless, 32^3 bricks, 3 levels), bench/render/mri_shaded_scene.json at SIZE^2 (default 512), lod full.
# One cold process per run on one core (taskset -c 0, normal priority), configurations interleaved; the CSV
# holds every run (kernel ms, gradient-cache build ms from --stats, load), the summary prints medians, the
# ratios against central differences and against the plain frame, the load, and the cached frames' RMSE against
# the central-difference frame.
# Usage: bench/bricks_shading_bench.sh BUILD_DIR OUT.csv [REPEATS] [SIZE]
set -euo pipefail
build=$1; out=$2; reps=${3:-3}; size=${4:-512}
here=$(cd "$(dirname "$0")" && pwd)
data="$here/../../shared/data/regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$build/volcl" --quiet encode "$data" --brick 32 --levels 3 -o "$tmp/mri.vcz"
configs=("plain --no-shading" "cache --gradient cache" "cache-nearest --gradient cache-nearest"
  "central --gradient central")
echo "config,run,kernel_ms,gradient_build_ms,gradient_bricks,load,size" >"$out"
for r in $(seq 1 "$reps"); do
  for c in "${configs[@]}"; do
    set -- $c
    name=$1
    shift
    err=$(taskset -c 0 "$build/volcl" render --scene "$here/render/mri_shaded_scene.json" --volume "$tmp/mri.vcz" \
      --width "$size" --height "$size" --lod full --stats "$@" -o "$tmp/$name.exr" 2>&1)
    kernel=$(grep -o '[0-9.]* ms kernel' <<<"$err" | cut -d' ' -f1)
    build_ms=$( (grep -o 'gradient cache built for [0-9]* bricks in [0-9.]* ms' <<<"$err" || true) | head -1 |
      awk '{print $8}')
    bricks=$( (grep -o 'gradient cache built for [0-9]* bricks' <<<"$err" || true) | head -1 | awk '{print $5}')
    load=$(cut -d' ' -f1 /proc/loadavg)
    echo "$name,$r,$kernel,${build_ms:-0},${bricks:-0},$load,$size" >>"$out"
  done
done
python3 - "$out" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
med = {}
for name in dict.fromkeys(r["config"] for r in rows):
    med[name] = statistics.median(float(r["kernel_ms"]) for r in rows if r["config"] == name)
loads = [float(r["load"]) for r in rows]
for name, ms in med.items():
    build = statistics.median(float(r["gradient_build_ms"]) for r in rows if r["config"] == name)
    print(f"{name}: {ms:.1f} ms kernel (median of {sum(r['config'] == name for r in rows)}), "
          f"{ms / med['plain']:.2f}x plain, {ms / med['central']:.3f}x central"
          + (f", cache built in {build:.1f} ms" if build > 0 else ""))
print(f"load average during the runs: {min(loads):.1f}-{max(loads):.1f}")
PY
# The cached frames' error against the central-difference frame of the same step (last run of each).
for name in cache cache-nearest; do
  rms=$(idiff -a "$tmp/central.exr" "$tmp/$name.exr" 2>&1 | grep -m1 'RMS error' | awk '{print $NF}')
  echo "$name: RMSE against the central-difference frame $rms"
done
