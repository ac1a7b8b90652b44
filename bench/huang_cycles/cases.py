"""The scenes of the huang-2022 / Cycles comparison as plain data: a camera, a delta light, the
strands (written as a cyHair .hair file both renderers read) and the fiber parameters, with the
fiberlab scene TOML written from them.

fiberlab's conventions throughout (Y up, light directions toward the light, strands root first,
`sigma_a` per unit major semi-axis); cycles_huang.py maps them onto Blender (Z up) with
bench/peers/scene.py's `y_up_to_z_up`, as bench/peers does.

Why these scenes:
* One straight fiber seen from the front, 128² (about 14 pixels wide), lit by one distant light
  and nothing else, on black: every pixel's radiance is single scattering of that light, so the
  fiber's summed radiance per unit length is the far-field model (Cycles' `eval` integrates the
  width; fiberlab's `eval` at each offset, averaged by the pixels). A straight fiber never
  re-hits itself, so the path depth does not matter.
* Elliptical fibers are placed where Cycles' major axis is known: Cycles aligns it with the curve
  normal, which Blender 4.2 computes for a polyline as normalize(tangent × Z_blender) (for a
  vertical curve, the X axis) — checked with `Curves.normals` in bpy 4.2. fiberlab's orientation
  is relative to the view (0°: across the view, 90°: toward the camera). So a horizontal fiber
  (along fiberlab x) has its major axis toward the camera (orientation 90) and a vertical one
  (along fiberlab y) across the view (orientation 0).
* A small tress of straight strands (multiple scattering between fibers, shadowing), circular.
* Opaque fibers: the R lobe alone in both.
"""

import math
import struct

import numpy as np

SIZE = 128
EYE = [0.0, 0.0, 4.0]
FOV = 30.0
# World length of one pixel in the plane z = 0 that holds every fiber (parallel to the image).
PIXEL = 2 * EYE[2] * math.tan(math.radians(FOV) / 2) / SIZE

FRONT_LIGHT = [0.3, 0.5, 1.0]   # above, to the right, from the camera's side: R and TRT
BACK_LIGHT = [0.25, 0.35, -1.0]  # behind the fiber: TT
IRRADIANCE = [2.0, 2.0, 2.0]
SIGMA_A = [0.3, 0.6, 1.2]       # per unit major semi-axis (a light brown)
OPAQUE = [40.0, 40.0, 40.0]

FIBER_RADIUS = 0.12             # 14.3 pixels wide
FIBER_HALF_LENGTH = 1.3         # past the image's edges (fiberlab refuses diameters > 10% of the
                                # hair's bounding-box diagonal: a guard against unit mistakes)
REGION_HALF_LENGTH = 0.48       # the compared part, lengthwise


def straight_fiber(direction):
    """One strand through the origin along `direction` (root first)."""
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    points = np.stack([-FIBER_HALF_LENGTH * d, FIBER_HALF_LENGTH * d])
    return [points], [FIBER_RADIUS]


def tress(strands=48, seed=3):
    """Straight strands along x in a bundle of cross-section 0.36 × 0.24, slightly splayed."""
    rng = np.random.default_rng(seed)
    polylines, radii = [], []
    for _ in range(strands):
        y0, z0 = rng.uniform(-0.18, 0.18), rng.uniform(-0.12, 0.12)
        dy, dz = rng.normal(0, 0.03, 2)
        polylines.append(np.array([[-0.75, y0 - dy, z0 - dz], [0.75, y0 + dy, z0 + dz]]))
        radii.append(0.02)
    return polylines, radii


def case(name, strands, light, roughness, aspect=1.0, orientation=0.0, tilt=2.0, eta=1.55,
         region="horizontal", depth=32, sigma_a=SIGMA_A, lobes=(1.0, 1.0, 1.0), cycles_lobes=None):
    """`lobes`: the R, TT, TRT multipliers (fiberlab's `reflection`, `transmission`,
    `secondary_reflection`; Blender's Reflection, Transmission, Secondary Reflection), the same in
    both renderers unless `cycles_lobes` says otherwise (see TRT_AND_RESIDUAL below)."""
    polylines, radii = strands
    return {"name": name, "polylines": polylines, "radii": radii, "light": light,
            "roughness": roughness, "aspect": aspect, "orientation": orientation, "tilt": tilt,
            "eta": eta, "sigma_a": sigma_a, "region": region, "max_depth": depth,
            "lobes": tuple(lobes), "cycles_lobes": tuple(cycles_lobes or lobes)}


# The lobe multipliers do not gate TRRT+ alike (issue 40's lobe-by-lobe split of the front-lit red
# excess). fiberlab's TRRT+ follows none of them: (0, 0, 0) leaves TRRT+ alone. Cycles computes
# TRRT+ inside its TRT branch (`bsdf_hair_huang_eval_residual`: run when TRT > 0, TRRT+ not
# scaled by it; nothing at all when TT = TRT = 0): TRT = 1e-4 leaves TRRT+ whole and TRT at 10⁻⁴
# of itself, TRT = 0 drops both. Delta lights only reach Cycles' `eval`, not its sampler (which
# draws TRRT+ whatever TRT is).
TRT_AND_RESIDUAL = (0.0, 0.0, 1.0)        # both renderers: TRT + TRRT+
RESIDUAL_ONLY = (0.0, 0.0, 0.0)           # fiberlab: TRRT+ alone
RESIDUAL_ONLY_CYCLES = (0.0, 0.0, 1e-4)   # Cycles: TRRT+ and 10⁻⁴ TRT


def cases():
    """Every compared scene."""
    horizontal = straight_fiber([1, 0, 0])
    vertical = straight_fiber([0, -1, 0])  # root at the top, hanging
    return [
        case("fiber α0.2", horizontal, FRONT_LIGHT, 0.2),
        case("fiber α0.5", horizontal, FRONT_LIGHT, 0.5),
        case("fiber α0.3 backlit", horizontal, BACK_LIGHT, 0.3),
        case("fiber α0.2 tilt 0°", horizontal, FRONT_LIGHT, 0.2, tilt=0.0),
        case("fiber α0.2 tilt 6°", horizontal, FRONT_LIGHT, 0.2, tilt=6.0),
        case("ellipse 0.7 major→camera", horizontal, FRONT_LIGHT, 0.3, aspect=0.7, orientation=90.0),
        case("ellipse 0.7 major across", vertical, FRONT_LIGHT, 0.3, aspect=0.7, orientation=0.0,
             region="vertical"),
        case("tress α0.3", tress(), FRONT_LIGHT, 0.3, region="tress"),
        case("tress α0.3 backlit", tress(), BACK_LIGHT, 0.3, region="tress"),
        # Opaque fibers (σ_a = 40 per radius: every internal path is absorbed): R alone.
        case("opaque α0.2 (R only)", horizontal, FRONT_LIGHT, 0.2, sigma_a=OPAQUE),
        case("opaque α0.5 (R only)", horizontal, FRONT_LIGHT, 0.5, sigma_a=OPAQUE),
        # Cases 1, 2 and 5 lobe by lobe: TRT = 0 (Cycles: R + TT; fiberlab: R + TT + TRRT+), then
        # R = TT = 0: TRT + TRRT+, then TRRT+ alone (TRT_AND_RESIDUAL above).
        *(case(f"fiber α{alpha}{'' if tilt == 2.0 else f' tilt {tilt:g}°'} {what}", horizontal,
               FRONT_LIGHT, alpha, tilt=tilt, lobes=lobes, cycles_lobes=cycles_lobes)
          for alpha, tilt in ((0.2, 2.0), (0.5, 2.0), (0.2, 6.0))
          for what, lobes, cycles_lobes in (("TRT=0", (1.0, 1.0, 0.0), None),
                                            ("TRT+TRRT+", TRT_AND_RESIDUAL, None),
                                            ("TRRT+ only", RESIDUAL_ONLY, RESIDUAL_ONLY_CYCLES))),
    ]


def slug(name):
    """A file-name form of a case name."""
    keep = {"α": "a", "°": "deg", "→": "-to-", ".": "p", " ": "_", "(": "", ")": "", "+": "plus",
            "=": ""}
    return "".join(keep.get(c, c) for c in name)


def write_hair(path, polylines, radii):
    """cyHair .hair file: segments, points and thickness (a diameter) arrays."""
    counts = [len(p) for p in polylines]
    points = np.concatenate(polylines).astype("<f4")
    thickness = np.concatenate([np.full(n, 2 * r) for n, r in zip(counts, radii)]).astype("<f4")
    header = struct.pack("<4sIIIIff3f", b"HAIR", len(polylines), len(points), 1 | 2 | 4, 1,
                         thickness[0], 1.0, 1.0, 1.0, 1.0)
    header += b"huang-2022 vs Cycles".ljust(88, b"\0")
    with open(path, "wb") as f:
        f.write(header)
        f.write(np.array([n - 1 for n in counts], "<u2").tobytes())
        f.write(points.tobytes())
        f.write(thickness.tobytes())


def fiberlab_toml(c, hair_file, spp):
    """The fiberlab scene of a case: the same camera, light and strands; no environment."""
    s = c["sigma_a"]
    r, tt, trt = c["lobes"]
    return f"""# huang-2022 vs Cycles: {c['name']} (written by bench/huang_cycles/cases.py)
[camera]
eye = {EYE}
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = {FOV}
width = {SIZE}
height = {SIZE}

[render]
spp = {spp}
max_depth = {c['max_depth']}

[materials.hair]
model = "huang-2022"
params = {{ eta = {c['eta']}, roughness = {c['roughness']}, aspect = {c['aspect']}, orientation = "{c['orientation']}", alpha = {c['tilt']}, sigma_a = [{s[0]}, {s[1]}, {s[2]}], reflection = {r}, transmission = {tt}, secondary_reflection = {trt} }}

[[hair]]
material = "hair"
file = "{hair_file}"

[[light]]
type = "distant"
direction = {c['light']}
irradiance = {IRRADIANCE}
"""


def region(c):
    """Pixel rectangle (row0, row1, col0, col1) summed, and the fiber width covered in it (pixels
    across, per renderer: fiberlab fills the tube's silhouette with the ellipse, Cycles shows the
    ellipse's own projected width and is transparent outside it).

    For a single fiber the rectangle spans ±REGION_HALF_LENGTH of the fiber lengthwise and its whole width
    with a margin; the summed radiance over the covered width is the far-field mean. For the tress
    it is the bundle's bounding box, compared as a plain mean."""
    centre = SIZE // 2
    half_len = int(REGION_HALF_LENGTH / PIXEL)
    half_width = int(FIBER_RADIUS / PIXEL) + 4
    if c["region"] == "tress":
        return (centre - int(0.3 / PIXEL), centre + int(0.3 / PIXEL),
                centre - int(0.7 / PIXEL), centre + int(0.7 / PIXEL)), None
    along = (centre - half_len, centre + half_len)
    across = (centre - half_width, centre + half_width)
    rect = across + along if c["region"] == "horizontal" else along + across
    return rect, 2 * FIBER_RADIUS / PIXEL


def cycles_visible_fraction(c):
    """Cycles' projected half-width of the ellipse over the major semi-axis seen from the camera:
    1 with the major axis across the view, b with it toward the camera (bsdf_hair_huang_setup's
    `radius`, beyond which the hit is made transparent)."""
    b = c["aspect"]
    psi = math.radians(c["orientation"])  # from across the view toward the camera
    return math.sqrt(math.cos(psi) ** 2 + (b * math.sin(psi)) ** 2)
