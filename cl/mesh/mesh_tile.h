/* What the tile kernels of meshes share (k-buffer, projected tetrahedra): one work-group per KB_TILE x KB_TILE
   pixel tile, its list from the order-keeping binning (kb_bin_count, kb_bin_scatter; BIN_CHUNKS chunks). */
#ifndef VOLCL_MESH_TILE_H
#define VOLCL_MESH_TILE_H

#ifndef KB_TILE
#define KB_TILE 16
#endif
#ifndef KB_TILE_THREADS
#define KB_TILE_THREADS 1
#endif
#ifndef BIN_CHUNKS
#define BIN_CHUNKS 64
#endif

/* Pixels of tile `tile` of a tilesX-wide grid: (x, y) its first pixel, (z, w) one past its last inside the image. */
inline int4 tile_bounds(uint tile, uint tilesX, uint width, uint height) {
    const int x0 = (int)(tile % tilesX) * KB_TILE, y0 = (int)(tile / tilesX) * KB_TILE;
    return (int4)(x0, y0, min(x0 + KB_TILE, (int)width), min(y0 + KB_TILE, (int)height));
}

/* [start, end) of the tile's entries in the binned list. */
inline uint2 tile_list(__global const uint* binEnds, uint tile) {
    return (uint2)(tile == 0 ? 0u : binEnds[(tile - 1) * BIN_CHUNKS + BIN_CHUNKS - 1],
                   binEnds[tile * BIN_CHUNKS + BIN_CHUNKS - 1]);
}

/* Clears the colours of the work-item's rows of the tile (those with (y - y0) % KB_TILE_THREADS == lid) and marks
   the pixels outside the image done; returns how many of its pixels are live. */
inline int tile_clear(__local float4* lacc, __local uchar* ldone, int4 bounds, uint lid) {
    int live = 0;
    for (int ly = (int)lid; ly < KB_TILE; ly += KB_TILE_THREADS)
        for (int lx = 0; lx < KB_TILE; ++lx) {
            const uint li = (uint)(ly * KB_TILE + lx);
            lacc[li] = (float4)(0.0f);
            const int in = bounds.y + ly < bounds.w && bounds.x + lx < bounds.z;
            ldone[li] = (uchar)!in;
            live += in;
        }
    return live;
}

/* Stores pixel li's new colour and retires the pixel once its opacity reaches earlyTermination (values >= 1
   never do); *live counts the work-item's pixels still taking fragments. */
inline void tile_store(__local float4* lacc, __local uchar* ldone, uint li, float4 acc,
                       float earlyTermination, int* live) {
    lacc[li] = acc;
    if (acc.w >= earlyTermination) {
        ldone[li] = 1;
        --*live;
    }
}

#endif
