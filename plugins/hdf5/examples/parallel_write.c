/* Parallel HDF5 through the volcl filter: all MPI ranks write one dataset collectively, any rank count reads it. */
#include "plugins/hdf5/H5Zvolcl.h"

#include <hdf5.h>
#include <mpi.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The generated field: a deterministic function of the global voxel index (smooth waves, a ball, some noise). */
static float field(hsize_t z, hsize_t y, hsize_t x) {
    uint32_t h = (uint32_t)(x * 73856093u ^ y * 19349663u ^ z * 83492791u);
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    float dx = (float)x - 80.0f, dy = (float)y - 70.0f, dz = (float)z - 60.0f;
    float ball = dx * dx + dy * dy + dz * dz < 1600.0f ? 1.0f : 0.0f;
    return 0.001f * (float)(x % 97) + 0.002f * (float)(y % 61) - 0.0015f * (float)(z % 43) + ball +
           (float)(h & 0xff) * 1e-4f;
}

struct options {
    hsize_t nz, ny, nx, chunk;
    double max_error; /* 0: lossless */
    int raw;          /* 1: no filter (measures the I/O path alone) */
    int warm;         /* 1: load the filter and build its kernels before the timed part */
};

/* Writes and reads one small chunk through the filter in an in-memory file of this rank alone, so the
   timed part excludes loading the plugin, creating the OpenCL context and building kernels. */
static int warm_filter(void) {
    hid_t fapl = H5Pcreate(H5P_FILE_ACCESS), dcpl = H5Pcreate(H5P_DATASET_CREATE),
          dapl = H5Pcreate(H5P_DATASET_ACCESS);
    hsize_t dims[3] = {16, 16, 16};
    float data[16 * 16 * 16];
    for (int i = 0; i < 16 * 16 * 16; ++i)
        data[i] = (float)(i % 37);
    H5Pset_fapl_core(fapl, 1 << 20, 0);
    H5Pset_chunk(dcpl, 3, dims);
    H5Pset_volcl_lossless(dcpl);
    H5Pset_chunk_cache(dapl, H5D_CHUNK_CACHE_NSLOTS_DEFAULT, 0,
                       1.0); /* no chunk cache: the write encodes, the read decodes */
    hid_t f = H5Fcreate("volcl-warm", H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
    hid_t s = H5Screate_simple(3, dims, NULL);
    hid_t d = H5Dcreate2(f, "w", H5T_IEEE_F32LE, s, H5P_DEFAULT, dcpl, dapl);
    int ok = d >= 0 && H5Dwrite(d, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0 &&
             H5Dread(d, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0;
    if (d >= 0) H5Dclose(d);
    H5Sclose(s);
    if (f >= 0) H5Fclose(f);
    H5Pclose(dapl);
    H5Pclose(dcpl);
    H5Pclose(fapl);
    return ok;
}

/* This rank's slab of whole chunk layers along z: [*z0, *z1). */
static void slab(const struct options* o, int rank, int size, hsize_t* z0, hsize_t* z1) {
    hsize_t layers = (o->nz + o->chunk - 1) / o->chunk;
    hsize_t first = layers * (hsize_t)rank / (hsize_t)size,
            last = layers * (hsize_t)(rank + 1) / (hsize_t)size;
    *z0 = first * o->chunk < o->nz ? first * o->chunk : o->nz;
    *z1 = last * o->chunk < o->nz ? last * o->chunk : o->nz;
}

static hid_t open_file(const char* path, int create) {
    hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
    H5Pset_fapl_mpio(fapl, MPI_COMM_WORLD, MPI_INFO_NULL);
    hid_t f =
        create ? H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, fapl) : H5Fopen(path, H5F_ACC_RDONLY, fapl);
    H5Pclose(fapl);
    return f;
}

/* Selects this rank's slab in `fspace` and returns a memory space for it (none selected when empty). */
static hid_t select_slab(hid_t fspace, const struct options* o, hsize_t z0, hsize_t z1) {
    hsize_t start[3] = {z0, 0, 0}, count[3] = {z1 - z0, o->ny, o->nx};
    if (z1 == z0) {
        H5Sselect_none(fspace);
        hsize_t one = 1;
        hid_t m = H5Screate_simple(1, &one, NULL);
        H5Sselect_none(m);
        return m;
    }
    H5Sselect_hyperslab(fspace, H5S_SELECT_SET, start, NULL, count, NULL);
    return H5Screate_simple(3, count, NULL);
}

static int run(const char* mode, const char* path, const struct options* o, int rank, int size) {
    hsize_t z0, z1;
    slab(o, rank, size, &z0, &z1);
    const size_t n = (size_t)(z1 - z0) * o->ny * o->nx;
    float* data = malloc(sizeof(float) * (n ? n : 1));
    if (!data) return 1;
    const int writing = strcmp(mode, "write") == 0;
    if (writing)
        for (hsize_t z = z0; z < z1; ++z)
            for (hsize_t y = 0; y < o->ny; ++y)
                for (hsize_t x = 0; x < o->nx; ++x)
                    data[((z - z0) * o->ny + y) * o->nx + x] = field(z, y, x);

    if (o->warm && !warm_filter()) {
        fprintf(stderr, "h5z-volcl-parallel: rank %d: the volcl filter failed on a test chunk\n", rank);
        free(data);
        return 1;
    }
    MPI_Barrier(MPI_COMM_WORLD);
    const double t0 = MPI_Wtime();
    hid_t file = open_file(path, writing);
    hid_t dset = -1, fspace = -1;
    int ok = file >= 0;
    if (ok && writing) {
        hsize_t dims[3] = {o->nz, o->ny, o->nx}, chunk[3] = {o->chunk, o->chunk, o->chunk};
        for (int i = 1; i < 3; ++i)
            if (chunk[i] > dims[i]) chunk[i] = dims[i];
        hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
        H5Pset_chunk(dcpl, 3, chunk);
        /* No fill values: every chunk is written, and none need compressing at creation. */
        H5Pset_fill_time(dcpl, H5D_FILL_TIME_NEVER);
        if (!o->raw)
            ok = (o->max_error > 0 ? H5Pset_volcl_max_error(dcpl, o->max_error)
                                   : H5Pset_volcl_lossless(dcpl)) >= 0;
        fspace = H5Screate_simple(3, dims, NULL);
        dset = ok ? H5Dcreate2(file, "field", H5T_IEEE_F32LE, fspace, H5P_DEFAULT, dcpl, H5P_DEFAULT) : -1;
        H5Pclose(dcpl);
    } else if (ok) {
        dset = H5Dopen2(file, "field", H5P_DEFAULT);
        fspace = dset >= 0 ? H5Dget_space(dset) : -1;
        hsize_t dims[3] = {0, 0, 0};
        if (fspace < 0 || H5Sget_simple_extent_ndims(fspace) != 3)
            ok = 0;
        else
            H5Sget_simple_extent_dims(fspace, dims, NULL);
        if (dims[0] != o->nz || dims[1] != o->ny || dims[2] != o->nx) ok = 0;
    }
    ok = ok && dset >= 0;
    if (ok) {
        hid_t mspace = select_slab(fspace, o, z0, z1);
        hid_t dxpl = H5Pcreate(H5P_DATASET_XFER);
        H5Pset_dxpl_mpio(dxpl, H5FD_MPIO_COLLECTIVE); /* filtered datasets are written collectively */
        ok = (writing ? H5Dwrite(dset, H5T_NATIVE_FLOAT, mspace, fspace, dxpl, data)
                      : H5Dread(dset, H5T_NATIVE_FLOAT, mspace, fspace, dxpl, data)) >= 0;
        H5Pclose(dxpl);
        H5Sclose(mspace);
    }
    hsize_t stored = dset >= 0 ? H5Dget_storage_size(dset) : 0;
    if (dset >= 0) H5Dclose(dset);
    if (fspace >= 0) H5Sclose(fspace);
    if (file >= 0 && H5Fclose(file) < 0) ok = 0;
    const double seconds = MPI_Wtime() - t0;

    /* Lossless reads must equal the generator bit for bit; lossy ones stay within the bound. */
    long long bad = 0;
    double worst = 0;
    if (ok && !writing)
        for (hsize_t z = z0; z < z1; ++z)
            for (hsize_t y = 0; y < o->ny; ++y)
                for (hsize_t x = 0; x < o->nx; ++x) {
                    float want = field(z, y, x), got = data[((z - z0) * o->ny + y) * o->nx + x];
                    double err = got > want ? (double)got - want : (double)want - got;
                    if (err > worst) worst = err;
                    if (o->max_error > 0 ? !(err <= o->max_error) : memcmp(&want, &got, sizeof want) != 0)
                        ++bad;
                }
    free(data);

    int all_ok = 0;
    long long all_bad = 0;
    double slowest = 0, all_worst = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_LAND, MPI_COMM_WORLD);
    MPI_Allreduce(&bad, &all_bad, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    MPI_Allreduce(&seconds, &slowest, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    MPI_Allreduce(&worst, &all_worst, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    if (rank == 0) {
        const double mb = (double)o->nz * o->ny * o->nx * sizeof(float) / 1e6;
        if (!all_ok)
            fprintf(stderr, "h5z-volcl-parallel: %s %s failed (HDF5 error above)\n", mode, path);
        else
            printf("%s%s ranks=%d dims=%llux%llux%llu chunk=%llu raw_MB=%.1f stored_MB=%.2f ratio=%.2f "
                   "seconds=%.3f "
                   "MB/s=%.1f mismatches=%lld max_error=%.3g\n",
                   mode, o->raw ? "-raw" : "", size, (unsigned long long)o->nz, (unsigned long long)o->ny,
                   (unsigned long long)o->nx, (unsigned long long)o->chunk, mb, (double)stored / 1e6,
                   stored ? mb * 1e6 / (double)stored : 0.0, slowest, mb / slowest, all_bad, all_worst);
    }
    return all_ok && all_bad == 0 ? 0 : 1;
}

int main(int argc, char** argv) {
    MPI_Init(&argc, &argv);
    int rank = 0, size = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    struct options o = {128, 160, 160, 32, 0.0, 0, 0};
    int usage = argc < 3 || (strcmp(argv[1], "write") != 0 && strcmp(argv[1], "read") != 0);
    int i = 3;
    for (; !usage && i < argc && (strcmp(argv[i], "--raw") == 0 || strcmp(argv[i], "--warm") == 0); ++i)
        *(strcmp(argv[i], "--raw") == 0 ? &o.raw : &o.warm) = 1;
    for (; !usage && i + 1 < argc; i += 2) {
        char* end = NULL;
        double v = strtod(argv[i + 1], &end);
        if (*end != '\0' || v <= 0)
            usage = 1;
        else if (strcmp(argv[i], "--nz") == 0)
            o.nz = (hsize_t)v;
        else if (strcmp(argv[i], "--ny") == 0)
            o.ny = (hsize_t)v;
        else if (strcmp(argv[i], "--nx") == 0)
            o.nx = (hsize_t)v;
        else if (strcmp(argv[i], "--chunk") == 0)
            o.chunk = (hsize_t)v;
        else if (strcmp(argv[i], "--max-error") == 0)
            o.max_error = v;
        else
            usage = 1;
    }
    if (usage || (argc - 3 - o.raw - o.warm) % 2 != 0 || o.nz == 0 || o.ny == 0 || o.nx == 0 ||
        o.chunk == 0) {
        if (rank == 0)
            fprintf(stderr,
                    "usage: mpiexec -n N h5z-volcl-parallel write|read FILE.h5 [--raw] [--warm] [--nz N "
                    "--ny N --nx N --chunk N --max-error E]\n");
        MPI_Finalize();
        return 2;
    }
    int rc = run(argv[1], argv[2], &o, rank, size);
    MPI_Finalize();
    return rc;
}
