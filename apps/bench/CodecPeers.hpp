// The peers of `volcl bench codec` on the same voxels: zfp (reversible and fixed accuracy), zstd and xz -9.
#pragma once

#include "core/Volume.hpp"

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>

namespace volcl::cli {

/// One zfp run: compressed size, the decode as float32, median encode and decode milliseconds.
struct ZfpResult {
    std::size_t bytes = 0;
    double tolerance = 0; ///< the fixed-accuracy tolerance (0: reversible)
    Volume decoded;
    double encodeMs = 0, decodeMs = 0;
};

/// zfp on `v`: reversible on int32 copies of integer data (no `tolerance`), else fixed accuracy on float
/// copies; encode and decode each timed as the median of `runs` (0: one untimed run).
ZfpResult runZfp(const Volume& v, std::optional<double> tolerance, int runs);

/// zfp at the largest accuracy tolerance whose decode reaches `target` dB (bisection on log tolerance),
/// timed.
ZfpResult zfpAtPsnr(const Volume& v, double target, int runs);

/// zstd at `level` on the raw bytes: the compressed size, with median encode (`ms`) and decode (`decMs`)
/// times.
std::size_t zstdSize(const Volume& v, int level, double& ms, double& decMs, int runs);

/// xz -9 through the xz binary (the general-purpose reference ratio), one single-threaded run timed into
/// `ms`; the input goes through a temporary file in `tmpDir`. 0 when xz cannot run.
std::size_t xzSize(const Volume& v, const std::filesystem::path& tmpDir, double& ms);

/// The size of `file` compressed by a command-line compressor writing to stdout with -c ("gzip -9",
/// "xz -9 -T1"), one run timed into `ms`; 0 when it cannot run.
std::size_t compressedFileSize(const std::string& compressor, const std::filesystem::path& file, double& ms);

} // namespace volcl::cli
