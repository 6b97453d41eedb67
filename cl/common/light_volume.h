/* Shadows from light-attenuation volumes (cl/render/light_volume.cl builds them): the transmittance toward
   light i at a sample from one trilinear fetch of the optical depth in that light's volume, instead of a
   secondary ray. */
#ifndef VOLCL_LIGHT_VOLUME_H
#define VOLCL_LIGHT_VOLUME_H

#include "camera_rays.h"

#pragma OPENCL FP_CONTRACT OFF

/* a + t (b - a), the order the C++ reference rounds in (render/grid/LightVolume.cpp). */
inline float lv_lerp(float a, float b, float t) {
    return a + t * (b - a);
}

/* Transmittance toward light i at voxel coordinates p: exp of the optical depth trilinear in light i's nodes
   (clamped to the box). */
inline float light_volume_sample(__global const float* lv, const VolclLightVolumeParams* V, uint i,
                                 float3 p) {
    const int3 hiI = (int3)((int)V->dims[0] - 1, (int)V->dims[1] - 1, (int)V->dims[2] - 1);
    const float3 q = clamp(p * v3(V->toLight), (float3)(0.0f), convert_float3(hiI));
    const int3 i0 = min(convert_int3(floor(q)), max(hiI - 1, (int3)(0)));
    const int3 i1 = min(i0 + 1, hiI);
    const float3 f = q - convert_float3(i0);
    const uint nx = V->dims[0], nxy = V->dims[0] * V->dims[1];
    __global const float* base = lv + (size_t)i * V->dims[3];
    const uint z0 = (uint)i0.z * nxy, z1 = (uint)i1.z * nxy, y0 = (uint)i0.y * nx, y1 = (uint)i1.y * nx;
    const uint x0 = (uint)i0.x, x1 = (uint)i1.x;
    const float c00 = lv_lerp(base[z0 + y0 + x0], base[z0 + y0 + x1], f.x);
    const float c10 = lv_lerp(base[z0 + y1 + x0], base[z0 + y1 + x1], f.x);
    const float c01 = lv_lerp(base[z1 + y0 + x0], base[z1 + y0 + x1], f.x);
    const float c11 = lv_lerp(base[z1 + y1 + x0], base[z1 + y1 + x1], f.x);
    return exp(-lv_lerp(lv_lerp(c00, c10, f.y), lv_lerp(c01, c11, f.y), f.z));
}

#endif
