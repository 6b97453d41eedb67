/* The ray marcher of cl/render/raymarch.cl (every mode and effect, same kernels `raymarch` and `raymarch_packet`)
   reading its samples from the brick pool of decoded compressed bricks (common/brick_sample.h) instead of
   a whole grid. The `vol` argument is the pool; VOXEL_TYPE is float. */
#include "common/brick_sample.h"
#include "raymarch.cl"
