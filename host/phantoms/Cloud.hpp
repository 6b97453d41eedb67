// Cloud density volumes from seeded 3D noise: fBm of Perlin gradient noise eroded by Worley cellular noise
// under a vertical profile (z up), the model of Roettger's cloud layers.
#pragma once

#include "core/Volume.hpp"

#include <cstdint>

namespace volcl {

/// Noise coordinates are voxel indices divided by the largest axis extent (so the noise is isotropic in
/// voxel space whatever the size) times `frequency`.
struct CloudParams {
    Dims dims{128, 128, 32};
    std::uint32_t seed = 1;
    int octaves = 5;        ///< Perlin fBm octaves (each doubles the frequency, halves the amplitude)
    double frequency = 4.0; ///< base Perlin cells across the largest axis
    double coverage = 0.45; ///< fraction of the noise range that becomes cloud, in (0, 1]
    double erosion = 0.35;  ///< weight of the Worley fBm that carves billows into the Perlin shape, [0, 1]
};

/// Roettger's cloud layer: 513 x 513 x 65 voxels of 8-bit density.
CloudParams roettgerCloudPreset();

/// Density in [0, 1] at noise-space point (x, y, z) and height fraction h in [0, 1] (0 bottom, 1 top).
double cloudDensity(const CloudParams& p, double x, double y, double z, double h);

/// The cloud volume: uint8 density (255 = 1), spacing 1, origin 0. Same parameters, same bytes (any thread
/// count). Throws UsageError for out-of-range parameters. Example:
/// `Volume v = generateCloud(roettgerCloudPreset());`
Volume generateCloud(const CloudParams& p, unsigned threads = 0);

/// The box [lo, lo + out.dims()) of generateCloud(p), written into `out` (uint8): the voxels equal the whole
/// cloud's, so a cloud larger than memory can be produced piece by piece (`volcl generate cloud -o x.vcz`).
void generateCloudRegion(const CloudParams& p, Dims lo, Volume& out, unsigned threads = 0);

} // namespace volcl
