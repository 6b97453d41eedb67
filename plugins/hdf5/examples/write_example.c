/* Writes volcl-compressed HDF5 datasets beside uncompressed copies of the same data (the filter's C example). */
#include "plugins/hdf5/H5Zvolcl.h"

#include <hdf5.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

/* Writes `data` as dataset `name` (rank 3 or 4), chunked and filtered when `chunk` is given. */
static int write_dataset(hid_t file, const char* name, hid_t type, int rank, const hsize_t* dims,
                         const hsize_t* chunk, int rate, double bound, const void* data) {
    hid_t space = H5Screate_simple(rank, dims, NULL);
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    int ok = space >= 0 && dcpl >= 0;
    if (ok && chunk) {
        ok = H5Pset_chunk(dcpl, rank, chunk) >= 0;
        if (ok && rate == (int)H5Z_VOLCL_LOSSLESS) ok = H5Pset_volcl_lossless(dcpl) >= 0;
        if (ok && rate == (int)H5Z_VOLCL_MAX_ERROR) ok = H5Pset_volcl_max_error(dcpl, bound) >= 0;
        if (ok && rate == (int)H5Z_VOLCL_PSNR) ok = H5Pset_volcl_psnr(dcpl, bound) >= 0;
    }
    hid_t dset = ok ? H5Dcreate2(file, name, type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT) : -1;
    ok = dset >= 0 && H5Dwrite(dset, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0;
    if (ok && chunk) {
        hsize_t raw = H5Sget_simple_extent_npoints(space) * H5Tget_size(type);
        printf("%-16s %10llu bytes -> %9llu stored (ratio %.2f)\n", name, (unsigned long long)raw,
               (unsigned long long)H5Dget_storage_size(dset),
               (double)raw / (double)H5Dget_storage_size(dset));
    }
    if (dset >= 0) H5Dclose(dset);
    H5Pclose(dcpl);
    H5Sclose(space);
    if (!ok) fprintf(stderr, "h5z-volcl-example: writing %s failed\n", name);
    return ok;
}

int main(int argc, char** argv) {
    if (argc != 2) {
        fprintf(stderr,
                "usage: h5z-volcl-example OUT.h5   (needs HDF5_PLUGIN_PATH naming the plugin's folder)\n");
        return 2;
    }
    /* A smooth field with a sharp edge: dims (z, y, x) = 40 x 64 x 96, chunks 16 x 32 x 32 (edge chunks are partial). */
    enum { NZ = 40, NY = 64, NX = 96, NT = 3 };
    const hsize_t dims[3] = {NZ, NY, NX}, chunk[3] = {16, 32, 32};
    const hsize_t dims4[4] = {NT, NZ, NY, NX}, chunk4[4] = {2, 16, 32, 32};
    uint16_t* u16 = malloc(sizeof(uint16_t) * NZ * NY * NX);
    float* f32 = malloc(sizeof(float) * NZ * NY * NX);
    uint8_t* u8 = malloc((size_t)NT * NZ * NY * NX);
    if (!u16 || !f32 || !u8) return 1;
    for (int t = 0; t < NT; ++t)
        for (int z = 0; z < NZ; ++z)
            for (int y = 0; y < NY; ++y)
                for (int x = 0; x < NX; ++x) {
                    size_t i = ((size_t)z * NY + y) * NX + x;
                    double r =
                        sqrt((x - 48.0) * (x - 48.0) + (y - 32.0) * (y - 32.0) + (z - 20.0) * (z - 20.0));
                    double v = 0.5 + 0.5 * sin(0.21 * x + 0.13 * y * (1 + 0.1 * t)) * cos(0.17 * z) +
                               (r < 12 ? 0.8 : 0.0);
                    if (t == 0) {
                        u16[i] = (uint16_t)(v * 20000.0);
                        f32[i] = (float)(v * 3.0 - 1.0);
                    }
                    u8[(size_t)t * NZ * NY * NX + i] = (uint8_t)(v * 140.0);
                }
    hid_t file = H5Fcreate(argv[1], H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    int ok = file >= 0;
    ok = ok && write_dataset(file, "raw_u16", H5T_STD_U16LE, 3, dims, NULL, 0, 0, u16);
    ok = ok && write_dataset(file, "lossless_u16", H5T_STD_U16LE, 3, dims, chunk, H5Z_VOLCL_LOSSLESS, 0, u16);
    ok = ok && write_dataset(file, "raw_f32", H5T_IEEE_F32LE, 3, dims, NULL, 0, 0, f32);
    ok =
        ok && write_dataset(file, "lossless_f32", H5T_IEEE_F32LE, 3, dims, chunk, H5Z_VOLCL_LOSSLESS, 0, f32);
    ok = ok &&
         write_dataset(file, "max_error_f32", H5T_IEEE_F32LE, 3, dims, chunk, H5Z_VOLCL_MAX_ERROR, 0.01, f32);
    ok = ok && write_dataset(file, "psnr_f32", H5T_IEEE_F32LE, 3, dims, chunk, H5Z_VOLCL_PSNR, 50.0, f32);
    ok = ok && write_dataset(file, "raw_series_u8", H5T_STD_U8LE, 4, dims4, NULL, 0, 0, u8);
    ok = ok &&
         write_dataset(file, "lossless_series_u8", H5T_STD_U8LE, 4, dims4, chunk4, H5Z_VOLCL_LOSSLESS, 0, u8);
    if (file >= 0 && H5Fclose(file) < 0) ok = 0;
    free(u16);
    free(f32);
    free(u8);
    if (!ok) remove(argv[1]); /* no partial output */
    return ok ? 0 : 1;
}
