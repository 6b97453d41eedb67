// Octal buddy allocation and LRU eviction of decoded bricks.
#include "render/bricks/BrickPool.hpp"

#include "core/Error.hpp"

#include <algorithm>

namespace volcl {

BuddyAllocator::BuddyAllocator(std::size_t granule, int topOrder, std::size_t topCount)
    : granule_(granule), topOrder_(topOrder), topCount_(topCount), free_(std::size_t(topOrder) + 1) {
    if (granule == 0 || topOrder < 0 || topCount == 0) throw Error("internal: empty brick pool");
    const std::size_t top = blockFloats(topOrder) / granule;
    for (std::size_t i = 0; i < topCount; ++i)
        free_[std::size_t(topOrder)].insert(i * top);
}

std::size_t BuddyAllocator::blockFloats(int order) const noexcept {
    std::size_t n = granule_;
    for (int k = 0; k < order; ++k)
        n *= 8;
    return n;
}

int BuddyAllocator::orderFor(std::size_t floats) const noexcept {
    for (int k = 0; k <= topOrder_; ++k)
        if (blockFloats(k) >= floats) return k;
    return -1;
}

std::optional<std::size_t> BuddyAllocator::allocate(int order) {
    if (order < 0 || order > topOrder_) return std::nullopt;
    auto& list = free_[std::size_t(order)];
    if (list.empty()) {
        const auto parent = allocate(order + 1);
        if (!parent) return std::nullopt;
        used_ -= blockFloats(order + 1);
        const std::size_t g = *parent / granule_, step = blockFloats(order) / granule_;
        for (std::size_t j = 1; j < 8; ++j)
            list.insert(g + j * step);
        used_ += blockFloats(order);
        return *parent;
    }
    const std::size_t g = *list.begin();
    list.erase(list.begin());
    used_ += blockFloats(order);
    return g * granule_;
}

void BuddyAllocator::release(std::size_t offset, int order) {
    used_ -= blockFloats(order);
    std::size_t g = offset / granule_;
    while (order < topOrder_) {
        const std::size_t step = blockFloats(order) / granule_, base = g - g % (step * 8);
        auto& list = free_[std::size_t(order)];
        bool all = true;
        for (std::size_t j = 0; j < 8 && all; ++j)
            all = base + j * step == g || list.count(base + j * step);
        if (!all) break;
        for (std::size_t j = 0; j < 8; ++j)
            list.erase(base + j * step);
        g = base;
        ++order;
    }
    free_[std::size_t(order)].insert(g);
}

const CachedBrick* BrickCache::touch(const Key& key) {
    auto it = entries_.find(key);
    if (it == entries_.end()) return nullptr;
    lru_.splice(lru_.end(), lru_, it->second.second);
    return &it->second.first;
}

std::optional<CachedBrick> BrickCache::insert(const Key& key, std::size_t floats,
                                              const std::set<Key>& pinned) {
    const int order = alloc_.orderFor(floats);
    if (order < 0) return std::nullopt;
    std::optional<std::size_t> off = alloc_.allocate(order);
    auto victim = lru_.begin();
    while (!off && victim != lru_.end()) {
        if (pinned.count(*victim)) {
            ++victim;
            continue;
        }
        auto e = entries_.find(*victim);
        alloc_.release(e->second.first.offset, e->second.first.order);
        entries_.erase(e);
        victim = lru_.erase(victim);
        ++evictions_;
        off = alloc_.allocate(order);
    }
    if (!off) return std::nullopt;
    const CachedBrick c{*off, order, floats};
    lru_.push_back(key);
    entries_[key] = {c, std::prev(lru_.end())};
    return c;
}

std::optional<std::vector<BrickCache::Placement>>
BrickCache::repack(std::vector<std::pair<Key, std::size_t>> workingSet) {
    std::stable_sort(workingSet.begin(), workingSet.end(),
                     [](const auto& a, const auto& b) { return a.second > b.second; });
    std::vector<Placement> out;
    out.reserve(workingSet.size());
    for (const auto& [key, floats] : workingSet) {
        Placement p;
        p.key = key;
        p.slot.floats = floats;
        p.slot.order = alloc_.orderFor(floats);
        auto it = entries_.find(key);
        if (it != entries_.end()) {
            p.resident = true;
            p.from = it->second.first.offset;
        }
        out.push_back(p);
    }
    // Every block is released and placed again (the samples are not touched here); the working set's entries
    // come back in size order, so they are the most recently used.
    const std::size_t before = entries_.size();
    std::size_t residents = 0;
    releaseAll();
    for (Placement& p : out) {
        const std::optional<std::size_t> off =
            p.slot.order < 0 ? std::nullopt : alloc_.allocate(p.slot.order);
        if (!off) {
            releaseAll();
            evictions_ += before;
            return std::nullopt;
        }
        p.slot.offset = *off;
        lru_.push_back(p.key);
        entries_[p.key] = {p.slot, std::prev(lru_.end())};
        if (p.resident) ++residents;
    }
    evictions_ += before - residents;
    return out;
}

void BrickCache::releaseAll() {
    for (const auto& [k, e] : entries_)
        alloc_.release(e.first.offset, e.first.order);
    entries_.clear();
    lru_.clear();
}

void BrickCache::clear() {
    evictions_ += entries_.size();
    releaseAll();
}

} // namespace volcl
