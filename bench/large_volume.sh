#!/usr/bin/env bash
# A cloud larger than the process's memory use: generated straight into a .vcz (streamed brick row by brick
# row), then rendered from its bricks at 512^2 with a cache of 1/8 of the decoded volume, and a region of it
# rendered clipped from the .vcz against the same region decoded in full. Peak RSS from GNU time.
# Usage: bench/large_volume.sh BUILD_DIR OUT.log [Z]   (the volume is 1024 x 1024 x Z uint8, default 256)
set -euo pipefail
build=$1; out=$2; z=${3:-256}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cache=$((z / 8)) # MB: 1/8 of the 1024 x 1024 x Z bytes
cat > "$tmp/tf.json" <<'TF'
{"domain": [0, 255], "color": [[0, 0.2, 0.3, 0.9], [128, 1, 0.6, 0.2], [255, 1, 1, 1]],
  "extinction": [[0, 0], [40, 0], [90, 0.2], [255, 0.5]]}
TF
t() { /usr/bin/time -f "wall %e s, peak RSS %M KiB, CPU %P" "$@"; }
cam="--tf $tmp/tf.json --tf-range 0,255 --width 512 --height 512"
{
  uptime
  t "$build/volcl" generate cloud --size 1024,1024,$z --seed 7 --frequency 8 --octaves 4 --erosion 0 -o "$tmp/cloud.vcz"
  t "$build/volcl" render --volume "$tmp/cloud.vcz" $cam --orbit 30,25 --lod auto --cache-mb $cache --stats -o "$tmp/whole.exr"
  # A region of 4 x 3 x 2 bricks (24 MB of pool), clipped 1 voxel inside the brick faces so no neighbour is
  # in the working set.
  t "$build/volcl" decode "$tmp/cloud.vcz" --region 0,0,65:255,191,191 -o "$tmp/crop.nrrd"
  view="--eye 600,-400,450 --target 127,95,128 --view-height 400"
  t "$build/volcl" render --volume "$tmp/crop.nrrd" $cam $view -o "$tmp/crop.exr"
  t "$build/volcl" render --volume "$tmp/cloud.vcz" $cam $view --clip -1,0,0,254 --clip 0,-1,0,190 \
    --clip 0,0,1,-65 --clip 0,0,-1,190 --lod full --cache-mb $cache --stats -o "$tmp/clipped.exr"
  oiiotool "$tmp/crop.exr" "$tmp/clipped.exr" --diff || true
  uptime
} 2>&1 | sed "s|$tmp/||g" > "$out"
