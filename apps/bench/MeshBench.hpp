// `volcl bench render` on a tetrahedral mesh: each method's time, tets/s and error against the exact
// reference, and VTK's unstructured-grid mappers on the same mesh, TF, camera and image.
#pragma once

#include "apps/bench/BenchOutput.hpp"

#include "render/RenderInput.hpp"
#include "render/VolumeRenderer.hpp"

#include <string>

namespace volcl::cli {

/// RMSE over R, G, B of two images of one size (associated colour, i.e. over black).
double rmseRgb(const ImageBuffer& a, const ImageBuffer& b);
/// Median kernel milliseconds of `runs` frames after one warm-up frame (kernel build excluded).
double timeFrames(VolumeRenderer& r, int runs);

struct MeshBenchOptions {
    int runs = 5;
    bool vtk = false;
    std::string vtkScript; ///< bench/vtk_mesh.py
    std::string vtkImages; ///< folder for the peers' images and the reference (EXR); empty: not kept
    std::string csv;       ///< one row per configuration
    std::string lengths = "8,16,32,64"; ///< 3D table lengths swept for the cell method
    std::string vtkMappers = "bunyk,projected_tetrahedra,zsweep"; ///< the VTK peers to run
    int zsweepRuns = 1; ///< ZSweep takes a minute a frame on 0.2 M tets: fewer timed frames
};

/// Prints one row per configuration (cells with the 3D table at several length counts and point-sampled at
/// the scene's step and half of it; kbuffer at k = 2..8 when the build has it): wall and kernel ms per
/// frame, tets/s, RMSE of RGBA and RGB against meshReferenceRender; then, with `vtk`, Bunyk, projected
/// tetrahedra and ZSweep with their ratio to the fastest volcl configuration within the error of Bunyk.
void benchMeshRender(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                     const Scene& scene, const MeshBenchOptions& options);

} // namespace volcl::cli
