"""h5py-mpi: every rank writes its slab of a volcl-compressed dataset collectively; a read checks it bit-exact.

Usage: mpiexec -n N python3 h5py_mpi_roundtrip.py write|read FILE.h5   (HDF5_PLUGIN_PATH names the plugin)
"""
import sys

import h5py
import numpy as np
from mpi4py import MPI

SHAPE, CHUNKS = (64, 48, 40), (16, 48, 40)


def expected(z0, z1):
    z, y, x = np.indices((z1 - z0,) + SHAPE[1:])
    return ((z + z0) * 1000 + y * 37 + (x * x) % 101).astype(np.uint16)


def main():
    mode, path = sys.argv[1], sys.argv[2]
    comm = MPI.COMM_WORLD
    layers = SHAPE[0] // CHUNKS[0]
    z0 = layers * comm.rank // comm.size * CHUNKS[0]
    z1 = layers * (comm.rank + 1) // comm.size * CHUNKS[0]
    with h5py.File(path, "w" if mode == "write" else "r", driver="mpio", comm=comm) as f:
        if mode == "write":
            d = f.create_dataset("v", SHAPE, np.uint16, chunks=CHUNKS, compression=420)
            with d.collective:  # filtered datasets are written collectively
                d[z0:z1] = expected(z0, z1)
            ok = True
        else:
            d = f["v"]
            with d.collective:
                got = d[z0:z1]
            ok = np.array_equal(got, expected(z0, z1))
    ok = comm.allreduce(ok, op=MPI.LAND)
    if comm.rank == 0:
        print(f"h5py-mpi {mode} ranks={comm.size} {'ok' if ok else 'MISMATCH'}")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
