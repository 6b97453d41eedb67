// Gzipped raw uint8 volumes for the benchmarks (the BrainWeb T1 of bench codec, motion and series).
#include "apps/bench/GzipVolume.hpp"

#include "core/Error.hpp"

#include <zlib.h>

namespace volcl::cli {

Volume readGzipUInt8(const std::filesystem::path& p, Dims d) {
    Volume v(d, ScalarType::UInt8);
    gzFile f = gzopen(p.string().c_str(), "rb");
    if (!f) throw IoError(p.string() + ": cannot open");
    const int n = gzread(f, v.bytes().data(), static_cast<unsigned>(v.byteSize()));
    char extra;
    const int more = gzread(f, &extra, 1);
    gzclose(f);
    if (n != static_cast<int>(v.byteSize()) || more != 0)
        throw IoError(p.string() + ": unexpected size after gunzip");
    return v;
}

} // namespace volcl::cli
