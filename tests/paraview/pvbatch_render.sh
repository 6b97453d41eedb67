#!/usr/bin/env bash
# The ParaView reader plugin in pvbatch: a 2-rank volume render of a .vcz equals the 1-rank render within the
# compositing tolerance (check_render.py) and each rank decodes exactly the bricks of its slab (the reader's
# count); a .vcz of one brick on 2 ranks; a corrupt header and a corrupt brick fail with one line naming the
# file, no crash and no hang.
# Usage: pvbatch_render.sh MPIEXEC VCZ_MPI_DECODE PLUGIN PARAVIEW_PYTHONPATH TEST_DIR WORK_DIR
set -euo pipefail
mpiexec=$1 maker=$2 plugin=$3 pvpython=$4 here=$5 work=$6
[[ -f "$pvpython/paraview/simple.py" ]] ||
  { echo "pvbatch_render.sh: no paraview.simple under $pvpython: run scripts/setup.sh" >&2; exit 1; }
# Debian's pvbatch renders through GLX only (no EGL or OSMesa build): every rank draws on one Xvfb display
# (Mesa llvmpipe), started here for the whole test.
if [[ -z "${VOLCL_PVBATCH_XVFB:-}" ]]; then
  exec env VOLCL_PVBATCH_XVFB=1 xvfb-run -a -s "-screen 0 640x480x24" bash "$0" "$@"
fi
rm -rf "$work" && mkdir -p "$work" && cd "$work"
export PYTHONPATH=$pvpython OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
  OMPI_MCA_btl_vader_single_copy_mechanism=none
script=$here/pvbatch_render.py
check() { /usr/bin/python3 "$here/check_render.py" "$@"; }
one() { timeout 300 pvbatch "$script" "$plugin" "$@"; }
two() { timeout 300 "$mpiexec" -n 2 --oversubscribe pvbatch --mpi "$script" "$plugin" "$@"; }

# 96x80x128 in 32^3 bricks: 3x3x4 = 36 bricks; on 2 ranks two brick layers (18 bricks) each.
"$maker" make field.vcz 96 80 128
one field.vcz one.png one.json
check bricks one.json 36
two field.vcz two.png two.json
check bricks two.json 18,18
check images one.png two.png

# Fewer bricks than ranks: 24x20x16 is one brick; the ranks split its samples and both decode it.
"$maker" make tiny.vcz 24 20 16
one tiny.vcz tiny1.png tiny1.json
check bricks tiny1.json 1
two tiny.vcz tiny2.png tiny2.json
check bricks tiny2.json 1,1
check images tiny1.png tiny2.png

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
