#!/usr/bin/env bash
# Makes build/sz3-venv, the Python environment of the SZ3 peer in the series benchmark (bench/sz3_series.py):
# SZ3 from PyPI (pysz, pinned) and numpy. Benchmark only: nothing in the build or the tests needs it.
# Quiet and quick when the venv already holds the pinned version.
# Usage: scripts/sz3-venv.sh [DEST]   (DEST defaults to build/sz3-venv)
set -euo pipefail
cd "$(dirname "$0")/.."
dest=${1:-build/sz3-venv}
pin="pysz==1.1.0"
if [[ -x "$dest/bin/python" ]] && "$dest/bin/python" -c 'import importlib.metadata as m, sys; sys.exit(m.version("pysz") != "1.1.0")' 2>/dev/null; then
  exit 0
fi
/usr/bin/python3 -m venv "$dest"
"$dest/bin/python" -m pip install -q --disable-pip-version-check "$pin" numpy
