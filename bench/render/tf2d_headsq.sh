#!/usr/bin/env bash
# The CT head (headsq, 64x64x93 int16, 3.2 x 3.2 x 1.5 mm) seen from the front with the best 1D TF of the skin's
# value band and with a 2D TF (a Gaussian widget on the air/soft-tissue arc of the value x gradient histogram),
# and that histogram (docs/transfer-functions.md, "Gradient transfer functions").
# Usage: bench/render/tf2d_headsq.sh [VOLCL] [OUT_DIR]   (default build/volcl, docs/images)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
volcl=${1:-$root/build/volcl}
out=${2:-$root/docs/images}
ct=$root/../shared/data/regular/headsq/quarter.nhdr
[[ -f $ct ]] || { echo "tf2d_headsq.sh: $ct not found (the shared data sits beside the repository)" >&2; exit 1; }
mkdir -p "$out"
"$volcl" info "$ct" --histogram2d "$out/tf2d_headsq_histogram.png" | tail -1
# Facing the face: VTK's classic camera for this data set (from -y, z down).
camera=(--eye 100.8,-600,69 --target 100.8,100.8,69 --up 0,0,-1 --view-height 215)
for d in 1d 2d; do
  "$volcl" -q render --volume "$ct" --tf "$here/headsq_skin_${d}_tf.json" --width 256 --height 256 \
    --shading 0.3,0.7,0.2,16 "${camera[@]}" -o "$out/tf2d_headsq_${d}.png"
done
