/* The light-volume sweep of cl/render/light_volume.cl (same kernel `light_volume_slice`) reading its field from a
   pool of decoded compressed bricks (common/brick_sample.h) instead of a whole grid: the `vol` argument is a
   pool holding every brick of the frame at one level (render/bricks/BrickLightField.hpp); VOXEL_TYPE is float. */
#include "common/brick_sample.h"
#include "light_volume.cl"
