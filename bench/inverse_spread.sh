#!/usr/bin/env bash
# Spread of the batched inverse transform between fresh processes: runs volcl-bench-inverse N times on each
# FILE.vcz (alternating the files, and the builds when BUILDS lists several build directories), and prints
# per process the median wall ms, median process CPU ms and the load average.
# Usage: bench/inverse_spread.sh N FILE.vcz... ; BUILDS="dirA dirB" to alternate builds (default: build/).
set -euo pipefail
n=$1
shift
builds=${BUILDS:-build}
for ((i = 0; i < n; ++i)); do
    for f in "$@"; do
        for b in $builds; do
            out=$(LD_LIBRARY_PATH="$b" "$b/bench/volcl-bench-inverse" "$f" 9 | grep 'inverse wall')
            wall=$(sed -E 's/.*median ([0-9.]+) min.*/\1/' <<<"$out")
            cpu=$(sed -E 's/.*process CPU median ([0-9.]+);.*/\1/' <<<"$out")
            echo "$b $(basename "$f") wall $wall cpu $cpu load $(cut -d' ' -f1 /proc/loadavg)"
        done
    done
done
