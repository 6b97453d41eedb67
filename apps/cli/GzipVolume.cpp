// Gzipped raw uint8 volumes for the benchmarks.
#include "apps/cli/GzipVolume.hpp"

#include "core/Error.hpp"

#include <zlib.h>

namespace volcl::cli {

Volume readGzipUInt8(const std::filesystem::path& p, Dims d) {
    Volume v(d, ScalarType::UInt8);
    gzFile f = gzopen(p.string().c_str(), "rb");
    if (!f) throw IoError(p.string() + ": cannot open");
    const int n = gzread(f, v.bytes().data(), static_cast<unsigned>(v.byteSize()));
    gzclose(f);
    if (n != static_cast<int>(v.byteSize())) throw IoError(p.string() + ": unexpected size after gunzip");
    return v;
}

} // namespace volcl::cli
