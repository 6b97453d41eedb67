/* Camera rays for every renderer: pixel -> world ray, clip planes on the ray interval, ray packets. */
#ifndef VOLCL_CAMERA_RAYS_H
#define VOLCL_CAMERA_RAYS_H

#include "../volcl_shared.h"

#pragma OPENCL FP_CONTRACT OFF

inline float3 v3(const float a[4]) {
    return (float3)(a[0], a[1], a[2]);
}

/* A ray in world space: origin and unit direction. */
typedef struct {
    float3 o;
    float3 d;
} WorldRay;

/* The ray through the centre of pixel (x, y), y = 0 at the top. */
inline WorldRay camera_ray_world(const VolclCameraParams* C, uint x, uint y) {
    const float ndcX = 2.0f * ((float)x + 0.5f) / (float)C->width - 1.0f;
    const float ndcY = 1.0f - 2.0f * ((float)y + 0.5f) / (float)C->height;
    WorldRay r;
    const float3 f = v3(C->forward), right = v3(C->right), up = v3(C->up);
    if (C->perspective) {
        r.o = v3(C->origin);
        r.d = normalize(f + ndcX * right + ndcY * up);
    } else {
        r.o = v3(C->origin) + ndcX * right + ndcY * up;
        r.d = f;
    }
    return r;
}

/* Narrows the ray interval *span (in the parameter t of o + t d, d in world units per t) to the half-spaces
   the clip planes keep; an empty interval has span.y <= span.x. */
inline void clip_planes(const VolclClipParams* K, float3 o, float3 d, float2* span) {
    for (uint i = 0; i < K->count; ++i) {
        const float3 n = v3(K->plane[i]);
        const float a = dot(n, o) + K->plane[i][3], b = dot(n, d);
        if (b > 0.0f)
            span->x = fmax(span->x, -a / b);
        else if (b < 0.0f)
            span->y = fmin(span->y, -a / b);
        else if (a < 0.0f)
            span->y = -INFINITY;
    }
}

/* ---------------- ray packets ----------------
   PoCL runs one work-item's ray loop as scalar code (it cannot vectorise divergent loops across
   work-items), so the hot kernels march RAY_LANES rays per work-item in explicit float8 vectors:
   a 4x2 pixel block whose rays stay close, so they sample the same cache lines and end together.
   Lanes finish independently (masks); the arithmetic per lane is the scalar kernel's, operation for
   operation, so the image is the same. */
#define RAY_LANES 8
/* Packet helpers are inlined into the ray loop: as calls they pass their float8 values through the stack. */
#define PACKET_INLINE __attribute__((always_inline)) inline
#define PACKET_W 4
#define PACKET_H 2

typedef union {
    float8 v;
    float a[8];
} LaneF;
typedef union {
    int8 v;
    int a[8];
} LaneI;
typedef union {
    uint8 v;
    uint a[8];
} LaneU;

/* A packet of rays: origin o, direction d (per unit of the ray parameter). */
typedef struct {
    float8 ox, oy, oz, dx, dy, dz;
} RayPacket;

#endif
