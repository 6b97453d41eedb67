/* Parameters of the preview tiers (shear-warp, discrete ray casting), shared by host C++ and OpenCL C. */
#ifndef VOLCL_PREVIEW_SHARED_H
#define VOLCL_PREVIEW_SHARED_H

#include "../volcl_shared.h"

/* A transfer function tabulated at `size` nodes: node i holds the value at data value lo + i / scale. */
typedef struct VolclPreviewTable {
    float lo, scale, earlyTermination, pad0;
    volcl_uint size, pad1, pad2, pad3;
} VolclPreviewTable;

/* The shear-warp factorisation of an orthographic view (Lacroute and Levoy 1994). Slices are perpendicular to
   the principal axis c; a slice's scanlines run along axis a, its rows along axis b. Voxel (a, b) of slice k
   lies at intermediate-image pixel (a + offA + shearA k, b + offB + shearB k). */
typedef struct VolclShearWarpParams {
    volcl_uint axis[4];      /* c, a, b; [3]: 1 when the front slice is k = 0, 0 when it is k = nc - 1 */
    volcl_uint dims[4];      /* nc, na, nb, spare */
    volcl_uint inter[4];     /* intermediate image width, height; spare, spare */
    float shear[4];          /* shearA, shearB, offA, offB */
    VolclPreviewTable table; /* two tables back to back: full slice thickness, then half (end slices) */
} VolclShearWarpParams;

#endif
