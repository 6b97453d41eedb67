#!/usr/bin/env bash
# Parallel HDF5 through the volcl filter: 2 MPI ranks write one dataset collectively, 1 and 2 ranks read it
# back (lossless: bit-exact; max-error: within the bound). Optionally the same from h5py-mpi.
# Usage: parallel_roundtrip.sh MPIEXEC PLUGIN_DIR PARALLEL_EXE WORK_DIR [PYTHON H5PY_MPI_SCRIPT]
set -euo pipefail
mpiexec=$1 plugin_dir=$2 exe=$3 work=$4 python=${5:-} script=${6:-}
rm -rf "$work" && mkdir -p "$work" && cd "$work"
# OpenMPI refuses root without both variables; containers often lack the ptrace rights of its
# single-copy transport, so shared-memory messages are copied instead.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
export HDF5_PLUGIN_PATH=$plugin_dir
mpi() { local n=$1; shift; "$mpiexec" -n "$n" --oversubscribe "$@"; }

mpi 2 "$exe" write lossless.h5 --warm --nz 96 --ny 80 --nx 72 --chunk 32
mpi 1 "$exe" read lossless.h5 --nz 96 --ny 80 --nx 72 --chunk 32
mpi 2 "$exe" read lossless.h5 --nz 96 --ny 80 --nx 72 --chunk 32
mpi 2 "$exe" write lossy.h5 --nz 64 --ny 64 --nx 64 --chunk 32 --max-error 0.002
mpi 1 "$exe" read lossy.h5 --nz 64 --ny 64 --nx 64 --chunk 32 --max-error 0.002
# A read with the wrong shape or a missing file fails cleanly.
if mpi 1 "$exe" read lossless.h5 --nz 95 --ny 80 --nx 72 --chunk 32 2>/dev/null; then
  echo "a read of the wrong shape succeeded" >&2; exit 1
fi
if [[ -n "$python" && -n "$script" ]]; then
  mpi 2 "$python" "$script" write h5py-mpi.h5
  mpi 1 "$python" "$script" read h5py-mpi.h5
fi
