"""h5py writes and reads volcl-compressed datasets with only HDF5_PLUGIN_PATH set (run with Debian's python3).

Usage: HDF5_PLUGIN_PATH=PLUGIN_DIR python3 test_h5py.py WORK_DIR EXAMPLE_FILE HELPER_DIR CORRUPT_EXE
"""
import os
import subprocess
import sys
import unittest

import h5py
import numpy as np

WORK, EXAMPLE_FILE, HELPER_DIR, CORRUPT = sys.argv[1:5]
sys.path.insert(0, HELPER_DIR)
import volcl_hdf5  # noqa: E402


def field(shape, dtype, seed=0):
    """Smooth waves plus noise spanning most of the type's range, with its extremes included."""
    rng = np.random.default_rng(seed)
    idx = np.indices(shape).astype(np.float64)
    v = 0.5 + 0.3 * np.sin(0.2 * idx[-1]) * np.cos(0.15 * idx[-2]) + 0.1 * np.sin(0.1 * idx[-3])
    v += 0.05 * rng.uniform(-1, 1, shape)
    if np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        a = (info.min + v * (float(info.max) - info.min)).astype(dtype)
        a.flat[0], a.flat[-1] = info.min, info.max
        return a
    return (v * 200.0 - 100.0).astype(dtype)


class H5pyFilter(unittest.TestCase):
    def path(self, name):
        return os.path.join(WORK, name)

    def test_compression_420_alone_is_lossless_for_every_type(self):
        for dtype in (np.uint8, np.uint16, np.int16, np.float32):
            a = field((19, 40, 33), dtype, seed=1)
            if dtype == np.float32:
                a.flat[5:9] = [np.nan, np.inf, -np.inf, -0.0]
            with h5py.File(self.path("plain.h5"), "w") as f:
                f.create_dataset("v", data=a, chunks=(8, 16, 16), compression=420)
            with h5py.File(self.path("plain.h5"), "r") as f:
                d = f["v"]
                code, _, values, _ = d.id.get_create_plist().get_filter(0)
                self.assertEqual(code, 420)
                self.assertEqual(values[0], 0)  # lossless; set_local added type and chunk shape
                self.assertEqual(tuple(values[5:]), (3, 8, 16, 16))
                b = d[...]
            self.assertEqual(b.dtype, a.dtype)
            self.assertEqual(a.tobytes(), b.tobytes(), dtype)  # bit-exact, NaN payloads and -0 included

    def test_max_error_holds_its_bound_and_compresses(self):
        a = field((32, 48, 64), np.float32, seed=2)
        for bound in (0.001, 0.05, 1.0):
            with h5py.File(self.path("lossy.h5"), "w") as f:
                d = f.create_dataset("v", data=a, chunks=(32, 32, 32), **volcl_hdf5.filter(max_error=bound))
                stored = d.id.get_storage_size()
            with h5py.File(self.path("lossy.h5"), "r") as f:
                b = f["v"][...]
            err = float(np.max(np.abs(b.astype(np.float64) - a.astype(np.float64))))
            self.assertLessEqual(err, bound)
            self.assertLess(stored, a.nbytes)
        # The recipe without the helper module gives the same words.
        import struct
        words = (1,) + struct.unpack("<II", struct.pack("<d", 0.05))
        self.assertEqual(words, volcl_hdf5.cd_values(max_error=0.05))

    def test_float64_is_kept_exact_or_within_the_bound(self):
        # float64 beyond float32's precision and range: lossless is bit for bit, max_error holds in double.
        a = field((16, 24, 40), np.float64, seed=5) * 1e200 + 1e-3 * field((16, 24, 40), np.float64, seed=6)
        a[0, 0, :4] = [np.nan, np.inf, -0.0, 5e-324]
        for kwargs in ({}, {"max_error": 1e190}):
            with h5py.File(self.path("f64.h5"), "w") as f:
                f.create_dataset("v", data=a, chunks=(16, 16, 16), **volcl_hdf5.filter(**kwargs))
            with h5py.File(self.path("f64.h5"), "r") as f:
                b = f["v"][...]
            self.assertEqual(b.dtype, np.float64)
            special = np.zeros(a.shape, bool)
            special[0, 0, :4] = True
            self.assertEqual(b[special].tobytes(), a[special].tobytes(), kwargs)
            if kwargs:
                self.assertLessEqual(float(np.max(np.abs(b[~special] - a[~special]))), kwargs["max_error"])
            else:
                self.assertEqual(b.tobytes(), a.tobytes())

    def test_psnr_and_four_dimensional_series(self):
        a = field((4, 16, 24, 24), np.uint16, seed=3)
        with h5py.File(self.path("series.h5"), "w") as f:
            f.create_dataset("lossless", data=a, chunks=(2, 16, 16, 16), compression=420)
            f.create_dataset("psnr", data=a, chunks=(1, 16, 24, 24), **volcl_hdf5.filter(psnr=50))
        with h5py.File(self.path("series.h5"), "r") as f:
            self.assertTrue(np.array_equal(f["lossless"][...], a))
            b = f["psnr"][...].astype(np.float64)
            frame_psnr = []
            for t in range(a.shape[0]):
                ref = a[t].astype(np.float64)
                mse = np.mean((b[t] - ref) ** 2)
                frame_psnr.append(10 * np.log10((ref.max() - ref.min()) ** 2 / mse) if mse > 0 else np.inf)
            self.assertGreaterEqual(min(frame_psnr), 49.5, frame_psnr)
            # Partial reads decode only what they need and agree with the whole.
            self.assertTrue(np.array_equal(f["lossless"][1:3, 5:9, 3:20, 17], a[1:3, 5:9, 3:20, 17]))

    def test_every_rate_mode_holds_on_the_real_voxels_of_edge_chunks(self):
        # Datasets that are not multiples of the chunk shape: HDF5 pads the edge chunks (with the fill
        # value), and each chunk's real voxels must meet the bound on their own, PSNR over their own range.
        cases = ((np.float32, (33, 17, 70), (16, 8, 32), 0.0), (np.uint16, (21, 19, 37), (8, 8, 16), 0.0),
                 (np.int16, (3, 20, 19, 37), (2, 16, 16, 16), 0.0), (np.float32, (20, 12, 40), (16, 8, 16), 7.5))
        for dtype, shape, chunks, fill in cases:
            a = field(shape, dtype, seed=len(shape) + shape[0])
            grid = [range(0, n, c) for n, c in zip(shape, chunks)]
            origins = [o for o in np.ndindex(*[len(g) for g in grid])]
            blocks = [tuple(slice(i * c, min((i + 1) * c, n)) for i, c, n in zip(o, chunks, shape)) for o in origins]
            for mode, kw in (("lossless", {"compression": 420}), ("max_error", volcl_hdf5.filter(max_error=0.5)),
                             ("psnr", volcl_hdf5.filter(psnr=40)), ("bpv", volcl_hdf5.filter(bpv=4))):
                what = f"{np.dtype(dtype).name} {shape} in {chunks} fill {fill} {mode}"
                with h5py.File(self.path("edges.h5"), "w") as f:
                    d = f.create_dataset("v", data=a, chunks=chunks, fillvalue=dtype(fill), **kw)
                    sizes = [d.id.get_chunk_info(i).size for i in range(d.id.get_num_chunks())]
                with h5py.File(self.path("edges.h5"), "r") as f:
                    b = f["v"][...]
                for block in blocks:
                    ref, got = a[block].astype(np.float64), b[block].astype(np.float64)
                    err = np.abs(got - ref)
                    if mode == "lossless":
                        self.assertEqual(a[block].tobytes(), b[block].tobytes(), what)
                    elif mode == "max_error":
                        self.assertLessEqual(float(err.max()), 0.5, what)
                    elif mode == "psnr":
                        # 4D chunks: per frame, as the filter defines PSNR for a series.
                        frames = [(r, e) for r, e in zip(ref, err)] if len(shape) == 4 else [(ref, err)]
                        for r, e in frames:
                            mse = float(np.mean(e ** 2))
                            if mse > 0:
                                psnr = 10 * np.log10((r.max() - r.min()) ** 2 / mse)
                                self.assertGreaterEqual(psnr, 40.0, f"{what} chunk {block}")
                if mode == "bpv":
                    # The budget counts every voxel of a stored chunk, padding included.
                    self.assertLessEqual(max(sizes) * 8, 4 * np.prod(chunks), what)

    def test_reads_the_c_example_file(self):
        with h5py.File(EXAMPLE_FILE, "r") as f:
            self.assertTrue(np.array_equal(f["lossless_u16"][...], f["raw_u16"][...]))
            self.assertEqual(f["lossless_f32"][...].tobytes(), f["raw_f32"][...].tobytes())
            self.assertTrue(np.array_equal(f["lossless_series_u8"][...], f["raw_series_u8"][...]))
            raw = f["raw_f32"][...].astype(np.float64)
            self.assertLessEqual(float(np.max(np.abs(f["max_error_f32"][...] - raw))), 0.01)

    def test_unsupported_types_and_shapes_are_refused(self):
        with h5py.File(self.path("refused.h5"), "w") as f:
            for name, data, chunks in (("i64", np.zeros((8, 8, 8), np.int64), (8, 8, 8)),
                                       ("i32", np.zeros((8, 8, 8), np.int32), (8, 8, 8)),
                                       ("plane", np.zeros((8, 8), np.uint8), (8, 8))):
                with self.assertRaises((ValueError, OSError, RuntimeError), msg=name):
                    f.create_dataset(name, data=data, chunks=chunks, compression=420)
            with self.assertRaises(ValueError):
                volcl_hdf5.cd_values(max_error=-1)

    def test_corrupted_chunk_raises(self):
        a = field((16, 16, 32), np.int16, seed=4)
        with h5py.File(self.path("corrupt.h5"), "w") as f:
            f.create_dataset("v", data=a, chunks=(16, 16, 16), compression=420)
        subprocess.run([CORRUPT, self.path("corrupt.h5"), "v"], check=True)
        with h5py.File(self.path("corrupt.h5"), "r") as f:
            with self.assertRaises(OSError) as caught:
                f["v"][...]
            self.assertIn("filter", str(caught.exception).lower())
            # The intact chunk still reads.
            self.assertTrue(np.array_equal(f["v"][:, :, 16:], a[:, :, 16:]))


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0], "-v"])
