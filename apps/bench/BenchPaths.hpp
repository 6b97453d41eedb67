// Where `volcl bench` finds its peer scripts and the shared data sets by default.
#pragma once

#include <string>

namespace volcl::cli {

/// The folder of the peer scripts (vtk_raycast.py, vtk_mesh.py, vtk_preint_peer.py): $VOLCL_BENCH_DIR when
/// set, else bench/ of the source tree this executable was built from.
std::string peerScriptDir();

/// The default of the benchmarks' --data: shared/data beside the source tree this executable was built from.
std::string defaultSharedDataDir();

} // namespace volcl::cli
