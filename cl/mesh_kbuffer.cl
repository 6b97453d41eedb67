/* k-buffer (HAVS, Callahan 2005) rendering of tetrahedral meshes: point projection, per-face centroid sort
   keys and screen-tile rectangles, order-keeping tile binning, and the tile rasteriser whose per-pixel
   k-buffer pops the nearest fragment and composites the segment to the second nearest through the 3D
   pre-integration table. Defines: KB_K (entries per pixel, 2..8), KB_TILE (tile edge in pixels),
   KB_TILE_THREADS (work-items per tile; each owns the tile rows y with (y - y0) % KB_TILE_THREADS == lid),
   BIN_CHUNKS (work-items of the binning passes), table lookups as PREINT 3 of cl/common/tf_lookup.h. The C++ mirror is host/render/mesh/KBufferReference.cpp. */
#include "mesh_kbuffer_shared.h"

#pragma OPENCL FP_CONTRACT OFF

#ifndef KB_K
#define KB_K 6
#endif
#ifndef KB_TILE
#define KB_TILE 16
#endif
#ifndef KB_TILE_THREADS
#define KB_TILE_THREADS 1
#endif
#ifndef BIN_CHUNKS
#define BIN_CHUNKS 64
#endif

/* Face rectangles at least this many pixels wide (minus one) get their rows narrowed to the edges' span. */
#define KB_SPAN_MIN 4

/* Nearest view depth (normalized units) a perspective vertex may have; faces with a vertex closer are not drawn. */
#define KB_NEAR 1e-4f

/* proj[i] = (screen x, screen y, view depth z, 1 / z) of point i; pixel (x, y) has its centre at integer
   screen coordinates. w = 0 marks a perspective point at or behind the near distance. */
__kernel void kb_project(__global const float4* points, const VolclKBufferParams P, __global float4* proj) {
    const uint i = get_global_id(0);
    if (i >= P.pointCount) return;
    const float4 p = points[i];
    const float rx = p.x - P.eye[0], ry = p.y - P.eye[1], rz = p.z - P.eye[2];
    const float z = rx * P.forward[0] + ry * P.forward[1] + rz * P.forward[2];
    const float xr = rx * P.right[0] + ry * P.right[1] + rz * P.right[2];
    const float yu = rx * P.up[0] + ry * P.up[1] + rz * P.up[2];
    float nx, ny, w = 1.0f;
    if (P.perspective) {
        if (z > KB_NEAR) {
            w = 1.0f / z;
            nx = xr / (z * P.halfX);
            ny = yu / (z * P.halfY);
        } else {
            w = 0.0f;
            nx = 0.0f;
            ny = 0.0f;
        }
    } else {
        nx = xr / P.halfX;
        ny = yu / P.halfY;
    }
    const float sx = (nx + 1.0f) * (0.5f * (float)P.width) - 0.5f;
    const float sy = (1.0f - ny) * (0.5f * (float)P.height) - 0.5f;
    proj[i] = (float4)(sx, sy, z, w);
}

/* Float-to-key transform (Hacker's Delight): unsigned order of the keys is the order of the floats. */
inline uint kb_float_key(float f) {
    const uint u = as_uint(f);
    return u ^ ((u & 0x80000000u) ? 0xFFFFFFFFu : 0x80000000u);
}

/* Sort key (centroid view depth, orthographic; centroid distance to the eye, perspective) and the rectangle
   of screen tiles of face i: rects[i] = (x0 | y0 << 16, x1 | y1 << 16), empty (x0 > x1) when the face covers
   no pixel centre, is seen edge-on or crosses the near distance. */
__kernel void kb_face_keys(__global const float4* points, __global const float4* proj, __global const uint4* faces,
                           const VolclKBufferParams P, __global uint* keys, __global uint* vals,
                           __global uint2* rects) {
    const uint i = get_global_id(0);
    if (i >= P.faceCount) return;
    const uint4 f = faces[i];
    const float4 p0 = points[f.x], p1 = points[f.y], p2 = points[f.z];
    const float cx = (p0.x + p1.x + p2.x) / 3.0f - P.eye[0];
    const float cy = (p0.y + p1.y + p2.y) / 3.0f - P.eye[1];
    const float cz = (p0.z + p1.z + p2.z) / 3.0f - P.eye[2];
    const float depth = P.perspective ? sqrt(cx * cx + cy * cy + cz * cz)
                                      : cx * P.forward[0] + cy * P.forward[1] + cz * P.forward[2];
    keys[i] = kb_float_key(depth);
    vals[i] = i;
    const float4 a = proj[f.x], b = proj[f.y], c = proj[f.z];
    const float orient = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    uint2 rect = (uint2)(1u, 0u);
    if (orient != 0.0f && a.w != 0.0f && b.w != 0.0f && c.w != 0.0f) {
        const float x0 = ceil(fmax(fmin(fmin(a.x, b.x), c.x), 0.0f));
        const float x1 = floor(fmin(fmax(fmax(a.x, b.x), c.x), (float)(P.width - 1)));
        const float y0 = ceil(fmax(fmin(fmin(a.y, b.y), c.y), 0.0f));
        const float y1 = floor(fmin(fmax(fmax(a.y, b.y), c.y), (float)(P.height - 1)));
        if (x0 <= x1 && y0 <= y1) {
            const uint tx0 = (uint)x0 / KB_TILE, tx1 = (uint)x1 / KB_TILE;
            const uint ty0 = (uint)y0 / KB_TILE, ty1 = (uint)y1 / KB_TILE;
            rect = (uint2)(tx0 | (ty0 << 16), tx1 | (ty1 << 16));
        }
    }
    rects[i] = rect;
}

/* The sorted faces and their tile rectangles gathered into sorted order once: the binning passes then read
   both in order, and the tile lists hold face records, so the rasteriser reads its list front to back
   instead of missing the cache on a face record per entry. */
__kernel void kb_gather(__global const uint* order, __global const uint4* faces, __global const uint2* rects,
                        const uint n, __global uint4* sortedFaces, __global uint2* sortedRects) {
    const uint pos = get_global_id(0);
    if (pos >= n) return;
    const uint f = order[pos];
    sortedFaces[pos] = faces[f];
    sortedRects[pos] = rects[f];
}

/* counts[tile * BIN_CHUNKS + c] = entries chunk c (a contiguous run of sorted positions) adds to each tile. */
__kernel void kb_bin_count(__global const uint2* sortedRects, const uint n, const uint tilesX, __global uint* counts) {
    const uint c = get_global_id(0);
    if (c >= BIN_CHUNKS) return;
    const uint per = (n + BIN_CHUNKS - 1) / BIN_CHUNKS;
    const uint lo = min(n, c * per), hi = min(n, lo + per);
    for (uint pos = lo; pos < hi; ++pos) {
        const uint2 r = sortedRects[pos];
        const uint x0 = r.x & 0xFFFFu, y0 = r.x >> 16, x1 = r.y & 0xFFFFu, y1 = r.y >> 16;
        if (x0 > x1) continue;
        for (uint ty = y0; ty <= y1; ++ty)
            for (uint tx = x0; tx <= x1; ++tx) counts[(ty * tilesX + tx) * BIN_CHUNKS + c]++;
    }
}

/* After the exclusive scan of the counts: appends each chunk's face records to every tile list they touch, in
   sorted order. Afterwards offsets[tile * BIN_CHUNKS + BIN_CHUNKS - 1] is the end of the tile's list. */
__kernel void kb_bin_scatter(__global const uint4* sortedFaces, __global const uint2* sortedRects, const uint n,
                             const uint tilesX, __global uint* offsets, __global uint4* list) {
    const uint c = get_global_id(0);
    if (c >= BIN_CHUNKS) return;
    const uint per = (n + BIN_CHUNKS - 1) / BIN_CHUNKS;
    const uint lo = min(n, c * per), hi = min(n, lo + per);
    for (uint pos = lo; pos < hi; ++pos) {
        const uint2 r = sortedRects[pos];
        const uint x0 = r.x & 0xFFFFu, y0 = r.x >> 16, x1 = r.y & 0xFFFFu, y1 = r.y >> 16;
        if (x0 > x1) continue;
        const uint4 face = sortedFaces[pos];
        for (uint ty = y0; ty <= y1; ++ty)
            for (uint tx = x0; tx <= x1; ++tx) list[offsets[(ty * tilesX + tx) * BIN_CHUNKS + c]++] = face;
    }
}

/* ---------------- the rasteriser ---------------- */

#define KB_PIXELS (KB_TILE * KB_TILE)
/* Slots per pixel: a ring of 8 (KB_K <= 8 of them in use), so the ring index wraps with a mask. */
#define KB_RING 8

/* Per-pixel k-buffers kept sorted by distance in a ring: the nearest entry at head, the others after it in
   order (equal distances in arrival order). A fragment arriving in order (the common case after the centroid
   sort) then costs one comparison and one store, and a pop takes the head and its successor: no search over
   the k entries per fragment. */
typedef struct {
    __local float* t;     /* KB_PIXELS * KB_RING distances */
    __local float* s;     /* scalars */
    __local uchar* f;     /* fragment flags */
    __local uchar* count; /* stored entries per pixel */
    __local uchar* head;  /* ring slot of the nearest entry */
    __local float4* acc;  /* composited colour per pixel */
} KBuffer;

#define KB_INLINE __attribute__((always_inline)) inline

/* Table value at fractional node coordinates (front u, back v) of slice k: bilinear (tf_lookup.h's
   table_bilinear, inlined into the fragment loop). */
KB_INLINE float4 kb_bilinear(__global const float4* table, uint n, uint k, float u, float v) {
    const float hi = (float)(n - 1);
    u = clamp(u, 0.0f, hi);
    v = clamp(v, 0.0f, hi);
    const uint i0 = min((uint)u, n - 2), j0 = min((uint)v, n - 2);
    const float fu = u - (float)i0, fv = v - (float)j0;
    __global const float4* row0 = table + ((size_t)k * n + i0) * n;
    __global const float4* row1 = row0 + n;
    const float4 a = row0[j0] + fv * (row0[j0 + 1] - row0[j0]);
    const float4 b = row1[j0] + fv * (row1[j0 + 1] - row1[j0]);
    return a + fu * (b - a);
}

/* tf_lookup.h's preint_segment for the 3D table with the frame's factors precomputed (the lookup was a third
   of the frame as a call with two divisions): associated (rgb, alpha) of the segment sf -> sb of length len. */
KB_INLINE float4 kb_preint(__global const float4* table, const VolclKBufferParams* P, float sf, float sb, float len) {
    const VolclTfParams* T = &P->tf;
    const float u = (sf - T->domainLo) * P->tableScale, v = (sb - T->domainLo) * P->tableScale;
    const float kf = len * P->lengthScale - 1.0f;
    float4 e;
    float tableLen = len;
    if (kf <= 0.0f) {
        e = kb_bilinear(table, T->tableSize, 0, u, v) * fmax(kf + 1.0f, 0.0f);
    } else if (kf >= (float)(T->tableLengths - 1)) {
        e = kb_bilinear(table, T->tableSize, T->tableLengths - 1, u, v);
        tableLen = T->tableMaxLength;
    } else {
        const uint k0 = (uint)kf;
        const float fk = kf - (float)k0;
        const float4 a = kb_bilinear(table, T->tableSize, k0, u, v);
        e = a + fk * (kb_bilinear(table, T->tableSize, k0 + 1, u, v) - a);
    }
    if (len != tableLen) {
        /* Longer than the table (level of detail, misordered fragments): exact for a constant scalar. */
        const float a = clamp(e.w, 0.0f, 1.0f);
        const float an = a < 1.0f ? 1.0f - pow(1.0f - a, len / tableLen) : 1.0f;
        const float3 rgb = a > 0.0f ? e.xyz * (an / a) : e.xyz * (len / tableLen);
        e = (float4)(rgb, an);
    }
    return e;
}

/* Composites the segment from fragment (t0, s0, f0) to the next one (t1, s1, f1): nothing when it lies
   outside the mesh (after a leaving boundary face or before an entering one) or has no length. */
KB_INLINE float4 kb_segment(float4 acc, float t0, float s0, uint f0, float t1, float s1, uint f1,
                         __global const float4* table, const VolclKBufferParams* P) {
    if ((f0 & KB_FRAG_EXIT) || (f1 & KB_FRAG_ENTER)) return acc;
    const float len = (t1 - t0) * P->worldScale;
    if (!(len > 0.0f)) return acc;
    const float4 c = kb_preint(table, P, s0, s1, len);
    return acc + (1.0f - acc.w) * c;
}

/* Stores (t, s, fl) into the sorted ring of n entries starting at slot h of pixel base: after every entry not
   farther than t (equal distances keep their arrival order). */
KB_INLINE void kb_place(KBuffer kb, uint base, uint h, uint n, float t, float s, uint fl) {
    uint j = n;
    while (j > 0) {
        const uint src = base + ((h + j - 1) & (KB_RING - 1));
        const float tj = kb.t[src];
        if (!(tj > t)) break;
        const uint dst = base + ((h + j) & (KB_RING - 1));
        kb.t[dst] = tj;
        kb.s[dst] = kb.s[src];
        kb.f[dst] = kb.f[src];
        --j;
    }
    const uint at = base + ((h + j) & (KB_RING - 1));
    kb.t[at] = t;
    kb.s[at] = s;
    kb.f[at] = (uchar)fl;
}

/* Inserts a fragment into pixel li's k-buffer; when it is full, pops the nearest of the k + 1 fragments and
   composites it with the second nearest (a stored entry nearer than or as near as the incoming fragment goes
   first). Returns 1 when the pixel reached the early-termination opacity. */
KB_INLINE int kb_insert(KBuffer kb, uint li, float t, float s, uint fl, __global const float4* table,
                     const VolclKBufferParams* P) {
    const uint base = li * KB_RING;
    const uint n = kb.count[li];
    const uint h = kb.head[li];
    if (n < KB_K) {
        kb_place(kb, base, h, n, t, s, fl);
        kb.count[li] = (uchar)(n + 1);
        return 0;
    }
    const uint h0 = base + h;
    const float mt = kb.t[h0];
    float4 acc = kb.acc[li];
    if (t < mt) {
        acc = kb_segment(acc, t, s, fl, mt, kb.s[h0], kb.f[h0], table, P);
    } else {
        const uint h1 = base + ((h + 1) & (KB_RING - 1));
        const float rt = kb.t[h1];
        if (t < rt) acc = kb_segment(acc, mt, kb.s[h0], kb.f[h0], t, s, fl, table, P);
        else acc = kb_segment(acc, mt, kb.s[h0], kb.f[h0], rt, kb.s[h1], kb.f[h1], table, P);
        const uint nh = (h + 1) & (KB_RING - 1);
        kb.head[li] = (uchar)nh;
        kb_place(kb, base, nh, KB_K - 1, t, s, fl);
    }
    kb.acc[li] = acc;
    return acc.w >= P->earlyTermination;
}

/* Pops the remaining fragments of pixel li in order (the k - 1 segments still stored). */
KB_INLINE void kb_flush(KBuffer kb, uint li, __global const float4* table, const VolclKBufferParams* P) {
    const uint base = li * KB_RING;
    const uint n = kb.count[li];
    uint h = kb.head[li];
    float4 acc = kb.acc[li];
    for (uint i = 1; i < n && acc.w < P->earlyTermination; ++i) {
        const uint a = base + h, b = base + ((h + 1) & (KB_RING - 1));
        acc = kb_segment(acc, kb.t[a], kb.s[a], kb.f[a], kb.t[b], kb.s[b], kb.f[b], table, P);
        h = (h + 1) & (KB_RING - 1);
    }
    kb.acc[li] = acc;
}

/* Edge function of the directed edge p -> q at (x, y). Every edge is evaluated from its lower-indexed vertex,
   so the two faces sharing it compute the same value, and ties (value 0) go to exactly one of them. */
inline float kb_edge(float px, float py, float qx, float qy, float x, float y) {
    return (qx - px) * (y - py) - (qy - py) * (x - px);
}
inline int kb_tie_side(float px, float py, float qx, float qy) {
    const float dx = qx - px, dy = qy - py;
    return (dy > 0.0f || (dy == 0.0f && dx < 0.0f)) ? 1 : -1;
}

/* One edge of a face: canonical endpoints, the sign turning its edge function into the face's inside
   measure, and whether a zero value counts as inside. */
typedef struct {
    float px, py, qx, qy;
    float sigma;
    int tie;
} KbEdge;

inline KbEdge kb_make_edge(float4 u, uint iu, float4 v, uint iv, float orientSign) {
    KbEdge e;
    float s;
    if (iu < iv) { e.px = u.x; e.py = u.y; e.qx = v.x; e.qy = v.y; s = 1.0f; }
    else { e.px = v.x; e.py = v.y; e.qx = u.x; e.qy = u.y; s = -1.0f; }
    e.sigma = orientSign * s;
    e.tie = e.sigma * (float)kb_tie_side(e.px, e.py, e.qx, e.qy) > 0.0f;
    return e;
}

/* Narrows [*xl, *xr] to the x where edge e can be inside on row y (the edge function is linear in x), with a
   margin far above float rounding: the exact per-pixel test still decides, this only skips pixels. */
inline void kb_row_span(const KbEdge* e, float fy, float* xl, float* xr) {
    const float ex = e->qx - e->px, ey = e->qy - e->py;
    const float b = -e->sigma * ey;
    if (b == 0.0f) return;
    const float ta = ex * (fy - e->py), tb = ey * e->px;
    const float xc = -(e->sigma * (ta + tb)) / b;
    const float m = 1.0f + 1e-5f * ((fabs(ta) + fabs(tb)) / fabs(b) + fabs(xc));
    if (b > 0.0f) *xl = fmax(*xl, xc - m);
    else *xr = fmin(*xr, xc + m);
}

/* Rasterises one tile (work-group): its faces in sorted order into per-pixel k-buffers in local memory, then
   flushes them and writes the composited pixels (linear, associated RGBA). */
__kernel void kb_raster(__global const float4* proj, __global const float* scalars, __global const uint* binEnds,
                        __global const uint4* list, const VolclKBufferParams P,
                        __global const float4* table, __global float4* out) {
    __local float lt[KB_PIXELS * KB_RING];
    __local float ls[KB_PIXELS * KB_RING];
    __local uchar lf[KB_PIXELS * KB_RING];
    __local uchar lcount[KB_PIXELS];
    __local uchar lhead[KB_PIXELS];
    __local uchar ldone[KB_PIXELS];
    __local float4 lacc[KB_PIXELS];
    KBuffer kb = {lt, ls, lf, lcount, lhead, lacc};

    const uint tile = get_group_id(0);
    const uint lid = get_local_id(0);
    const int tx0 = (int)(tile % P.tilesX) * KB_TILE, ty0 = (int)(tile / P.tilesX) * KB_TILE;
    const int xEnd = min(tx0 + KB_TILE, (int)P.width), yEnd = min(ty0 + KB_TILE, (int)P.height);
    int live = 0;
    for (int ly = (int)lid; ly < KB_TILE; ly += KB_TILE_THREADS)
        for (int lx = 0; lx < KB_TILE; ++lx) {
            const uint li = (uint)(ly * KB_TILE + lx);
            lcount[li] = 0;
            lhead[li] = 0;
            lacc[li] = (float4)(0.0f);
            const int in = ty0 + ly < yEnd && tx0 + lx < xEnd;
            ldone[li] = (uchar)!in;
            live += in;
        }
    const uint start = tile == 0 ? 0u : binEnds[(tile - 1) * BIN_CHUNKS + BIN_CHUNKS - 1];
    const uint end = binEnds[tile * BIN_CHUNKS + BIN_CHUNKS - 1];

    for (uint e = start; e < end && live > 0; ++e) {
        const uint4 fv = list[e];
        const float4 a = proj[fv.x], b = proj[fv.y], c = proj[fv.z];
        const float orient = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        const float sg = orient > 0.0f ? 1.0f : -1.0f;
        /* Outward winding seen counter-clockwise from outside appears clockwise on the y-down screen. */
        const uint fl = (fv.w & KB_FACE_BOUNDARY) ? (orient < 0.0f ? KB_FRAG_ENTER : KB_FRAG_EXIT) : 0u;
        const KbEdge ea = kb_make_edge(b, fv.y, c, fv.z, sg);
        const KbEdge eb = kb_make_edge(c, fv.z, a, fv.x, sg);
        const KbEdge ec = kb_make_edge(a, fv.x, b, fv.y, sg);
        const float sa = scalars[fv.x], sb = scalars[fv.y], sc = scalars[fv.z];
        const int x0 = (int)ceil(fmax(fmin(fmin(a.x, b.x), c.x), (float)tx0));
        const int x1 = (int)floor(fmin(fmax(fmax(a.x, b.x), c.x), (float)(xEnd - 1)));
        int y0 = (int)ceil(fmax(fmin(fmin(a.y, b.y), c.y), (float)ty0));
        const int y1 = (int)floor(fmin(fmax(fmax(a.y, b.y), c.y), (float)(yEnd - 1)));
        y0 += (int)(((uint)(KB_TILE_THREADS - ((y0 - ty0) % KB_TILE_THREADS)) + lid) % KB_TILE_THREADS);
        for (int y = y0; y <= y1; y += KB_TILE_THREADS) {
            const float fy = (float)y;
            int xs = x0, xe = x1;
            if (x1 - x0 >= KB_SPAN_MIN) { /* narrow wide rows; a few pixels are cheaper to test than to narrow */
                float xl = (float)x0, xr = (float)x1;
                kb_row_span(&ea, fy, &xl, &xr);
                kb_row_span(&eb, fy, &xl, &xr);
                kb_row_span(&ec, fy, &xl, &xr);
                xs = (int)ceil(xl);
                xe = (int)floor(xr);
            }
            for (int x = xs; x <= xe; ++x) {
                const uint li = (uint)((y - ty0) * KB_TILE + (x - tx0));
                if (ldone[li]) continue;
                const float fx = (float)x;
                const float wa = ea.sigma * kb_edge(ea.px, ea.py, ea.qx, ea.qy, fx, fy);
                const float wb = eb.sigma * kb_edge(eb.px, eb.py, eb.qx, eb.qy, fx, fy);
                const float wc = ec.sigma * kb_edge(ec.px, ec.py, ec.qx, ec.qy, fx, fy);
                if (!(wa > 0.0f || (wa == 0.0f && ea.tie))) continue;
                if (!(wb > 0.0f || (wb == 0.0f && eb.tie))) continue;
                if (!(wc > 0.0f || (wc == 0.0f && ec.tie))) continue;
                const float sum = wa + wb + wc;
                const float la = wa / sum, lb = wb / sum, lc = wc / sum;
                float t, s;
                if (P.perspective) {
                    const float q = la * a.w + lb * b.w + lc * c.w;
                    const float z = 1.0f / q;
                    s = (la * (sa * a.w) + lb * (sb * b.w) + lc * (sc * c.w)) * z;
                    const float ndcX = 2.0f * (fx + 0.5f) / (float)P.width - 1.0f;
                    const float ndcY = 1.0f - 2.0f * (fy + 0.5f) / (float)P.height;
                    const float dx = ndcX * P.halfX, dy = ndcY * P.halfY;
                    t = z * sqrt(1.0f + dx * dx + dy * dy);
                } else {
                    t = la * a.z + lb * b.z + lc * c.z;
                    s = la * sa + lb * sb + lc * sc;
                }
                if (kb_insert(kb, li, t, s, fl, table, &P)) {
                    ldone[li] = 1;
                    --live;
                }
            }
        }
    }

    for (int ly = (int)lid; ly < KB_TILE; ly += KB_TILE_THREADS)
        for (int lx = 0; lx < KB_TILE; ++lx) {
            const int x = tx0 + lx, y = ty0 + ly;
            if (x >= xEnd || y >= yEnd) continue;
            const uint li = (uint)(ly * KB_TILE + lx);
            kb_flush(kb, li, table, &P);
            out[(size_t)y * P.width + (size_t)x] = lacc[li];
        }
}
