// The HDF5 filter plugin H5Zvolcl (id 420): can_apply, set_local and the filter over ChunkCodec.
#include "plugins/hdf5/H5Zvolcl.h"
#include "plugins/hdf5/ChunkCodec.hpp"
#include "plugins/hdf5/Hdf5Runtime.hpp"

#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"

#include <H5PLextern.h>

#include <cstring>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace volcl::hdf5 {
namespace {

// The process's OpenCL context, created by the first chunk that needs it (most HDF5 programs never touch
// a volcl dataset, and loading the plugin must stay free). HDF5 gives filters no context argument, so it
// lives here for the life of the process; the mutex serialises chunks (one queue, one context).
struct SharedCompute {
    std::mutex mutex;
    std::unique_ptr<ComputeContext> context;
    std::string failure; ///< why the context could not be created, repeated for every later chunk
};

SharedCompute& sharedCompute() {
    static SharedCompute s;
    return s;
}

// Element type of a dataset, or nullopt (with the reason) when the codec does not take it.
std::optional<ScalarType> elementType(const Hdf5Runtime& h5, hid_t type, std::string& why) {
    const H5T_class_t cls = h5.typeClass(type);
    const size_t size = h5.typeSize(type);
    if (h5.typeOrder(type) != H5T_ORDER_LE && size > 1) {
        why = "big-endian element types are not supported (store little-endian)";
        return std::nullopt;
    }
    if (cls == H5T_FLOAT && size == 4) return ScalarType::Float32;
    if (cls == H5T_FLOAT && size == 8) return ScalarType::Float64;
    if (cls == H5T_INTEGER) {
        const bool isSigned = h5.typeSign(type) == H5T_SGN_2;
        if (size == 1 && !isSigned) return ScalarType::UInt8;
        if (size == 2 && !isSigned) return ScalarType::UInt16;
        if (size == 2 && isSigned) return ScalarType::Int16;
    }
    why = "the element type must be uint8, uint16, int16, float32 or float64";
    return std::nullopt;
}

// Chunk dims of a dataset creation property list, or 0 dims (with the reason) when not 3D or 4D.
unsigned chunkDims(const Hdf5Runtime& h5, hid_t dcpl, hsize_t (&dims)[H5S_MAX_RANK], std::string& why) {
    const int rank = h5.getChunk(dcpl, H5S_MAX_RANK, dims);
    if (rank != 3 && rank != 4) {
        why = "the dataset must be chunked with 3 (z, y, x) or 4 (t, z, y, x) chunk dimensions, got " +
              std::to_string(rank);
        return 0;
    }
    for (int i = 0; i < rank; ++i)
        if (dims[i] == 0 || dims[i] > 0xffffffffu) {
            why = "chunk dimensions must be between 1 and 2^32-1";
            return 0;
        }
    return unsigned(rank);
}

// The user's cd_values on this property list (at most kMaxFilterValues are read).
std::vector<unsigned> userParameters(const Hdf5Runtime& h5, hid_t dcpl) {
    unsigned flags = 0;
    size_t count = kMaxFilterValues;
    std::vector<unsigned> values(kMaxFilterValues, 0);
    if (h5.getFilterById(dcpl, H5Z_FILTER_VOLCL, &flags, &count, values.data(), 0, nullptr, nullptr) < 0)
        throw UsageError("the volcl filter is not in the dataset's filter pipeline");
    values.resize(std::min(count, kMaxFilterValues));
    return values;
}

htri_t canApply(hid_t dcpl, hid_t type, hid_t /*space*/) {
    const Hdf5Runtime* h5 = Hdf5Runtime::of(__builtin_return_address(0));
    if (!h5) return -1;
    try { // nothing may unwind into HDF5's C code
        std::string why;
        hsize_t dims[H5S_MAX_RANK];
        const auto element = elementType(*h5, type, why);
        if (!element || chunkDims(*h5, dcpl, dims, why) == 0) {
            h5->error("H5Zvolcl can_apply", "volcl filter: " + why);
            return 0;
        }
        ChunkRate rate;
        double bound;
        parseUserValues(userParameters(*h5, dcpl), rate, bound);
        if (*element == ScalarType::Float64 && rate == ChunkRate::Bpv) {
            h5->error(
                "H5Zvolcl can_apply",
                "volcl filter: float64 datasets take the lossless or bounded rates (a bit budget would bound "
                "no voxel)");
            return 0;
        }
        return 1;
    } catch (const std::exception& e) {
        h5->error("H5Zvolcl can_apply", e.what());
        return 0;
    }
}

// Records element type and chunk dims in cd_values, so the filter can rebuild chunks from bytes alone.
herr_t setLocal(hid_t dcpl, hid_t type, hid_t /*space*/) {
    const Hdf5Runtime* h5 = Hdf5Runtime::of(__builtin_return_address(0));
    if (!h5) return -1;
    try {
        std::string why;
        hsize_t dims[H5S_MAX_RANK];
        const auto element = elementType(*h5, type, why);
        const unsigned rank = element ? chunkDims(*h5, dcpl, dims, why) : 0;
        if (rank == 0) throw UsageError("volcl filter: " + why);
        FilterParameters p;
        parseUserValues(userParameters(*h5, dcpl), p.rate, p.bound);
        p.type = *element;
        p.rank = rank;
        for (unsigned i = 0; i < rank; ++i)
            p.chunk[i] = dims[i];
        const std::vector<unsigned> values = packParameters(p);
        if (h5->modifyFilter(dcpl, H5Z_FILTER_VOLCL, H5Z_FLAG_MANDATORY, values.size(), values.data()) < 0)
            throw UsageError("volcl filter: could not store its parameters on the dataset");
        return 0;
    } catch (const std::exception& e) {
        h5->error("H5Zvolcl set_local", e.what());
        return -1;
    }
}

// Encodes (or with H5Z_FLAG_REVERSE decodes) one chunk; returns the new size, 0 on failure (HDF5 error).
size_t filterChunk(unsigned flags, size_t cdCount, const unsigned cdValues[], size_t nbytes, size_t* bufSize,
                   void** buf) {
    const Hdf5Runtime* h5 = Hdf5Runtime::of(__builtin_return_address(0));
    if (!h5) return 0;
    const bool decode = (flags & H5Z_FLAG_REVERSE) != 0;
    void* out = nullptr;
    try {
        const FilterParameters p = unpackParameters({cdValues, cdCount});
        const std::span<const std::byte> in(static_cast<const std::byte*>(*buf), nbytes);
        SharedCompute& compute = sharedCompute();
        std::lock_guard lock(compute.mutex);
        if (!compute.context) {
            if (!compute.failure.empty()) throw DataError(compute.failure);
            try {
                compute.context = std::make_unique<ComputeContext>();
            } catch (const std::exception& e) {
                compute.failure = std::string("no OpenCL device for the volcl filter: ") + e.what();
                throw;
            }
        }
        size_t outBytes = 0;
        if (decode) {
            outBytes = p.chunkBytes();
            out = h5->allocateBuffer(outBytes);
            if (!out) throw DataError("volcl filter: out of memory for a chunk");
            decodeChunk(*compute.context, p, in, {static_cast<std::byte*>(out), outBytes});
        } else {
            const std::vector<std::byte> stored = encodeChunk(*compute.context, p, in);
            outBytes = stored.size();
            out = h5->allocateBuffer(outBytes);
            if (!out) throw DataError("volcl filter: out of memory for a chunk");
            std::memcpy(out, stored.data(), outBytes);
        }
        h5->releaseBuffer(*buf);
        *buf = out;
        *bufSize = outBytes;
        return outBytes;
    } catch (const std::exception& e) {
        if (out) h5->releaseBuffer(out);
        h5->error(decode ? "H5Zvolcl decode" : "H5Zvolcl encode",
                  std::string(decode ? "volcl filter (decode): " : "volcl filter (encode): ") + e.what());
        return 0;
    }
}

const H5Z_class2_t kFilterClass = {
    H5Z_CLASS_T_VERS, H5Z_filter_t(H5Z_FILTER_VOLCL), 1, 1, "volcl wavelet codec", canApply, setLocal,
    filterChunk,
};

} // namespace
} // namespace volcl::hdf5

extern "C" H5PLUGIN_DLL H5PL_type_t H5PLget_plugin_type(void) {
    return H5PL_TYPE_FILTER;
}
extern "C" H5PLUGIN_DLL const void* H5PLget_plugin_info(void) {
    return &volcl::hdf5::kFilterClass;
}
