/* The iso-surfaces a linear scalar crosses along a segment, in ray order: shared by the mesh renderers (the cell
   caster's tets, the k-buffer's fragment pairs). */
#ifndef VOLCL_ISO_CROSSINGS_H
#define VOLCL_ISO_CROSSINGS_H

#include "../volcl_shared.h"

/* The scalar runs linearly from sa to sb: every iso-value v with (sa >= v) != (sb >= v) is crossed at
   u = (v - sa) / (sb - sa) in [0, 1]. Writes the crossings' u (ascending; equal u keep the layers' order) and
   layer indices into us and ids (room for I->count each) and returns their number. */
inline int iso_crossings(const VolclIsoParams* I, float sa, float sb, float* us, int* ids) {
    int nc = 0;
    for (int i = 0; i < (int)I->count; ++i) {
        const float v = I->value[i];
        if ((sa >= v) != (sb >= v)) {
            const float u = clamp((v - sa) / (sb - sa), 0.0f, 1.0f);
            int j = nc++;
            while (j > 0 && us[j - 1] > u) {
                us[j] = us[j - 1];
                ids[j] = ids[j - 1];
                --j;
            }
            us[j] = u;
            ids[j] = i;
        }
    }
    return nc;
}

#endif
