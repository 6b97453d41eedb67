// Fuzz target for .vcm compressed meshes: the container's checks, the cut-border connectivity decoder, the
// geometry decoder and the mesh builder behind readVcm, within the fuzz memory budget.
#include "core/Error.hpp"
#include "fuzz/FuzzSupport.hpp"
#include "host/mesh/TetMesh.hpp"
#include "meshcodec/MeshCodec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace volcl;
    try {
        meshcodec::DecodedMesh d = meshcodec::decodeMesh({data, size}, "input.vcm", fuzz::kFuzzMemoryBudget);
        // Every index in range (ASan catches a short array) before the builder reads them.
        double sum = 0;
        for (const mesh::Tet& t : d.tets)
            for (const std::uint32_t v : t)
                sum += d.points.at(v)[0] + d.scalars.at(v);
        (void)sum;
        mesh::TetSoup soup;
        soup.points = std::move(d.points);
        soup.scalars = std::move(d.scalars);
        soup.tets = std::move(d.tets);
        (void)mesh::buildTetMesh(std::move(soup), "input.vcm", d.header.scalarName);
    } catch (const Error&) {
        // Refused as corrupt (IoError) or as no mesh (DataError): expected.
    }
    return 0;
}
