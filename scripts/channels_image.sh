#!/usr/bin/env bash
# Regenerates docs/images/channels_mni.png (docs/channels.md): three co-registered MNI volumes as the channels of
# one scene: the Colin 27 T1 head (uint8), its brain extraction converted to float32, and the AAL atlas (uint8),
# each with its own transfer function, blended additively, seen from the front with the face cropped away.
# Usage: bash scripts/channels_image.sh TEMPLATE_DIR [path/to/volcl]
#   TEMPLATE_DIR holds ch2.nii.gz, ch2bet.nii.gz and aal.nii.gz (MRIcron's templates, Debian package mricron-data).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
templates="${1:?usage: channels_image.sh TEMPLATE_DIR [volcl]}"
volcl="${2:-$root/build/volcl}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# Channel 1 in another type than the others: channels keep their own types.
"$volcl" -q convert "$templates/ch2bet.nii.gz" --to-type float32 -o "$work/brain_f32.nii.gz"
cat > "$work/head.json" <<'JSON'
{"color": [[0, 0.8, 0.8, 0.85], [255, 1.0, 1.0, 1.0]],
 "extinction": [[0, 0.0], [60, 0.0], [90, 0.06], [255, 0.1]]}
JSON
cat > "$work/brain.json" <<'JSON'
{"color": [[0, 1.0, 0.55, 0.2], [255, 1.0, 0.85, 0.5]],
 "extinction": [[0, 0.0], [70, 0.0], [100, 0.15], [255, 0.3]]}
JSON
cat > "$work/atlas.json" <<'JSON'
{"color": [[0, 0.1, 0.3, 1.0], [58, 0.1, 0.9, 0.6], [116, 0.9, 0.2, 0.9]],
 "extinction": [[0, 0.0], [0.5, 0.0], [1, 0.5], [116, 0.5]]}
JSON
cat > "$work/scene.json" <<JSON
{
  "volume": "$templates/ch2.nii.gz",
  "channels": [
    {"tf": "$work/head.json"},
    {"tf": "$work/brain.json", "volume": "$work/brain_f32.nii.gz"},
    {"tf": "$work/atlas.json", "volume": "$templates/aal.nii.gz"}
  ],
  "blend": "additive",
  "image": {"width": 480, "height": 480, "background": [0, 0, 0, 1]},
  "effects": {"crop_box": {"box": [[0, 0, 0], [180, 120, 180]], "units": "voxels"}}
}
JSON
mkdir -p "$root/docs/images"
"$volcl" render --scene "$work/scene.json" -o "$root/docs/images/channels_mni.png"
echo "wrote $root/docs/images/channels_mni.png"
