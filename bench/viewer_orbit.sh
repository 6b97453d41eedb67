#!/usr/bin/env bash
# Adaptive-quality measurement (`volcl bench view`): orbits the BrainWeb MRI (180x216x180) at 512x512 in a
# headless viewer run (one full-quality frame, 60 interactive frames of 3 degrees, one full-quality frame,
# then 3 more still frames), writes per-frame times to bench/results/viewer/viewer-orbit-mri.csv, the summary to
# bench/results/viewer/viewer-orbit-mri.json and the plot to docs/images/viewer-orbit-mri.png. Usage:
#   bench/viewer_orbit.sh [VOLCL_BINARY] [TARGET_MS]
set -euo pipefail
cd "$(dirname "$0")/.."
volcl=${1:-build/volcl}
target=${2:-100}
mri=${VOLCL_SHARED_DATA_DIR:-../shared/data}/regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz
[[ -f "$mri" ]] || { echo "viewer_orbit: $mri is absent" >&2; exit 1; }
echo "load before: $(uptime)"
env -u DISPLAY "$volcl" bench view "$mri" --tf bench/viewer/mri_tf.json --width 512 --height 512 \
  --frames 62 --spin 3 --stills 3 --target-ms "$target" \
  --csv bench/results/viewer/viewer-orbit-mri.csv --json bench/results/viewer/viewer-orbit-mri.json
echo "load after: $(uptime)"
/usr/bin/python3 bench/plot_viewer_orbit.py bench/results/viewer/viewer-orbit-mri.csv "$target" docs/images/viewer-orbit-mri.png
