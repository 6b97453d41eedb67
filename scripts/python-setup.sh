#!/usr/bin/env bash
# Makes the Python venv build/venv (PyPI: the build backend, nanobind, numpy, the test packages) and installs
# the volcl package into it from this checkout (pip install .), reusing the build/ tree scripts/setup.sh made
# (a plain `pip install .` builds in a temporary directory instead).
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
# The wheel is built in build/ (pyproject.toml's default is a temporary directory), with build/'s generator
# and options: the library and the executable scripts/setup.sh compiled are reused and only the module
# compiles. Options pyproject.toml turns off for a plain `pip install .` keep build/'s values (CMake's
# defaults when build/ is not configured yet), so this install never drops tests or plugins from build/.
config=(--config-settings=build-dir=build "--config-settings=cmake.args=-GUnix Makefiles")
for option in VOLCL_BUILD_TESTS:ON VOLCL_BUILD_BENCH:ON VOLCL_BUILD_PLUGINS:ON VOLCL_FUZZ:OFF; do
  name=${option%%:*}
  value=${option#*:}
  if [[ -f build/CMakeCache.txt ]]; then
    cached=$(sed -n "s/^$name:BOOL=//p" build/CMakeCache.txt)
    value=${cached:-$value}
  fi
  config+=("--config-settings=cmake.define.$name=$value")
done
# Makefiles build one file at a time unless told: as many jobs as cores.
export CMAKE_BUILD_PARALLEL_LEVEL=${CMAKE_BUILD_PARALLEL_LEVEL:-$(nproc 2>/dev/null || echo 2)}
"$venv/bin/python" -m pip install "${quiet[@]}" --disable-pip-version-check --no-build-isolation "${config[@]}" \
  ".[test]"
