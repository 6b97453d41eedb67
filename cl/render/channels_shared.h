/* Structs shared by the multi-channel ray marcher (raymarch_channels.cl) and its host (ChannelRenderer). */
#ifndef VOLCL_CHANNELS_SHARED_H
#define VOLCL_CHANNELS_SHARED_H

#include "../volcl_shared.h"

#define VOLCL_MAX_CHANNELS 4

/* Per-channel classification: knots of channel c are knots[knotStart[c] .. knotStart[c] + knotCount[c]);
   visible[c] = 0 leaves the channel out. colorScale: DIRECT colour's factor from stored value to [0, 1].
   nanRgbt: the NaN colour (straight rgb, extinction). */
typedef struct VolclChannelParams {
    volcl_uint knotStart[VOLCL_MAX_CHANNELS];
    volcl_uint knotCount[VOLCL_MAX_CHANNELS];
    volcl_uint visible[VOLCL_MAX_CHANNELS];
    float colorScale[VOLCL_MAX_CHANNELS];
    float nanRgbt[4];
} VolclChannelParams;

typedef struct VolclChannelRenderParams {
    VolclCameraParams camera;
    VolclClipParams clip;
    VolclMarchParams march;
    VolclGridParams grid;
    VolclChannelParams channels;
} VolclChannelRenderParams;

#ifndef __OPENCL_VERSION__
static_assert(sizeof(VolclChannelParams) == 80, "VolclChannelParams layout must match OpenCL C");
static_assert(sizeof(VolclChannelRenderParams) == 80 + 144 + 16 + 96 + 80,
              "VolclChannelRenderParams layout must match OpenCL C");
#endif

#endif
