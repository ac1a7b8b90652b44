"""fiberlab models as Mitsuba 3 BSDFs (`fiberlab.mitsuba`), checked by Mitsuba itself.

Optional: skipped where `mitsuba` is not installed (CI does not install it). (a) The adapter
passes Mitsuba's own χ² harness (`mitsuba.chi2.ChiSquareTest` with its `BSDFAdapter`, as
mitsuba3's `src/bsdfs/tests/test_hair.py` runs it for the `hair` plugin) for `chiang`,
`kajiya-kay` and `deon`; (b) Mitsuba's built-in `hair` (Chiang et al. 2016) and fiberlab's
`chiang` with the parameter mapping of `fiberlab.mitsuba` give the same `eval` and `pdf` through
the adapter; (c) the adapter's values are the fiberlab model's in the mapped frame.

The χ² harness needs a vectorized variant: `llvm_ad_rgb` where Dr.Jit's LLVM backend works
(probed in a subprocess, because an LLVM too old for Dr.Jit aborts the process), else those
tests skip and the rest run in `scalar_rgb`.
"""

import os
import subprocess
import sys

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba")
dr = pytest.importorskip("drjit")

import fiberlab as fl  # noqa: E402

_PROBE = """
import drjit as dr, mitsuba as mi
mi.set_variant("llvm_ad_rgb")
x = dr.maximum(mi.Float([1.0, 2.0]), mi.Float([2.0, 1.0]))
print(float(dr.sum(x)[0]) if hasattr(dr.sum(x), '__getitem__') else float(dr.sum(x)))
"""


def _llvm_works() -> bool:
    if "llvm_ad_rgb" not in mi.variants():
        return False
    r = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, timeout=300,
                       env=dict(os.environ))
    return r.returncode == 0 and r.stdout.strip() == "4.0"


LLVM = _llvm_works()
VARIANT = "llvm_ad_rgb" if LLVM else "scalar_rgb"
needs_llvm = pytest.mark.skipif(not LLVM, reason="Dr.Jit's LLVM backend does not work here (χ² needs it)")


@pytest.fixture(scope="module", autouse=True)
def variant():
    mi.set_variant(VARIANT)
    fl.mitsuba.register()
    yield VARIANT


def _unit(theta, phi):
    return dr.normalize(mi.ScalarVector3f(np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)))


CHI2_CASES = [
    ({"type": "fiberlab", "model": "chiang", "sigma_a": [0.8, 0.8, 0.8], "beta_m": 0.5, "beta_n": 0.8}, 0.3, 0.5),
    ({"type": "fiberlab", "model": "chiang", "sigma_a": [0.8, 0.8, 0.8], "beta_m": 0.5, "beta_n": 0.8}, 1.2, 2.0),
    ({"type": "fiberlab", "model": "chiang", "beta_m": 0.3, "beta_n": 0.3}, 0.7, 1.0),
    ({"type": "fiberlab", "model": "kajiya-kay"}, 0.3, 0.5),
    ({"type": "fiberlab", "model": "kajiya-kay", "p": 40}, 1.2, 2.0),
    ({"type": "fiberlab", "model": "deon"}, 1.2, 2.0),
    # Marschner 2003: rejected while its TRT sampling density was infinite on the caustic
    # (this grid quadrature cannot integrate it) and while TRT without glints drew ~4 % of its
    # samples where the lobe is zero (Mitsuba counts those as lost); see
    # crates/scatter/src/marschner_2003/sampling.rs. The defaults pass now.
    ({"type": "fiberlab", "model": "marschner"}, 0.3, 0.5),
    # Still rejected (measured with mitsuba 3.9.1: Mitsuba's pdf sum 1.0025, 1.0004, 1.0010 where
    # fiberlab's own quadrature gives 1 to 1e-5); the cause is not the caustic (the sum does not
    # change with the smoothing width) and is open.
    pytest.param({"type": "fiberlab", "model": "marschner", "glints": "off"}, 1.2, 2.0,
                 marks=pytest.mark.xfail(reason="open: Mitsuba's pdf sum 1.0025", strict=False)),
    pytest.param({"type": "fiberlab", "model": "marschner", "lobes": "trt"}, 0.7, 1.0,
                 marks=pytest.mark.xfail(reason="open: χ² p ≈ 4e-4", strict=False)),
    pytest.param({"type": "fiberlab", "model": "marschner", "lobes": "trt", "glints": "off"}, 1.2, 2.0,
                 marks=pytest.mark.xfail(reason="open: Mitsuba's pdf sum 1.0010", strict=False)),
]


@needs_llvm
@pytest.mark.parametrize("props, theta, phi", CHI2_CASES)
def test_mitsuba_chi2_harness_accepts_the_adapter(props, theta, phi, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a rejection writes chi2_data.py into the working directory
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain

    sample_func, pdf_func = BSDFAdapter("fiberlab", props, wi=_unit(theta, phi))
    chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sample_func, pdf_func=pdf_func, sample_dim=3,
                         res=201)
    assert chi2.run(), chi2.messages


@needs_llvm
def test_mitsuba_chi2_harness_rejects_a_wrong_pdf(tmp_path, monkeypatch):
    """The harness as used above can fail: the adapter's sampler against the pdf of a rougher
    fiber is rejected."""
    monkeypatch.chdir(tmp_path)  # the rejection writes chi2_data.py into the working directory
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain

    wi = _unit(0.7, 1.0)
    sample_func, _ = BSDFAdapter("fiberlab", {"type": "fiberlab", "model": "chiang", "beta_m": 0.3}, wi=wi)
    _, pdf_func = BSDFAdapter("fiberlab", {"type": "fiberlab", "model": "chiang", "beta_m": 0.36}, wi=wi)
    chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sample_func, pdf_func=pdf_func, sample_dim=3,
                         res=201)
    assert not chi2.run()


# Mitsuba `hair` ↔ fiberlab `chiang` (see fiberlab/mitsuba.py): roughnesses by the same names'
# maps, scale_tilt = −alpha, eta = int_ior/ext_ior, melanin concentrations as they are; and the
# relative tolerance of each comparison. Mitsuba evaluates in float32: where the longitudinal
# variance v = (0.726β_m + 0.812β_m² + 3.7β_m²⁰)² is ≥ 0.1 (β_m = 0.6: v = 0.53) the two agree
# to 8e-5 (measured). Below 0.1 (β_m = 0.3: v = 0.085; β_m = 0.15: v = 0.015) Mitsuba's
# longitudinal term (`warp::square_to_rough_fiber_pdf`) switches to a log-space form with an
# asymptotic log I₀ and a rounded ln 2, fiberlab's does not: Mitsuba's values are lower by up to
# 0.51 % (β_m = 0.3) and 0.58 % (β_m = 0.15), median 0.06 % and 0.14 % (measured on these 4000
# pairs).
HAIR_PAIRS = [
    ({"longitudinal_roughness": 0.3, "azimuthal_roughness": 0.3, "scale_tilt": 2.0, "eumelanin": 1.3,
      "pheomelanin": 0.2},
     {"beta_m": 0.3, "beta_n": 0.3, "alpha": -2.0, "eumelanin": 1.3, "pheomelanin": 0.2}, 1e-2),
    ({"longitudinal_roughness": 0.6, "azimuthal_roughness": 0.8, "scale_tilt": -3.0, "eumelanin": 0.2,
      "pheomelanin": 0.9},
     {"beta_m": 0.6, "beta_n": 0.8, "alpha": 3.0, "eumelanin": 0.2, "pheomelanin": 0.9}, 3e-4),
    ({"longitudinal_roughness": 0.15, "azimuthal_roughness": 0.5, "scale_tilt": 0.0, "eumelanin": 0.0,
      "pheomelanin": 0.0},
     {"beta_m": 0.15, "beta_n": 0.5, "alpha": 0.0, "sigma_a": 0.0}, 1e-2),
]


def _random_directions(rng, n):
    z = rng.uniform(-0.999, 0.999, n)
    p = rng.uniform(-np.pi, np.pi, n)
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(p), r * np.sin(p), z], axis=-1)


def _batch(rng, n):
    """Viewer (si.wi) and light (wo) directions in Mitsuba's frame, (n, 3) each; the viewer on
    the side of the surface normal +z, as at every hit of a ray on a fiber. (Behind it Mitsuba's
    `hair` takes γ beyond ±π/2 where fiberlab's γ = asin h folds back: the two differ there.)"""
    wi = _random_directions(rng, n)
    wi[:, 2] = np.abs(wi[:, 2])
    return wi, _random_directions(rng, n)


def _mitsuba_values(bsdf, wi, wo):
    ctx = mi.BSDFContext()
    if VARIANT.startswith("scalar"):
        vals, pdfs = [], []
        for a, b in zip(wi, wo):
            si = mi.SurfaceInteraction3f()
            si.wi = mi.Vector3f(*a)
            v, p = bsdf.eval_pdf(ctx, si, mi.Vector3f(*b))
            vals.append(np.array(v).reshape(3))
            pdfs.append(float(p))
        return np.array(vals), np.array(pdfs)
    n = len(wi)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(*[mi.Float(c) for c in wi.T.astype(np.float32)])
    w = mi.Vector3f(*[mi.Float(c) for c in wo.T.astype(np.float32)])
    v, p = bsdf.eval_pdf(ctx, si, w)
    return np.array(v).T.reshape(n, 3), np.array(p).reshape(n)


@pytest.mark.parametrize("hair_props, chiang_props, rtol", HAIR_PAIRS)
def test_mitsuba_hair_and_fiberlab_chiang_agree(hair_props, chiang_props, rtol):
    rng = np.random.default_rng(5)
    n = 4000 if LLVM else 400
    wi, wo = _batch(rng, n)
    hair = mi.load_dict({"type": "hair", "int_ior": 1.55, "ext_ior": 1.0, **hair_props})
    ours = mi.load_dict({"type": "fiberlab", "model": "chiang", "eta": 1.55, **chiang_props})
    f_hair, p_hair = _mitsuba_values(hair, wi, wo)
    f_ours, p_ours = _mitsuba_values(ours, wi, wo)
    assert np.isfinite(f_ours).all() and (f_ours > 0).any()
    scale = np.abs(f_hair).max()
    np.testing.assert_allclose(f_ours, f_hair, rtol=rtol, atol=1e-6 * scale)
    np.testing.assert_allclose(p_ours, p_hair, rtol=rtol, atol=1e-6 * np.abs(p_hair).max())


def test_the_tilt_sign_matters_in_the_comparison():
    """The comparison can fail: with the tilt mapped with the wrong sign, values differ."""
    rng = np.random.default_rng(6)
    wi, wo = _batch(rng, 400)
    hair = mi.load_dict({"type": "hair", "int_ior": 1.55, "ext_ior": 1.0, "scale_tilt": 3.0})
    wrong = mi.load_dict({"type": "fiberlab", "model": "chiang", "eta": 1.55, "alpha": 3.0, "pheomelanin": 0.2,
                          "eumelanin": 1.3})
    f_hair, _ = _mitsuba_values(hair, wi, wo)
    f_wrong, _ = _mitsuba_values(wrong, wi, wo)
    assert np.max(np.abs(f_wrong - f_hair) / np.abs(f_hair).max()) > 0.05


def test_adapter_values_are_the_model_values_in_the_mapped_frame():
    rng = np.random.default_rng(7)
    wi, wo = _batch(rng, 300)
    bsdf = mi.load_dict({"type": "fiberlab", "model": "kajiya-kay", "k_d": [0.2, 0.3, 0.4]})
    f, p = _mitsuba_values(bsdf, wi, wo)
    # fiberlab: light = Mitsuba's wo, viewer = si.wi, h from the viewer direction.
    m = fl.KajiyaKay(k_d=[0.2, 0.3, 0.4])
    wi32, wo32 = wi.astype(np.float32).astype(np.float64), wo.astype(np.float32).astype(np.float64)
    light = fl.frames.from_mitsuba(wo32 / np.linalg.norm(wo32, axis=-1, keepdims=True))
    viewer = fl.frames.from_mitsuba(wi32 / np.linalg.norm(wi32, axis=-1, keepdims=True))
    h = fl.frames.offset_from_mitsuba(fl.frames.mitsuba_offset(wi32))
    np.testing.assert_allclose(f, m.eval(light, viewer, h), rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(p, m.pdf(light, viewer, h), rtol=1e-5, atol=1e-9)
    # Mitsuba's eval is f_s·|cos θ| of its wo, θ from the normal plane (sin θ = wo.y).
    np.testing.assert_allclose(f, m.eval_fs(light, viewer, h) * np.sqrt(1 - light[:, :1] ** 2), rtol=1e-5,
                               atol=1e-9)


def test_sample_reports_weight_pdf_and_lobe():
    rng = np.random.default_rng(8)
    n = 2000 if LLVM else 50
    bsdf = mi.load_dict({"type": "fiberlab", "model": "chiang"})
    ctx = mi.BSDFContext()
    wi = _random_directions(rng, 1)[0]
    u = rng.uniform(0, 1, (n, 3)).astype(np.float32)
    if VARIANT.startswith("scalar"):
        rows = []
        for k in range(n):
            si = mi.SurfaceInteraction3f()
            si.wi = mi.Vector3f(*wi)
            bs, w = bsdf.sample(ctx, si, float(u[k, 0]), mi.Point2f(float(u[k, 1]), float(u[k, 2])))
            rows.append((np.array(bs.wo), float(bs.pdf), np.array(w).reshape(3), int(bs.sampled_component)))
        wo = np.array([r[0] for r in rows])
        pdf = np.array([r[1] for r in rows])
        weight = np.array([r[2] for r in rows])
        lobe = np.array([r[3] for r in rows])
    else:
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        si.wi = mi.ScalarVector3f(*wi)
        bs, w = bsdf.sample(ctx, si, mi.Float(u[:, 0]), mi.Point2f(mi.Float(u[:, 1]), mi.Float(u[:, 2])))
        wo, pdf, weight = np.array(bs.wo).T, np.array(bs.pdf), np.array(w).T
        lobe = np.array(bs.sampled_component)
    ok = pdf > 0
    assert ok.mean() > 0.99
    assert set(np.unique(lobe[ok])) <= {0, 1, 2, 3}
    # weight = eval / pdf at the sampled direction, as Mitsuba's own samplers return it.
    si_wi = np.broadcast_to(wi, wo.shape)
    f, p = _mitsuba_values(bsdf, si_wi[ok], wo[ok])
    np.testing.assert_allclose(p, pdf[ok], rtol=1e-4)
    np.testing.assert_allclose(weight[ok], f / p[:, None], rtol=1e-3, atol=1e-7)


@needs_llvm
def test_mitsuba_renders_with_the_adapter_like_with_its_hair():
    """Mitsuba's path tracer pointed at the adapter: a fiber (a cylinder, tangent on its axis)
    under a distant light, rendered with Mitsuba's `hair` and with fiberlab's `chiang` (the
    mapped parameters, β_m = 0.6 where the two agree pointwise), different seeds. Measured: the
    image means agree to 0.21 %; asserted within 2 % (Monte Carlo noise of 256 spp)."""
    loops, calls = dr.flag(dr.JitFlag.SymbolicLoops), dr.flag(dr.JitFlag.SymbolicCalls)
    dr.set_flag(dr.JitFlag.SymbolicLoops, False)  # a Python BSDF cannot be traced into a kernel
    dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    try:
        def render(bsdf, seed):
            scene = mi.load_dict({
                "type": "scene",
                "integrator": {"type": "path", "max_depth": 2},
                "sensor": {"type": "perspective", "fov": 30,
                           "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 4], target=[0, 0, 0], up=[0, 1, 0]),
                           "film": {"type": "hdrfilm", "width": 24, "height": 24},
                           "sampler": {"type": "independent", "sample_count": 256}},
                "emitter": {"type": "directional", "direction": [0.3, -0.5, -1.0], "irradiance": 1.0},
                "fiber": {"type": "cylinder", "radius": 0.5, "p0": [0, -2, 0], "p1": [0, 2, 0], "bsdf": bsdf},
            })
            return np.array(mi.render(scene, seed=seed))

        hair = render({"type": "hair", "int_ior": 1.55, "ext_ior": 1.0, "longitudinal_roughness": 0.6,
                       "azimuthal_roughness": 0.8, "scale_tilt": 0.0}, 1)
        ours = render({"type": "fiberlab", "model": "chiang", "eta": 1.55, "beta_m": 0.6, "beta_n": 0.8,
                       "alpha": 0.0, "eumelanin": 1.3, "pheomelanin": 0.2}, 2)
    finally:
        dr.set_flag(dr.JitFlag.SymbolicLoops, loops)
        dr.set_flag(dr.JitFlag.SymbolicCalls, calls)
    assert np.isfinite(ours).all() and ours.mean() > 0
    np.testing.assert_allclose(ours.mean(axis=(0, 1)), hair.mean(axis=(0, 1)), rtol=0.02)
