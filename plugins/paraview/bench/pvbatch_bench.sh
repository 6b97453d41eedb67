#!/usr/bin/env bash
# The ParaView reader at 1 and 2 pvbatch ranks against vcz-mpi-decode (the same decode without ParaView) on
# the same file: per rank the bricks decoded, decode and exchange time, then the update and render times,
# warm (kernels built, file read), runs interleaved 1, 2, 1, 2, ... One core per rank: PoCL and llvmpipe
# one thread each, the 1-rank runs pinned to one core.
# Usage: plugins/paraview/bench/pvbatch_bench.sh BUILD_DIR OUT.csv [REPEATS] [N]   (N^3 uint16 volume)
set -euo pipefail
build=$(cd "$1" && pwd); out=$2; reps=${3:-3}; n=${4:-192}
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../../.." && pwd)
plugin=$build/lib/volcl/paraview/VolclReader/VolclReader.so
maker=$build/plugins/paraview/vcz-mpi-decode
script=$src/tests/paraview/pvbatch_render.py
if [[ -z "${DISPLAY_OF_TEST:-}" ]]; then # a private Xvfb display (Debian's pvbatch renders through GLX only)
  exec env DISPLAY_OF_TEST=1 bash "$src/tests/paraview/with_xvfb.sh" bash "$0" "$@"
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export PYTHONPATH=$build/paraview-python/usr/lib/python3/dist-packages OMPI_ALLOW_RUN_AS_ROOT=1 \
  OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none POCL_MAX_PTHREAD_COUNT=1 \
  LP_NUM_THREADS=1
"$maker" make "$tmp/field.vcz" "$n" "$n" "$n"
echo "tool,ranks,run,level,rank,bricks,file_bricks,decode_ms,exchange_ms,read_ms,update_s,render_s,load" >"$out"
load() { cut -d' ' -f1 /proc/loadavg; }
for r in $(seq 1 "$reps"); do
  for ranks in 1 2; do
    if (( ranks == 1 )); then launch=(taskset -c 0); else launch=(mpiexec -n 2 --oversubscribe); fi
    flags=(); (( ranks == 1 )) || flags=(--mpi)
    "${launch[@]}" pvbatch "${flags[@]}" "$script" "$plugin" "$tmp/field.vcz" "$tmp/img.png" "$tmp/r.json" \
      --bench 2 >/dev/null 2>"$tmp/err" || { cat "$tmp/err" >&2; exit 1; }
    /usr/bin/python3 - "$tmp/r.json" "$ranks" "$r" "$(load)" >>"$out" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); ranks, run, load = sys.argv[2:]
for w in d["warm"][-2:]:  # the last round: level+1, then the level itself
    for p in w["pieces"]:
        print("pvbatch,%s,%s,%d,%d,%d,%d,%.1f,%.2f,%.1f,%.3f,%.3f,%s" % (ranks, run, w["level"], p["piece"],
              p["bricks"], p["file_bricks"], p["decode_ms"], p["exchange_ms"], p["read_ms"], w["update_s"],
              w["render_s"], load))
PY
    for level in 0 1; do
      "${launch[@]}" "$maker" "$tmp/field.vcz" --level "$level" >"$tmp/peer.txt"
      /usr/bin/python3 - "$tmp/peer.txt" "$ranks" "$r" "$level" "$(load)" >>"$out" <<'PY'
import re, sys
ranks, run, level, load = sys.argv[2:]
for line in open(sys.argv[1]):
    m = re.match(r"rank (\d+) extent z \[\d+, \d+\) bricks (\d+) of (\d+) read_ms ([\d.]+) decode_ms ([\d.]+)", line)
    if m:
        print("vcz-mpi-decode,%s,%s,%s,%s,%s,%s,%s,,%s,,,%s" % (ranks, run, level, m[1], m[2], m[3], m[5], m[4], load))
PY
    done
  done
done
echo "wrote $out"
