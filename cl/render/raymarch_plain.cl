/* A DVR kernel written without any optional effect: the baseline that shows unused effects cost nothing. */
#include "common/camera_rays.h"
#include "common/grid_sample.h"
#include "common/tf_lookup.h"

/* Point-sampled emission-absorption with early termination, in 4x2 ray packets: the same arithmetic as
   raymarch_packet in raymarch.cl built with MODE=0 PREINT=0 EARLY_TERMINATION, but from source that never
   contained the other features. */
__kernel void raymarch_plain(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                             __global const float4* table, __global const uchar* macroEmpty,
                             const VolclGridRenderParams params, __global float4* out,
                             __global float* depthOut, __global const float* fogMap,
                             __global const float* lightVol, __global const uint* gradCache) {
    (void)fogMap; /* the launcher passes every grid kernel the same arguments */
    (void)lightVol;
    (void)gradCache;
    const VolclGridRenderParams* P = &params;
    const uint x0 = get_global_id(0) * PACKET_W, y0 = get_global_id(1) * PACKET_H;
    if (x0 >= params.camera.width || y0 >= params.camera.height) return;
    const float3 hi = grid_hi(&P->grid);
    RayPacket rp;
    LaneF ox, oy, oz, dx, dy, dz, enter, exit;
    LaneI nsegL, act;
    for (int l = 0; l < RAY_LANES; ++l) {
        const uint x = x0 + (uint)(l % PACKET_W), y = y0 + (uint)(l / PACKET_W);
        const Ray r = grid_ray(&P->grid, camera_ray_world(&P->camera, min(x, params.camera.width - 1),
                                                          min(y, params.camera.height - 1)));
        const float2 span = clip_box(r.o, r.d, hi, 0.0f, INFINITY);
        const bool on = x < params.camera.width && y < params.camera.height && span.y > span.x;
        ox.a[l] = r.o.x;
        oy.a[l] = r.o.y;
        oz.a[l] = r.o.z;
        dx.a[l] = r.d.x;
        dy.a[l] = r.d.y;
        dz.a[l] = r.d.z;
        enter.a[l] = on ? span.x : 0.0f;
        exit.a[l] = on ? span.y : 0.0f;
        nsegL.a[l] = on ? max((int)ceil((span.y - span.x) / P->march.step), 1) : 0;
        act.a[l] = on ? -1 : 0;
    }
    rp.ox = ox.v;
    rp.oy = oy.v;
    rp.oz = oz.v;
    rp.dx = dx.v;
    rp.dy = dy.v;
    rp.dz = dz.v;
    const float8 tEnter = enter.v, tExit = exit.v;
    const int8 nseg = nsegL.v;
    const float step = P->march.step;
    int8 active = act.v;
    int8 k = (int8)(0);
    float8 cr = (float8)(0.0f), cg = (float8)(0.0f), cb = (float8)(0.0f), T = (float8)(1.0f);
    while (any(active)) {
        const float8 t0 = tEnter + convert_float8(k) * step;
        const float8 t1 = select(fmin(t0 + step, tExit), tExit, k == nseg - 1);
        const float8 len = t1 - t0;
        LaneF s, er, eg, eb, ea;
        s.v = sample_packet(vol, &P->grid, &rp, t0 + 0.5f * len);
        for (int l = 0; l < RAY_LANES; ++l) {
            const float4 e = tf_sample(knots, P->tf.knotCount, s.a[l]);
            er.a[l] = e.x;
            eg.a[l] = e.y;
            eb.a[l] = e.z;
            ea.a[l] = e.w;
        }
        const float8 a = 1.0f - exp(-ea.v * len);
        cr = select(cr, cr + T * a * er.v, active);
        cg = select(cg, cg + T * a * eg.v, active);
        cb = select(cb, cb + T * a * eb.v, active);
        T = select(T, T * (1.0f - a), active);
        k -= active;
        active &= k < nseg;
        active &= !(1.0f - T >= P->march.earlyTermination);
    }
    LaneF R, G, Bc, A;
    R.v = cr;
    G.v = cg;
    Bc.v = cb;
    A.v = 1.0f - T;
    for (int l = 0; l < RAY_LANES; ++l) {
        const uint x = x0 + (uint)(l % PACKET_W), y = y0 + (uint)(l / PACKET_W);
        if (x < params.camera.width && y < params.camera.height)
            out[(size_t)y * params.camera.width + x] = (float4)(R.a[l], G.a[l], Bc.a[l], A.a[l]);
    }
}
