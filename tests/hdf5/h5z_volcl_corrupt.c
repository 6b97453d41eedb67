/* Test helper: flips one byte in the middle of a stored chunk (direct chunk I/O, which bypasses filters). */
#include <hdf5.h>
#include <stdio.h>
#include <stdlib.h>

int main(int argc, char** argv) {
    if (argc != 3) {
        fprintf(stderr, "usage: h5z-volcl-corrupt FILE.h5 DATASET   (corrupts the dataset's first chunk)\n");
        return 2;
    }
    hid_t f = H5Fopen(argv[1], H5F_ACC_RDWR, H5P_DEFAULT);
    hid_t d = f >= 0 ? H5Dopen2(f, argv[2], H5P_DEFAULT) : -1;
    hsize_t offset[H5S_MAX_RANK] = {0}, size = 0;
    uint32_t mask = 0;
    int ok = d >= 0 && H5Dget_chunk_storage_size(d, offset, &size) >= 0 && size > 0;
    unsigned char* raw = ok ? malloc(size) : NULL;
    ok = ok && raw && H5Dread_chunk(d, H5P_DEFAULT, offset, &mask, raw) >= 0;
    if (ok) raw[size / 2] ^= 0x40;
    ok = ok && H5Dwrite_chunk(d, H5P_DEFAULT, mask, offset, size, raw) >= 0;
    free(raw);
    if (d >= 0) H5Dclose(d);
    if (f >= 0 && H5Fclose(f) < 0) ok = 0;
    if (!ok)
        fprintf(stderr, "h5z-volcl-corrupt: %s: could not corrupt the first chunk of %s\n", argv[1], argv[2]);
    return ok ? 0 : 1;
}
