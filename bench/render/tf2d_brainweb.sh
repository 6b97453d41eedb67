#!/usr/bin/env bash
# The BrainWeb T1 MRI (180x216x180 uint8, 1 mm) seen from the left with the 1D TF of the white matter's value band
# and with a 2D TF (one Gaussian widget on the grey/white-matter arc of the value x gradient histogram), and that
# histogram (docs/transfer-functions.md, "An MRI: the white-matter surface through the scalp").
# Usage: bench/render/tf2d_brainweb.sh [VOLCL] [OUT_DIR]   (default build/volcl, docs/images)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
volcl=${1:-$root/build/volcl}
out=${2:-$root/docs/images}
mri=$root/../shared/data/regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz
[[ -f $mri ]] || { echo "tf2d_brainweb.sh: $mri not found (the shared data sits beside the repository)" >&2; exit 1; }
mkdir -p "$out"
"$volcl" info "$mri" --histogram2d "$out/tf2d_brainweb_histogram.png" | tail -1
# The left side of the head: x runs right to left in the volume, z up.
camera=(--eye -600,108,80 --target 90,108,80 --up 0,0,1 --view-height 230)
for d in 1d 2d; do
  "$volcl" -q render --volume "$mri" --tf "$here/brainweb_wm_${d}_tf.json" --width 320 --height 320 \
    --shading 0.3,0.7,0.2,16 "${camera[@]}" -o "$out/tf2d_brainweb_${d}.png"
done
