#!/usr/bin/env bash
# The ParaView reader plugin in pvbatch: a 2-rank volume render of a .vcz equals the 1-rank render within the
# compositing tolerance (check_render.py) and each rank decodes exactly the bricks of its slab (the reader's
# count); a .vcz of one brick on 2 ranks; a series' time steps and frame; a corrupt header and a corrupt
# brick fail with one line naming the file, no crash and no hang.
# Usage: pvbatch_render.sh MPIEXEC VCZ_MPI_DECODE PLUGIN PARAVIEW_PYTHONPATH TEST_DIR WORK_DIR
set -euo pipefail
mpiexec=$1 maker=$2 plugin=$3 pvpython=$4 here=$5 work=$6
[[ -f "$pvpython/paraview/simple.py" ]] ||
  { echo "pvbatch_render.sh: no paraview.simple under $pvpython: run scripts/setup.sh" >&2; exit 1; }
# Debian's pvbatch renders through GLX only (no EGL or OSMesa build): every rank draws on one private Xvfb
# display (Mesa llvmpipe), started here for the whole test.
if [[ -z "${DISPLAY_OF_TEST:-}" ]]; then
  exec env DISPLAY_OF_TEST=1 bash "$here/with_xvfb.sh" bash "$0" "$@"
fi
rm -rf "$work" && mkdir -p "$work" && cd "$work"
export PYTHONPATH=$pvpython OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
  OMPI_MCA_btl_vader_single_copy_mechanism=none
script=$here/pvbatch_render.py
check() { /usr/bin/python3 "$here/check_render.py" "$@"; }
one() { timeout 300 pvbatch "$script" "$plugin" "$@"; }
two() { timeout 300 "$mpiexec" -n 2 --oversubscribe pvbatch --mpi "$script" "$plugin" "$@"; }

# A generated volume (32^3 bricks) on 1 and 2 ranks: bricks per rank, then the 2-rank image against the
# 1-rank one. Usage: renders NAME NX NY NZ BRICKS_1_RANK BRICKS_PER_RANK_ON_2 [FRAMES TIME LEVEL]
renders() {
  local name=$1 b1=$5 b2=$6 frames=${7:-1} at=()
  [[ -z "${8:-}" ]] || at=(--time "$8" --level "$9")
  "$maker" make "$name.vcz" "$2" "$3" "$4" "$frames"
  one "$name.vcz" "$name-1.png" "$name-1.json" "${at[@]}"
  check bricks "$name-1.json" "$b1"
  two "$name.vcz" "$name-2.png" "$name-2.json" "${at[@]}"
  check bricks "$name-2.json" "$b2"
  check images "$name-1.png" "$name-2.png"
}
# 96x80x128: 3x3x4 = 36 bricks; on 2 ranks two brick layers (18 bricks) each.
renders field 96 80 128 36 18,18
# Fewer bricks than ranks: 24x20x16 is one brick; the ranks split its samples and both decode it.
renders tiny 24 20 16 1 1,1
# A series of 3 frames at times 0, 10, 20 (the ball moves), at level 1 (48x40x64 in 16^3 bricks, still 36):
# ParaView gets the time steps, and at time 20 every rank decodes frame 2 at level 1.
renders series 96 80 128 36 18,18 3 20 1
check frames series-1.json 0,10,20 2 1
check frames series-2.json 0,10,20 2 1

# Corrupt files: the run exits 1 (not a signal), says which file, writes no image.
fails() { # label, expected text, command...
  local label=$1 text=$2
  shift 2
  local rc=0
  "$@" >"$label.out" 2>&1 || rc=$?
  if (( rc == 0 || rc >= 124 )); then
    echo "$label: exit code $rc (want a clean failure)" >&2; cat "$label.out" >&2; exit 1
  fi
  grep -q "$text" "$label.out" || { echo "$label: no '$text' in the output" >&2; cat "$label.out" >&2; exit 1; }
  [[ ! -e "$label.png" ]] || { echo "$label: wrote an image" >&2; exit 1; }
  echo "$label: failed cleanly (exit $rc): $(grep -m1 "$text" "$label.out")"
}
/usr/bin/python3 - field.vcz <<'PY'
import sys
data = bytearray(open(sys.argv[1], "rb").read())
header = bytearray(data); header[20] ^= 0xff            # inside the header: its checksum fails
brick = bytearray(data); brick[len(brick) - 100] ^= 0x5a  # inside the last brick (the top slab's)
open("badheader.vcz", "wb").write(header)
open("badbrick.vcz", "wb").write(brick)
PY
fails badheader "badheader.vcz: header checksum mismatch" one badheader.vcz badheader.png badheader.json
fails badbrick "badbrick.vcz: brick .* checksum mismatch" two badbrick.vcz badbrick.png badbrick.json
