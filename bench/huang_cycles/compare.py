"""huang-2022 in fiberlab against Blender Cycles' Principled Hair BSDF (model HUANG): the scenes of
cases.py rendered by both, region means per channel, their Monte Carlo errors and the verdict.
Run it through bench/huang_cycles/run (which makes the venv and builds fiberlab).

Each case is rendered SEEDS times by each renderer at SPP samples per pixel with independent
seeds. The statistic of one render is
  * a single fiber: the radiance summed over a rectangle holding ±0.48 of the fiber's length
    (of ±1.3, past the image's edges) and all its width, divided by the fiber's covered area (the number of columns times its
    projected width in pixels): the mean radiance over the fiber's width, i.e. the far field.
    The covered width is the tube's diameter in fiberlab (its ellipse fills the tube's silhouette)
    and Cycles' projected width of the ellipse (the rest of the tube is transparent there).
  * the tress: the plain mean over the bundle's bounding box (black background).
The Monte Carlo standard error of the mean over seeds is std/√SEEDS (Cycles' own eval is a noisy
quadrature too: its random microfacets are part of that variance), and a case agrees when
|fiberlab − Cycles| < 3·√(se_f² + se_c²) per channel. Differences beyond it are convention or
model differences, explained in docs/theory/peer-discrepancies.md ("Huang 2022 against Cycles").

Environment: SPP (128), SEEDS (8), HUANG_CYCLES_OUT (bench/huang_cycles/out), CASES (comma list of
indices into cases.cases(), default all), FIBERLAB (the binary), HUANG_CYCLES_PYTHON (the venv's
python for the Cycles process), HUANG_CYCLES_THREADS (threads for both renderers; 2), REUSE (1: keep the EXRs of both renderers
already in the output folder).
"""

import json
import math
import os
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import OpenEXR

from cases import (cases, cycles_visible_fraction, fiberlab_toml, region, slug, write_hair)

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
FIBERLAB = Path(os.environ.get("FIBERLAB", REPO / "target" / "release" / "fiberlab"))
PYTHON = os.environ.get("HUANG_CYCLES_PYTHON", sys.executable)
OUT = Path(os.environ.get("HUANG_CYCLES_OUT", HERE / "out")).resolve()
SPP = int(os.environ.get("SPP", "128"))
SEEDS = list(range(int(os.environ.get("SEEDS", "8"))))
THREADS = os.environ.get("HUANG_CYCLES_THREADS", "2")
AGREE_SIGMAS = 3.0


def read_rgb(path):
    """Linear RGB (H×W×3, row 0 at the top) of an EXR: R, G, B by name (fiberlab's EXRs carry
    sample sums after them), or the RGB(A) layer Blender writes."""
    with OpenEXR.File(str(path)) as exr:
        channels = exr.channels()
        if "RGBA" in channels or "RGB" in channels:
            return np.asarray((channels.get("RGBA") or channels["RGB"]).pixels, float)[..., :3]
        return np.stack([np.asarray(channels[c].pixels, float) for c in "RGB"], -1)


def statistic(image, c, width_fraction):
    """The region statistic of one render (module docs), per channel."""
    (r0, r1, c0, c1), width = region(c)
    block = image[r0:r1, c0:c1]
    if width is None:
        return block.reshape(-1, 3).mean(0)
    lengthwise = (c1 - c0) if c["region"] == "horizontal" else (r1 - r0)
    return block.reshape(-1, 3).sum(0) / (lengthwise * width * width_fraction)


def render_fiberlab(c, index):
    stem = OUT / slug(c["name"])
    write_hair(f"{stem}.hair", c["polylines"], c["radii"])
    scene = Path(f"{stem}.toml")
    scene.write_text(fiberlab_toml(c, Path(f"{stem}.hair").name, SPP))
    paths = []
    for seed in SEEDS:
        prefix = f"{stem}_fiberlab_s{seed}"
        paths.append(f"{prefix}.exr")
        if os.environ.get("REUSE") == "1" and Path(f"{prefix}.exr").exists():
            continue
        subprocess.run([str(FIBERLAB), "render", str(scene), "--seed", str(seed), "--threads", THREADS,
                        "--out", prefix, "--quiet"], check=True, stdout=subprocess.DEVNULL)
    return paths


def render_cycles(indices):
    env = dict(os.environ, HUANG_CYCLES_THREADS=THREADS)
    with open(OUT / "cycles.log", "w") as log:
        subprocess.run([PYTHON, str(HERE / "cycles_huang.py"), str(OUT), str(SPP),
                        ",".join(map(str, SEEDS)), *map(str, indices)],
                       check=True, stdout=log, stderr=subprocess.STDOUT, env=env)


def write_png(path, linear, exposure):
    """8-bit sRGB PNG of a linear RGB image scaled by `exposure` (clipped to [0, 1])."""
    x = np.clip(np.asarray(linear) * exposure, 0, 1)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)
    rows = (srgb * 255 + 0.5).astype(np.uint8)
    raw = b"".join(b"\0" + row.tobytes() for row in rows)
    chunk = lambda kind, data: (struct.pack(">I", len(data)) + kind + data  # noqa: E731
                                + struct.pack(">I", zlib.crc32(kind + data)))
    h, w = rows.shape[:2]
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def side_by_side(rows, out_png):
    """fiberlab | Cycles, one row per case, each pair at the exposure that puts fiberlab's 99.5th
    percentile at 0.9 (montage by `fiberlab montage`)."""
    tiles = []
    for number, (name, fiberlab, cycles) in enumerate(rows, 1):
        exposure = 0.9 / max(np.percentile(fiberlab, 99.5), 1e-6)
        for who, image in (("fiberlab", fiberlab), ("Cycles", cycles)):
            path = OUT / f"{slug(name)}_{who}_mean.png"
            write_png(path, image, exposure)
            tiles.append(f"{path}={number}. {who}")
    subprocess.run([str(FIBERLAB), "montage", "--columns", "4", "--out", str(out_png), "--title",
                    f"huang-2022 in fiberlab | Cycles HUANG ({len(SEEDS)}×{SPP} spp)", *tiles],
                   check=True)


def summarize(values):
    v = np.asarray(values)
    return v.mean(0), v.std(0, ddof=1) / math.sqrt(len(v))


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    all_cases = cases()
    indices = [int(i) for i in os.environ.get("CASES", "").split(",") if i] or range(len(all_cases))
    # Cycles renders already in OUT (same SPP and seeds: the file names carry the seed) are kept
    # when REUSE=1, so an interrupted run resumes.
    todo = [i for i in indices if os.environ.get("REUSE") != "1" or not all(
        (OUT / f"{slug(all_cases[i]['name'])}_cycles_s{s}.exr").exists() for s in SEEDS)]
    if todo:
        render_cycles(todo)
    rows, images = [], []
    for i in indices:
        c = all_cases[i]
        fiberlab_images = [read_rgb(p) for p in render_fiberlab(c, i)]
        cycles_images = [read_rgb(OUT / f"{slug(c['name'])}_cycles_s{s}.exr") for s in SEEDS]
        images.append((c["name"], np.mean(fiberlab_images, 0), np.mean(cycles_images, 0)))
        fiberlab = [statistic(image, c, 1.0) for image in fiberlab_images]
        cycles = [statistic(image, c, cycles_visible_fraction(c)) for image in cycles_images]
        (mf, sf), (mc, sc) = summarize(fiberlab), summarize(cycles)
        sigma = np.sqrt(sf ** 2 + sc ** 2)
        z = (mf - mc) / sigma
        rows.append({"case": c["name"], "fiberlab": mf.tolist(), "fiberlab_se": sf.tolist(),
                     "cycles": mc.tolist(), "cycles_se": sc.tolist(), "ratio": (mf / mc).tolist(),
                     "z": z.tolist(), "agree": bool(np.all(np.abs(z) < AGREE_SIGMAS))})
    print(f"huang-2022 (fiberlab) vs Cycles HUANG: {len(SEEDS)} seeds × {SPP} spp each, "
          f"128², means per channel (R, G, B)\n")
    print("| # | case | fiberlab | Cycles | fiberlab / Cycles | z = Δ/σ | within 3σ |")
    print("|---|---|---|---|---|---|---|")
    fmt = lambda v: " ".join(f"{x:.4f}" for x in v)  # noqa: E731
    for number, r in enumerate(rows, 1):
        print(f"| {number} | {r['case']} | {fmt(r['fiberlab'])} | {fmt(r['cycles'])} | "
              f"{' '.join(f'{x:.3f}' for x in r['ratio'])} | {' '.join(f'{x:+.1f}' for x in r['z'])} | "
              f"{'yes' if r['agree'] else 'no'} |")
    (OUT / "results.json").write_text(json.dumps(rows, indent=1))
    side_by_side(images, OUT / "side_by_side.png")
    print(f"\nwrote {OUT / 'results.json'} and {OUT / 'side_by_side.png'}")


if __name__ == "__main__":
    main()
