#!/usr/bin/env bash
# A tiny case of every kernel family on Oclgrind (memory and data-race checks), compared with PoCL or a reference.
# Usage: run_kernels.sh VOLCL_EXE TESTS_DIR WORK_DIR  (TESTS_DIR: the build's tests/ with its gtest binaries)
# Every volcl command runs twice: on PoCL (the system's ICDs) and on Oclgrind alone (OCL_ICD_VENDORS names a
# folder holding only Oclgrind's ICD, and VOLCL_DEVICE=Oclgrind, so nothing else can run the kernels). Any line
# Oclgrind logs (invalid access, data race, API error, crash) fails the run, and so does any difference from
# PoCL beyond the stated tolerance. Cases are 8^3-16^3 volumes and 12x10 images: Oclgrind interprets every
# work-item. See docs/reliability.md, "Second OpenCL implementation (Oclgrind)".
set -uo pipefail
volcl=$(realpath "$1")
tests=$(realpath "$2")
work=$3
here=$(cd "$(dirname "$0")" && pwd)

icd_lib=$(dpkg -L oclgrind 2>/dev/null | grep -m1 'liboclgrind-rt-icd\.so$' || true)
for p in /usr/lib/oclgrind/liboclgrind-rt-icd.so /usr/lib/x86_64-linux-gnu/liboclgrind-rt-icd.so; do
  [[ -z $icd_lib && -f $p ]] && icd_lib=$p
done
if [[ -z $icd_lib ]]; then
  echo "Oclgrind's ICD (liboclgrind-rt-icd.so) not found: install the Debian package oclgrind" >&2
  exit 1
fi

rm -rf "$work"
mkdir -p "$work/icd" "$work/pocl" "$work/ocl"
echo "$icd_lib" >"$work/icd/oclgrind.icd"
log=$work/oclgrind.log
failures=0
fail() {
  echo "FAIL: $*" >&2
  failures=$((failures + 1))
}

# Oclgrind's environment: memory checking is always on; data races and API errors are asked for; its log
# (every report) goes to one file that must stay empty. The program cache is off so every kernel is built
# by Oclgrind itself.
# OCLGRIND_INST_COUNTS prints each kernel's name as it finishes: the coverage check at the end reads them.
# VOLCL_OCLGRIND_UNINITIALIZED=1 adds the uninitialised-value checks, on unoptimised builds: on optimised code
# Oclgrind 21.10 stops at LLVM's freeze instruction ("Unsupported instruction: freeze") and reports the
# undef its own store splitting writes first (tests/oclgrind/vector_store_split.cl). Oclgrind stops logging
# after 1000 reports, which would hide the later kernels of a command: the sweep lifts that limit, and at the end
# lists each case's reports by kernel and source line (each case's full log: WORK/ocl/CASE.oclgrind.log).
uninit=()
if [[ ${VOLCL_OCLGRIND_UNINITIALIZED:-0} == 1 ]]; then
  uninit=(OCLGRIND_UNINITIALIZED=1 OCLGRIND_BUILD_OPTIONS=-cl-opt-disable OCLGRIND_MAX_ERRORS=10000000)
fi
on_oclgrind() {
  env OCL_ICD_VENDORS="$work/icd" VOLCL_DEVICE=Oclgrind VOLCL_CACHE_DIR=off OCLGRIND_LOG="$log" \
    OCLGRIND_DATA_RACES=1 OCLGRIND_CHECK_API=1 OCLGRIND_INST_COUNTS=1 "${uninit[@]}" "$@"
}
on_pocl() {
  env -u OCL_ICD_VENDORS -u VOLCL_DEVICE "$@"
}

# run NAME CMD...: CMD on Oclgrind; fails on a non-zero exit or any Oclgrind report.
run() {
  local name=$1
  shift
  : >"$log"
  local start=$SECONDS
  if ! on_oclgrind "$@" >"$work/ocl/$name.out" 2>&1; then
    fail "$name: exit status on Oclgrind"
    tail -5 "$work/ocl/$name.out" >&2
  fi
  if [[ -s $log ]]; then
    fail "$name: Oclgrind reported $(grep -c '^[A-Z]' "$log") problems (all in ocl/$name.oclgrind.log); the first:"
    head -12 "$log" >&2
    cp "$log" "$work/ocl/$name.oclgrind.log"
  fi
  echo "  $name: $((SECONDS - start)) s"
}

# both NAME OUT CMD... : CMD with output OUT (a file name) on Oclgrind (into ocl/) and on PoCL (into pocl/).
both() {
  local name=$1 out=$2
  shift 2
  run "$name" "$@" -o "$work/ocl/$out"
  on_pocl "$@" -o "$work/pocl/$out" >"$work/pocl/$name.out" 2>&1 || fail "$name: exit status on PoCL"
}

# same_image OUT TOL: the two EXR images within TOL on every channel of every pixel.
same_image() {
  if ! idiff -q -fail "$2" -failpercent 0 -warn "$2" "$work/pocl/$1" "$work/ocl/$1" >"$work/idiff.out" 2>&1; then
    fail "$1: Oclgrind and PoCL differ by more than $2"
    cat "$work/idiff.out" >&2
  fi
}

# max_error A B: volcl compare's largest voxel difference.
max_error() {
  on_pocl "$volcl" compare "$1" "$2" | awk '$1 == "max_abs_error" {print $2}'
}
# within A B TOL NAME
within() {
  local e
  e=$(max_error "$1" "$2")
  if [[ -z $e ]] || ! awk -v e="$e" -v t="$3" 'BEGIN { exit !(e <= t) }'; then
    fail "$4: max error ${e:-?} > $3"
  fi
}

echo "== the device"
devices=$(on_oclgrind "$volcl" devices 2>&1)
if [[ $(grep -c '^\*\? *[0-9]*:' <<<"$devices") != 1 || $devices != *"Oclgrind Simulator"* ]]; then
  fail "the Oclgrind environment must list Oclgrind's device alone:"
  echo "$devices" >&2
fi
if on_pocl "$volcl" devices 2>&1 | grep -q Oclgrind; then fail "the PoCL environment lists Oclgrind"; fi

echo "== inputs (on PoCL)"
on_pocl "$volcl" -q demo --ml-size 9 --phantom-size 8 -o "$work/in" >/dev/null 2>&1 || fail "volcl demo"
ml=$work/in/marschner_lobb.nrrd
python3 "$here/make_inputs.py" "$work/in" || fail "make_inputs.py"

# gtest NAME BINARY FILTER: tests of the suite (kernels against their C++ references) on Oclgrind.
gtest() {
  : >"$log"
  if ! on_oclgrind "$tests/$2" --gtest_brief=1 --gtest_filter="$3" >"$work/ocl/$1.out" 2>&1; then
    fail "$1: $2 on Oclgrind"
    tail -20 "$work/ocl/$1.out" >&2
  fi
  if [[ -s $log ]]; then
    fail "$1: Oclgrind reported $(grep -c '^[A-Z]' "$log") problems (all in ocl/$1.oclgrind.log); the first:"
    head -12 "$log" >&2
    cp "$log" "$work/ocl/$1.oclgrind.log"
  fi
}

echo "== suite tests (kernels against their C++ references): phantoms, copy, TF sampling, motion, plain march, light volumes"
gtest phantoms test_phantoms \
  'Phantoms/MarschnerLobbSizes.*/0:Phantoms/MarschnerLobbSizes.*/3:Phantoms/SheppLoganSizes.*/0:Phantoms/SheppLoganSizes.*/3'
gtest runtime test_runtime 'Runtime.CopyKernelRoundTripsDataWithOddSizes:Runtime.OversizedBufferIsRefused:'\
'Runtime.DeviceProfileIsChosenByDeviceKind:Runtime.EventTimingIsPositiveAndBandwidthMeasurable'
gtest tf_sample test_tf 'TransferFunction.HostAndKernelSamplingAreBitIdentical'
gtest tf_gradient test_render_tf2d 'GradientTf.FlatDataHasGradientZero:GradientTf.NanVoxelsStayFiniteAndLocal'
gtest labels test_render_labels 'Labels.TinyCaseMatchesItsReference'
gtest motion test_motion_compensation 'MotionCompensation.TinyVolumeMatchesTheReferenceOnBothKernels'
gtest plain test_render 'Render.PlainKernelMatchesBaseline'
gtest light_volume test_shadow_volume 'LightVolume.KernelMatchesItsReference'
gtest gradient_cache test_gradient_cache \
  'GradientCache.KernelMatchesHostReferenceBitForBit:GradientCache.ExactFormHoldsTheCentralDifferences'
# NaN voxels (NAN_COLOR): point-sampled and pre-integrated dvr, MIP/x-ray skipping, iso cells with NaN corners
gtest nan test_render_nan 'RenderNan.DvrDrawsTheNanColourWhereTheRuleSays:'\
'RenderNan.SkippingKeepsCellsWhereOnlyTheNanColourShows:RenderNan.MipAndXraySkipSamplesThatAreNotFinite:'\
'RenderNan.IsoSurfacesNeedCellsWithFiniteCorners'
# The multi-channel ray marcher: 4 channels of 4 types in every blend, and a NaN channel, against the reference.
gtest channels test_channels 'ChannelRender.FourChannelsAndEveryBlendMatchTheReference:'\
'ChannelRender.NanChannelFollowsTheNanRule'

echo "== codec: both lifting paths, lossless and lossy, entropy coding, decode"
for path in streaming brick; do
  for v in "$ml" "$work/in/blob_16x12x8_uint8.raw"; do
    b=$(basename "$v" | cut -d_ -f1)_$path
    VOLCL_LIFTING_PATH=$path both "ll_$b" "ll_$b.vcz" "$volcl" -q encode "$v" --lossless --brick 8 --levels 2
    VOLCL_LIFTING_PATH=$path both "lld_$b" "lld_$b.nrrd" "$volcl" -q decode "$work/ocl/ll_$b.vcz"
    within "$v" "$work/ocl/lld_$b.nrrd" 0 "lossless round trip $b"
    cmp -s "$work/pocl/ll_$b.vcz" "$work/ocl/ll_$b.vcz" || fail "ll_$b: Oclgrind's file differs from PoCL's"
  done
  VOLCL_LIFTING_PATH=$path both "ly_$path" "ly_$path.vcz" "$volcl" -q encode "$ml" --max-error 1e-3 --brick 8 \
    --levels 2
  VOLCL_LIFTING_PATH=$path both "lyd_$path" "lyd_$path.nrrd" "$volcl" -q decode "$work/ocl/ly_$path.vcz"
  within "$ml" "$work/ocl/lyd_$path.nrrd" 1e-3 "lossy max-error bound ($path)"
  within "$work/pocl/lyd_$path.nrrd" "$work/ocl/lyd_$path.nrrd" 1e-6 "lossy decode vs PoCL ($path)"
done

echo "== motion compensation (P and B frames)"
frames=("$work"/in/frame*_16x12x8_uint8.raw)
both series series.vcz "$volcl" -q encode "${frames[@]}" --lossless --brick 8 --levels 2 --gop 3 --b-frames 1
for k in 0 1 2; do
  both "series_d$k" "series_$k.nrrd" "$volcl" -q decode "$work/ocl/series.vcz" --frame "$k"
  within "${frames[$k]}" "$work/ocl/series_$k.nrrd" 0 "series frame $k"
done

echo "== pre-integration tables (every method, against the reference)"
tf=$work/in/phantom_tf.json
for m in exact incremental integral-function roettger-2d polynomial; do
  both "preint_$m" "preint_$m.exr" "$volcl" -q preint --tf "$tf" --size 16 --lengths 3 --max-length 2 --method "$m"
  same_image "preint_$m.exr" 1e-5
done
both preint_2d preint_2d.exr "$volcl" -q preint --tf "$tf" --size 20 --step 0.5
same_image preint_2d.exr 1e-5
on_pocl "$volcl" preint --check "$work/ocl/preint_2d.exr" --tf "$tf" --samples 0 --tolerance 1e-4 \
  >"$work/check.out" 2>&1 || fail "preint --check of Oclgrind's 2D table"

echo "== ray marcher: every effect"
R=("$volcl" -q render --volume "$ml" --tf "$tf" --width 12 --height 10)
both dvr dvr.exr "${R[@]}"
both dvr_noskip dvr_noskip.exr "${R[@]}" --no-skipping
both mip mip.exr "${R[@]}" --mode mip
both xray xray.exr "${R[@]}" --mode xray
both iso iso.exr "${R[@]}" --mode iso --iso 0.5 --iso 0.8:1,0,0,0.5
both shading shading.exr "${R[@]}" --shading 0.2,0.7,0.3,32 --sobel
# Shaded from the gradient cache on the packet kernel (trilinear blend, nearest voxel, with 2D pre-integration)
both shading_cache shading_cache.exr "${R[@]}" --shading 0.2,0.7,0.3,32
both shading_nearest shading_nearest.exr "${R[@]}" --shading 0.2,0.7,0.3,20.5 --gradient cache-nearest
both shading_cache_pre2d shading_cache_pre2d.exr "${R[@]}" --shading 0.2,0.7,0.3,32 --preintegration 2d \
  --table-size 32 --clip 1,0,0,-4
both shadows shadows.exr "${R[@]}" --shading 0.2,0.7,0.3,32 --shadows
# Light volumes (light_volume_slice): a diagonal sun on a 3-voxel grid, a point light inside the volume; rays.
both shadows_dir shadows_dir.exr "${R[@]}" --shading 0.2,0.7,0.3,32 --shadows --light dir:1,1,1 --light-volume-cell 3
both shadows_point shadows_point.exr "${R[@]}" --shading 0.2,0.7,0.3,32 --shadows --light point:4,3,5
both shadows_rays shadows_rays.exr "${R[@]}" --shading 0.2,0.7,0.3,32 --shadows --shadow-method rays
both scatter scatter.exr "${R[@]}" --scattering 0.8,0.3
both pre2d pre2d.exr "${R[@]}" --preintegration 2d --table-size 32
both pre3d pre3d.exr "${R[@]}" --preintegration 3d --table-size 16 --table-lengths 4
both cubic cubic.exr "${R[@]}" --filter cubic --smoothing 1
both clip clip.exr "${R[@]}" --clip 1,0,0,-4 --projection perspective
# Eight clip planes: a crop box in voxels and two planes; the emission-only mode, cropped.
both crop crop.exr "${R[@]}" --crop-box 1,2,1:7,6.5,8vox --clip 1,0,0,-4 --clip 0,1,1,-6
both emission emission.exr "${R[@]}" --mode emission --crop-box 0,1,0:6,8,8
both fog fog.exr "$volcl" -q render --scene "$work/in/fog_scene.json" --volume "$ml" --tf "$tf" --width 12 \
  --height 10
for i in dvr dvr_noskip mip xray iso shading shading_cache shading_nearest shading_cache_pre2d shadows shadows_dir \
  shadows_point shadows_rays scatter pre2d pre3d cubic clip crop emission fog; do
  same_image "$i.exr" 1e-4
done
both pathtrace pathtrace.exr "${R[@]}" --scattering 0.8,0.3 --scattering-order multiple --samples 2
same_image pathtrace.exr 1e-3

echo "== preview tiers: shear-warp and discrete ray casting"
both shearwarp shearwarp.exr "${R[@]}" --method shear-warp
both shearwarp_iso shearwarp_iso.exr "${R[@]}" --method shear-warp --view iso
both drc drc.exr "${R[@]}" --method drc --view iso
both drc_persp drc_persp.exr "${R[@]}" --method drc --projection perspective
for i in shearwarp shearwarp_iso drc drc_persp; do
  same_image "$i.exr" 1e-4
done

# A gradient TF (tf_gradient in common/tf_lookup.h: gradient-opacity knots and the three widget shapes after the
# value knots), on the grid and, below, on the bricks.
tf2d=$work/in/gradient_tf.json
printf '%s\n' '{"domain": [0, 1], "color": [[0, 0.2, 0.4, 1], [1, 1, 0.8, 0.6]], "extinction": [[0, 0], [1, 2]],' \
  '"gradient_opacity": [[0, 0.3], [2, 1]], "widgets": [{"type": "box", "value": [0.3, 0.7], "gradient": [0.5, 50],' \
  '"color": [1, 0.2, 0.2], "extinction": 3}, {"type": "gaussian", "center": [0.6, 2], "sigma": [0.2, 5],' \
  '"color": [0.2, 1, 0.2], "extinction": 2}, {"type": "paraview_box", "value": [0.1, 0.9], "gradient": [0, 8],' \
  '"color": [0.3, 0.3, 1], "opacity": 0.8, "unit_distance": 0.5}]}' >"$tf2d"
both tf2d tf2d.exr "$volcl" -q render --volume "$ml" --tf "$tf2d" --width 12 --height 10 --shading 0.2,0.7,0.3,32
same_image tf2d.exr 1e-4

echo "== compressed-brick renderer"
both bricks bricks.exr "$volcl" -q render --volume "$work/ocl/ll_marschner_brick.vcz" --tf "$tf" --width 12 \
  --height 10
same_image bricks.exr 1e-4
both bricks_tf2d bricks_tf2d.exr "$volcl" -q render --volume "$work/ocl/ll_marschner_brick.vcz" --tf "$tf2d" \
  --width 12 --height 10
same_image bricks_tf2d.exr 1e-4
both bricks_iso bricks_iso.exr "$volcl" -q render --volume "$work/ocl/ll_marschner_brick.vcz" --tf "$tf" \
  --width 12 --height 10 --mode iso --iso 0.5
same_image bricks_iso.exr 1e-4
# Light volumes from every brick (light_volume_slice over common/brick_sample.h, render/light_volume_bricks.cl): a
# point light inside the volume at level 0, a diagonal sun on 2-voxel cells (the lossy file's bricks at level 1).
both bricks_shadows bricks_shadows.exr "$volcl" -q render --volume "$work/ocl/ll_marschner_brick.vcz" --tf "$tf" \
  --width 12 --height 10 --shading 0.2,0.7,0.3,32 --shadows --light point:4,3,5
both bricks_shadows_l1 bricks_shadows_l1.exr "$volcl" -q render --volume "$work/ocl/ly_brick.vcz" --tf "$tf" \
  --width 12 --height 10 --shading 0.2,0.7,0.3,32 --shadows --light dir:1,1,1 --light-volume-cell 2 --stats
grep -q "bricks at level 1" "$work/ocl/bricks_shadows_l1.out" ||
  fail "bricks_shadows_l1: the light volume did not read level 1"
same_image bricks_shadows.exr 1e-4
same_image bricks_shadows_l1.exr 1e-4
# Shaded from the bricks' gradient cache (brick_gradient_build, the packet kernel's brick lookup): at level 0, then
# lod auto on the uint8 blob (integer lifting has levels: its 4 bricks drawn at level 1), trilinear and nearest.
both bricks_cache bricks_cache.exr "$volcl" -q render --volume "$work/ocl/ll_marschner_brick.vcz" --tf "$tf" \
  --width 12 --height 10 --shading 0.2,0.7,0.3,32 --gradient cache
for g in cache cache-nearest; do
  both "bricks_${g}_auto" "bricks_${g}_auto.exr" "$volcl" -q render --volume "$work/ocl/ll_blob_brick.vcz" \
    --tf "$tf" --width 12 --height 10 --shading 0.2,0.7,0.3,32 --gradient "$g" --lod auto --lod-error 0.5
done
for i in bricks_cache bricks_cache_auto bricks_cache-nearest_auto; do
  same_image "$i.exr" 1e-4
done

echo "== tetrahedral meshes: cell ray caster, k-buffer (radix sort), projected tetrahedra"
M=("$volcl" -q render --volume "$work/in/cubes.vtk" --tf "$tf" --width 12 --height 10 --view iso --table-size 16
  --table-lengths 4)
# At Oclgrind's default -Oz, first_entry's `found = sn.x <= sn.y` becomes a vector compare whose lane Oclgrind
# reads as 255, not 1 (tests/oclgrind/vector_compare_lane.cl), and 16 of the 120 pixels stay empty; -O2 keeps it
# scalar.
OCLGRIND_BUILD_OPTIONS=-O2 both cells cells.exr "${M[@]}" --method cells
OCLGRIND_BUILD_OPTIONS=-O2 both cells_emission cells_emission.exr "${M[@]}" --method cells --mode emission \
  --crop-box 0.2,0.1,0.3:1.6,1.8,1.5
# The k-buffer with the device radix sort (centroid) and with the default face order of this convex mesh (the
# host's MPVO order through kb_gather).
both kbuffer kbuffer.exr "${M[@]}" --method kbuffer --k 4 --sort centroid
both kbuffer_order kbuffer_order.exr "${M[@]}" --method kbuffer --k 2
# Projected tetrahedra: the tile rectangles, the k-buffer's binning and the tile compositing, with a clip plane.
both pt pt.exr "${M[@]}" --method pt --sort centroid --clip 1,0.3,0,-0.4
same_image cells.exr 1e-4
same_image cells_emission.exr 1e-4
same_image kbuffer.exr 1e-4
same_image kbuffer_order.exr 1e-4
same_image pt.exr 1e-4
# Mode iso: two transparent layers lit by the head light, the k-buffer's KB_ISO raster (faces per fragment,
# smooth vertex normals, SHADING). The cell caster's iso mode is not here: at -O2 Oclgrind 21.10 creates no
# mesh_cells kernel with MODE 2 (CL_INVALID_KERNEL_NAME) and at -Oz it meets the vector-compare defect above.
ISO=(--mode iso --iso 0.3:1,0.7,0.4,0.5 --iso 0.6:0.4,0.6,1,0.6)
both kbuffer_iso kbuffer_iso.exr "${M[@]}" --method kbuffer --k 4 "${ISO[@]}"
same_image kbuffer_iso.exr 1e-4

echo "== tetrahedral meshes whose tets may overlap: the cell caster's union walk (MESH_OVERLAPS)"
# Two blocks whose boxes overlap and that share no face (make_inputs.py): --stats says whether the renderer took
# the mesh as possibly overlapping, which compiles mesh_cells with MESH_OVERLAPS.
OCLGRIND_BUILD_OPTIONS=-O2 both cells_overlap cells_overlap.exr "$volcl" -q render --volume \
  "$work/in/overlapping_blocks.vtk" --tf "$tf" --width 12 --height 10 --view iso --method cells --stats
grep -q "tets may overlap" "$work/ocl/cells_overlap.out" ||
  fail "cells_overlap: the mesh was not taken as possibly overlapping (no MESH_OVERLAPS)"
same_image cells_overlap.exr 1e-4

echo "== coverage: every kernel in cl/ ran on Oclgrind"
ran=$(cat "$work"/ocl/*.out | grep -o "Instructions executed for kernel '[A-Za-z0-9_]*'" | cut -d"'" -f2 | sort -u)
for k in $(grep -rhoE 'kernel( __attribute__\(\(.*\)\))? void [A-Za-z0-9_]+' "$here/../../cl" | awk '{print $NF}' |
  sort -u); do
  grep -qx "$k" <<<"$ran" || fail "kernel $k never ran on Oclgrind"
done

echo "== the Oclgrind defects the kernels work around (tests/oclgrind/*.cl)"
bash "$here/check_reproducers.sh" "$work/icd" || fail "check_reproducers.sh"

if ((${#uninit[@]} > 0)); then
  echo "== the sweep's reports: case, count, kind, kernel, source line"
  for f in "$work"/ocl/*.oclgrind.log; do
    [[ -e $f ]] || continue
    # A report is a line starting with a capital, then its Kernel: and At line ... of FILE lines.
    awk -v c="$(basename "$f" .oclgrind.log)" '
      /^[A-Z]/ { kind = $0; sub(/ address 0x[0-9a-f]*$/, "", kind); k = ""; next }
      /^\tKernel: / { k = $2 }
      /^\tAt line / && k != "" { src = $NF; sub(/:$/, "", src); n[kind "\t" k "\t" src ":" $3]++; k = "" }
      END { for (r in n) printf "  %s\t%d\t%s\n", c, n[r], r }' "$f" | sort
  done
fi

if ((failures > 0)); then
  echo "$failures failure(s); outputs in $work" >&2
  exit 1
fi
echo "every kernel family ran on Oclgrind with no report and matched"
