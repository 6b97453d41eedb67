// Per-device tuning: work-group sizes of every kernel launch family, CPU/GPU choices, macrocell edge.
#pragma once

#include <cstddef>
#include <string_view>

namespace volcl {

struct DeviceInfo;

/// A work-group (local) size; unused dimensions stay 1.
struct LocalSize {
    std::size_t x = 1, y = 1, z = 1;
};

/// The tuning values one kind of device runs with, chosen once per ComputeContext (see deviceProfileFor).
/// Launch sites, and the kernel defines derived from a launch size, read them here; the values and the
/// reasons for them are in the one table of DeviceProfile.cpp.
struct DeviceProfile {
    std::string_view entry; ///< name of the table entry ("cpu", "any")

    /// Defaults of ComputeContext::launch1d/2d/3d when a call names no local size.
    struct Launch {
        std::size_t local1d = 0;
        LocalSize local2d, local3d;
    } launch;
    /// Host buffers are worked on in place (CL_MEM_USE_HOST_PTR over pooled host memory) instead of copied.
    bool hostBuffersInPlace = false;
    std::size_t copyLocal = 0; ///< copy_float16 of the bandwidth ceiling (copyKernelBandwidthGBs)
    LocalSize phantom;         ///< marschner_lobb and shepp_logan, one work-item per voxel

    /// Wavelet lifting (codec/lifting.cl, codec/lifting_brick.cl).
    struct Lifting {
        LocalSize x, yz;                          ///< lift_x; lift_yz
        LocalSize copy;                           ///< copy_corner
        bool brickResident = false;               ///< LiftingPath::Auto may pick the brick-resident kernel
        std::size_t brickLocal = 0;               ///< lift_bricks
        std::size_t brickItemsPerComputeUnit = 0; ///< lift_bricks work-items per compute unit
    } lifting;

    /// Motion search and compensation (codec/ motion kernels).
    struct Motion {
        std::size_t search = 0, reduce = 0; ///< per (block, candidate) pair; per block
        std::size_t costs = 0;              ///< block mode costs, per block
        LocalSize rows;                     ///< compensation and reconstruction by rows (blocks of 8 and up)
        LocalSize voxels;                   ///< compensation per voxel (blocks below 8)
    } motion;

    /// Pre-integration tables (preint/preint.cl).
    struct Preintegration {
        std::size_t rowMax = 0, rowMultiple = 0; ///< width along the back index: at most rowMax, a multiple
        std::size_t exactRow = 0;                ///< preint_exact_row groups of 16 back nodes, at most
    } preintegration;

    /// Ray marchers of grids and bricks (render/ kernels) and the grid path tracer.
    struct RayMarch {
        LocalSize tile, packet; ///< one ray per work-item; one 4x2 packet of rays per work-item
        LocalSize pathTrace;
        unsigned macrocellEdge = 0; ///< voxels per macrocell edge of the empty-space skipping grid
        /// render.skipping auto: the probe frame's pixels (at most), its interleaved timing rounds, and the
        /// coarser edges tried besides macrocellEdge, as multiples of it (merged cells; 0 ends the list).
        std::size_t skipProbePixels = 0;
        int skipProbeRounds = 0;
        unsigned skipEdgeFactors[3] = {0, 0, 0};
        /// The viewer's compressed bricks: bricks decoded at their chosen level per frame while a view refines
        /// (the others drawn from a coarser level already held, or their coarsest level decoded first), and
        /// more while their predicted decode time stays within this share of the last frame's kernel time.
        std::size_t refineBricksPerFrame = 0;
        double refineKernelShare = 0.0;
    } rayMarch;

    /// Preview tiers of grids (render/shearwarp.cl, render/drc.cl).
    struct Preview {
        std::size_t scanlines = 0; ///< shearwarp_composite work-items (intermediate scanlines) per group
        LocalSize warp, drc;       ///< one final pixel per work-item
    } preview;

    /// Tetrahedral meshes: the cell caster (mesh/mesh_cells.cl), the k-buffer (mesh/mesh_kbuffer.cl) and
    /// its radix sort (mesh/radix_sort.cl).
    struct Mesh {
        std::size_t cellRaysX = 0,
                    cellRaysY = 0; ///< pixels a mesh_cells work-item walks together (RAYS_X, RAYS_Y)
        LocalSize cells;           ///< mesh_cells work-items per group
        std::size_t kbuffer = 0;   ///< per-vertex, per-face and table passes of the k-buffer
        std::size_t binChunks = 0, binLocal = 0;     ///< kb_bin_count/kb_bin_scatter work-items (BIN_CHUNKS)
        std::size_t tileThreads = 0;                 ///< kb_raster work-items per tile (KB_TILE_THREADS)
        std::size_t radixBlocks = 0, radixLocal = 0; ///< histogram and scatter work-items (RADIX_BLOCKS)
    } mesh;
};

/// The profile of the first table entry that matches `device` (the last entry matches every device).
const DeviceProfile& deviceProfileFor(const DeviceInfo& device);
/// The entry for devices of no particular kind: what code without a device (C++ references, planners)
/// mirrors.
const DeviceProfile& genericDeviceProfile();

} // namespace volcl
