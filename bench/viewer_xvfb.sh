#!/usr/bin/env bash
# Opens `volcl view` on the BrainWeb MRI in an Xvfb X server, drives it with xdotool (orbit drag, wheel
# zoom, the shading key, overlay off and on, the screenshot key), checks from the viewer's log that each input took effect,
# and saves a screenshot of the X screen. Usage:
#   bench/viewer_xvfb.sh [VOLCL_BINARY] [SCREENSHOT.png]
# Defaults: build/volcl and docs/images/viewer-screenshot.png. Needs xvfb, xdotool, imagemagick (scripts/apt-packages.txt).
set -euo pipefail
cd "$(dirname "$0")/.."
volcl=$(realpath "${1:-build/volcl}")
shot=${2:-docs/images/viewer-screenshot.png}
mri=${VOLCL_SHARED_DATA_DIR:-../shared/data}/regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz
[[ -x "$volcl" ]] || { echo "viewer_xvfb: $volcl is not an executable" >&2; exit 1; }
[[ -f "$mri" ]] || { echo "viewer_xvfb: $mri is absent" >&2; exit 1; }
for tool in Xvfb xdotool import; do
  command -v "$tool" >/dev/null || { echo "viewer_xvfb: $tool missing (scripts/setup.sh installs it)" >&2; exit 1; }
done

work=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT

# A free display number: the first without a lock file.
disp=90
while [[ -e /tmp/.X$disp-lock || -e /tmp/.X11-unix/X$disp ]]; do disp=$((disp + 1)); done
Xvfb ":$disp" -screen 0 800x800x24 -nolisten tcp >"$work/xvfb.log" 2>&1 &
pids+=($!)
export DISPLAY=":$disp"
for _ in $(seq 50); do xdotool getmouselocation >/dev/null 2>&1 && break; sleep 0.1; done

"$volcl" view "$mri" --tf bench/viewer/mri_tf.json --width 480 --height 480 --step 1 \
  -o "$work/key-shot.png" 2>"$work/view.log" &
viewer=$!
pids+=($viewer)

wid=$(timeout 60 xdotool search --sync --name "volcl view" | head -1)
[[ -n "$wid" ]] || { echo "viewer_xvfb: no viewer window appeared" >&2; cat "$work/view.log" >&2; exit 1; }
xdotool windowfocus --sync "$wid" 2>/dev/null || xdotool windowfocus "$wid"

# Waits until the window title (set after every frame) matches the extended regex $1; prints it.
wait_title() {
  local t
  for _ in $(seq 1800); do
    t=$(xdotool getwindowname "$wid")
    [[ "$t" =~ $1 ]] && { echo "$t"; return 0; }
    sleep 0.1
  done
  echo "viewer_xvfb: the title never matched '$1' (last: '$t')" >&2
  return 1
}
# Waits until the log has a line matching $1.
wait_log() {
  for _ in $(seq 1800); do grep -q -- "$1" "$work/view.log" && return 0; sleep 0.1; done
  echo "viewer_xvfb: no '$1' in the viewer log" >&2; cat "$work/view.log" >&2; return 1
}
full='fps\) \| adaptive [0-9]+ ms$'   # a full-quality frame: no [interactive] suffix
coarse='\[interactive\]$'

t=$(wait_title "$full")
echo "first frame:   $t"
# Orbit: a left-button drag across the window, in small moves like a hand would make.
xdotool mousemove --sync 240 240 mousedown 1
for i in $(seq 1 20); do xdotool mousemove --sync $((240 + i * 8)) $((240 - i * 3)); sleep 0.05; done
t=$(wait_title "$coarse")
echo "while orbiting: $t"
xdotool mouseup 1
t=$(wait_title "$full")
echo "settled:       $t"
# Zoom in two wheel notches: coarse frames, then full quality again.
xdotool click 4 click 4
t=$(wait_title "$coarse")
echo "zooming:       $t"
t=$(wait_title "$full")
echo "settled:       $t"
# Shading on (the viewer adds a light), then mip and back is skipped: the screenshot shows shading.
xdotool key 1
wait_log "shading on"
t=$(wait_title "shading.*$full")
echo "after key 1:   $t"
# The overlay (frame time, level, effects, transport) toggles with o; it is on in the screenshot.
xdotool key o
wait_log "overlay off"
xdotool key o
wait_log "overlay on"
t=$(wait_title "$full")
xdotool key s
wait_log "view: screenshot"
[[ -s "$work/key-shot.png" ]] || { echo "viewer_xvfb: the s key wrote no screenshot" >&2; exit 1; }
mkdir -p "$(dirname "$shot")"
import -window "$wid" "$work/screen.png"
mv "$work/screen.png" "$shot"
echo "screenshot:    $shot"
xdotool key q
for _ in $(seq 100); do kill -0 "$viewer" 2>/dev/null || break; sleep 0.1; done
if kill -0 "$viewer" 2>/dev/null; then echo "viewer_xvfb: q did not close the viewer" >&2; exit 1; fi
wait "$viewer" || { echo "viewer_xvfb: the viewer exited with an error" >&2; cat "$work/view.log" >&2; exit 1; }
echo "viewer log:"
sed 's/^/  /' "$work/view.log"
