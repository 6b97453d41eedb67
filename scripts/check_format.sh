#!/usr/bin/env bash
# Checks that every tracked C, C++ and OpenCL C file is formatted as .clang-format says (clang-format 14).
# Usage: scripts/check_format.sh [--fix]   (--fix formats the files in place)
set -euo pipefail
cd "$(dirname "$0")/.."
mapfile -t files < <(git ls-files '*.c' '*.h' '*.cpp' '*.hpp' '*.cxx' '*.cl')
if [[ "${1:-}" == "--fix" ]]; then
  clang-format -i "${files[@]}"
  exit 0
fi
report=$(clang-format --dry-run --Werror "${files[@]}" 2>&1) && status=0 || status=$?
if (( status != 0 )); then
  grep -E '^[^ ].*: (warning|error):' <<<"$report" | cut -d: -f1 | sort -u | sed 's/^/not formatted: /'
  echo "run scripts/check_format.sh --fix" >&2
  exit 1
fi
echo "format: ${#files[@]} files as .clang-format says"
