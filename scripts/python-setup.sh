#!/usr/bin/env bash
# Makes the Python venv build/venv (PyPI: the build backend, nanobind, numpy, the test packages) and installs
# the volcl package into it from this checkout (pip install .), reusing the build/ tree scripts/setup.sh made.
# Usage: scripts/python-setup.sh [--quiet]. Afterwards: build/venv/bin/python -c "import volcl".
set -euo pipefail
cd "$(dirname "$0")/.."
quiet=()
[[ "${1:-}" == "--quiet" ]] && quiet=(-q)

# Debian's interpreter (python3-venv, python3-dev): the one scripts/apt-packages.txt installs headers for.
python=/usr/bin/python3
[[ -x "$python" ]] || python=python3
venv=build/venv
if [[ ! -x "$venv/bin/python" ]]; then
  "$python" -m venv "$venv"
  "$venv/bin/python" -m pip install "${quiet[@]}" --disable-pip-version-check --upgrade pip
fi
# The build requirements (pyproject.toml's build-system.requires) go into the venv so pip builds without an
# isolated environment: the build tree then records the venv's interpreter and nanobind, which stay valid
# for later builds of the same tree. The test extra brings pytest, numcodecs, zarr and zfpy.
mapfile -t requires < <("$venv/bin/python" -c \
  'import tomllib; print("\n".join(tomllib.load(open("pyproject.toml", "rb"))["build-system"]["requires"]))')
"$venv/bin/python" -m pip install "${quiet[@]}" --disable-pip-version-check "${requires[@]}"
"$venv/bin/python" -m pip install "${quiet[@]}" --disable-pip-version-check --no-build-isolation ".[test]"
