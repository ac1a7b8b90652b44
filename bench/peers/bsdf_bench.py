"""Time Mitsuba's `hair` BSDF eval and sample (run by peers.py in its own process per variant).

usage: bsdf_bench.py VARIANT SCENE.toml RESULT.json

scalar_rgb: one direction pair per call from a Python loop over 1024 prepared inputs; the same loop
calling the trivial binding `bsdf.flags()` is the baseline, so raw - baseline is the cost net of
the Python loop and call overhead. llvm_ad_rgb: one call over LANES lanes after a warm-up call
(which compiles the kernel), wall time / LANES.

The local frame is Mitsuba's own test_hair.py setup: shading normal +z, the fiber tangent along the
local y axis; h follows from si.wi. Incident directions are uniform on the front hemisphere,
outgoing ones on the sphere.
"""

import json
import statistics
import sys
import time

import drjit as dr
import mitsuba as mi
import numpy as np

from peer_mitsuba import hair_bsdf
from scene import load_scene

INPUTS = 1024
SCALAR_CALLS = 40_960
LANES = 1 << 20
REPEATS = 5


def random_directions(rng, n, hemisphere):
    """n unit vectors, uniform on the sphere (or on the z > 0 hemisphere)."""
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    if hemisphere:
        v[:, 2] = np.abs(v[:, 2])
    return v


def interaction(wi):
    """A SurfaceInteraction3f at the origin with normal +z and incident direction wi (local)."""
    si = mi.SurfaceInteraction3f()
    si.p = mi.Point3f(0, 0, 0)
    si.n = mi.Normal3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(si.n)
    si.wi = wi
    return si


def median_seconds(run):
    """Median wall time of REPEATS calls of run()."""
    times = []
    for _ in range(REPEATS):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def bench_scalar(bsdf, rng):
    """ns per call of eval, sample and the baseline binding call, from a Python loop."""
    wis = random_directions(rng, INPUTS, hemisphere=True)
    wos = random_directions(rng, INPUTS, hemisphere=False)
    us = rng.random((INPUTS, 3))
    data = [(interaction(mi.Vector3f(wi)), mi.Vector3f(wo), float(u[0]), mi.Point2f(u[1], u[2]))
            for wi, wo, u in zip(wis, wos, us)] * (SCALAR_CALLS // INPUTS)
    ctx = mi.BSDFContext()

    def baseline():
        for si, wo, u1, u2 in data:
            bsdf.flags()

    def evaluate():
        for si, wo, u1, u2 in data:
            bsdf.eval(ctx, si, wo)

    def sample():
        for si, wo, u1, u2 in data:
            bsdf.sample(ctx, si, u1, u2)

    ns = {name: median_seconds(run) * 1e9 / len(data)
          for name, run in (("baseline", baseline), ("eval", evaluate), ("sample", sample))}
    return {"calls": len(data), "baseline_ns": ns["baseline"], "eval_ns": ns["eval"],
            "sample_ns": ns["sample"], "eval_net_ns": ns["eval"] - ns["baseline"],
            "sample_net_ns": ns["sample"] - ns["baseline"]}


def bench_vectorized(bsdf, rng):
    """ns per lane of eval and sample over LANES lanes, after a warm-up call of each."""
    def vector(a):
        return mi.Vector3f(mi.Float(a[:, 0]), mi.Float(a[:, 1]), mi.Float(a[:, 2]))

    si = interaction(vector(random_directions(rng, LANES, hemisphere=True)))
    wo = vector(random_directions(rng, LANES, hemisphere=False))
    us = rng.random((3, LANES)).astype(np.float32)
    u1, u2 = mi.Float(us[0]), mi.Point2f(mi.Float(us[1]), mi.Float(us[2]))
    dr.eval(si, wo, u1, u2)
    ctx = mi.BSDFContext()

    def evaluate():
        dr.eval(bsdf.eval(ctx, si, wo))
        dr.sync_thread()

    def sample():
        bs, weight = bsdf.sample(ctx, si, u1, u2)
        dr.eval(bs.wo, bs.pdf, weight)
        dr.sync_thread()

    evaluate()
    sample()
    return {"lanes": LANES, "eval_ns": median_seconds(evaluate) * 1e9 / LANES,
            "sample_ns": median_seconds(sample) * 1e9 / LANES}


def main():
    """Run the variant's benchmark and write the JSON result."""
    variant, scene_toml, result_path = sys.argv[1:4]
    mi.set_variant(variant)
    bsdf = mi.load_dict(hair_bsdf(load_scene(scene_toml)["hair"]))
    rng = np.random.default_rng(1)
    bench = bench_scalar if variant.startswith("scalar") else bench_vectorized
    result = {"variant": variant, "threads": dr.thread_count(), **bench(bsdf, rng)}
    with open(result_path, "w") as f:
        json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
