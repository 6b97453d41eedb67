#!/usr/bin/env bash
# Renders a fixed set of scenes with the CLI (every mode and effect, on the MRI bench scene and generated
# phantoms) so two builds can be compared byte for byte: a refactoring of the renderer must not move a bit.
#
#   tests/render_identity.sh render VOLCL OUTDIR     render every scene with the binary VOLCL into OUTDIR
#   tests/render_identity.sh compare DIR_A DIR_B     exit 0 when every file is byte-identical (an EXR's
#                                                    capDate stamp aside), else list the others
#
# Typical use: render with the old build, rebuild, render with the new one, compare.
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
src="$(dirname "$here")"
data="${VOLCL_SHARED_DATA_DIR:-$src/../shared/data}"

render_all() {
    local volcl="$1" out="$2"
    mkdir -p "$out"
    local work
    work="$(mktemp -d)"
    trap 'rm -rf "$work"' RETURN
    # Phantoms: Shepp-Logan and Marschner-Lobb (float voxels), with the demo's transfer function.
    "$volcl" -q demo -o "$work/demo" --ml-size 41 --phantom-size 64 >/dev/null
    cp "$work/demo/phantom.png" "$out/demo_phantom.png"
    local sl="$work/demo/shepp_logan.nrrd" ml="$work/demo/marschner_lobb.nrrd" ptf="$work/demo/phantom_tf.json"
    local n=0
    # Skipping auto (the default) picks by timing, which the effects attribute records: fixed to on (the old
    # default) wherever the build has the flag, so two runs compare byte for byte.
    local skip=()
    if "$volcl" render --help | grep -q -- '--skipping'; then skip=(--skipping on); fi
    r() { # name, then render flags
        local name="$1"
        shift
        "$volcl" -q render "${skip[@]}" "$@" -o "$out/$name.exr"
        n=$((n + 1))
    }
    local light=(--light dir:0.4,0.6,-0.7 --shading 0.2,0.7,0.3,32)
    local P=(--volume "$sl" --tf "$ptf" --width 96 --height 80 --step 0.5)
    r sl_dvr_none "${P[@]}" --preintegration none
    r sl_dvr_2d "${P[@]}" --preintegration 2d
    r sl_dvr_3d "${P[@]}" --preintegration 3d --table-lengths 8
    r sl_dvr_noskip "${P[@]}" --no-skipping --early-termination 1
    r sl_mip "${P[@]}" --mode mip
    r sl_xray "${P[@]}" --mode xray
    r sl_iso "${P[@]}" --mode iso --iso 0.25:0.9,0.8,0.7,1 --iso 0.5:0.2,0.4,1,0.5
    r sl_dvr_iso "${P[@]}" --iso 0.3:1,1,1,0.4
    r sl_shading "${P[@]}" "${light[@]}"
    r sl_shading_sobel "${P[@]}" "${light[@]}" --sobel
    r sl_shadows "${P[@]}" "${light[@]}" --shadows --shadow-step 1
    r sl_scattering "${P[@]}" --light point:80,-40,-60@2 --scattering 0.7,0.3
    r sl_scatter_shadow_2d "${P[@]}" --light head --scattering 0.5,-0.2 --shadows --preintegration 2d
    r sl_iso_lit "${P[@]}" --mode iso --iso 0.25 "${light[@]}" --shadows
    r sl_clip "${P[@]}" --clip 1,0,0,-30 --clip 0,1,1,-60
    r sl_clip_3d "${P[@]}" --clip -1,0,0,40 --preintegration 3d
    r sl_persp "${P[@]}" --projection perspective --eye 90,20,-120 --target 31.5,31.5,31.5 --fov 35
    r ml_iso_persp --volume "$ml" --tf "$ptf" --width 80 --height 80 --step 0.25 --mode iso --iso 0.5 \
        --projection perspective --eye 60,50,-40 --target 20,20,20 --fov 40 --light head --shading 0.3,0.6,0.4,16
    r ml_dvr_2d --volume "$ml" --tf "$ptf" --width 80 --height 64 --step 0.5 --preintegration 2d
    # The MRI bench scene (uint8: the packet kernel reads 8 corner bytes per cell).
    local mri="$src/bench/render/mri_scene.json"
    if [ -f "$data/regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz" ]; then
        local M=(--scene "$mri" --width 160 --height 144)
        r mri_dvr_2d "${M[@]}"
        r mri_dvr_none "${M[@]}" --preintegration none
        r mri_dvr_3d "${M[@]}" --preintegration 3d
        r mri_noskip "${M[@]}" --no-skipping
        r mri_mip "${M[@]}" --mode mip
        r mri_xray "${M[@]}" --mode xray
        r mri_iso "${M[@]}" --mode iso --iso 90:0.9,0.85,0.75,1 "${light[@]}"
        r mri_shading "${M[@]}" "${light[@]}" --step 1
        r mri_shadows "${M[@]}" "${light[@]}" --shadows --shadow-step 3 --step 1
        r mri_scattering "${M[@]}" --light head --scattering 0.8,0.3 --step 1
        r mri_clip "${M[@]}" --clip 1,0,0,-90
        r mri_sharp "${M[@]/$mri/$src/bench/render/mri_sharp_scene.json}" --preintegration 3d
        r mri_persp "${M[@]}" --projection perspective --fov 30 --eye 300,-150,-250
    else
        echo "render_identity: $data/regular not found, MRI scenes skipped" >&2
    fi
    # The viewer's headless frame after toggles (PNG of the OpenGL framebuffer), when EGL is available.
    if "$volcl" -q view --headless --volume "$sl" --tf "$ptf" --width 64 --height 64 --frames 2 --keys 1m \
        -o "$out/view_headless.png" >/dev/null 2>"$work/view.err"; then
        n=$((n + 1))
    else
        echo "render_identity: headless viewer unavailable ($(head -1 "$work/view.err")), skipped" >&2
    fi
    echo "render_identity: $n images in $out"
}

# True when two files are identical apart from the value of an EXR "capDate" attribute (the writer stamps
# the time of writing); every other header byte and every pixel byte must match.
same_but_date() {
    python3 - "$1" "$2" <<'PY'
import struct, sys
def undated(path):
    data = bytearray(open(path, "rb").read())
    key = b"capDate\0string\0"
    at = data.find(key)
    if at >= 0:
        start = at + len(key)
        (size,) = struct.unpack_from("<i", data, start)
        data[start + 4 : start + 4 + size] = bytes(size)
    return bytes(data)
sys.exit(0 if undated(sys.argv[1]) == undated(sys.argv[2]) else 1)
PY
}

compare_all() {
    local a="$1" b="$2" bad=0 count=0
    for f in "$a"/*; do
        local name
        name="$(basename "$f")"
        count=$((count + 1))
        if [ ! -f "$b/$name" ]; then
            echo "missing in $b: $name"
            bad=$((bad + 1))
        elif ! cmp -s "$f" "$b/$name" && ! same_but_date "$f" "$b/$name"; then
            echo "differs: $name"
            bad=$((bad + 1))
        fi
    done
    for f in "$b"/*; do
        [ -f "$a/$(basename "$f")" ] || { echo "missing in $a: $(basename "$f")"; bad=$((bad + 1)); }
    done
    echo "render_identity: $count files compared, $bad differ"
    [ "$bad" -eq 0 ]
}

case "${1:-}" in
render) render_all "$2" "$3" ;;
compare) compare_all "$2" "$3" ;;
*)
    echo "usage: $0 render VOLCL OUTDIR | compare DIR_A DIR_B" >&2
    exit 2
    ;;
esac
