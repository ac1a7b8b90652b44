"""Render the peer scene with Mitsuba 3 in one variant (run by peers.py in its own process).

usage: peer_mitsuba.py VARIANT SCENE.toml HAIR SPP OUT_PREFIX [CURVE [EXTRA_SPP]] RESULT.json

Writes OUT_PREFIX.exr (linear RGB) and RESULT.json with the load time and both render times (the
first render of a process includes the LLVM variant's kernel compilation: "cold"; the second
reuses the cached kernels: "warm"). CURVE is the shape type of the strands, `linearcurve`
(default) or `bsplinecurve` (the same points as uniform cubic B-spline control points).
EXTRA_SPP, a comma list, adds one (warm) render per sample count, OUT_PREFIX_<n>spp.exr, for
the RMSE-versus-time curve.
"""

import json
import os
import sys
import time

import drjit as dr
import mitsuba as mi

from scene import load_scene, read_hair


def write_curves(hair_path, txt_path):
    """Write the strands in Mitsuba's curve text format: 'x y z radius' per point, blank line between."""
    points, radii, counts = read_hair(hair_path)
    rows = [f"{x:.7g} {y:.7g} {z:.7g} {r:.7g}" for (x, y, z), r in zip(points, radii)]
    lines, start = [], 0
    for count in counts:
        lines.extend(rows[start:start + count])
        lines.append("")
        start += count
    with open(txt_path, "w") as f:
        f.write("\n".join(lines))


def rgb(value):
    """A constant RGB texture."""
    return {"type": "rgb", "value": list(value)}


def hair_bsdf(params):
    """Mitsuba's `hair` BSDF (Chiang et al. 2016, pbrt-v4 port) with fiberlab's parameters."""
    return {
        "type": "hair",
        # Same d'Eon melanin table as fiberlab (absorption per unit radius).
        "eumelanin": params["eumelanin"], "pheomelanin": params["pheomelanin"],
        "longitudinal_roughness": params["beta_m"], "azimuthal_roughness": params["beta_n"],
        # pbrt-v4 tilt convention: the opposite sign of fiberlab's alpha (see peers.py).
        "scale_tilt": -params["alpha"],
        # eta = int_ior / ext_ior; ext_ior defaults to air (1.000277), fiberlab's exterior is 1.
        "int_ior": params["eta"], "ext_ior": 1.0,
    }


def scene_dict(s, curves_txt, spp, curve="linearcurve"):
    """The Mitsuba scene description with fiberlab's conventions mapped (see peers.py)."""
    cam = s["camera"]
    return {
        "type": "scene",
        # Mitsuba's max_depth counts path vertices including the camera's: events + 1.
        "integrator": {"type": "path", "max_depth": s["max_depth"] + 1},
        "sensor": {
            "type": "perspective", "fov": cam["fov"], "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=cam["eye"], target=cam["target"], up=cam["up"]),
            "film": {"type": "hdrfilm", "width": cam["width"], "height": cam["height"],
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "head": {"type": "sphere", "center": s["sphere_center"], "radius": s["sphere_radius"],
                 "bsdf": {"type": "diffuse", "reflectance": rgb(s["skin_albedo"])}},
        # linearcurve = Embree round linear curves: the same polyline of tubes as fiberlab's;
        # bsplinecurve = Embree round B-spline curves through the same control points.
        "hair": {"type": curve, "filename": curves_txt, "bsdf": hair_bsdf(s["hair"])},
        "env": {"type": "constant", "radiance": rgb(s["env_radiance"])},
        # Mitsuba's `direction` is the direction light travels: minus fiberlab's (toward the light).
        "sun": {"type": "directional", "direction": [-c for c in s["sun_direction"]],
                "irradiance": rgb(s["sun_irradiance"])},
    }


def timed_render(scene, spp, seed):
    """Render once and wait for the result; returns (image, seconds)."""
    start = time.perf_counter()
    image = mi.render(scene, spp=spp, seed=seed)
    dr.eval(image)
    dr.sync_thread()
    return image, time.perf_counter() - start


def main():
    """Load, render twice (cold, warm), write the image and the timings."""
    variant, scene_toml, hair_path, spp, prefix = sys.argv[1:6]
    options, result_path = sys.argv[6:-1], sys.argv[-1]
    curve = options[0] if options else "linearcurve"
    extra_spp = [int(n) for n in options[1].split(",") if n] if len(options) > 1 else []
    spp = int(spp)
    mi.set_variant(variant)
    dr.set_thread_count(os.cpu_count())
    curves_txt = f"{prefix}_curves.txt"
    write_curves(hair_path, curves_txt)
    s = load_scene(scene_toml)
    start = time.perf_counter()
    scene = mi.load_dict(scene_dict(s, curves_txt, spp, curve))
    load = time.perf_counter() - start
    _, cold = timed_render(scene, spp, seed=0)
    image, warm = timed_render(scene, spp, seed=1)
    mi.Bitmap(image).write(f"{prefix}.exr")
    extra = []
    for n in extra_spp:
        image, seconds = timed_render(scene, n, seed=2)
        mi.Bitmap(image).write(f"{prefix}_{n}spp.exr")
        extra.append({"spp": n, "render_s": seconds, "exr": f"{prefix}_{n}spp.exr"})
    os.remove(curves_txt)
    result = {"load_s": load, "renders_s": {"cold": cold, "warm": warm},
              "used": "warm" if warm <= cold else "cold", "curve": curve, "extra": extra,
              "exr": f"{prefix}.exr", "version": f"mitsuba {mi.__version__} {variant}",
              "threads": dr.thread_count()}
    with open(result_path, "w") as f:
        json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
