"""Which axis does Mitsuba 3's `hair` BSDF read as the fiber tangent, on `linearcurve` and on
`bsplinecurve`? One straight, dark fiber (R lobe only) along +x, root at -x, seen by a camera on
+z and lit head-on by a distant light with no x component (theta_i = 0). Along the fiber the view
direction's longitudinal angle changes, sin theta_o = -x / |eye - p|, so the highlight sits where
the R lobe's centre theta_o = -theta_i + (lobe shift) is met: with the cuticle tilt alpha the
highlight moves along x by about 2 alpha in theta_o, toward the root or the tip. A BSDF that took
another axis as its tangent would not put the highlight at theta_o = 0 for alpha = 0, nor move it
with the tilt.

The same fiber is rendered by fiberlab (a .hair file of 8 collinear points, basis linear and
bspline), so the measured positions are compared with fiberlab's at the same tilt.

usage: bench/peers/.venv/bin/python bench/peers/tangent_probe.py [OUT_DIR]
(bench/peers/run sets up the venv; the scalar_rgb variant needs no libLLVM.) FIBERLAB names the
binary (default target/release/fiberlab). Prints one row per renderer, curve type and tilt, and
the answer.
"""

import math
import os
import struct
import subprocess
import sys
from pathlib import Path

import mitsuba as mi
import numpy as np

HERE = Path(__file__).resolve().parent
FIBERLAB = Path(os.environ.get("FIBERLAB", HERE.parents[1] / "target" / "release" / "fiberlab"))
WIDTH, HEIGHT = 512, 32
DISTANCE = 4.0          # camera on +z at this distance from the fiber
HALF_WIDTH = 2.4        # the image spans x in [-HALF_WIDTH, HALF_WIDTH] at the fiber
RADIUS = 0.03
POINTS = 8              # collinear control points from x = -X_END to +X_END (root first)
X_END = 3.2
ALPHA = 10.0            # degrees; large so that the shift (2 alpha = 20 degrees) is unmistakable
SPP = 64
TO_LIGHT = np.array([0.0, 0.3, 1.0]) / math.hypot(0.3, 1.0)   # theta_i = 0 (no x component)
HAIR = {"eumelanin": 8.0, "pheomelanin": 0.0, "beta_m": 0.1, "beta_n": 0.3, "eta": 1.55}


def control_points():
    """The fiber's control points, root (-x) first."""
    return [(x, 0.0, 0.0) for x in np.linspace(-X_END, X_END, POINTS)]


def vertical_fov():
    """Vertical field of view (degrees) of an image spanning x in +-HALF_WIDTH at the fiber."""
    tan_half_x = HALF_WIDTH / DISTANCE
    return 2 * math.degrees(math.atan(tan_half_x * HEIGHT / WIDTH))


def write_hair(path):
    """cyHair .hair: one strand, points only, the diameter in the header's default thickness."""
    pts = control_points()
    header = b"HAIR" + struct.pack("<IIII", 1, len(pts), 2, len(pts) - 1)
    header += struct.pack("<f f 3f", 2 * RADIUS, 1.0, 1.0, 1.0, 1.0)
    header += b"\0" * (128 - len(header))
    with open(path, "wb") as f:
        f.write(header + struct.pack(f"<{3 * len(pts)}f", *[c for p in pts for c in p]))


def fiberlab_scene(path, hair, basis, alpha):
    """The probe scene as a fiberlab TOML file."""
    path.write_text(f"""[camera]
eye = [0.0, 0.0, {DISTANCE}]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = {vertical_fov()!r}
width = {WIDTH}
height = {HEIGHT}

[render]
spp = {SPP}
max_depth = 1
seed = 0
exposure = 0.0

[materials.hair]
model = "chiang"
params = {{ eumelanin = {HAIR['eumelanin']}, pheomelanin = 0.0, beta_m = {HAIR['beta_m']}, beta_n = {HAIR['beta_n']}, alpha = {alpha}, eta = {HAIR['eta']} }}

[[hair]]
material = "hair"
file = "{hair.name}"
basis = "{basis}"
segments_per_curve = 8

[[light]]
type = "distant"
direction = {list(TO_LIGHT)}
irradiance = [1.0, 1.0, 1.0]
""")


def render_fiberlab(out, basis, alpha):
    """fiberlab's image (H×W×3) of the probe."""
    hair = out / "probe.hair"
    write_hair(hair)
    scene = out / f"probe_fiberlab_{basis}_{alpha:+g}.toml"
    fiberlab_scene(scene, hair, basis, alpha)
    prefix = out / scene.stem
    subprocess.run([str(FIBERLAB), "render", str(scene), "--out", str(prefix), "--quiet"], check=True,
                   capture_output=True)
    return read_exr(f"{prefix}.exr")


def render_mitsuba(out, curve, scale_tilt):
    """Mitsuba scalar_rgb's image (H×W×3) of the probe on `linearcurve` or `bsplinecurve`."""
    txt = out / "probe_curve.txt"
    txt.write_text("\n".join(f"{x:.7g} {y:.7g} {z:.7g} {RADIUS:.7g}" for x, y, z in control_points()) + "\n")
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 2},   # camera vertex + one scattering event
        "sensor": {
            "type": "perspective", "fov": vertical_fov(), "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, DISTANCE], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": WIDTH, "height": HEIGHT, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": SPP},
        },
        "hair": {"type": curve, "filename": str(txt),
                 "bsdf": {"type": "hair", "eumelanin": HAIR["eumelanin"], "pheomelanin": 0.0,
                          "longitudinal_roughness": HAIR["beta_m"], "azimuthal_roughness": HAIR["beta_n"],
                          "scale_tilt": scale_tilt, "int_ior": HAIR["eta"], "ext_ior": 1.0}},
        "sun": {"type": "directional", "direction": list(-TO_LIGHT), "irradiance": {"type": "rgb", "value": [1, 1, 1]}},
    })
    return np.array(mi.render(scene), dtype=np.float64)


def read_exr(path):
    """Linear RGB (H×W×3) of an EXR."""
    bitmap = mi.Bitmap(str(path))
    names = [field.name for field in bitmap.struct_()]
    return np.array(bitmap, dtype=np.float64)[..., [names.index(c) for c in "RGB"]]


def highlight(image):
    """Where along the fiber the highlight is: the luminance summed over rows per column, its
    peak column refined by the centroid of the columns above half the peak; returns the
    fiber's x there and theta_o (degrees, against the root->tip tangent +x)."""
    profile = image.mean(axis=2).sum(axis=0)
    if not profile.max() > 0:
        return None
    peak = int(profile.argmax())
    lo, hi = peak, peak
    while lo > 0 and profile[lo - 1] > 0.5 * profile[peak]:
        lo -= 1
    while hi < len(profile) - 1 and profile[hi + 1] > 0.5 * profile[peak]:
        hi += 1
    cols = np.arange(lo, hi + 1)
    u = float((profile[cols] * (cols + 0.5)).sum() / profile[cols].sum())
    x = (2 * u / WIDTH - 1) * HALF_WIDTH
    return x, math.degrees(math.asin(-x / math.hypot(x, DISTANCE)))


def main():
    out = Path(sys.argv[1] if len(sys.argv) > 1 else HERE / "out" / "tangent_probe").resolve()
    out.mkdir(parents=True, exist_ok=True)
    mi.set_variant("scalar_rgb")
    rows = []
    # fiberlab alpha > 0 tilts toward the root; peers.py maps it to Mitsuba scale_tilt = -alpha.
    for alpha in (-ALPHA, 0.0, ALPHA):
        for basis, curve in (("linear", "linearcurve"), ("bspline", "bsplinecurve")):
            rows.append(("fiberlab", basis, alpha, highlight(render_fiberlab(out, basis, alpha))))
            rows.append((f"mitsuba {curve}", basis, alpha, highlight(render_mitsuba(out, curve, -alpha))))
    print(f"straight fiber along +x (root at -x), theta_i = 0, beta_m = {HAIR['beta_m']}, R lobe only "
          f"(eumelanin {HAIR['eumelanin']}); {SPP} spp, {WIDTH}x{HEIGHT}; highlight = centroid of the "
          "columns above half the peak")
    print(f"{'renderer':<24} {'alpha':>6} {'scale_tilt':>10} {'highlight x':>12} {'theta_o deg':>12}")
    for name, basis, alpha, h in rows:
        text = "no highlight" if h is None else f"{h[0]:>12.3f} {h[1]:>12.2f}"
        print(f"{name + ' (' + basis + ')' if name == 'fiberlab' else name:<24} {alpha:>+6g} {-alpha:>+10g} {text}")
    print()
    for name in ("mitsuba linearcurve", "mitsuba bsplinecurve"):
        basis = "linear" if "linear" in name else "bspline"
        ref = {a: h for (n, b, a, h) in rows if n == "fiberlab" and b == basis}
        got = {a: h for (n, b, a, h) in rows if n == name}
        if any(h is None for h in got.values()):
            print(f"{name}: no highlight at some tilt: the hair BSDF does not see this fiber's tangent")
            continue
        shift = got[ALPHA][1] - got[-ALPHA][1]
        ref_shift = ref[ALPHA][1] - ref[-ALPHA][1]
        centred = abs(got[0.0][1]) < 2.0
        follows = abs(shift - ref_shift) < 0.25 * abs(ref_shift)
        verdict = ("the curve direction (root->tip) is the tangent" if centred and follows else
                   "NOT the curve direction: the highlight does not sit at theta_o = 0 / move with the tilt as fiberlab's")
        print(f"{name}: theta_o at alpha 0 = {got[0.0][1]:+.2f} deg (fiberlab {ref[0.0][1]:+.2f}); "
              f"shift alpha -{ALPHA:g} -> +{ALPHA:g} = {shift:+.2f} deg (fiberlab {ref_shift:+.2f}): {verdict}")


if __name__ == "__main__":
    main()
