"""Image input/output and the block-mean comparison, with numpy and Mitsuba's Bitmap (scalar_rgb:
file I/O only, nothing is rendered in this process)."""

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

BLOCK = 16
SKY_TOLERANCE = 0.05  # a block is sky when its mean is within this L1 distance of the sky radiance
DIFF_SCALE = 4.0
GAP = 4  # pixels between panels of the side-by-side figure


def read_exr(path):
    """Linear RGB float32 array (H×W×3) of an EXR (any channel layout Mitsuba reads)."""
    # fiberlab's EXRs carry more channels after R, G, B (the sample count and sums a render
    # resumes from): pick R, G, B by name.
    bitmap = mi.Bitmap(str(path))
    names = [field.name for field in bitmap.struct_()]
    if all(c in names for c in "RGB"):
        return np.array(bitmap, dtype=np.float32)[..., [names.index(c) for c in "RGB"]]
    bitmap = bitmap.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    return np.array(bitmap)


def write_png(path, linear):
    """Write a linear RGB array as an 8-bit sRGB PNG (clipped to [0, 1])."""
    bitmap = mi.Bitmap(np.ascontiguousarray(np.clip(linear, 0, 1), dtype=np.float32),
                       mi.Bitmap.PixelFormat.RGB)
    bitmap.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True).write(str(path))


def block_means(image):
    """Mean colour of each BLOCK×BLOCK block (H/BLOCK × W/BLOCK × 3)."""
    h, w, c = image.shape
    return image.reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK, c).mean(axis=(1, 3))


def non_sky_blocks(reference, sky_radiance):
    """Mask of the reference's blocks that are not (almost) pure sky."""
    return np.abs(block_means(reference) - np.asarray(sky_radiance)).sum(-1) > SKY_TOLERANCE


def block_agreement(reference, test, mask):
    """Per-channel ratio test/reference of the mean over the masked blocks, and the relative RMS
    difference of those block means (noise plus any systematic mismatch)."""
    ref, tst = block_means(reference)[mask], block_means(test)[mask]
    ratio = tst.mean(0) / ref.mean(0)
    rel_rms = float(np.sqrt(((tst - ref) ** 2).mean()) / ref.mean())
    return [float(r) for r in ratio], rel_rms


def side_by_side(path, images, names, reference, shape, fiberlab, spp, ref_spp):
    """Row 1: the images (None: a grey panel) labelled with their renderer; row 2:
    |image - reference| × DIFF_SCALE, laid out and labelled by `fiberlab montage`."""
    import subprocess
    import tempfile
    h, w = shape[:2]
    grey = np.full((h, w, 3), 0.18, np.float32)
    top = [grey if im is None else im for im in images]
    bottom = [grey if im is None else np.abs(im - reference) * DIFF_SCALE for im in images]
    with tempfile.TemporaryDirectory() as tmp:
        panels = []
        for k, (a, name, missing) in enumerate(zip(top, names, [im is None for im in images])):
            write_png(f"{tmp}/top{k}.png", a)
            panels.append(f"{tmp}/top{k}.png={name}, {spp} spp" + (" (not available)" if missing else ""))
        for k, (b, name) in enumerate(zip(bottom, names)):
            write_png(f"{tmp}/diff{k}.png", b)
            panels.append(f"{tmp}/diff{k}.png=|{name} - reference| x {DIFF_SCALE:g}")
        title = f"peer scene: top, each renderer at {spp} spp; bottom, |image - fiberlab {ref_spp}-spp reference| x {DIFF_SCALE:g}"
        subprocess.run([str(fiberlab), "montage", "--columns", str(len(images)), "--title", title,
                        "--out", str(path), *panels], check=True)
