#!/usr/bin/env bash
# The Oclgrind 21.10 defects volcl's kernels work around, each still shown by its reproducer, workaround right.
# Usage: check_reproducers.sh ICD_DIR  (ICD_DIR: a folder holding only Oclgrind's .icd file; exit 1 when a defect is gone, so its workaround and docs/reliability.md entry
# can go, or when a workaround form no longer gives the right result).
set -uo pipefail
cd "$(dirname "$0")"
failures=0
fail() {
  echo "FAIL: $*" >&2
  failures=$((failures + 1))
}
# dumped NAME ARG: the values oclgrind-kernel dumps for argument ARG, space-separated.
dumped() { awk -v a="$2" '$1 ~ "^"a"\\[[0-9]+\\]$" && $2 == "=" {printf "%s ", $3}' <<<"$1"; }

# Integer clamp of an int8 with scalar bounds: wrong past lane 0; vector bounds right.
out=$(oclgrind-kernel int_clamp_scalar.sim 2>&1)
[[ $(dumped "$out" vectorBounds) == "2 2 2 3 4 4 4 4 " ]] || fail "int_clamp_scalar: vector bounds: $(dumped "$out" vectorBounds)"
[[ $(dumped "$out" scalarBounds) != "2 2 2 3 4 4 4 4 " ]] || fail "int_clamp_scalar: the scalar-bound defect is gone"

# One lane of a vector compare as a bool: 255 at Oclgrind's default -Oz, 1 at -O2.
out=$(oclgrind-kernel vector_compare_lane.sim 2>&1)
[[ $(dumped "$out" out) == "255 255 255 255 " ]] || fail "vector_compare_lane -Oz: the defect is gone: $(dumped "$out" out)"
out=$(oclgrind-kernel --build-options -O2 vector_compare_lane.sim 2>&1)
[[ $(dumped "$out" out) == "1 1 1 1 " ]] || fail "vector_compare_lane -O2: $(dumped "$out" out)"

# fmax of float16 halves: a false uninitialised report, optimised or not; the scalar tree has none.
for opt in "" -cl-opt-disable; do
  out=$(oclgrind-kernel --uninitialized ${opt:+--build-options $opt} fmax_half_vectors.sim 2>&1)
  [[ $(dumped "$out" halves) == "16 " && $(dumped "$out" scalars) == "16 " ]] || fail "fmax_half_vectors $opt: results"
  n=$(grep -c "uninitialized value" <<<"$out")
  lines=$(grep -o "At line [0-9]*" <<<"$out" | sort -u | tr '\n' ' ')
  [[ $n -ge 1 && $lines == "At line 7 " ]] || fail "fmax_half_vectors $opt: expected reports at line 7 only, got $n: $lines"
done

# A float4 built from scalars and assigned: a false uninitialised write when optimised; vstore4 has none.
out=$(oclgrind-kernel --uninitialized vector_store_split.sim 2>&1)
lines=$(grep -o "At line [0-9]*" <<<"$out" | sort -u | tr '\n' ' ')
[[ $lines == "At line 11 " ]] || fail "vector_store_split: expected reports at line 11 only, got: $lines"
[[ $(dumped "$out" stored) == "$(dumped "$out" assigned)" ]] || fail "vector_store_split: the two stores differ"
out=$(oclgrind-kernel --uninitialized --build-options -cl-opt-disable vector_store_split.sim 2>&1)
grep -q "^Uninitialized" <<<"$out" && fail "vector_store_split: a report without optimisation"

# Buffers made with CL_MEM_USE_HOST_PTR or filled by clEnqueueFillBuffer read as uninitialised; those made with
# CL_MEM_COPY_HOST_PTR or written by clEnqueueWriteBuffer do not (a host program).
exe=$(mktemp -d)/host_buffers
if cc -std=c11 -o "$exe" host_buffers.c -lOpenCL; then
  for mode in use fill copy write; do
    out=$(OCL_ICD_VENDORS=$1 OCLGRIND_UNINITIALIZED=1 "$exe" "$mode" 2>&1)
    n=$(grep -ci "uninitialized value" <<<"$out")
    [[ $(tail -1 <<<"$out") == 4 ]] || fail "host_buffers $mode: result $(tail -1 <<<"$out")"
    case $mode in
      use | fill) ((n >= 1)) || fail "host_buffers $mode: the false report is gone" ;;
      *) ((n == 0)) || fail "host_buffers $mode: $n reports" ;;
    esac
  done
else
  fail "host_buffers.c does not build"
fi

# A buffer's uninitialised-value record is sized by its last host write, or kept from a released buffer of the same
# number: the work-items whose loads lie past it report (a host program; in any order, Oclgrind runs work-groups
# on several threads).
if cc -std=c11 -o "$exe.shadow" buffer_shadow_size.c -lOpenCL; then
  for expect in "split:8 9 10 11 12 13 14 15 " "whole:" "reuse:2 3 4 5 6 7 8 9 10 11 12 13 14 15 " "fresh:"; do
    mode=${expect%%:*}
    out=$(OCL_ICD_VENDORS=$1 OCLGRIND_UNINITIALIZED=1 "$exe.shadow" "$mode" 2>&1)
    [[ $(tail -1 <<<"$out") == equal ]] || fail "buffer_shadow_size $mode: result $(tail -1 <<<"$out")"
    items=$(grep -A2 "^Uninitialized value" <<<"$out" | grep -o "Global([0-9]*" | cut -d"(" -f2 | sort -n | tr "\\n" " ")
    [[ $(grep -c "^[A-Z]" <<<"$out") == $(wc -w <<<"${expect#*:}") && $items == "${expect#*:}" ]] ||
      fail "buffer_shadow_size $mode: expected reports from work-items [${expect#*:}], got [$items]"
  done
else
  fail "buffer_shadow_size.c does not build"
fi

((failures == 0)) || exit 1
echo "the Oclgrind defects are as documented"
