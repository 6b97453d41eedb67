// Multi-channel volumes: grid checks and (de)interleaving of components.
#include "core/Channels.hpp"

#include "core/Error.hpp"

#include <cstring>

namespace volcl {

namespace {

bool sameGeometry(const Volume& a, const Volume& b) noexcept {
    return a.dims() == b.dims() && a.spacing == b.spacing && a.origin == b.origin &&
           a.direction == b.direction;
}

} // namespace

void ChannelVolume::validate() const {
    if (channels.empty()) throw DataError("multi-channel volume has no channel");
    for (std::size_t c = 1; c < channels.size(); ++c)
        if (!sameGeometry(channels[c], channels[0]))
            throw DataError("channel " + std::to_string(c) + " is on a different grid than channel 0");
    if (!names.empty() && names.size() != channels.size())
        throw DataError("multi-channel volume has " + std::to_string(names.size()) + " names for " +
                        std::to_string(channels.size()) + " channels");
}

std::vector<Volume> splitInterleaved(const Volume& interleaved, std::size_t components, const Volume& grid) {
    const std::size_t n = grid.voxelCount(), size = scalarSize(interleaved.type());
    if (components == 0 || interleaved.voxelCount() != n * components)
        throw DataError("interleaved components do not fill the grid");
    std::vector<Volume> out;
    out.reserve(components);
    const std::byte* src = interleaved.bytes().data();
    for (std::size_t c = 0; c < components; ++c) {
        Volume v(grid.dims(), interleaved.type());
        v.spacing = grid.spacing;
        v.origin = grid.origin;
        v.direction = grid.direction;
        v.anatomical = grid.anatomical;
        std::byte* dst = v.bytes().data();
        for (std::size_t i = 0; i < n; ++i)
            std::memcpy(dst + i * size, src + (i * components + c) * size, size);
        out.push_back(std::move(v));
    }
    return out;
}

Volume interleaveChannels(const std::vector<Volume>& channels) {
    if (channels.empty()) throw DataError("no channel to interleave");
    const Volume& first = channels.front();
    for (const Volume& c : channels)
        if (c.type() != first.type() || c.dims() != first.dims())
            throw DataError("channels of different types or sizes cannot share one file: convert them to one "
                            "type first");
    const std::size_t k = channels.size(), n = first.voxelCount(), size = scalarSize(first.type());
    Volume out({k, first.dims().x * first.dims().y, first.dims().z}, first.type());
    std::byte* dst = out.bytes().data();
    for (std::size_t c = 0; c < k; ++c) {
        const std::byte* src = channels[c].bytes().data();
        for (std::size_t i = 0; i < n; ++i)
            std::memcpy(dst + (i * k + c) * size, src + i * size, size);
    }
    return out;
}

} // namespace volcl
