#!/usr/bin/env bash
# The install a new user does, checked: `git clone` of this repository (its committed HEAD) into a temporary
# folder, `pip install` of the clone into a new venv (build requirements from PyPI, pip's temporary build
# directory), then the package used from outside the source tree: import, the `volcl` console script, the
# clone left untouched, and the zarr 3 tests (python/tests/test_zarr3.py, zarr and numcodecs from PyPI).
# Usage: scripts/python-install-check.sh [-v] (-v: pip shows CMake's progress). Prints the install time.
set -euo pipefail
cd "$(dirname "$0")/.."
verbose=(-q)
[[ "${1:-}" == "-v" ]] && verbose=(-v)
python=/usr/bin/python3
[[ -x "$python" ]] || python=python3

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
git clone --quiet "$PWD" "$tmp/volcl"
"$python" -m venv "$tmp/venv"
pip=("$tmp/venv/bin/python" -m pip --disable-pip-version-check)
start=$(date +%s)
"${pip[@]}" install "${verbose[@]}" "$tmp/volcl[test-zarr3]"
echo "pip install of a fresh clone (build requirements, compile, zarr 3 and pytest): $(($(date +%s) - start)) s"

# Nothing was written into the checkout (no build/, no egg-info): a read-only checkout installs the same way.
left=$(git -C "$tmp/volcl" status --porcelain --ignored)
[[ -z "$left" ]] || { echo "pip install wrote into the source tree:"; echo "$left"; exit 1; }

cd "$tmp"
"$tmp/venv/bin/volcl" --version
"$tmp/venv/bin/python" - <<'EOF'
import numpy as np, volcl
a = np.arange(24 * 20 * 16, dtype=np.uint16).reshape(24, 20, 16)
f = volcl.VczFile(volcl.encode(a))
assert np.array_equal(np.asarray(f), a) and np.array_equal(f[-1, ::2], a[-1, ::2])
print("volcl", volcl.__version__, "from", volcl.__file__, "on", volcl.devices()[0]["name"])
EOF
"$tmp/venv/bin/python" -m pytest -q -p no:cacheprovider "$tmp/volcl/python/tests/test_zarr3.py"
