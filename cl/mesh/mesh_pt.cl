/* Projected tetrahedra (render.method "pt"): the cells in a visibility order (back to front, from the host) get
   their screen rectangles, the k-buffer's binning (mesh_kbuffer.cl) appends them to the 16x16-pixel tiles they
   touch keeping the order, and one work-group per tile composites its cells front to back: at each pixel the
   thick ray segment between the cell's entry and exit faces, its scalar linear from s_front to s_back, through
   the 3D pre-integration table (PREINT 3 of cl/common/tf_lookup.h). Defines: KB_TILE, KB_TILE_THREADS (work-items
   per tile, each owning the rows y with (y - y0) % KB_TILE_THREADS == lid), BIN_CHUNKS (as the binning's),
   CLIPPING (clip planes cut the segments), NAN_COLOR (NaN cells drawn with the NaN colour). The C++ mirror is
   render/mesh/PtReference.cpp. */
#include "../common/camera_rays.h"
#include "../common/tf_lookup.h"
#include "mesh_kbuffer_shared.h"

#pragma OPENCL FP_CONTRACT OFF

#include "mesh_tile.h"

/* float4s per cell record: the four face planes (unit outward normal, offset), then the field (gradient, value),
   all in the normalised frame (render/mesh/PtRenderer.cpp, mesh_detail::normalisedTet). */
#define PT_TET_STRIDE 5

/* Per position of the order: the tile rectangle rects[pos] (as kb_face_keys makes them: (x0 | y0 << 16,
   x1 | y1 << 16), empty when x0 > x1) and the tile-list item (tet, pixel x0 | y0 << 16, pixel x1 | y1 << 16, 0).
   A cell wholly behind the eye plane covers nothing; a perspective cell with a vertex at or behind the near
   distance (proj.w = 0) gets the whole image, the exact per-pixel test deciding. */
__kernel void pt_tet_rects(__global const uint* order, __global const uint4* tets,
                           __global const float4* proj, const uint n, const VolclKBufferParams P,
                           __global uint4* items, __global uint2* rects) {
    const uint pos = get_global_id(0);
    if (pos >= n) return;
    const uint t = order[pos];
    const uint4 v = tets[t];
    const float4 a = proj[v.x], b = proj[v.y], c = proj[v.z], d = proj[v.w];
    uint2 rect = (uint2)(1u, 0u);
    uint4 item = (uint4)(t, 1u, 0u, 0u);
    const float zMax = fmax(fmax(a.z, b.z), fmax(c.z, d.z));
    if (zMax > 0.0f) {
        float x0 = 0.0f, y0 = 0.0f, x1 = (float)(P.width - 1), y1 = (float)(P.height - 1);
        if (!P.perspective || (a.w != 0.0f && b.w != 0.0f && c.w != 0.0f && d.w != 0.0f)) {
            x0 = ceil(fmax(fmin(fmin(a.x, b.x), fmin(c.x, d.x)), 0.0f));
            x1 = floor(fmin(fmax(fmax(a.x, b.x), fmax(c.x, d.x)), (float)(P.width - 1)));
            y0 = ceil(fmax(fmin(fmin(a.y, b.y), fmin(c.y, d.y)), 0.0f));
            y1 = floor(fmin(fmax(fmax(a.y, b.y), fmax(c.y, d.y)), (float)(P.height - 1)));
        }
        if (x0 <= x1 && y0 <= y1) {
            const uint px0 = (uint)x0, px1 = (uint)x1, py0 = (uint)y0, py1 = (uint)y1;
            rect = (uint2)(px0 / KB_TILE | ((py0 / KB_TILE) << 16), px1 / KB_TILE | ((py1 / KB_TILE) << 16));
            item = (uint4)(t, px0 | (py0 << 16), px1 | (py1 << 16), 0u);
        }
    }
    items[pos] = item;
    rects[pos] = rect;
}

/* The segment of the ray o + t d (t >= tMin, inside the clip span) in the cell whose planes are pl: [*t0, *t1],
   empty when *t1 <= *t0. A ray lying in a face plane (b = 0, a = 0) counts for exactly one of the two cells
   sharing the face: their planes are exact negatives, and the one whose normal's first non-zero component is
   positive takes it. */
inline void pt_segment(__global const float4* pl, float3 o, float3 d, float tMin, float tMax, float* t0,
                       float* t1) {
    float lo = tMin, hi = tMax;
    for (int f = 0; f < 4; ++f) {
        const float4 p = pl[f];
        const float a = p.x * o.x + p.y * o.y + p.z * o.z + p.w;
        const float b = p.x * d.x + p.y * d.y + p.z * d.z;
        if (b > 0.0f)
            hi = fmin(hi, -a / b);
        else if (b < 0.0f)
            lo = fmax(lo, -a / b);
        else if (a > 0.0f ||
                 (a == 0.0f && (p.x < 0.0f || (p.x == 0.0f && (p.y < 0.0f || (p.y == 0.0f && p.z < 0.0f))))))
            hi = -INFINITY;
    }
    *t0 = lo;
    *t1 = hi;
}

/* Composites one tile (work-group): its cells from the nearest to the farthest (the list holds them back to
   front), each over the pixels of its rectangle, into per-pixel colours in local memory; writes them (linear,
   associated RGBA). */
__kernel void pt_raster(__global const float4* cells, __global const uint* binEnds,
                        __global const uint4* list, const VolclKBufferParams P, const VolclClipParams K,
                        __global const float4* table, __global float4* out) {
    __local float4 lacc[KB_TILE * KB_TILE];
    __local uchar ldone[KB_TILE * KB_TILE];
    const uint tile = get_group_id(0);
    const uint lid = get_local_id(0);
    const int4 bounds = tile_bounds(tile, P.tilesX, P.width, P.height);
    const int tx0 = bounds.x, ty0 = bounds.y, xEnd = bounds.z, yEnd = bounds.w;
    int live = tile_clear(lacc, ldone, bounds, lid);
    const uint2 range = tile_list(binEnds, tile);
    const uint start = range.x, end = range.y;
    const float3 eye = (float3)(P.eye[0], P.eye[1], P.eye[2]);
    const float3 fw = (float3)(P.forward[0], P.forward[1], P.forward[2]);
    const float3 rt = (float3)(P.right[0], P.right[1], P.right[2]);
    const float3 up = (float3)(P.up[0], P.up[1], P.up[2]);
    const VolclTfParams T = P.tf;

    for (uint e = end; e > start && live > 0; --e) {
        const uint4 item = list[e - 1];
        __global const float4* cell = cells + (size_t)item.x * PT_TET_STRIDE;
        const float4 field = cell[4];
        const int x0 = max((int)(item.y & 0xFFFFu), tx0), x1 = min((int)(item.z & 0xFFFFu), xEnd - 1);
        int y0 = max((int)(item.y >> 16), ty0);
        const int y1 = min((int)(item.z >> 16), yEnd - 1);
        y0 += (int)(((uint)(KB_TILE_THREADS - ((y0 - ty0) % KB_TILE_THREADS)) + lid) % KB_TILE_THREADS);
        for (int y = y0; y <= y1; y += KB_TILE_THREADS) {
            const float ndcY = 1.0f - 2.0f * ((float)y + 0.5f) / (float)P.height;
            for (int x = x0; x <= x1; ++x) {
                const uint li = (uint)((y - ty0) * KB_TILE + (x - tx0));
                if (ldone[li]) continue;
                const float ndcX = 2.0f * ((float)x + 0.5f) / (float)P.width - 1.0f;
                float3 o = eye, d = fw;
                if (P.perspective)
                    d = normalize(fw + (ndcX * P.halfX) * rt + (ndcY * P.halfY) * up);
                else
                    o = eye + (ndcX * P.halfX) * rt + (ndcY * P.halfY) * up;
                /* Parameters from the point nearest the mesh centre (the origin) keep float precision for
                   far cameras; the eye is at -base. */
                const float base = fmax(-dot(o, d), 0.0f);
                o += base * d;
                float2 span = (float2)(-base, INFINITY);
#ifdef CLIPPING
                clip_planes(&K, o, d, &span);
                span.x = fmax(span.x, -base);
#endif
                float t0, t1;
                pt_segment(cell, o, d, span.x, span.y, &t0, &t1);
                if (!(t1 > t0)) continue;
                const float len = (t1 - t0) * P.worldScale;
                const float3 g = field.xyz;
                const float sf = dot(g, o + t0 * d) + field.w, sb = dot(g, o + t1 * d) + field.w;
                float4 c;
#ifdef NAN_COLOR
                if (!isfinite(sf) || !isfinite(sb)) {
                    const float a = 1.0f - exp(-NAN_TAU * len);
                    c = (float4)(NAN_R * a, NAN_G * a, NAN_B * a, a);
                } else
#endif
                    c = preint_segment(table, &T, sf, sb, len);
                tile_store(lacc, ldone, li, lacc[li] + (1.0f - lacc[li].w) * c, P.earlyTermination, &live);
            }
        }
    }

    for (int ly = (int)lid; ly < KB_TILE; ly += KB_TILE_THREADS)
        for (int lx = 0; lx < KB_TILE; ++lx) {
            const int x = tx0 + lx, y = ty0 + ly;
            if (x >= xEnd || y >= yEnd) continue;
            out[(size_t)y * P.width + (size_t)x] = lacc[(uint)(ly * KB_TILE + lx)];
        }
}
