#!/usr/bin/env bash
# The full form of the out-of-core test: a 1280 MiB volume (4x a 320 MiB limit) encoded, listed, rendered
# and viewed headless, each command's peak RSS under the limit (tests/outofcore/out_of_core.py), pinned to
# one core at normal priority.
# Usage: bench/out_of_core.sh BUILD_DIR OUT.log [LIMIT_MB] [CACHE_MB]
set -euo pipefail
build=$1; out=$2; limit=${3:-320}; cache=${4:-64}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
here=$(cd "$(dirname "$0")/.." && pwd)
taskset -c 0 python3 "$here/tests/outofcore/out_of_core.py" "$build/volcl" "$tmp" --limit-mb "$limit" \
  --factor 4 --cache-mb "$cache" --log "$tmp/log" || status=$?
sed "s|$tmp/||g" "$tmp/log" > "$out"
exit ${status:-0}
