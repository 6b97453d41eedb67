# A tour of the volcl Python package, as notebook cells (`# %%`): read an MRI, compress it at 50 dB, decode a
# region, render it to a numpy image and show it with matplotlib. CI runs it (python/tests/test_examples.py).
# Run: build/venv/bin/python docs/examples/python_tour.py [OUTPUT_FOLDER]   (figures go there, default .)

# %% Read an MRI: any format the volcl command reads (here NIfTI). The array is a[z, y, x]; spacing is x, y, z.
import os
import sys

import matplotlib

matplotlib.use("Agg")  # files, no window: the script also runs headless
import matplotlib.pyplot as plt
import numpy as np

import volcl

out_dir = sys.argv[1] if len(sys.argv) > 1 else "."
mri_path = "/usr/share/mricron/templates/ch2better.nii.gz"  # Debian's mricron-data (scripts/apt-packages.txt)
vol = volcl.read(mri_path)
print("read", mri_path, vol.array.shape, vol.array.dtype, "spacing", vol.spacing, vol.metadata)

# %% Compress at 50 dB PSNR (over the volume's value range). `report` receives what the encoder measured.
report = {}
vcz = volcl.encode(vol, psnr=50, report=report)
print(f"compressed {vol.array.nbytes} -> {len(vcz)} bytes ({vol.array.nbytes / len(vcz):.1f}:1), "
      f"PSNR {report['psnr']:.2f} dB, max error {report['max_error']:.3g}")
decoded = volcl.decode(vcz)
a, b = vol.array.astype(np.float64), decoded.astype(np.float64)
psnr = 10 * np.log10((a.max() - a.min()) ** 2 / np.mean((a - b) ** 2))
assert psnr >= 49.5, psnr
print(f"PSNR measured here: {psnr:.2f} dB")

# %% Decode only a region: numpy slices in array order (z, y, x). Only the bricks it touches are decoded.
f = volcl.VczFile(vcz)
z = f.shape[0] // 2
region = f[z - 8:z + 8, 40:150, 30:160]
assert np.array_equal(region, decoded[z - 8:z + 8, 40:150, 30:160])
coarse = f.read(level=2)  # a 4x-downsampled approximation, without decoding finer detail
print("region", region.shape, "level 2", coarse.array.shape, "spacing", coarse.spacing)

# %% Render: the ray marcher of `volcl render`, into a float RGBA numpy array (linear, associated colour).
lo, hi = np.percentile(vol.array, [50, 99.5])
tf = volcl.TransferFunction(domain=(float(lo), float(hi)),
                            color=[(lo, 0.9, 0.7, 0.6), (hi, 1.0, 1.0, 0.9)],
                            extinction=[(lo, 0.0), (lo + 0.45 * (hi - lo), 0.0), (hi, 0.6)])
# A head light with Blinn-Phong shading shows the folds of the cortex (effects as in the scene JSON).
image = volcl.render(vol, tf, view="iso", width=320, height=320, step=0.5, effects={"shading": {}},
                     lights=[{"type": "directional", "direction": [0.3, -0.6, -0.7]}])
print("image", image.shape, image.dtype, "alpha max", float(image[..., 3].max()))

# %% Show it with matplotlib: composite over black and sRGB-encode, as `volcl render -o x.png` does.
fig, axes = plt.subplots(1, 3, figsize=(12, 4.2))
axes[0].imshow(vol.array[z], cmap="gray", origin="lower")
axes[0].set_title("slice z=%d (input)" % z)
axes[1].imshow(np.abs(a[z] - b[z]), cmap="magma", origin="lower")
axes[1].set_title(f"|error| at 50 dB ({vol.array.nbytes / len(vcz):.0f}:1)")
axes[2].imshow(volcl.composite(image))
axes[2].set_title("volcl.render, iso view, shaded")
for ax in axes:
    ax.set_axis_off()
fig.tight_layout()
figure = os.path.join(out_dir, "python-tour.png")
fig.savefig(figure, dpi=80)
print("wrote", figure)
