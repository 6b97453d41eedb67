/* The volcl HDF5 filter's id and helpers that add it to a dataset creation property list (C and C++). */
#ifndef H5ZVOLCL_H
#define H5ZVOLCL_H

#include <hdf5.h>
#include <stdint.h>
#include <string.h>

/* In HDF5's range for unregistered filters (256-511). */
#define H5Z_FILTER_VOLCL 420

/* cd_values[0]: the rate. */
#define H5Z_VOLCL_LOSSLESS 0u
#define H5Z_VOLCL_MAX_ERROR 1u
#define H5Z_VOLCL_PSNR 2u
#define H5Z_VOLCL_BPV 3u
#define H5Z_VOLCL_REL_ERROR 4u
#define H5Z_VOLCL_PW_REL_ERROR 5u

/* Adds the filter with cd_values {rate, low word, high word of the bound as an IEEE double}. The dataset
   must be chunked with 3 (z, y, x) or 4 (t, z, y, x) chunk dimensions and hold little-endian uint8, uint16,
   int16 or float32. HDF5 loads the filter from HDF5_PLUGIN_PATH when a dataset is created or read. */
static inline herr_t H5Pset_volcl(hid_t dcpl, unsigned rate, double bound) {
    uint64_t bits;
    unsigned cd[3];
    memcpy(&bits, &bound, sizeof bits);
    cd[0] = rate;
    cd[1] = (unsigned)(bits & 0xffffffffu);
    cd[2] = (unsigned)(bits >> 32);
    return H5Pset_filter(dcpl, H5Z_FILTER_VOLCL, H5Z_FLAG_MANDATORY, rate == H5Z_VOLCL_LOSSLESS ? 1 : 3, cd);
}
/* Exact: every voxel (float bit patterns included) comes back as written. */
static inline herr_t H5Pset_volcl_lossless(hid_t dcpl) {
    return H5Pset_volcl(dcpl, H5Z_VOLCL_LOSSLESS, 0.0);
}
/* Every voxel within max_error (data units, > 0) of the input. */
static inline herr_t H5Pset_volcl_max_error(hid_t dcpl, double max_error) {
    return H5Pset_volcl(dcpl, H5Z_VOLCL_MAX_ERROR, max_error);
}
/* Each frame of each chunk at psnr_db dB or more over its value range (an edge chunk: over its real voxels,
   padding excluded). */
static inline herr_t H5Pset_volcl_psnr(hid_t dcpl, double psnr_db) {
    return H5Pset_volcl(dcpl, H5Z_VOLCL_PSNR, psnr_db);
}
/* Each stored chunk at most bits_per_voxel bits per voxel (> 0), its header included. */
static inline herr_t H5Pset_volcl_bpv(hid_t dcpl, double bits_per_voxel) {
    return H5Pset_volcl(dcpl, H5Z_VOLCL_BPV, bits_per_voxel);
}
/* Every voxel within rel_error (> 0) times the value range (max - min) of the finite values of its chunk's
   frame (an edge chunk: of its real voxels and the copies padding them). */
static inline herr_t H5Pset_volcl_rel_error(hid_t dcpl, double rel_error) {
    return H5Pset_volcl(dcpl, H5Z_VOLCL_REL_ERROR, rel_error);
}
/* Every voxel within pw_rel_error (0 < R < 1) times its own magnitude: zeros exact, signs kept. */
static inline herr_t H5Pset_volcl_pw_rel_error(hid_t dcpl, double pw_rel_error) {
    return H5Pset_volcl(dcpl, H5Z_VOLCL_PW_REL_ERROR, pw_rel_error);
}

#endif
