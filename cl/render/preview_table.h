/* The preview tiers' TF tables (VolclPreviewTable): a node table looked up linearly between nodes. */
#ifndef VOLCL_PREVIEW_TABLE_H
#define VOLCL_PREVIEW_TABLE_H

#include "preview_shared.h"

#pragma OPENCL FP_CONTRACT OFF

/* The table's value at data value s (clamped to the nodes), linear between nodes: shear-warp's associated
   (r a, g a, b a, a), discrete ray casting's straight (r, g, b, tau). */
inline float4 preview_lookup(__global const float4* table, const VolclPreviewTable* T, float s) {
    const float x = clamp((s - T->lo) * T->scale, 0.0f, (float)(T->size - 1));
    const uint i = min((uint)x, T->size - 2);
    const float f = x - (float)i;
    return table[i] + f * (table[i + 1] - table[i]);
}

#endif
