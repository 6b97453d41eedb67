#!/usr/bin/env bash
# Label maps over the ch2better MRI (Debian's mricron-data templates, MNI space): the AAL atlas replacing the
# MRI's TF inside its regions behind a crop box, the JHU white-matter labels alone, and the smooth boundary
# against the nearest label voxel's staircase; then the frame cost of labels against the plain frame
# (medians of interleaved one-core runs, the load stated) (docs/labels.md).
# Usage: bench/render/labels_mricron.sh [VOLCL] [OUT_DIR] [LOG]
#        (default build/volcl, docs/images, bench/results/rendering/labels-ch2.txt)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
volcl=${1:-$root/build/volcl}
out=${2:-$root/docs/images}
log=${3:-$root/bench/results/rendering/labels-ch2.txt}
t=/usr/share/mricron/templates
[[ -f $t/ch2better.nii.gz && -f $t/aal.nii.gz ]] ||
  { echo "labels_mricron.sh: $t not found (install mricron-data: scripts/apt-packages.txt)" >&2; exit 1; }
mkdir -p "$out" "$(dirname "$log")"
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
mri=$t/ch2better.nii.gz
tf=$here/labels_ch2_tf.json
common=(--volume "$mri" --tf "$tf" --width 384 --height 384 --view front --step 0.5)
# AAL (1 mm grid) over the MRI (0.5 mm grid): the MRI's TF outside the atlas, the atlas's colours (aal.nii.lut
# beside aal.nii.txt) inside; the front half cut away by a crop box (a coronal cut).
"$volcl" -q render "${common[@]}" --labels "$t/aal.nii.gz" --label-table "$t/aal.nii.txt" --label-mode replace \
  --crop-box 0,0,0:300,180,315vox --shading 0.3,0.7,0.2,16 -o "$out/labels_ch2_aal_replace.png"
# The JHU white-matter tracts alone (their .lut palette), unshaded, seen from the front.
"$volcl" -q render --volume "$mri" --tf "$tf" --width 384 --height 384 --view front --view-height 150 --step 0.5 \
  --labels "$t/JHU-WhiteMatter-labels-1mm.nii.gz" --label-table "$t/JHU-WhiteMatter-labels-1mm.nii.txt" \
  --label-mode alone -o "$out/labels_ch2_jhu_alone.png"
# The staircase the smooth boundary removes: AAL alone, unshaded (shading takes the MRI's gradient, whose
# contours would cover the labels' boundaries), a close-up, nearest label voxel vs smooth.
for b in nearest smooth; do
  "$volcl" -q render --volume "$mri" --tf "$tf" --width 256 --height 256 --view left --step 0.25 \
    --view-height 50 --labels "$t/aal.nii.gz" --label-table "$t/aal.nii.txt" --label-mode alone \
    --label-boundary "$b" -o "$out/labels_ch2_aal_$b.png"
done

# Cost: kernel milliseconds of the same 384^2 frame without labels, with labels (smooth) and nearest, interleaved,
# pinned to one core; medians of 7 rounds.
{
  echo "# AAL labels (181x217x181, 1 mm) on ch2better (301x370x316, 0.5 mm), 384x384, step 0.5, shaded, cropped,"
  echo "# one core (taskset -c 0), $(date -u +%Y-%m-%dT%H:%MZ)"
  echo "# load (uptime): $(uptime)"
  declare -A ms
  for round in 1 2 3 4 5 6 7; do
    for v in plain smooth nearest; do
      extra=()
      [[ $v != plain ]] && extra=(--labels "$t/aal.nii.gz" --label-table "$t/aal.nii.txt" --label-mode replace
        --label-boundary "$v")
      line=$(taskset -c 0 "$volcl" render "${common[@]}" --crop-box 0,0,0:300,180,315vox --shading 0.3,0.7,0.2,16 "${extra[@]}" \
        -o "$scratch/frame.png" 2>&1 | grep 'ms kernel')
      ms[$v]+="$(sed -E 's/.*: ([0-9.]+) ms kernel.*/\1/' <<<"$line") "
    done
  done
  for v in plain smooth nearest; do
    med=$(tr ' ' '\n' <<<"${ms[$v]}" | grep . | sort -n | sed -n 4p)
    echo "$v: kernel ms ${ms[$v]}-> median $med"
  done
  echo "# load after: $(uptime)"
} | tee "$log"
