"""Surface models (`wood`, `lambertian`, `sadeghi-2013`, `irawan-2012`) through `fiberlab.Model`,
and `compare_model` / `evaluate` against the command line.

Compared with independent computations: the command line's `fiberlab eval` (a separate program
reading CSV text), the closed form of the Lambertian BRDF (ρ/π), the pdf at the sampled
directions, and the command line's `compare-model --json` and `evaluate`'s `metrics.json`.
"""

import csv
import io
import json
import pathlib

import numpy as np
import pytest

import fiberlab as fl
from test_models import ROOT, run_cli

# Parameters that make each surface model's code paths matter; `wood` with a rough finish so
# that every lobe has a density (its smooth finish, a delta lobe, is tested on its own).
SURFACE_PARAMS = {
    "lambertian": {"k_d": [0.8, 0.5, 0.3]},
    "wood": {"roughness": 0.3, "fiber_angle": 20.0, "fiber_dip": 10.0, "beta": 8.0},
    "sadeghi-2013": {"preset": "silk-shot"},
    "irawan-2012": {"preset": "silk-charmeuse", "u": 0.3, "v": 0.7},
    "leaf": {"cab": 30.0, "roughness": 0.3},
}


def hemisphere(n_theta=6, n_phi=8, below=False):
    """Directions in a surface's local frame (z = normal), θ from the normal."""
    theta = np.linspace(0.05, 1.5, n_theta)
    if below:
        theta = np.concatenate([theta, np.pi - theta[:2]])
    phi = np.linspace(-np.pi, np.pi, n_phi, endpoint=False) + 0.2
    t, p = np.meshgrid(theta, phi, indexing="ij")
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)


def test_every_surface_model_is_a_model_with_its_kind():
    kinds = {m["name"]: m["kind"] for m in fl.models()}
    assert {n for n, k in kinds.items() if k == "surface"} == set(SURFACE_PARAMS)
    for name, params in SURFACE_PARAMS.items():
        m = fl.Model(name, **params)
        assert m.flags["kind"] == "surface" and "transmits" in m.flags, name
        assert len(m.lobes) >= 1 and set(m.params) >= set(params), name
    assert fl.Chiang().flags["kind"] == "fiber"
    assert fl.Wood().flags["lobes"] == "delta"  # smooth finish by default
    with pytest.raises(ValueError, match="roughness"):
        fl.Wood(roughness=2.0)


@pytest.mark.parametrize("name", sorted(SURFACE_PARAMS))
def test_surface_eval_fs_and_pdf_equal_the_command_line_bit_for_bit(name):
    params = SURFACE_PARAMS[name]
    model = fl.Model(name, **params)
    d = hemisphere(below=True)
    wi = np.repeat(d, len(d), axis=0)
    wo = np.tile(d, (len(d), 1))
    rows = ["wi_x,wi_y,wi_z,wo_x,wo_y,wo_z"] + [",".join(repr(float(x)) for x in (*a, *b)) for a, b in zip(wi, wo)]
    args = ["eval", "--model", name]
    for k, v in params.items():
        text = ",".join(str(x) for x in v) if isinstance(v, list) else str(v)
        args += ["--param", f"{k}={text}"]
    table = list(csv.DictReader(io.StringIO(run_cli(*args, stdin="\n".join(rows) + "\n"))))
    expected_f = np.array([[float(r["f_r"]), float(r["f_g"]), float(r["f_b"])] for r in table])
    expected_pdf = np.array([float(r["pdf"]) for r in table])
    np.testing.assert_array_equal(model.eval_fs(wi, wo), expected_f)
    np.testing.assert_array_equal(model.pdf(wi, wo), expected_pdf)
    assert np.all(np.isfinite(expected_f)) and np.all(expected_f >= 0) and expected_f.max() > 0
    # h is ignored by a surface model; eval is f_r·|cos θ_i| from the normal.
    np.testing.assert_array_equal(model.eval_fs(wi, wo, h=0.7), expected_f)
    np.testing.assert_allclose(model.eval(wi, wo), expected_f * np.abs(wi[:, 2:3]), rtol=1e-15, atol=0)


def test_lambertian_is_rho_over_pi():
    rho = np.array([0.8, 0.5, 0.3])
    m = fl.Lambertian(k_d=rho.tolist())
    d = hemisphere()
    wi = np.repeat(d, len(d), axis=0)
    wo = np.tile(d, (len(d), 1))
    np.testing.assert_allclose(m.eval_fs(wi, wo), np.broadcast_to(rho / np.pi, wi.shape), rtol=1e-15)
    # Light below the surface: nothing (an opaque surface).
    below = wi * np.array([1.0, 1.0, -1.0])
    assert (m.eval_fs(below, wo) == 0).all()
    # Cosine-weighted sampling: weight f·cosθ/pdf = ρ for every sample.
    rng = np.random.default_rng(4)
    s = m.sample(wo[:500], rng.uniform(0, 1, (500, 4)))
    ok = s.pdf > 0
    assert ok.mean() > 0.99
    np.testing.assert_allclose(s.weight[ok], np.broadcast_to(rho, s.weight[ok].shape), rtol=1e-12)
    np.testing.assert_allclose(s.pdf[ok], s.wi[ok, 2] / np.pi, rtol=1e-12)


@pytest.mark.parametrize("name", sorted(SURFACE_PARAMS))
def test_surface_sample_agrees_with_eval_and_pdf(name):
    model = fl.Model(name, **SURFACE_PARAMS[name])
    rng = np.random.default_rng(12)
    n = 2000
    theta, phi = np.arccos(rng.uniform(0.05, 1.0, n)), rng.uniform(-np.pi, np.pi, n)
    wo = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=-1)
    s = model.sample(wo, rng.uniform(0, 1, (n, 4)))
    ok = s.pdf > 0
    assert ok.mean() > 0.5, ok.mean()
    np.testing.assert_allclose(np.linalg.norm(s.wi[ok], axis=-1), 1.0, rtol=1e-9)
    np.testing.assert_allclose(s.pdf[ok], model.pdf(s.wi[ok], wo[ok]), rtol=1e-6)
    value = model.eval(s.wi[ok], wo[ok])
    np.testing.assert_allclose(s.weight[ok], value / s.pdf[ok][:, None], rtol=1e-6, atol=1e-12)
    assert ((s.lobe[ok] >= 0) & (s.lobe[ok] < len(model.lobes))).all()
    assert not model.is_delta(s.lobe[ok]).any()


def test_smooth_wood_samples_its_finish_as_a_delta_lobe():
    m = fl.Wood()  # roughness 0: a smooth finish, a mirror reflection
    wo = np.array([np.sin(0.5), 0.0, np.cos(0.5)])
    s = m.sample(np.tile(wo, (4000, 1)), np.random.default_rng(2).uniform(0, 1, (4000, 4)))
    delta = m.is_delta(s.lobe)
    assert delta.any() and (~delta).any()
    np.testing.assert_allclose(s.wi[delta], np.broadcast_to(wo * [-1.0, -1.0, 1.0], s.wi[delta].shape), atol=1e-12)
    assert (s.pdf[delta] == 0).all() and (s.pdf[~delta & (s.lobe >= 0)] > 0).all()


def test_check_runs_the_surface_harness():
    rows = fl.check(fl.Lambertian(k_d=0.6), chi2_samples=20_000, samples=20_000, pairs=200)
    claims = [r for r in rows if not r["report"]]
    assert claims and all(r["pass"] for r in claims), [r for r in claims if not r["pass"]]


def _compare_cli(table, name, params):
    args = ["compare-model", "--json", "--table", str(table), "--model", name]
    for k, v in params.items():
        args += ["--param", f"{k}={v}"]
    return json.loads(run_cli(*args))


def test_compare_model_equals_the_command_line_json(tmp_path):
    fiber = tmp_path / "fiber"
    run_cli("measure", "--param", "sigma_a=0.5", "--theta-i", "0,30", "--rays", "20000", "--bins", "9,18",
            "--out", str(fiber))
    for name, params in [("chiang", {"sigma_a": 0.5, "beta_m": 0.3}), ("marschner", {"sigma_a": 0.5})]:
        ours = fl.compare_model(fl.Model(name, **params), fiber.with_suffix(".csv"))
        # chiang has no `lobes` parameter: only `all`; marschner is compared lobe by lobe.
        assert set(ours) >= ({"r", "tt", "trt", "all"} if name == "marschner" else {"all"}), ours.keys()
        assert ours == _compare_cli(fiber.with_suffix(".csv"), name, params)
        assert len(ours["all"]["per_theta_i"]) == 2 and 0 < ours["all"]["rel_l2"] < 10
    surface = tmp_path / "surface"
    run_cli("measure", "--surface", "--theta-i", "30", "--rays", "20000", "--bins", "9,18", "--out", str(surface))
    for name, params in [("lambertian", {"k_d": 0.2}), ("wood", {"roughness": 0.2})]:
        ours = fl.compare_model(fl.Model(name, **params), surface.with_suffix(".csv"))
        assert list(ours) == (["fiber"] if name == "wood" else ["all"])
        assert ours == _compare_cli(surface.with_suffix(".csv"), name, params)
    with pytest.raises(ValueError, match=r"missing\.csv: No such file"):
        fl.compare_model(fl.Chiang(), tmp_path / "missing.csv")


def test_evaluate_equals_the_command_line_metrics(tmp_path):
    table = tmp_path / "t"
    run_cli("measure", "--param", "sigma_a=0.5", "--theta-i", "0,30", "--rays", "20000", "--bins", "9,18",
            "--out", str(table))
    text = (ROOT / "examples" / "groom.toml").read_text()
    text = text.replace("width = 160", "width = 24").replace("height = 160", "height = 24")
    text = text.replace('file = "groom.hair"', f'file = "{ROOT / "examples" / "groom.hair"}"')
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    models = "chiang,marschner,deon,kajiya-kay"
    run_cli("evaluate", "--scene", str(scene), "--table", str(table.with_suffix(".csv")), "--models", models,
            "--param", "marschner:beta_r=9", "--spp", "2", "--reference-spp", "2", "--out", str(tmp_path / "ev"))
    expected = json.loads((tmp_path / "ev" / "metrics.json").read_text())
    ours = fl.evaluate(scene, models=models.split(","), params={"marschner": {"beta_r": "9"}},
                       table=table.with_suffix(".csv"), spp=2, reference_spp=2)
    assert ours["metrics"] == expected
    assert [r["model"] for r in ours["metrics"]] == ["chiang", "marschner", "deon", "kajiya-kay"]
    assert set(ours["images"]) == {"reference", "chiang", "marschner", "deon", "kajiya-kay"}
    # Kajiya–Kay's colour: matched in the scene by default, from one fiber on request.
    assert "in the scene" in ours["metrics"][3]["given"]
    fiber = fl.evaluate(scene, models=["kajiya-kay"], table=table.with_suffix(".csv"), spp=2, reference_spp=2,
                        kajiya_kay_colour="fiber")
    assert "in the scene" not in fiber["metrics"][0]["given"]
    with pytest.raises(ValueError, match="known: scene, fiber"):
        fl.evaluate(scene, models=["kajiya-kay"], table=table.with_suffix(".csv"), spp=2, reference_spp=2,
                    kajiya_kay_colour="photo")
    assert all(a.shape == (24, 24, 3) and a.dtype == np.float32 for a in ours["images"].values())
    # The images are the renders the metrics were computed from.
    m = fl.compare(ours["images"]["reference"], ours["images"]["chiang"])
    assert m["rmse"] == pytest.approx(ours["metrics"][0]["rmse"], rel=1e-5)
    with pytest.raises(ValueError, match="table"):
        fl.evaluate(scene, models=["chiang"], spp=1, reference_spp=1)
