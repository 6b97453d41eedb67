// The .vcm side of `volcl encode`, `decode` and `info`: mesh compression from the command line.
#pragma once

#include "apps/cli/MeshInfo.hpp"
#include "meshcodec/MeshCodec.hpp"

#include <ostream>
#include <string>

namespace volcl::cli {

/// True when an encode writes a mesh: the output ends in .vcm.
bool writesVcm(const std::string& out);

/// `volcl encode MESH -o OUT.vcm`: reads any mesh, writes the .vcm, reports sizes unless quiet.
void encodeMeshCommand(const std::string& in, const std::string& out, const meshcodec::VcmOptions& options,
                       const MeshReadFlags& read, bool quiet);

/// `volcl decode IN.vcm -o OUT.vtu`.
void decodeMeshCommand(const std::string& in, const std::string& out, const VtuWriteFlags& write, bool quiet);

/// `volcl info IN.vcm`: the mesh summary and the file's sections, bits per tet and per vertex.
void printVcmInfo(std::ostream& out, const std::string& path, const MeshReadFlags& read, bool json);

} // namespace volcl::cli
