// Reading a volume file's voxels by slabs without loading the file, for streaming encodes of volumes
// larger than memory: raw, NRRD and NIfTI files whose samples are raw or one gzip stream.
#pragma once

#include "core/Volume.hpp"
#include "host/io/VolumeIo.hpp"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

namespace volcl {

/// A 3D volume file opened for reads of boxes spanning whole x lines: `read(lo, out)` fills `out` with the
/// voxels [lo, lo + out.dims()), lo.x = 0 and out.dims().x = dims().x (a streaming encoder's brick rows).
/// Raw samples are read at their offsets (memory: the box); a gzip stream is decompressed forward once,
/// one slab of out.dims().z slices at a time, so its boxes must come slab after slab with z never going
/// back (memory: one slab, dims().x x dims().y x out.dims().z samples). Samples are converted as the
/// whole-file readers convert them (type(), byte order).
class VolumeSlabReader {
public:
    /// nullopt when the file is not one that reads by slabs (another format, ascii, several data files,
    /// 4D, line skips, NIfTI values scaled to data units): read it whole. Throws IoError naming the file
    /// for a broken header or an uncompressed data size that does not match, as readVolumeFile would.
    static std::optional<VolumeSlabReader> open(const std::filesystem::path& path,
                                                const ReadOptions& options);
    ~VolumeSlabReader();
    VolumeSlabReader(VolumeSlabReader&&) noexcept;
    VolumeSlabReader& operator=(VolumeSlabReader&&) noexcept;

    Dims dims() const noexcept;
    ScalarType type() const noexcept;
    std::array<double, 3> spacing() const noexcept;
    std::array<double, 3> origin() const noexcept;
    Direction3 direction() const noexcept;
    bool anatomical() const noexcept;
    /// The header and the data file (the same for a single file).
    std::vector<std::filesystem::path> files() const;
    bool gzip() const noexcept;

    /// Throws IoError naming the file when the data ends early (a truncated gzip stream) or cannot be read,
    /// UsageError when a box does not span whole x lines or a gzip read goes back in z.
    void read(Dims lo, Volume& out);

private:
    struct State;
    explicit VolumeSlabReader(std::unique_ptr<State> state);
    std::unique_ptr<State> s_;
};

} // namespace volcl
