/* Analytic test volumes: Marschner-Lobb and the 3D Shepp-Logan phantom, sampled on [-1,1]^3 node-centred. */
#include "volcl_shared.h"

/* Node-centred coordinate of sample i of n on [-1, 1] (the single sample of n = 1 sits at 0). */
inline float unit_coord(uint i, uint n) {
    return n > 1 ? -1.0f + 2.0f * (float)i / (float)(n - 1) : 0.0f;
}

/* Marschner & Lobb (1994): rho = (1 - sin(pi z / 2) + alpha (1 + cos(2 pi fM cos(pi r / 2)))) / (2 (1 + alpha)). */
__kernel void marschner_lobb(__global float* out, uint nx, uint ny, uint nz, float fM, float alpha) {
    uint i = get_global_id(0), j = get_global_id(1), k = get_global_id(2);
    if (i >= nx || j >= ny || k >= nz) return;
    float x = unit_coord(i, nx), y = unit_coord(j, ny), z = unit_coord(k, nz);
    float r = sqrt(x * x + y * y);
    float rr = cos(2.0f * M_PI_F * fM * cos(M_PI_F * r * 0.5f));
    out[i + nx * (j + (size_t)ny * k)] =
        (1.0f - sin(M_PI_F * z * 0.5f) + alpha * (1.0f + rr)) / (2.0f * (1.0f + alpha));
}

/* Sum of the values of all ellipsoids containing the sample point. */
__kernel void shepp_logan(__global float* out, uint nx, uint ny, uint nz, __global const VolclEllipsoid* e,
                          uint count) {
    uint i = get_global_id(0), j = get_global_id(1), k = get_global_id(2);
    if (i >= nx || j >= ny || k >= nz) return;
    float3 p = (float3)(unit_coord(i, nx), unit_coord(j, ny), unit_coord(k, nz));
    float density = 0.0f;
    for (uint n = 0; n < count; ++n) {
        __global const VolclEllipsoid* el = e + n;
        float3 q = (float3)(el->rot[0] * p.x + el->rot[1] * p.y + el->rot[2] * p.z,
                            el->rot[3] * p.x + el->rot[4] * p.y + el->rot[5] * p.z,
                            el->rot[6] * p.x + el->rot[7] * p.y + el->rot[8] * p.z);
        float3 d = (q - (float3)(el->centre[0], el->centre[1], el->centre[2])) *
                   (float3)(el->invSemiAxis[0], el->invSemiAxis[1], el->invSemiAxis[2]);
        if (dot(d, d) <= 1.0f) density += el->value;
    }
    /* Cancelling intensities (1 - 0.8 - 0.2) leave float round-off below zero; densities are >= 0. */
    out[i + nx * (j + (size_t)ny * k)] = fmax(density, 0.0f);
}
