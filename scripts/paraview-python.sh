#!/usr/bin/env bash
# Unpacks python3-paraview (pvbatch's Python modules) into build/paraview-python, never into the system:
# Debian's python3-paraview conflicts with python3-vtk9 (both ship the vtkmodules package), which the
# project's VTK peers need. pvbatch then runs with PYTHONPATH=build/paraview-python/usr/lib/python3/dist-packages.
# Quiet and quick when the unpacked version matches the installed paraview; does nothing without paraview.
# Usage: scripts/paraview-python.sh [DEST]   (DEST defaults to build/paraview-python)
set -euo pipefail
cd "$(dirname "$0")/.."
dest=${1:-build/paraview-python}
version=$(dpkg-query -W -f='${Version}' paraview 2>/dev/null || true)
[[ -n "$version" ]] || exit 0
stamp="$dest/.version"
[[ -f "$stamp" && "$(cat "$stamp")" == "$version" && -f "$dest/usr/lib/python3/dist-packages/paraview/simple.py" ]] &&
  exit 0
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# apt-get download writes into the current directory and needs no root; the same version as paraview (the
# modules are built against its libraries).
fetch() { (cd "$work" && apt-get download -qq "python3-paraview=$version" >/dev/null 2>"$work/err"); }
if ! fetch; then
  # Package lists cleaned since paraview was installed: refresh them once (root or sudo) and retry.
  sudo=""
  [[ $(id -u) -ne 0 ]] && command -v sudo >/dev/null && sudo="sudo"
  $sudo apt-get update -qq >/dev/null 2>&1 || true
  fetch || { echo "setup: apt-get download python3-paraview=$version failed: $(tail -1 "$work/err")" >&2; exit 1; }
fi
rm -rf "$dest"
mkdir -p "$dest"
dpkg -x "$work"/python3-paraview_*.deb "$dest"
echo "$version" >"$stamp"
