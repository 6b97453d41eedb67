"""h5py keyword arguments for the volcl HDF5 filter (id 420); the plugin loads from HDF5_PLUGIN_PATH.

    import h5py, volcl_hdf5
    f.create_dataset("v", data=a, chunks=(32, 32, 32), **volcl_hdf5.filter(max_error=0.5))

`compression=420` alone is lossless.
"""
import struct

FILTER_ID = 420
LOSSLESS, MAX_ERROR, PSNR, BPV, REL_ERROR, PW_REL_ERROR = 0, 1, 2, 3, 4, 5


def cd_values(max_error=None, psnr=None, bpv=None, rel_error=None, pw_rel_error=None):
    """The filter's cd_values: (0,) lossless, else (rate, low word, high word) of the bound as a double.
    rel_error: R x each chunk's value range; pw_rel_error: R x each voxel's magnitude (0 < R < 1)."""
    given = [(rate, bound) for rate, bound in ((MAX_ERROR, max_error), (PSNR, psnr), (BPV, bpv),
                                               (REL_ERROR, rel_error), (PW_REL_ERROR, pw_rel_error))
             if bound is not None]
    if len(given) > 1:
        raise ValueError("give one of max_error, rel_error, pw_rel_error, psnr and bpv")
    if not given:
        return (LOSSLESS,)
    rate, bound = given[0]
    if not (bound > 0 and bound != float("inf")):
        raise ValueError("the bound must be a finite number > 0")
    low, high = struct.unpack("<II", struct.pack("<d", float(bound)))
    return (rate, low, high)


def filter(max_error=None, psnr=None, bpv=None, rel_error=None, pw_rel_error=None):
    """Keyword arguments for h5py's create_dataset: compression and compression_opts."""
    return {"compression": FILTER_ID,
            "compression_opts": cd_values(max_error, psnr, bpv, rel_error, pw_rel_error)}
