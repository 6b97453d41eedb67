/* Ray marcher: DVR (point sampled or pre-integrated), MIP, x-ray, iso-surfaces; effects only when -D asks. */
#include "volcl_shared.h"
#include "transfer_function.h"
#include "raymarch_core.h"

/* Compile-time features (the host defines exactly those a scene needs, see host/render/Effects.cpp):
   MODE          0 dvr, 1 mip, 2 iso, 3 xray
   PREINT        0 point sampling, 2 2D table at the render step, 3 3D table over segment lengths
   SKIPPING      empty-space skipping with the macrocell grid
   EARLY_TERMINATION  stop when opacity reaches params.earlyTermination
   ISO_COUNT     iso-surfaces composited in ray order (iso mode, or mixed into dvr)
   SHADING       Blinn-Phong with params.lightCount lights (GRADIENT_SOBEL: Sobel instead of central differences)
   SHADOWS       transmittance to each light by secondary marching
   SCATTERING    single scattering, Henyey-Greenstein phase
   CLIPPING      params.clipCount clipping planes */
#ifndef MODE
#define MODE 0
#endif
#ifndef PREINT
#define PREINT 0
#endif
#ifndef ISO_COUNT
#define ISO_COUNT 0
#endif
#if defined(SHADING) || defined(SCATTERING)
#define NEEDS_LIGHTS 1
#endif

#if defined(SHADING) || ISO_COUNT > 0
/* World-space gradient at voxel coordinates p. */
inline float3 gradient(__global const voxel_t* vol, const VolclRenderParams* P, float3 p) {
    const float3 inv = v3(P->volInvSpacing);
#ifdef GRADIENT_SOBEL
    /* Sobel-weighted central differences: each axis smoothed over the other two with weights 1-2-1. */
    float3 g = (float3)(0.0f);
    for (int a = -1; a <= 1; ++a)
        for (int b = -1; b <= 1; ++b) {
            const float w = (a == 0 ? 2.0f : 1.0f) * (b == 0 ? 2.0f : 1.0f);
            g.x += w * (sample_volume(vol, P, p + (float3)(1, a, b)) - sample_volume(vol, P, p + (float3)(-1, a, b)));
            g.y += w * (sample_volume(vol, P, p + (float3)(a, 1, b)) - sample_volume(vol, P, p + (float3)(a, -1, b)));
            g.z += w * (sample_volume(vol, P, p + (float3)(a, b, 1)) - sample_volume(vol, P, p + (float3)(a, b, -1)));
        }
    return g * (1.0f / 32.0f) * inv;
#else
    const float gx = sample_volume(vol, P, p + (float3)(1, 0, 0)) - sample_volume(vol, P, p - (float3)(1, 0, 0));
    const float gy = sample_volume(vol, P, p + (float3)(0, 1, 0)) - sample_volume(vol, P, p - (float3)(0, 1, 0));
    const float gz = sample_volume(vol, P, p + (float3)(0, 0, 1)) - sample_volume(vol, P, p - (float3)(0, 0, 1));
    return (float3)(gx, gy, gz) * 0.5f * inv;
#endif
}
#endif

#ifdef NEEDS_LIGHTS
/* Unit direction from world point x toward light i, and the distance to it (INFINITY for directional). */
inline float3 light_dir(const VolclRenderParams* P, const Ray* r, int i, float3 x, float* dist) {
    const float kind = P->lightPos[i][3];
    if (kind == VOLCL_LIGHT_POINT) {
        const float3 v = v3(P->lightPos[i]) - x;
        *dist = length(v);
        return *dist > 0.0f ? v / *dist : -r->dWorld;
    }
    if (kind == VOLCL_LIGHT_HEAD) {
        if (P->dims[3]) {
            const float3 v = r->oWorld - x;
            *dist = length(v);
            return *dist > 0.0f ? v / *dist : -r->dWorld;
        }
        *dist = INFINITY;
        return -r->dWorld;
    }
    *dist = INFINITY;
    return v3(P->lightPos[i]);
}

#ifdef SHADOWS
/* Transmittance from world point x toward a light, point sampled at params.shadowStep. */
inline float shadow_transmittance(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                                  const VolclRenderParams* P, float3 x, float3 L, float dist) {
    const float3 inv = v3(P->volInvSpacing);
    const float3 o = (x - v3(P->volOrigin)) * inv, d = L * inv;
    const float3 hi = (float3)(P->dims[0] - 1, P->dims[1] - 1, P->dims[2] - 1);
    const float2 span = clip_box(o, d, hi, 0.0f, dist);
    if (!(span.y > span.x)) return 1.0f;
    const float h = P->shadowStep;
    float depth = 0.0f;
    for (float t = span.x + 0.5f * h; t < span.y; t += h) {
        const float len = fmin(h, span.y - (t - 0.5f * h));
        depth += tf_sample(knots, P->knotCount, sample_volume(vol, P, o + t * d)).w * len;
        if (depth > 7.0f) return 0.0f; /* below 1e-3: the light is blocked for display purposes */
    }
    return exp(-depth);
}
#endif

/* Light reaching the eye from a sample of straight colour c at world point x: shading and/or scattering. */
inline float3 light_sample(__global const voxel_t* vol, __global const VolclTfKnot* knots, const VolclRenderParams* P,
                           const Ray* r, float3 x, float3 p, float3 c) {
    float3 out = (float3)(0.0f);
#ifdef SHADING
    const float3 g = gradient(vol, P, p);
    const float gl = length(g);
    float3 N = gl > P->gradientMin ? -g / gl : (float3)(0.0f);
    const float3 V = -r->dWorld;
    if (dot(N, V) < 0.0f) N = -N;
    float3 diffuse = (float3)(0.0f), specular = (float3)(0.0f);
#endif
#ifdef SCATTERING
    float3 scattered = (float3)(0.0f);
#endif
    for (uint i = 0; i < P->lightCount; ++i) {
        float dist;
        const float3 L = light_dir(P, r, (int)i, x, &dist);
        const float3 lc = v3(P->lightColor[i]);
#ifdef SHADOWS
        const float vis = shadow_transmittance(vol, knots, P, x, L, dist);
#else
        const float vis = 1.0f;
#endif
#ifdef SHADING
        if (gl > P->gradientMin) {
            const float3 H = normalize(L + V);
            diffuse += lc * vis * fmax(dot(N, L), 0.0f);
            specular += lc * vis * pow(fmax(dot(N, H), 0.0f), P->shininess);
        } else {
            diffuse += lc * vis; /* no defined normal (flat region): lit as if facing the light, no highlight */
        }
#endif
#ifdef SCATTERING
        const float g = P->phaseG, ct = dot(L, r->dWorld);
        const float denom = 1.0f + g * g - 2.0f * g * ct;
        const float phase = (1.0f - g * g) / (4.0f * M_PI_F * denom * sqrt(denom));
        scattered += lc * vis * phase;
#endif
    }
#ifdef SHADING
    out += c * (P->ambient + P->diffuse * diffuse) + P->specular * specular;
#else
    out += c;
#endif
#ifdef SCATTERING
    out += P->albedo * c * scattered;
#endif
    return out;
}
#endif

#if PREINT == 2 || PREINT == 3
/* Table value at fractional node coordinates (front u, back v) of slice k: bilinear. */
inline float4 table_bilinear(__global const float4* table, uint n, uint k, float u, float v) {
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

/* Associated (rgb, alpha) of a segment with linear scalar from sf to sb and length len. */
inline float4 preint_segment(__global const float4* table, const VolclRenderParams* P, float sf, float sb, float len) {
    const float scale = (float)(P->tableSize - 1) / (P->domainHi - P->domainLo);
    const float u = (sf - P->domainLo) * scale, v = (sb - P->domainLo) * scale;
#if PREINT == 2
    float4 e = table_bilinear(table, P->tableSize, 0, u, v);
    const float tableLen = P->step;
#else
    /* Slices hold l_k = (k + 1) D / L; below l_0 interpolate toward the empty segment. */
    const float kf = len * (float)P->tableLengths / P->tableMaxLength - 1.0f;
    float4 e;
    float tableLen = len;
    if (kf <= 0.0f) {
        e = table_bilinear(table, P->tableSize, 0, u, v) * fmax(kf + 1.0f, 0.0f);
    } else if (kf >= (float)(P->tableLengths - 1)) {
        e = table_bilinear(table, P->tableSize, P->tableLengths - 1, u, v);
        tableLen = P->tableMaxLength;
    } else {
        const uint k0 = (uint)kf;
        const float fk = kf - (float)k0;
        const float4 a = table_bilinear(table, P->tableSize, k0, u, v);
        e = a + fk * (table_bilinear(table, P->tableSize, k0 + 1, u, v) - a);
    }
#endif
    if (len != tableLen) {
        /* Other length: exact for a constant scalar (alpha from optical depth, colour in proportion). */
        const float a = clamp(e.w, 0.0f, 1.0f);
        const float an = a < 1.0f ? 1.0f - pow(1.0f - a, len / tableLen) : 1.0f;
        const float3 rgb = a > 0.0f ? e.xyz * (an / a) : e.xyz * (len / tableLen);
        e = (float4)(rgb, an);
    }
    return e;
}
#endif

#ifdef SKIPPING
/* Macrocell index holding voxel point p and the ray parameter where the ray leaves that cell. */
inline uint macro_cell(const VolclRenderParams* P, const Ray* r, float t, float* exitT) {
    const float3 p = ray_at(r, t);
    const float B = (float)P->macroDims[3];
    const int3 m = (int3)((int)P->macroDims[0] - 1, (int)P->macroDims[1] - 1, (int)P->macroDims[2] - 1);
    const int3 c = clamp(convert_int3(floor(p / B)), (int3)(0), m);
    const float3 lo = convert_float3(c) * B;
    const float3 hiBox = (float3)(P->dims[0] - 1, P->dims[1] - 1, P->dims[2] - 1);
    const float3 hi = fmin(lo + B, hiBox);
    const float pa[3] = {p.x, p.y, p.z}, da[3] = {r->d.x, r->d.y, r->d.z};
    const float la[3] = {lo.x, lo.y, lo.z}, ha[3] = {hi.x, hi.y, hi.z};
    float e = INFINITY;
    for (int a = 0; a < 3; ++a) {
        if (da[a] > 0.0f) e = fmin(e, (ha[a] - pa[a]) / da[a]);
        else if (da[a] < 0.0f) e = fmin(e, (la[a] - pa[a]) / da[a]);
    }
    *exitT = t + fmax(e, 0.0f);
    return ((uint)c.z * P->macroDims[1] + (uint)c.y) * P->macroDims[0] + (uint)c.x;
}
#endif

#include "raymarch_iso.h"

__kernel void raymarch(__global const voxel_t* vol, __global const VolclTfKnot* knots, __global const float4* table,
                       __global const uchar* macroEmpty, const VolclRenderParams params, __global float4* out,
                       __global float* depthOut) {
    const uint x = get_global_id(0), y = get_global_id(1);
    if (x >= params.width || y >= params.height) return;
    const VolclRenderParams* P = &params;
    const Ray r = camera_ray(P, x, y);
    const float3 hi = (float3)(P->dims[0] - 1, P->dims[1] - 1, P->dims[2] - 1);
    float2 span = clip_box(r.o, r.d, hi, 0.0f, INFINITY);
#ifdef CLIPPING
    for (uint i = 0; i < P->clipCount; ++i) {
        const float3 n = v3(P->clipPlane[i]);
        const float a = dot(n, r.oWorld) + P->clipPlane[i][3], b = dot(n, r.dWorld);
        if (b > 0.0f) span.x = fmax(span.x, -a / b);
        else if (b < 0.0f) span.y = fmin(span.y, -a / b);
        else if (a < 0.0f) span.y = -INFINITY;
    }
#endif
    float3 rgb = (float3)(0.0f);
    float T = 1.0f;
    float depth = INFINITY;
    const size_t pix = (size_t)y * params.width + x;
    if (!(span.y > span.x)) {
        out[pix] = (float4)(0.0f);
#if ISO_COUNT > 0
        depthOut[pix] = INFINITY;
#endif
        return;
    }
    const float tEnter = span.x, tExit = span.y, step = P->step;
    const float lenTotal = tExit - tEnter;
    const int nseg = max((int)ceil(lenTotal / step), 1);
    float4 result;

#if MODE == 1 /* ---------------- maximum intensity projection ---------------- */
    float smax = -INFINITY;
    for (int k = 0; k <= nseg; ++k) {
        const float t = k == nseg ? tExit : tEnter + (float)k * step;
        smax = fmax(smax, sample_volume(vol, P, ray_at(&r, t)));
    }
    const float4 e = tf_sample(knots, P->knotCount, smax);
    const float a = 1.0f - exp(-e.w);
    result = (float4)(e.xyz * a, a);

#elif MODE == 3 /* ---------------- x-ray: absorption only ---------------- */
    float opticalDepth = 0.0f;
    for (int k = 0; k < nseg; ++k) {
        const float t0 = tEnter + (float)k * step, t1 = fmin(t0 + step, tExit);
        const float len = t1 - t0;
        opticalDepth += tf_sample(knots, P->knotCount, sample_volume(vol, P, ray_at(&r, t0 + 0.5f * len))).w * len;
    }
    const float a = 1.0f - exp(-opticalDepth);
    result = (float4)(a, a, a, a);

#else /* ---------------- dvr and iso: front-to-back compositing ---------------- */
#if PREINT != 0 || ISO_COUNT > 0
    float sPrev = sample_volume(vol, P, ray_at(&r, tEnter));
#endif
#ifdef SKIPPING
    float cellExit = -INFINITY;
#endif
#if ISO_COUNT > 0
    IsoState iso; /* the iso-surfaces' cell walk carries over from segment to segment */
    iso_begin(&iso, &r);
#endif
    int k = 0;
    while (k < nseg) {
        const float t0 = tEnter + (float)k * step;
#ifdef SKIPPING
        if (t0 >= cellExit) {
            float exitT;
            const uint cell = macro_cell(P, &r, t0, &exitT);
            cellExit = exitT;
            if (macroEmpty[cell]) {
                /* Segments with both ends in an empty cell add nothing: jump to the last one starting in it. */
                const int j = min((int)floor((exitT - tEnter) / step), nseg);
                if (j > k) {
                    k = j;
#if PREINT != 0 || ISO_COUNT > 0
                    if (k < nseg) sPrev = sample_volume(vol, P, ray_at(&r, tEnter + (float)k * step));
#endif
                    continue;
                }
            }
        }
#endif
        const float t1 = k == nseg - 1 ? tExit : fmin(t0 + step, tExit);
        const float len = t1 - t0;
#if PREINT != 0 || ISO_COUNT > 0
        const float sNext = sample_volume(vol, P, ray_at(&r, t1));
#endif
#if ISO_COUNT > 0
        iso_march(vol, knots, P, &r, &iso, t0, t1, &rgb, &T, &depth);
#endif
#if MODE == 0
#if PREINT == 0
        const float tm = t0 + 0.5f * len;
        const float3 pm = ray_at(&r, tm);
        const float4 e = tf_sample(knots, P->knotCount, sample_volume(vol, P, pm));
        const float a = 1.0f - exp(-e.w * len);
        float3 c = e.xyz;
#ifdef NEEDS_LIGHTS
        if (a > 0.0f) c = light_sample(vol, knots, P, &r, r.oWorld + tm * r.dWorld, pm, c);
#endif
        rgb += T * a * c;
        T *= 1.0f - a;
#else
        const float4 e = preint_segment(table, P, sPrev, sNext, len);
        float3 c = e.xyz;
#ifdef NEEDS_LIGHTS
        /* Lighting scales the segment's associated colour as it would scale a straight colour. */
        if (e.w > 0.0f) {
            const float tm = t0 + 0.5f * len;
            c = light_sample(vol, knots, P, &r, r.oWorld + tm * r.dWorld, ray_at(&r, tm), c);
        }
#endif
        rgb += T * c;
        T *= 1.0f - e.w;
#endif
#endif
#if PREINT != 0 || ISO_COUNT > 0
        sPrev = sNext;
#endif
#ifdef EARLY_TERMINATION
        if (1.0f - T >= P->earlyTermination) break;
#endif
        ++k;
    }
    result = (float4)(rgb, 1.0f - T);
#endif
    out[pix] = result;
#if ISO_COUNT > 0
    depthOut[pix] = depth;
#endif
}

#if MODE == 0 && !defined(NEEDS_LIGHTS) && ISO_COUNT == 0
/* Macrocells of a packet at ray parameter t: index and the parameter where each ray leaves its cell
   (macro_cell per lane, vectorised). */
PACKET_INLINE uint8 macro_cell8(const VolclRenderParams* P, const RayPacket* r, float8 t, float8* exitT) {
    const float8 px = r->ox + t * r->dx, py = r->oy + t * r->dy, pz = r->oz + t * r->dz;
    const float B = (float)P->macroDims[3];
    const int8 cx = clamp(convert_int8(floor(px / B)), 0, (int)P->macroDims[0] - 1);
    const int8 cy = clamp(convert_int8(floor(py / B)), 0, (int)P->macroDims[1] - 1);
    const int8 cz = clamp(convert_int8(floor(pz / B)), 0, (int)P->macroDims[2] - 1);
    const float8 lx = convert_float8(cx) * B, ly = convert_float8(cy) * B, lz = convert_float8(cz) * B;
    const float8 hx = fmin(lx + B, (float)(P->dims[0] - 1)), hy = fmin(ly + B, (float)(P->dims[1] - 1)),
                 hz = fmin(lz + B, (float)(P->dims[2] - 1));
    float8 e = (float8)(INFINITY);
    e = select(e, fmin(e, (hx - px) / r->dx), r->dx > 0.0f);
    e = select(e, fmin(e, (lx - px) / r->dx), r->dx < 0.0f);
    e = select(e, fmin(e, (hy - py) / r->dy), r->dy > 0.0f);
    e = select(e, fmin(e, (ly - py) / r->dy), r->dy < 0.0f);
    e = select(e, fmin(e, (hz - pz) / r->dz), r->dz > 0.0f);
    e = select(e, fmin(e, (lz - pz) / r->dz), r->dz < 0.0f);
    *exitT = t + fmax(e, 0.0f);
    return (convert_uint8(cz) * P->macroDims[1] + convert_uint8(cy)) * P->macroDims[0] + convert_uint8(cx);
}

#if PREINT == 2 || PREINT == 3
/* Bilinear table value of slice k at node cell (i0, j0) with fractions (fu, fv): table_bilinear's arithmetic
   after its index computation. */
PACKET_INLINE float4 table_cell(__global const float4* table, uint n, uint k, uint i0, uint j0, float fu, float fv) {
    __global const float4* row0 = table + ((size_t)k * n + i0) * n;
    __global const float4* row1 = row0 + n;
    const float4 a = row0[j0] + fv * (row0[j0 + 1] - row0[j0]);
    const float4 b = row1[j0] + fv * (row1[j0 + 1] - row1[j0]);
    return a + fu * (b - a);
}

/* preint_segment for a packet: index arithmetic and the length correction in float8, the four table reads
   per lane. Returns associated (r, g, b, alpha) per lane. */
PACKET_INLINE void preint_packet(__global const float4* table, const VolclRenderParams* P, float8 sf, float8 sb,
                                 float8 len, float8* outR, float8* outG, float8* outB, float8* outA) {
    const uint n = P->tableSize;
    const float scale = (float)(n - 1) / (P->domainHi - P->domainLo);
    const float hi = (float)(n - 1);
    const float8 u = clamp((sf - P->domainLo) * scale, 0.0f, hi), v = clamp((sb - P->domainLo) * scale, 0.0f, hi);
    LaneU i0, j0;
    i0.v = min(convert_uint8(u), n - 2);
    j0.v = min(convert_uint8(v), n - 2);
    LaneF fu, fv;
    fu.v = u - convert_float8(i0.v);
    fv.v = v - convert_float8(j0.v);
    LaneF er, eg, eb, ea;
#if PREINT == 2
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const float4 e = table_cell(table, n, 0, i0.a[l], j0.a[l], fu.a[l], fv.a[l]);
        er.a[l] = e.x; eg.a[l] = e.y; eb.a[l] = e.z; ea.a[l] = e.w;
    }
    const float8 tableLen = (float8)(P->step);
#else
    /* Slices hold l_k = (k + 1) D / L; below l_0 interpolate toward the empty segment. */
    const uint L = P->tableLengths;
    LaneF kf;
    kf.v = len * (float)L / P->tableMaxLength - 1.0f;
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const float k = kf.a[l];
        float4 e;
        if (k <= 0.0f) {
            e = table_cell(table, n, 0, i0.a[l], j0.a[l], fu.a[l], fv.a[l]) * fmax(k + 1.0f, 0.0f);
        } else if (k >= (float)(L - 1)) {
            e = table_cell(table, n, L - 1, i0.a[l], j0.a[l], fu.a[l], fv.a[l]);
        } else {
            const uint k0 = (uint)k;
            const float fk = k - (float)k0;
            const float4 a = table_cell(table, n, k0, i0.a[l], j0.a[l], fu.a[l], fv.a[l]);
            e = a + fk * (table_cell(table, n, k0 + 1, i0.a[l], j0.a[l], fu.a[l], fv.a[l]) - a);
        }
        er.a[l] = e.x; eg.a[l] = e.y; eb.a[l] = e.z; ea.a[l] = e.w;
    }
    const float8 tableLen = select(len, (float8)(P->tableMaxLength), (kf.v > 0.0f) & (kf.v >= (float)(L - 1)));
#endif
    const int8 other = len != tableLen;
    if (any(other)) {
        /* Other length: exact for a constant scalar (alpha from optical depth, colour in proportion). */
        const float8 a = clamp(ea.v, 0.0f, 1.0f);
        const float8 an = select((float8)(1.0f), 1.0f - pow(1.0f - a, len / tableLen), a < 1.0f);
        const float8 ratio = select(len / tableLen, an / a, a > 0.0f);
        er.v = select(er.v, er.v * ratio, other);
        eg.v = select(eg.v, eg.v * ratio, other);
        eb.v = select(eb.v, eb.v * ratio, other);
        ea.v = select(ea.v, an, other);
    }
    *outR = er.v;
    *outG = eg.v;
    *outB = eb.v;
    *outA = ea.v;
}
#endif

/* DVR (point sampled or pre-integrated, skipping, early termination, clipping) for a 4x2 block of pixels
   per work-item; the host launches it instead of `raymarch` when the scene has no lights and no
   iso-surfaces. Same image as `raymarch`. */
__kernel void raymarch_packet(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                              __global const float4* table, __global const uchar* macroEmpty,
                              const VolclRenderParams params, __global float4* out, __global float* depthOut) {
    const VolclRenderParams* P = &params;
    const uint x0 = get_global_id(0) * PACKET_W, y0 = get_global_id(1) * PACKET_H;
    if (x0 >= params.width || y0 >= params.height) return;
    const float3 hi = (float3)(P->dims[0] - 1, P->dims[1] - 1, P->dims[2] - 1);
    RayPacket rp;
    LaneF ox, oy, oz, dx, dy, dz, enter, exit;
    LaneI nsegL, act;
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const uint x = x0 + (uint)(l % PACKET_W), y = y0 + (uint)(l / PACKET_W);
        const Ray r = camera_ray(P, min(x, params.width - 1), min(y, params.height - 1));
        float2 span = clip_box(r.o, r.d, hi, 0.0f, INFINITY);
#ifdef CLIPPING
        for (uint i = 0; i < P->clipCount; ++i) {
            const float3 n = v3(P->clipPlane[i]);
            const float a = dot(n, r.oWorld) + P->clipPlane[i][3], b = dot(n, r.dWorld);
            if (b > 0.0f) span.x = fmax(span.x, -a / b);
            else if (b < 0.0f) span.y = fmin(span.y, -a / b);
            else if (a < 0.0f) span.y = -INFINITY;
        }
#endif
        const bool on = x < params.width && y < params.height && span.y > span.x;
        ox.a[l] = r.o.x; oy.a[l] = r.o.y; oz.a[l] = r.o.z;
        dx.a[l] = r.d.x; dy.a[l] = r.d.y; dz.a[l] = r.d.z;
        enter.a[l] = on ? span.x : 0.0f;
        exit.a[l] = on ? span.y : 0.0f;
        nsegL.a[l] = on ? max((int)ceil((span.y - span.x) / P->step), 1) : 0;
        act.a[l] = on ? -1 : 0;
    }
    rp.ox = ox.v; rp.oy = oy.v; rp.oz = oz.v; rp.dx = dx.v; rp.dy = dy.v; rp.dz = dz.v;
    const float8 tEnter = enter.v, tExit = exit.v;
    const int8 nseg = nsegL.v;
    const float step = P->step;
    int8 active = act.v;
    int8 k = (int8)(0);
    float8 cr = (float8)(0.0f), cg = (float8)(0.0f), cb = (float8)(0.0f), T = (float8)(1.0f);
#if PREINT != 0
    float8 sPrev = sample_packet(vol, P, &rp, tEnter);
#endif
#ifdef SKIPPING
    float8 cellExit = (float8)(-INFINITY);
#endif
    while (any(active)) {
        float8 t0 = tEnter + convert_float8(k) * step;
#ifdef SKIPPING
        const int8 need = active & (t0 >= cellExit);
        if (any(need)) {
            float8 exitT;
            LaneU cell;
            cell.v = macro_cell8(P, &rp, t0, &exitT);
            cellExit = select(cellExit, exitT, need);
            LaneI empty;
            _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) empty.a[l] = macroEmpty[cell.a[l]] ? -1 : 0;
            /* Segments with both ends in an empty cell add nothing: jump to the last one starting in it. */
            const int8 j = min(convert_int8(floor((exitT - tEnter) / step)), nseg);
            const int8 jump = need & empty.v & (j > k);
            if (any(jump)) {
                k = select(k, j, jump);
                active &= k < nseg;
                t0 = tEnter + convert_float8(k) * step;
#if PREINT != 0
                sPrev = select(sPrev, sample_packet(vol, P, &rp, t0), jump);
#endif
                if (!any(active)) break;
            }
        }
#endif
        const float8 t1 = select(fmin(t0 + step, tExit), tExit, k == nseg - 1);
        const float8 len = t1 - t0;
        LaneF er, eg, eb, ea;
#if PREINT == 0
        LaneF s;
        s.v = sample_packet(vol, P, &rp, t0 + 0.5f * len);
        _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
            const float4 e = tf_sample(knots, P->knotCount, s.a[l]);
            er.a[l] = e.x; eg.a[l] = e.y; eb.a[l] = e.z; ea.a[l] = e.w;
        }
        const float8 a = 1.0f - exp(-ea.v * len);
        const float8 wr = T * a * er.v, wg = T * a * eg.v, wb = T * a * eb.v;
#else
        const float8 sNext = sample_packet(vol, P, &rp, t1);
        preint_packet(table, P, sPrev, sNext, len, &er.v, &eg.v, &eb.v, &ea.v);
        const float8 a = ea.v;
        const float8 wr = T * er.v, wg = T * eg.v, wb = T * eb.v;
        sPrev = sNext;
#endif
        cr = select(cr, cr + wr, active);
        cg = select(cg, cg + wg, active);
        cb = select(cb, cb + wb, active);
        T = select(T, T * (1.0f - a), active);
        k -= active; /* active lanes are -1 */
        active &= k < nseg;
#ifdef EARLY_TERMINATION
        active &= !(1.0f - T >= P->earlyTermination);
#endif
    }
    LaneF R, G, Bc, A;
    R.v = cr; G.v = cg; Bc.v = cb; A.v = 1.0f - T;
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const uint x = x0 + (uint)(l % PACKET_W), y = y0 + (uint)(l / PACKET_W);
        if (x < params.width && y < params.height)
            out[(size_t)y * params.width + x] = (float4)(R.a[l], G.a[l], Bc.a[l], A.a[l]);
    }
}
#endif
