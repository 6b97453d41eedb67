/* k-buffer (HAVS, Callahan 2005) rendering of tetrahedral meshes: point projection, per-face centroid sort
   keys and screen-tile rectangles, order-keeping tile binning, and the tile rasteriser whose per-pixel
   k-buffer pops the nearest fragment and composites the segment to the second nearest through the 3D
   pre-integration table. Defines: KB_K (entries per pixel, 2..8), KB_TILE (tile edge in pixels),
   KB_TILE_THREADS (work-items per tile; each owns the tile rows y with (y - y0) % KB_TILE_THREADS == lid),
   BIN_CHUNKS (work-items of the binning passes), table lookups as PREINT 3 of cl/common/tf_lookup.h. The C++ mirror is render/mesh/KBufferReference.cpp.
   NAN_COLOR: the mesh has NaN cells, drawn with the NaN colour NAN_R/G/B/TAU (see kb_composite).
   KB_ISO (mode iso): instead of the table, each popped segment composites the iso-surfaces ISO_COUNT it crosses
   (the scalar is linear along it), in ray order; SHADING lights them with the vertex normals interpolated on
   the two fragments' faces and along the segment (kb_iso_segment). */
#include "mesh_kbuffer_shared.h"
#ifdef KB_ISO
#include "common/iso_crossings.h"
#include "common/shading.h"
#endif

#pragma OPENCL FP_CONTRACT OFF

#ifndef KB_K
#define KB_K 6
#endif
#include "mesh_tile.h"

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
__kernel void kb_face_keys(__global const float4* points, __global const float4* proj,
                           __global const uint4* faces, const VolclKBufferParams P, __global uint* keys,
                           __global uint* vals, __global uint2* rects) {
    const uint i = get_global_id(0);
    if (i >= P.faceCount) return;
    const uint4 f = faces[i];
    const float4 a = proj[f.x], b = proj[f.y], c = proj[f.z];
    float depth;
    if (P.perspective) {
        const float4 p0 = points[f.x], p1 = points[f.y], p2 = points[f.z];
        const float cx = (p0.x + p1.x + p2.x) / 3.0f - P.eye[0];
        const float cy = (p0.y + p1.y + p2.y) / 3.0f - P.eye[1];
        const float cz = (p0.z + p1.z + p2.z) / 3.0f - P.eye[2];
        depth = sqrt(cx * cx + cy * cy + cz * cz);
    } else {
        /* The view depth is linear: the centroid's is the mean of the projected vertices' (no point reads). */
        depth = (a.z + b.z + c.z) / 3.0f;
    }
    keys[i] = kb_float_key(depth);
    vals[i] = i;
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
__kernel void kb_bin_count(__global const uint2* sortedRects, const uint n, const uint tilesX,
                           __global uint* counts) {
    const uint c = get_global_id(0);
    if (c >= BIN_CHUNKS) return;
    const uint per = (n + BIN_CHUNKS - 1) / BIN_CHUNKS;
    const uint lo = min(n, c * per), hi = min(n, lo + per);
    for (uint pos = lo; pos < hi; ++pos) {
        const uint2 r = sortedRects[pos];
        const uint x0 = r.x & 0xFFFFu, y0 = r.x >> 16, x1 = r.y & 0xFFFFu, y1 = r.y >> 16;
        if (x0 > x1) continue;
        for (uint ty = y0; ty <= y1; ++ty)
            for (uint tx = x0; tx <= x1; ++tx)
                counts[(ty * tilesX + tx) * BIN_CHUNKS + c]++;
    }
}

/* After the exclusive scan of the counts: appends each chunk's face records to every tile list they touch, in
   sorted order. Afterwards offsets[tile * BIN_CHUNKS + BIN_CHUNKS - 1] is the end of the tile's list. */
__kernel void kb_bin_scatter(__global const uint4* sortedFaces, __global const uint2* sortedRects,
                             const uint n, const uint tilesX, __global uint* offsets, __global uint4* list) {
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
            for (uint tx = x0; tx <= x1; ++tx)
                list[offsets[(ty * tilesX + tx) * BIN_CHUNKS + c]++] = face;
    }
}

/* The device table is half precision (8 bytes a node and length): the lookups miss the cache on a table of
   16 MiB (256^2 nodes x 16 lengths) and were a third of the raster in float; half of the bytes took 10-17 %
   off the frame's CPU time (1.57 M tets, loaded machine). Rounding (to nearest even, relative 2^-11) happens here; the host reads the rounded values
   back with kb_table_from_half, so the C++ mirror uses the values the kernels see. */
__kernel void kb_table_to_half(__global const float4* in, const uint n, __global half* out) {
    const uint i = get_global_id(0);
    if (i < n) vstore_half4_rte(in[i], i, out);
}
__kernel void kb_table_from_half(__global const half* in, const uint n, __global float4* out) {
    const uint i = get_global_id(0);
    if (i < n) out[i] = vload_half4(i, in);
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
#ifdef KB_ISO
    __local uint* e; /* the fragment's face as its tile-list entry (its normal is recomputed at a crossing) */
#endif
} KBuffer;

/* One fragment: distance, scalar, flags and (KB_ISO) tile-list entry of its face. */
typedef struct {
    float t, s;
    uint f, e;
} KbFrag;

#define KB_INLINE __attribute__((always_inline)) inline

/* The device copy of the 3D table is blocked (kbufferBlockedTable on the host): KB_TBLOCK x KB_TBLOCK front x
   back node blocks, each node's lengths contiguous. The eight entries a lookup blends (two nodes on each axis)
   then lie in one 4 KiB block and its lengths k, k + 1 side by side; the plain layout (a slice per length,
   rows of n nodes) put them on four pages 4 KiB and 1 MiB apart, and the lookups were half the raster. */
#define KB_TBLOCK 4
KB_INLINE size_t kb_table_index(uint i, uint j, uint k, uint nb, uint lengths) {
    return (((size_t)(i / KB_TBLOCK) * nb + j / KB_TBLOCK) * (KB_TBLOCK * KB_TBLOCK) +
            (i % KB_TBLOCK) * KB_TBLOCK + j % KB_TBLOCK) *
               lengths +
           k;
}

/* Table value at fractional node coordinates (front u, back v) of length slices k0 and k1: bilinear in each
   (tf_lookup.h's table_bilinear, inlined into the fragment loop); a and b receive the two slices. */
KB_INLINE void kb_bilinear2(__global const half* table, uint n, uint lengths, uint k0, uint k1, float u,
                            float v, float4* ea, float4* eb) {
    const float hi = (float)(n - 1);
    u = clamp(u, 0.0f, hi);
    v = clamp(v, 0.0f, hi);
    const uint i0 = min((uint)u, n - 2), j0 = min((uint)v, n - 2);
    const float fu = u - (float)i0, fv = v - (float)j0;
    const uint nb = (n + KB_TBLOCK - 1) / KB_TBLOCK;
    const size_t p00 = kb_table_index(i0, j0, 0, nb, lengths),
                 p01 = kb_table_index(i0, j0 + 1, 0, nb, lengths);
    const size_t p10 = kb_table_index(i0 + 1, j0, 0, nb, lengths),
                 p11 = kb_table_index(i0 + 1, j0 + 1, 0, nb, lengths);
    {
        const float4 t00 = vload_half4(p00 + k0, table), t01 = vload_half4(p01 + k0, table);
        const float4 t10 = vload_half4(p10 + k0, table), t11 = vload_half4(p11 + k0, table);
        const float4 a = t00 + fv * (t01 - t00);
        const float4 b = t10 + fv * (t11 - t10);
        *ea = a + fu * (b - a);
    }
    {
        const float4 t00 = vload_half4(p00 + k1, table), t01 = vload_half4(p01 + k1, table);
        const float4 t10 = vload_half4(p10 + k1, table), t11 = vload_half4(p11 + k1, table);
        const float4 a = t00 + fv * (t01 - t00);
        const float4 b = t10 + fv * (t11 - t10);
        *eb = a + fu * (b - a);
    }
}

/* tf_lookup.h's preint_segment for the 3D table with the frame's factors precomputed (the lookup was a third
   of the frame as a call with two divisions): associated (rgb, alpha) of the segment sf -> sb of length len. */
KB_INLINE float4 kb_preint(__global const half* table, const VolclKBufferParams* P, float sf, float sb,
                           float len) {
    const VolclTfParams* T = &P->tf;
    const float u = (sf - T->domainLo) * P->tableScale, v = (sb - T->domainLo) * P->tableScale;
    const float kf = len * P->lengthScale - 1.0f;
    const uint L = T->tableLengths;
    float4 e, e1;
    float tableLen = len;
    if (kf <= 0.0f) {
        kb_bilinear2(table, T->tableSize, L, 0, 0, u, v, &e, &e1);
        e = e * fmax(kf + 1.0f, 0.0f);
    } else if (kf >= (float)(L - 1)) {
        kb_bilinear2(table, T->tableSize, L, L - 1, L - 1, u, v, &e, &e1);
        tableLen = T->tableMaxLength;
    } else {
        const uint k0 = (uint)kf;
        const float fk = kf - (float)k0;
        float4 a;
        kb_bilinear2(table, T->tableSize, L, k0, k0 + 1, u, v, &a, &e1);
        e = a + fk * (e1 - a);
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

/* World length of the segment from fragment (t0, f0) to the next one (t1, f1); 0 when it lies outside the
   mesh (after a leaving boundary face or before an entering one) or has no length: nothing to composite. */
KB_INLINE float kb_segment_length(float t0, uint f0, float t1, uint f1, const VolclKBufferParams* P) {
    if ((f0 & KB_FRAG_EXIT) || (f1 & KB_FRAG_ENTER)) return 0.0f;
    const float len = (t1 - t0) * P->worldScale;
    return len > 0.0f ? len : 0.0f;
}

/* Composites the segment s0 -> s1 of length len > 0 behind acc. NAN_COLOR: a segment with a non-finite end
   lies in a NaN cell (a fragment on a face with a non-finite vertex is non-finite, and both tets of that face
   hold the vertex): a constant segment of the NaN colour, looked up nowhere. */
KB_INLINE float4 kb_composite(float4 acc, float s0, float s1, float len, __global const half* table,
                              const VolclKBufferParams* P) {
#ifdef NAN_COLOR
    if (!isfinite(s0) || !isfinite(s1)) {
        const float a = 1.0f - exp(-NAN_TAU * len);
        return acc + (1.0f - acc.w) * (float4)(NAN_R * a, NAN_G * a, NAN_B * a, a);
    }
#endif
    const float4 c = kb_preint(table, P, s0, s1, len);
    return acc + (1.0f - acc.w) * c;
}

/* Stores fragment q into the sorted ring of n entries starting at slot h of pixel base: after every entry not
   farther than q.t (equal distances keep their arrival order). */
KB_INLINE void kb_place(KBuffer kb, uint base, uint h, uint n, KbFrag q) {
    uint j = n;
    while (j > 0) {
        const uint src = base + ((h + j - 1) & (KB_RING - 1));
        const float tj = kb.t[src];
        if (!(tj > q.t)) break;
        const uint dst = base + ((h + j) & (KB_RING - 1));
        kb.t[dst] = tj;
        kb.s[dst] = kb.s[src];
        kb.f[dst] = kb.f[src];
#ifdef KB_ISO
        kb.e[dst] = kb.e[src];
#endif
        --j;
    }
    const uint at = base + ((h + j) & (KB_RING - 1));
    kb.t[at] = q.t;
    kb.s[at] = q.s;
    kb.f[at] = (uchar)q.f;
#ifdef KB_ISO
    kb.e[at] = q.e;
#endif
}

/* The fragment in ring slot `slot` (an index into the tile's slots). */
KB_INLINE KbFrag kb_get(KBuffer kb, uint slot) {
    KbFrag q;
    q.t = kb.t[slot];
    q.s = kb.s[slot];
    q.f = kb.f[slot];
#ifdef KB_ISO
    q.e = kb.e[slot];
#else
    q.e = 0u;
#endif
    return q;
}

/* Inserts fragment q into pixel li's k-buffer; when it is full, pops the nearest of the k + 1 fragments, whose
   segment to the second nearest (a stored entry nearer than or as near as the incoming fragment goes first) is
   returned: its length (0: nothing to composite) and its two fragments in *pa, *pb. */
KB_INLINE float kb_insert(KBuffer kb, uint li, KbFrag q, const VolclKBufferParams* P, KbFrag* pa,
                          KbFrag* pb) {
    const uint base = li * KB_RING;
    const uint n = kb.count[li];
    const uint h = kb.head[li];
    if (n < KB_K) {
        kb_place(kb, base, h, n, q);
        kb.count[li] = (uchar)(n + 1);
        return 0.0f;
    }
    const uint h0 = base + h;
    const float mt = kb.t[h0];
    if (q.t < mt) {
        *pa = q;
        *pb = kb_get(kb, h0);
        return kb_segment_length(q.t, q.f, mt, kb.f[h0], P);
    }
    const uint h1 = base + ((h + 1) & (KB_RING - 1));
    const float rt = kb.t[h1];
    float len;
    *pa = kb_get(kb, h0);
    if (q.t < rt) {
        *pb = q;
        len = kb_segment_length(mt, kb.f[h0], q.t, q.f, P);
    } else {
        *pb = kb_get(kb, h1);
        len = kb_segment_length(mt, kb.f[h0], rt, kb.f[h1], P);
    }
    const uint nh = (h + 1) & (KB_RING - 1);
    kb.head[li] = (uchar)nh;
    kb_place(kb, base, nh, KB_K - 1, q);
    return len;
}

#ifdef KB_ISO
/* What an iso-surface crossing is lit with: the tile list (faces of the fragments), the projected points and the
   point normals (smoothed gradients in normalized units, render/mesh/VertexNormals.hpp), iso-surfaces, lights. */
typedef struct {
    __global const uint4* list;
    __global const float4* proj;
    __global const float4* normals;
    const VolclIsoParams* iso;
    const VolclLightingParams* light;
} KbIso;

/* The normal at pixel (fx, fy) on the face of fragment q: its vertex normals interpolated with the pixel's
   barycentric weights (perspective-correct), as the fragment's scalar is. */
KB_INLINE float3 kb_frag_normal(const KbIso* X, KbFrag q, float fx, float fy, uint perspective) {
    const uint4 fv = X->list[q.e];
    const float4 a = X->proj[fv.x], b = X->proj[fv.y], c = X->proj[fv.z];
    float wa = (c.x - b.x) * (fy - b.y) - (c.y - b.y) * (fx - b.x);
    float wb = (a.x - c.x) * (fy - c.y) - (a.y - c.y) * (fx - c.x);
    float wc = (b.x - a.x) * (fy - a.y) - (b.y - a.y) * (fx - a.x);
    if (perspective) {
        wa *= a.w;
        wb *= b.w;
        wc *= c.w;
    }
    const float sum = wa + wb + wc;
    return (wa * X->normals[fv.x].xyz + wb * X->normals[fv.y].xyz + wc * X->normals[fv.z].xyz) / sum;
}

/* Composites behind acc the iso-surfaces the segment from fragment p to fragment q of pixel (fx, fy) crosses,
   in ray order: the scalar is linear along the segment (inside one tet at full level of detail), so a crossing
   lies at u = (v - s_p) / (s_q - s_p), as in the cell caster; lit with the normal linear along the segment
   between the fragments' normals (the tet's interpolated vertex normals are linear too). */
KB_INLINE float4 kb_iso_segment(float4 acc, KbFrag p, KbFrag q, float fx, float fy, const KbIso* X,
                                const VolclKBufferParams* P) {
    const VolclIsoParams* I = X->iso;
    float us[ISO_COUNT];
    int ids[ISO_COUNT];
    const int nc = iso_crossings(I, p.s, q.s, us, ids);
    if (nc == 0) return acc;
#ifdef SHADING
    const VolclLightingParams* Lp = X->light;
    const float ndcX = 2.0f * (fx + 0.5f) / (float)P->width - 1.0f;
    const float ndcY = 1.0f - 2.0f * (fy + 0.5f) / (float)P->height;
    const float3 eye = v3(P->eye), side = (ndcX * P->halfX) * v3(P->right) + (ndcY * P->halfY) * v3(P->up);
    /* Perspective: t is the distance from the eye along the pixel's ray; orthographic: the view depth from
       the pixel's point on the eye plane. */
    const float3 dir = P->perspective ? normalize(v3(P->forward) + side) : v3(P->forward);
    const float3 origin = P->perspective ? eye : eye + side;
    const float3 np = kb_frag_normal(X, p, fx, fy, P->perspective);
    const float3 nq = kb_frag_normal(X, q, fx, fy, P->perspective);
#endif
    for (int c = 0; c < nc; ++c) {
        const int i = ids[c];
        const float ia = I->color[i][3];
        float3 rgb = (float3)(I->color[i][0], I->color[i][1], I->color[i][2]);
#ifdef SHADING
        const float u = us[c];
        const float3 x = origin + (p.t + (q.t - p.t) * u) * dir;
        LightSum ls = light_begin(Lp, np + (nq - np) * u, dir);
        for (uint l = 0; l < Lp->lightCount; ++l) {
            float dist;
            const float3 L = light_dir(Lp, P->perspective, eye, dir, (int)l, x, &dist);
            light_add(&ls, Lp, (int)l, L, 1.0f, dir);
        }
        rgb = light_finish(&ls, Lp, rgb);
#endif
        acc += (1.0f - acc.w) * (float4)(rgb * ia, ia);
    }
    return acc;
}
#endif

/* Pops the remaining fragments of pixel li, at (fx, fy), in order (the k - 1 segments still stored). */
#ifdef KB_ISO
KB_INLINE void kb_flush(KBuffer kb, uint li, float fx, float fy, const KbIso* X,
                        const VolclKBufferParams* P) {
#else
KB_INLINE void kb_flush(KBuffer kb, uint li, __global const half* table, const VolclKBufferParams* P) {
#endif
    const uint base = li * KB_RING;
    const uint n = kb.count[li];
    uint h = kb.head[li];
    float4 acc = kb.acc[li];
    for (uint i = 1; i < n && acc.w < P->earlyTermination; ++i) {
        const uint a = base + h, b = base + ((h + 1) & (KB_RING - 1));
        const float len = kb_segment_length(kb.t[a], kb.f[a], kb.t[b], kb.f[b], P);
#ifdef KB_ISO
        if (len > 0.0f) acc = kb_iso_segment(acc, kb_get(kb, a), kb_get(kb, b), fx, fy, X, P);
#else
        if (len > 0.0f) acc = kb_composite(acc, kb.s[a], kb.s[b], len, table, P);
#endif
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
    if (iu < iv) {
        e.px = u.x;
        e.py = u.y;
        e.qx = v.x;
        e.qy = v.y;
        s = 1.0f;
    } else {
        e.px = v.x;
        e.py = v.y;
        e.qx = u.x;
        e.qy = u.y;
        s = -1.0f;
    }
    e.sigma = orientSign * s;
    e.tie = e.sigma * (float)kb_tie_side(e.px, e.py, e.qx, e.qy) > 0.0f;
    return e;
}

/* The row-span factors of edge e, once per face: the x coefficient b of its inside measure and 1 / b (0 when the
   edge is horizontal: it never narrows a row). */
inline float2 kb_span_factors(const KbEdge* e) {
    const float b = -e->sigma * (e->qy - e->py);
    return (float2)(b, b != 0.0f ? 1.0f / b : 0.0f);
}

/* Narrows [*xl, *xr] to the x where edge e can be inside on row y (the edge function is linear in x), with a
   margin far above float rounding (the reciprocal's included): the exact per-pixel test still decides, this
   only skips pixels. f: kb_span_factors(e). */
inline void kb_row_span(const KbEdge* e, float2 f, float fy, float* xl, float* xr) {
    if (f.x == 0.0f) return;
    const float ex = e->qx - e->px, ey = e->qy - e->py;
    const float ta = ex * (fy - e->py), tb = ey * e->px;
    const float xc = -(e->sigma * (ta + tb)) * f.y;
    const float m = 1.0f + 1e-5f * ((fabs(ta) + fabs(tb)) * fabs(f.y) + fabs(xc));
    if (f.x > 0.0f)
        *xl = fmax(*xl, xc - m);
    else
        *xr = fmin(*xr, xc + m);
}

/* Rasterises one tile (work-group): its faces in sorted order into per-pixel k-buffers in local memory, then
   flushes them and writes the composited pixels (linear, associated RGBA). */
__kernel void kb_raster(__global const float4* proj, __global const float* scalars,
                        __global const uint* binEnds, __global const uint4* list, const VolclKBufferParams P,
                        __global const half* table, __global const float4* normals, const VolclIsoParams iso,
                        const VolclLightingParams light, __global float4* out) {
    __local float lt[KB_PIXELS * KB_RING];
    __local float ls[KB_PIXELS * KB_RING];
    __local uchar lf[KB_PIXELS * KB_RING];
    __local uchar lcount[KB_PIXELS];
    __local uchar lhead[KB_PIXELS];
    __local uchar ldone[KB_PIXELS];
    __local float4 lacc[KB_PIXELS];
#ifdef KB_ISO
    /* Iso-surfaces are composited as they pop (no table lookups to batch), so the fragments' faces take the local
       memory the pending pops take in dvr. */
    __local uint le[KB_PIXELS * KB_RING];
    KBuffer kb = {lt, ls, lf, lcount, lhead, lacc, le};
    const VolclIsoParams isoP = iso;
    const VolclLightingParams lightP = light;
    const KbIso X = {list, proj, normals, &isoP, &lightP};
    (void)table;
#else
    KBuffer kb = {lt, ls, lf, lcount, lhead, lacc};
    (void)normals;
    (void)iso;
    (void)light;
    /* Pops of the current face waiting for their table lookups: KB_PIXELS / KB_TILE_THREADS per work-item. */
    __local ushort lpli[KB_PIXELS];
    __local float lps0[KB_PIXELS], lps1[KB_PIXELS], lplen[KB_PIXELS];
#endif

    const uint tile = get_group_id(0);
    const uint lid = get_local_id(0);
    const int4 bounds = tile_bounds(tile, P.tilesX, P.width, P.height);
    const int tx0 = bounds.x, ty0 = bounds.y, xEnd = bounds.z, yEnd = bounds.w;
    int live = tile_clear(lacc, ldone, bounds, lid);
    for (int ly = (int)lid; ly < KB_TILE; ly += KB_TILE_THREADS)
        for (int lx = 0; lx < KB_TILE; ++lx) {
            const uint li = (uint)(ly * KB_TILE + lx);
            lcount[li] = 0;
            lhead[li] = 0;
        }
    const uint2 range = tile_list(binEnds, tile);
    const uint start = range.x, end = range.y;

#ifndef KB_ISO
    const uint pendingBase = lid * (KB_PIXELS / KB_TILE_THREADS);
    __local ushort* pli = lpli + pendingBase;
    __local float* ps0 = lps0 + pendingBase;
    __local float* ps1 = lps1 + pendingBase;
    __local float* plen = lplen + pendingBase;
#endif
    for (uint e = start; e < end && live > 0; ++e) {
        uint np = 0;
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
        /* Wide rows are narrowed to the edges' span; a few pixels are cheaper to test than to narrow. */
        const int narrow = x1 - x0 >= KB_SPAN_MIN;
        float2 fa = (float2)(0.0f), fb = (float2)(0.0f), fc = (float2)(0.0f);
        if (narrow) {
            fa = kb_span_factors(&ea);
            fb = kb_span_factors(&eb);
            fc = kb_span_factors(&ec);
        }
        for (int y = y0; y <= y1; y += KB_TILE_THREADS) {
            const float fy = (float)y;
            int xs = x0, xe = x1;
            if (narrow) {
                float xl = (float)x0, xr = (float)x1;
                kb_row_span(&ea, fa, fy, &xl, &xr);
                kb_row_span(&eb, fb, fy, &xl, &xr);
                kb_row_span(&ec, fc, fy, &xl, &xr);
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
                KbFrag q, pa, pb;
                q.t = t;
                q.s = s;
                q.f = fl;
                q.e = e;
                const float len = kb_insert(kb, li, q, &P, &pa, &pb);
#ifdef KB_ISO
                if (len > 0.0f) {
                    const float4 acc = kb_iso_segment(lacc[li], pa, pb, fx, fy, &X, &P);
                    lacc[li] = acc;
                    if (acc.w >= P.earlyTermination) {
                        ldone[li] = 1;
                        --live;
                    }
                }
#else
                if (len > 0.0f) {
                    pli[np] = (ushort)li;
                    ps0[np] = pa.s;
                    ps1[np] = pb.s;
                    plen[np] = len;
                    ++np;
                }
#endif
            }
        }
        /* The face's pops composited in a pass of their own: a face gives a pixel at most one fragment, so this
           is the order of the inserts, and the table lookups of different pixels, independent of each other,
           overlap their cache misses instead of each stalling the rasterisation. */
#ifdef KB_ISO
        (void)np;
#else
        for (uint p = 0; p < np; ++p) {
            const uint li = pli[p];
            tile_store(lacc, ldone, li, kb_composite(lacc[li], ps0[p], ps1[p], plen[p], table, &P),
                       P.earlyTermination, &live);
        }
#endif
    }

    for (int ly = (int)lid; ly < KB_TILE; ly += KB_TILE_THREADS)
        for (int lx = 0; lx < KB_TILE; ++lx) {
            const int x = tx0 + lx, y = ty0 + ly;
            if (x >= xEnd || y >= yEnd) continue;
            const uint li = (uint)(ly * KB_TILE + lx);
#ifdef KB_ISO
            kb_flush(kb, li, (float)x, (float)y, &X, &P);
#else
            kb_flush(kb, li, table, &P);
#endif
            out[(size_t)y * P.width + (size_t)x] = lacc[li];
        }
}
