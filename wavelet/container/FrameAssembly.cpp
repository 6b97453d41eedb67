// Assembly of coded frames into a .vcz file.
#include "wavelet/container/FrameAssembly.hpp"

namespace volcl::codec {

std::vector<std::byte> assembleVcz(VczHeader& h, std::vector<CodedFrame>& frames) {
    // Sizes, checksums and ranges first: a series' compact index (and so where the payloads start) depends
    // on them.
    h.bricks.assign(frames.size(), std::vector<VczBrickEntry>(h.brickCount()));
    for (std::size_t f = 0; f < frames.size(); ++f) {
        for (std::size_t b = 0; b < h.brickCount(); ++b) {
            const auto& p = frames[f].payloads[b];
            VczBrickEntry& e = h.bricks[f][b];
            e.size = p.size();
            e.checksum = vczChecksum(p);
            e.min = frames[f].ranges[b].first;
            e.max = frames[f].ranges[b].second;
        }
        VczFrame& entry = h.frames[f];
        entry.auxSize = frames[f].aux.size();
        entry.auxChecksum = entry.auxSize ? vczChecksum(frames[f].aux) : 0;
        entry.auxOffset = 0;
    }
    std::size_t offset = vczPreambleSize(h);
    std::vector<std::vector<std::uint8_t>> payloads;
    for (std::size_t f = 0; f < frames.size(); ++f) {
        for (std::size_t b = 0; b < h.brickCount(); ++b) {
            h.bricks[f][b].offset = offset;
            offset += frames[f].payloads[b].size();
            payloads.push_back(std::move(frames[f].payloads[b]));
        }
        VczFrame& entry = h.frames[f];
        entry.auxOffset = entry.auxSize ? offset : 0;
        offset += entry.auxSize;
        if (entry.auxSize) payloads.push_back(std::move(frames[f].aux));
    }
    return writeVcz(h, payloads);
}

} // namespace volcl::codec
