/* A DVR kernel written without any optional effect: the baseline that shows unused effects cost nothing. */
#include "raymarch_core.h"
#include "transfer_function.h"

/* Point-sampled emission-absorption with early termination: the same arithmetic as raymarch.cl built with
   MODE=0 PREINT=0 EARLY_TERMINATION, but from source that never contained the other features. */
__kernel void raymarch_plain(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                             __global const float4* table, __global const uchar* macroEmpty,
                             const VolclRenderParams params, __global float4* out, __global float* depthOut) {
    const uint x = get_global_id(0), y = get_global_id(1);
    if (x >= params.width || y >= params.height) return;
    const VolclRenderParams* P = &params;
    const Ray r = camera_ray(P, x, y);
    const float3 hi = (float3)(P->dims[0] - 1, P->dims[1] - 1, P->dims[2] - 1);
    const float2 span = clip_box(r.o, r.d, hi, 0.0f, INFINITY);
    const size_t pix = (size_t)y * params.width + x;
    if (!(span.y > span.x)) {
        out[pix] = (float4)(0.0f);
        return;
    }
    const float tEnter = span.x, tExit = span.y, step = P->step;
    const int nseg = max((int)ceil((tExit - tEnter) / step), 1);
    float3 rgb = (float3)(0.0f);
    float T = 1.0f;
    for (int k = 0; k < nseg; ++k) {
        const float t0 = tEnter + (float)k * step;
        const float t1 = k == nseg - 1 ? tExit : fmin(t0 + step, tExit);
        const float len = t1 - t0;
        const float4 e = tf_sample(knots, P->knotCount, sample_volume(vol, P, ray_at(&r, t0 + 0.5f * len)));
        const float a = 1.0f - exp(-e.w * len);
        rgb += T * a * e.xyz;
        T *= 1.0f - a;
        if (1.0f - T >= P->earlyTermination) break;
    }
    out[pix] = (float4)(rgb, 1.0f - T);
}
