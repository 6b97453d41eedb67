#!/usr/bin/env bash
# Brick rendering from a .vcz: frame time, decode time and decoded voxels for lod full/auto at several
# lod_error values and cache budgets, on a BrainWeb MRI scene at 512^2 (bench/render/SCENE_scene.json, default
# mri; camera height VIEW_HEIGHT world units, default 900: zoomed out 3x), one cold process per run,
# configurations interleaved. CONFIGS (environment) replaces the list of "lod lod_error cache_mb" runs.
# Usage: bench/bricks_bench.sh BUILD_DIR OUT.csv [REPEATS] [SCENE] [VIEW_HEIGHT]
set -euo pipefail
build=$1; out=$2; reps=${3:-3}; scene=${4:-mri}; height=${5:-900}
here=$(cd "$(dirname "$0")" && pwd)
data="$here/../../shared/data/regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$build/volcl" --quiet encode "$data" --brick 32 --levels 3 -o "$tmp/mri.vcz"
configs=("full 0 512" "auto 0.005 512" "auto 0.01 512" "auto 0.02 512" "auto 0.05 512" "full 0 8" "full 0 2" "auto 0.01 2")
if [ -n "${CONFIGS:-}" ]; then IFS=';' read -r -a configs <<<"$CONFIGS"; fi
echo "lod,lod_error,cache_mb,run,wall_s,kernel_ms,decode_ms,decoded,voxels,coarsened,peak_mb,load,scene,view_height" > "$out"
for r in $(seq 1 "$reps"); do
  for c in "${configs[@]}"; do
    set -- $c
    start=$(date +%s.%N)
    err=$("$build/volcl" render --scene "$here/render/${scene}_scene.json" --volume "$tmp/mri.vcz" --view-height "$height" \
          --lod "$1" --lod-error "$2" --cache-mb "$3" --stats -o "$tmp/img.exr" 2>&1)
    end=$(date +%s.%N)
    kernel=$(grep -o '[0-9.]* ms kernel' <<<"$err" | cut -d' ' -f1)
    decode=$(grep -o 'decode [0-9.]* ms' <<<"$err" | cut -d' ' -f2)
    decoded=$(grep -o 'decoded [0-9]*,' <<<"$err" | head -1 | tr -dc 0-9)
    voxels=$(grep -o '([0-9]* voxels)' <<<"$err" | tr -dc 0-9)
    coarse=$( (grep -o 'coarsened to fit the budget [0-9]*' <<<"$err" || true) | tr -dc 0-9); coarse=${coarse:-0}
    peak=$(grep -o 'peak cache [0-9.]* MB' <<<"$err" | cut -d' ' -f3)
    load=$(cut -d' ' -f1 /proc/loadavg)
    echo "$1,$2,$3,$r,$(echo "$end - $start" | bc),$kernel,$decode,$decoded,$voxels,$coarse,$peak,$load,$scene,$height" >> "$out"
  done
done
