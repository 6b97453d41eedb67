#!/usr/bin/env bash
# Runs a command with DISPLAY on a private Xvfb server (Mesa llvmpipe), stopped afterwards. Xvfb -displayfd
# picks a free display number itself, so concurrent runs never share one (xvfb-run -a can pick a number
# another job's server just took, and that server going away aborts pvbatch). -noreset: by default the
# server resets when its last client leaves, and a pvbatch connecting during the reset aborts (2 of 8
# back-to-back runs did here). Usage: with_xvfb.sh CMD...
set -euo pipefail
dir=$(mktemp -d)
Xvfb -displayfd 3 -screen 0 640x480x24 -nolisten tcp -noreset 3>"$dir/display" 2>"$dir/log" &
server=$!
trap 'kill "$server" 2>/dev/null || true; wait "$server" 2>/dev/null || true; rm -rf "$dir"' EXIT
for _ in $(seq 1 100); do
  [[ -s "$dir/display" ]] && break
  kill -0 "$server" 2>/dev/null || { echo "with_xvfb.sh: Xvfb failed: $(tail -1 "$dir/log")" >&2; exit 1; }
  sleep 0.1
done
[[ -s "$dir/display" ]] || { echo "with_xvfb.sh: Xvfb gave no display within 10 s" >&2; exit 1; }
DISPLAY=:$(head -1 "$dir/display") "$@" || { rc=$?; cat "$dir/log" >&2; exit $rc; }
