#!/usr/bin/env bash
# Distributed .vcz decoding under MPI: 2 ranks decode disjoint brick slabs that gather to the 1-rank decode,
# at full resolution and at level 1; a missing file fails cleanly.
# Usage: mpi_decode.sh MPIEXEC VCZ_MPI_DECODE WORK_DIR
set -euo pipefail
mpiexec=$1 exe=$2 work=$3
rm -rf "$work" && mkdir -p "$work" && cd "$work"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
"$exe" make field.vcz 96 80 128
for level in 0 1; do
  "$mpiexec" -n 2 --oversubscribe "$exe" field.vcz --level "$level" --check | tee out.txt
  grep -q "slabs equal the 1-rank decode" out.txt
  # 96x80x128 in 32^3 bricks: 3x3x4 = 36 bricks, two layers of 18 per rank.
  [[ $(grep -c "bricks 18 of 36" out.txt) == 2 ]] || { echo "bricks not split 18/18" >&2; exit 1; }
done
if "$mpiexec" -n 1 --oversubscribe "$exe" missing.vcz 2>err.txt; then echo "missing file decoded" >&2; exit 1; fi
grep -q "missing.vcz" err.txt
