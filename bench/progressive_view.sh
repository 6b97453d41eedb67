#!/usr/bin/env bash
# Progressive refinement of compressed bricks in the viewer against render's whole working set: BrainWeb MRI
# encoded with 32^3 bricks and 3 levels, bench/render/mri_scene.json at 512^2 (camera height VIEW_HEIGHT,
# default 900: zoomed out 3x), lod auto. Per run, interleaved: `view --headless --frames 1` (its per-frame CSV:
# the first frame's time, the frames until the still view is refined, their sum) and `render` (decode of the
# whole working set + kernel, one frame). One cold process each, pinned to one core at normal priority.
# Usage: bench/progressive_view.sh BUILD_DIR OUT.csv [REPEATS] [VIEW_HEIGHT]
set -euo pipefail
build=$1; out=$2; reps=${3:-3}; height=${4:-900}
here=$(cd "$(dirname "$0")" && pwd)
data="$here/../../shared/data/regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$build/volcl" --quiet encode "$data" --brick 32 --levels 3 -o "$tmp/mri.vcz"
flags=(--volume "$tmp/mri.vcz" --view-height "$height" --lod auto --width 512 --height 512)
echo "run,command,first_frame_ms,frames,all_frames_ms,render_decode_ms,render_kernel_ms,wall_s,load" > "$out"
for r in $(seq 1 "$reps"); do
  start=$(date +%s.%N)
  taskset -c 0 "$build/volcl" --quiet view "$here/render/mri_scene.json" --headless --frames 1 "${flags[@]}" \
    --stats "$tmp/v.csv" -o "$tmp/v.png"
  end=$(date +%s.%N)
  # frame_ms is the CSV's last column.
  first=$(awk -F, 'NR==2 {print $NF}' "$tmp/v.csv")
  frames=$(awk 'END {print NR - 1}' "$tmp/v.csv")
  sum=$(awk -F, 'NR>1 {s += $NF} END {print s}' "$tmp/v.csv")
  echo "$r,view,$first,$frames,$sum,,,$(echo "$end - $start" | bc),$(cut -d' ' -f1 /proc/loadavg)" >> "$out"
  start=$(date +%s.%N)
  err=$(taskset -c 0 "$build/volcl" render --scene "$here/render/mri_scene.json" "${flags[@]}" --stats \
        -o "$tmp/r.exr" 2>&1)
  end=$(date +%s.%N)
  kernel=$(grep -o '[0-9.]* ms kernel' <<<"$err" | cut -d' ' -f1)
  decode=$(grep -o 'decode [0-9.]* ms' <<<"$err" | cut -d' ' -f2)
  echo "$r,render,,1,,$decode,$kernel,$(echo "$end - $start" | bc),$(cut -d' ' -f1 /proc/loadavg)" >> "$out"
done
