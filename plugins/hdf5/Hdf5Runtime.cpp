// Looks up the calling HDF5 library's functions with dladdr/dlsym, one table per library.
#include "plugins/hdf5/Hdf5Runtime.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <list>
#include <mutex>

namespace volcl::hdf5 {
namespace {

template <class F> bool bind(void* handle, const char* name, F& fn) {
    fn = reinterpret_cast<F>(dlsym(handle, name));
    return fn != nullptr;
}

// Opens the already loaded object holding `address` without loading anything; RTLD_DEFAULT when the
// address is in the executable itself (HDF5 linked statically).
void* loadedObjectOf(const void* address) {
    Dl_info info{};
    if (dladdr(address, &info) == 0 || info.dli_fname == nullptr) return RTLD_DEFAULT;
    void* handle = dlopen(info.dli_fname, RTLD_LAZY | RTLD_NOLOAD);
    return handle ? handle : RTLD_DEFAULT;
}

bool resolve(void* h, Hdf5Runtime& r) {
    bool ok = bind(h, "H5Pget_chunk", r.getChunk) && bind(h, "H5Pget_filter_by_id2", r.getFilterById) &&
              bind(h, "H5Pmodify_filter", r.modifyFilter) && bind(h, "H5Tget_class", r.typeClass) &&
              bind(h, "H5Tget_size", r.typeSize) && bind(h, "H5Tget_sign", r.typeSign) &&
              bind(h, "H5Tget_order", r.typeOrder) && bind(h, "H5Epush2", r.push) &&
              bind(h, "H5E_ERR_CLS_g", r.errorClass) && bind(h, "H5E_PLINE_g", r.pipelineMajor) &&
              bind(h, "H5E_CANTFILTER_g", r.filterMinor);
    // HDF5 >= 1.8.15; plain malloc/free match it on Linux when absent.
    bind(h, "H5allocate_memory", r.allocate);
    bind(h, "H5free_memory", r.release);
    return ok;
}

} // namespace

const Hdf5Runtime* Hdf5Runtime::of(const void* callerAddress) {
    // One entry per HDF5 library seen, kept for the life of the process: HDF5 has no per-call context to
    // carry it, and the library stays loaded while it can call the filter.
    struct Entry {
        void* base;
        Hdf5Runtime runtime;
        bool ok;
    };
    static std::mutex mutex;
    static std::list<Entry> entries;
    Dl_info info{};
    void* base = dladdr(callerAddress, &info) ? info.dli_fbase : nullptr;
    std::lock_guard lock(mutex);
    for (const Entry& e : entries)
        if (e.base == base) return e.ok ? &e.runtime : nullptr;
    Entry& e = entries.emplace_back(Entry{base, {}, false});
    e.ok = resolve(loadedObjectOf(callerAddress), e.runtime);
    return e.ok ? &e.runtime : nullptr;
}

void Hdf5Runtime::error(const char* function, const std::string& message) const {
    push(H5E_DEFAULT, __FILE__, function, __LINE__, *errorClass, *pipelineMajor, *filterMinor, "%s",
         message.c_str());
}

void* Hdf5Runtime::allocateBuffer(size_t bytes) const {
    return allocate ? allocate(bytes, false) : std::malloc(bytes);
}

void Hdf5Runtime::releaseBuffer(void* buffer) const {
    if (release)
        release(buffer);
    else
        std::free(buffer);
}

} // namespace volcl::hdf5
