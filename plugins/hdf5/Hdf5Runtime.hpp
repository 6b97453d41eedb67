// The HDF5 functions the filter calls, looked up in the HDF5 library that called it (serial or MPI build).
#pragma once

#include <hdf5.h>

#include <string>

namespace volcl::hdf5 {

/// The filter plugin is not linked to HDF5: Debian ships a serial and an MPI HDF5 with different sonames,
/// and one plugin file serves both. Each callback finds the library that called it (by return address) and
/// uses that library's functions, so property lists and error stacks are the caller's own.
struct Hdf5Runtime {
    int (*getChunk)(hid_t, int, hsize_t*) = nullptr;
    herr_t (*getFilterById)(hid_t, H5Z_filter_t, unsigned*, size_t*, unsigned*, size_t, char*,
                            unsigned*) = nullptr;
    herr_t (*modifyFilter)(hid_t, H5Z_filter_t, unsigned, size_t, const unsigned*) = nullptr;
    H5T_class_t (*typeClass)(hid_t) = nullptr;
    size_t (*typeSize)(hid_t) = nullptr;
    H5T_sign_t (*typeSign)(hid_t) = nullptr;
    H5T_order_t (*typeOrder)(hid_t) = nullptr;
    void* (*allocate)(size_t, hbool_t) = nullptr;
    herr_t (*release)(void*) = nullptr;
    herr_t (*push)(hid_t, const char*, const char*, unsigned, hid_t, hid_t, hid_t, const char*,
                   ...) = nullptr;
    const hid_t* errorClass = nullptr;    ///< H5E_ERR_CLS_g
    const hid_t* pipelineMajor = nullptr; ///< H5E_PLINE_g
    const hid_t* filterMinor = nullptr;   ///< H5E_CANTFILTER_g

    /// Functions of the HDF5 library containing `callerAddress`, resolved once per library; nullptr when
    /// none is found (the callback then fails without calling HDF5).
    static const Hdf5Runtime* of(const void* callerAddress);

    /// Pushes `message` on the caller's HDF5 error stack (shown by h5dump, raised by h5py).
    void error(const char* function, const std::string& message) const;
    /// Buffers handed back to HDF5 come from its allocator.
    void* allocateBuffer(size_t bytes) const;
    void releaseBuffer(void* buffer) const;
};

} // namespace volcl::hdf5
