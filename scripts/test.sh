#!/usr/bin/env bash
# Runs the whole test suite: the normal build (ctest), every kernel family on Oclgrind, the Python package (pytest),
# then the host code under ASan + UBSan and a short fuzz run.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
jobs=$(nproc 2>/dev/null || echo 2)

echo "== tests (Release build)"
ctest --test-dir build --output-on-failure -j"$jobs" --timeout 900 -LE "oclgrind|outofcore"

# ==== a volume larger than the memory it may use (a separate block, one test at a time: it measures each
# command's peak RSS; see docs/multires.md) ====
echo "== out of core: encode, info, render and view of a volume 4x what they may hold"
ctest --test-dir build --output-on-failure -L outofcore --timeout 900

# ==== kernels on Oclgrind (a separate block; see docs/reliability.md) ====
# A tiny case of every kernel family on Oclgrind, a second OpenCL implementation that checks every memory
# access and data race: any report, or any difference from PoCL beyond the stated tolerance, fails.
echo "== kernels on Oclgrind"
ctest --test-dir build --output-on-failure -L oclgrind --timeout 900

# ==== Python package (a separate block; see docs/python.md) ====
# pip install . into build/venv (reusing build/: only the module compiles), then the pytest suite, which
# compares the module with the volcl executable's outputs and runs docs/examples/python_tour.py.
echo "== Python package (pip install . into build/venv, pytest)"
bash scripts/python-setup.sh --quiet
build/venv/bin/python -m pytest -q python/tests
# The install a new user does: a fresh clone, pip install into a new venv (pip's temporary build directory,
# the library compiled again from scratch: the step's cost is in docs/python.md), then zarr 3's tests.
echo "== Python package from a fresh clone (pip install into a new venv, zarr 3)"
bash scripts/python-install-check.sh

# ==== fault injection (a separate block; see docs/reliability.md) ====
# Every writer (CLI commands and output formats, Python volcl.write) under full disks (an LD_PRELOAD shim
# failing the Nth write/fsync/close/rename/link call; a small tmpfs where a mount namespace can be made),
# SIGKILL/SIGTERM and four concurrent writers. ctest ran the short form of the CLI writers (faults_campaign);
# here the Python writers' short form, and with VOLCL_LONG=1 (nightly) the long form of every writer:
# every failing call, 10 kills per writer (over 200 in all), 5 concurrent rounds.
echo "== fault injection (Python writers$([[ "${VOLCL_LONG:-0}" == 1 ]] && echo "; long form of every writer"))"
faults=(python3 tests/faults/campaign.py --volcl build/volcl --shim build/tests/faults/libvolcl_fail_io.so
  --python build/venv/bin/python)
"${faults[@]}" --only '^python-' --work build/test-tmp/faults_python
if [[ "${VOLCL_LONG:-0}" == 1 ]]; then
  "${faults[@]}" --long --work build/test-tmp/faults_long
fi

echo "== tests (AddressSanitizer + UndefinedBehaviorSanitizer)"
# -O1: sanitizer builds compile much faster than at -O3 and still run the suite in minutes.
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=None "-DCMAKE_CXX_FLAGS=-O1 -g1" -DVOLCL_SANITIZE=ON \
  -DVOLCL_BUILD_BENCH=OFF >/dev/null
cmake --build build-asan -j"$jobs" -- --no-print-directory >/dev/null || cmake --build build-asan -j1
# Leak checking is on: a leak in volcl's code fails its test. tests/lsan.supp (set on the tests by CMake,
# and here for tests CMake does not set it on) suppresses only named third-party libraries, each with its
# reason. Memory errors and UB are fatal too. intercept_tls_get_addr=0: GCC 12's sanitizer runtime can
# mistake a malloc'd dynamic-TLS block (PoCL and LLVM use them) for an old glibc TLS header and read a wrong
# range, and LeakSanitizer's stop-the-world tracer then dies with signal 11 at exit after a passing test.
ASAN_OPTIONS=detect_leaks=1:intercept_tls_get_addr=0:abort_on_error=0:halt_on_error=1 \
UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp \
  ctest --test-dir build-asan --output-on-failure -j"$jobs" --timeout 1800

# ==== hardening: a short fuzz run (a separate block; see docs/reliability.md) ====
# The sanitizer build gains the fuzz targets (GCC: fuzz/ReplayDriver.cpp): every seed and kept regression
# input replays as a ctest test, then each target runs a fixed number of mutated inputs from a fixed seed.
echo "== fuzz corpora and short fuzz run (AddressSanitizer + UndefinedBehaviorSanitizer)"
cmake -S . -B build-asan -DVOLCL_FUZZ=ON >/dev/null
cmake --build build-asan -j"$jobs" -- --no-print-directory >/dev/null || cmake --build build-asan -j1
ASAN_OPTIONS=detect_leaks=1:intercept_tls_get_addr=0:abort_on_error=0:halt_on_error=1 \
UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j"$jobs" --timeout 600 -R '^fuzz_'
ASAN_OPTIONS=detect_leaks=1:intercept_tls_get_addr=0:abort_on_error=0:halt_on_error=1 \
UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  bash scripts/fuzz.sh --build build-asan --short
