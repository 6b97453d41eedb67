#!/usr/bin/env bash
# Adaptive-quality measurement: orbits the BrainWeb MRI (180x216x180) at 512x512 in a headless viewer run
# (one full-quality frame, 60 interactive frames of 3 degrees, one full-quality frame), writes per-frame
# times to docs/viewer-orbit-mri.csv and plots them to docs/viewer-orbit-mri.png. Usage:
#   bench/viewer_orbit.sh [VOLCL_BINARY] [TARGET_MS]
set -euo pipefail
cd "$(dirname "$0")/.."
volcl=${1:-build/volcl}
target=${2:-100}
mri=${VOLCL_SHARED_DATA_DIR:-../shared/data}/regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz
[[ -f "$mri" ]] || { echo "viewer_orbit: $mri is absent" >&2; exit 1; }
env -u DISPLAY "$volcl" view "$mri" --tf bench/viewer/mri_tf.json --headless --width 512 --height 512 \
  --frames 62 --orbit 3 --target-ms "$target" --stats docs/viewer-orbit-mri.csv -o docs/viewer-orbit-mri-last.png
/usr/bin/python3 bench/plot_viewer_orbit.py docs/viewer-orbit-mri.csv "$target" docs/viewer-orbit-mri.png
