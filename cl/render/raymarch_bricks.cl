/* The ray marcher of cl/render/raymarch.cl (every mode and effect, same kernels `raymarch` and `raymarch_packet`)
   reading its samples from the brick pool of decoded compressed bricks (common/brick_sample.h) instead of
   a whole grid. The `vol` argument is the pool; VOXEL_TYPE is float. With GRADIENT_CACHE the `gradCache`
   argument is the pool too: its words sit beside the samples (common/brick_gradient_cache.h). */
#include "common/brick_sample.h"
#ifdef GRADIENT_CACHE
#include "common/brick_gradient_cache.h"
#endif
#include "raymarch.cl"
