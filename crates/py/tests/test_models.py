"""Tests of the `fiberlab` Python package: models on NumPy arrays.

Compared with independent computations: the command line's `fiberlab eval` (a separate
program reading CSV text), Monte Carlo quadrature of the furnace integral, and the pdf at the
sampled directions. Run with `pytest crates/py/tests` after `pip install ./crates/py` and
`cargo build --release` (the CLI binary: $FIBERLAB_BIN, else target/release/fiberlab).
"""

import csv
import io
import os
import pathlib
import subprocess

import numpy as np
import pytest

import fiberlab as fl

ROOT = pathlib.Path(__file__).resolve().parents[3]


def cli_binary() -> pathlib.Path:
    if "FIBERLAB_BIN" in os.environ:
        return pathlib.Path(os.environ["FIBERLAB_BIN"])
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    path = target / "release" / "fiberlab"
    assert path.exists(), f"{path} missing: run `cargo build --release` first"
    return path


def run_cli(*args, stdin=None, cwd=None) -> str:
    out = subprocess.run([str(cli_binary()), *args], input=stdin, capture_output=True, text=True, cwd=cwd)
    assert out.returncode == 0, out.stderr
    return out.stdout


# Parameters for each model that make every lobe and code path matter (the measured model
# gets its table from the goniophotometer, in `measured_table`).
MODEL_PARAMS = {
    "diffuse": {"albedo": 0.7},
    "lambertian-cylinder": {"albedo": [0.8, 0.5, 0.3]},
    "specular": {"azimuth": "uniform"},
    "kajiya-kay": {"k_d": 0.4, "k_s": 0.3, "p": 20},
    "goldman": {"rho_reflect": 0.6, "rho_transmit": 0.3},
    "marschner": {"sigma_a": 0.8, "eccentricity": 0.9},
    "chiang": {"eumelanin": 0.8, "beta_m": 0.35, "beta_n": 0.4, "alpha": 2.5},
    "deon": {"sigma_a": [0.3, 0.6, 1.2], "beta_m": 0.3},
    "yan-fur": {"sigma_c_a": [0.3, 0.6, 1.2], "kappa": 0.7, "sigma_m_s": 2.0, "layers": 1.5, "alpha": 4.0},
    "hollow-fiber": {"kappa": 0.5, "lumen_eta": 1.0, "sigma_a": [0.3, 0.6, 1.2], "beta_m": 0.3},
    "huang-2022": {"roughness": 0.4, "aspect": 0.8, "orientation": "20", "eumelanin": 0.8, "alpha": 2.5},
    "sadeghi-thread": {"eta": 1.345, "k_d": 0.2, "albedo": [0.8, 0.5, 0.3], "gamma_s": 6.0, "gamma_v": 14.0},
}


def grid_directions(n_theta=7, n_phi=9):
    theta = np.linspace(-1.4, 1.4, n_theta)
    phi = np.linspace(-np.pi, np.pi, n_phi, endpoint=False) + 0.1
    t, p = np.meshgrid(theta, phi, indexing="ij")
    return fl.directions_from_angles(t, p).reshape(-1, 3)


def test_every_registered_model_is_reachable():
    names = {m["name"] for m in fl.models() if m["kind"] == "fiber"}
    assert names == set(MODEL_PARAMS) | {"measured"}
    for spec in fl.models():
        constructor = "".join(part.capitalize() for part in spec["name"].split("-"))
        assert hasattr(fl, constructor), constructor
        assert spec["summary"] in getattr(fl, constructor).__doc__


@pytest.mark.parametrize("name", sorted(MODEL_PARAMS))
def test_eval_fs_and_pdf_equal_the_command_line_bit_for_bit(name):
    params = MODEL_PARAMS[name]
    model = fl.load_dict({"type": name, **params})
    d = grid_directions()
    wi = np.repeat(d, len(d), axis=0)
    wo = np.tile(d, (len(d), 1))
    h = np.tile(np.linspace(-1.0, 1.0, 7), len(wi) // 7 + 1)[: len(wi)]
    rows = ["wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,h"]
    rows += [",".join(repr(float(x)) for x in (*a, *b, c)) for a, b, c in zip(wi, wo, h)]
    args = ["eval", "--model", name]
    for k, v in params.items():
        text = ",".join(str(x) for x in v) if isinstance(v, list) else str(v)
        args += ["--param", f"{k}={text}"]
    table = list(csv.DictReader(io.StringIO(run_cli(*args, stdin="\n".join(rows) + "\n"))))
    expected_f = np.array([[float(r["f_r"]), float(r["f_g"]), float(r["f_b"])] for r in table])
    expected_pdf = np.array([float(r["pdf"]) for r in table])
    np.testing.assert_array_equal(model.eval_fs(wi, wo, h), expected_f)
    np.testing.assert_array_equal(model.pdf(wi, wo, h), expected_pdf)
    assert np.all(np.isfinite(expected_f)) and np.all(expected_f >= 0)


def test_a_measured_table_is_a_model_and_matches_the_command_line(tmp_path):
    run_cli("measure", "--param", "sigma_a=0.5", "--theta-i", "0,30", "--rays", "20000",
            "--bins", "18,36", "--out", str(tmp_path / "m"))
    table = tmp_path / "m.csv"
    model = fl.Measured(table=str(table))
    d = grid_directions(5, 6)
    wi = np.repeat(d, len(d), axis=0)
    wo = np.tile(d, (len(d), 1))
    rows = ["wi_x,wi_y,wi_z,wo_x,wo_y,wo_z"] + [",".join(repr(float(x)) for x in (*a, *b)) for a, b in zip(wi, wo)]
    out = run_cli("eval", "--model", "measured", "--param", f"table={table}", stdin="\n".join(rows) + "\n")
    expected = np.array([[float(r["f_r"]), float(r["f_g"]), float(r["f_b"])] for r in csv.DictReader(io.StringIO(out))])
    np.testing.assert_array_equal(model.eval_fs(wi, wo), expected)


@pytest.mark.parametrize(
    "name, lossless",
    [("chiang", {"sigma_a": 0.0}), ("deon", {"sigma_a": 0.0}), ("diffuse", {"albedo": 1.0}),
     ("lambertian-cylinder", {"albedo": 1.0})],
)
def test_lossless_models_pass_the_white_furnace_by_quadrature(name, lossless):
    # ∫ f_s cosθ_i dω_i = 1 for a lossless fiber (near-field models averaged over h), estimated
    # with uniform directions on the sphere — independent of the models' own sampling — and
    # judged against the estimate's own standard error.
    model = fl.load_dict({"type": name, **lossless})
    rng = np.random.default_rng(5)
    n = 1_000_000
    z = rng.uniform(-1, 1, n)
    a = rng.uniform(0, 2 * np.pi, n)
    r = np.sqrt(1 - z * z)
    wi = np.stack([z, r * np.cos(a), r * np.sin(a)], axis=-1)
    h = rng.uniform(-1, 1, n)
    for theta_o in (0.0, 0.6):
        wo = fl.directions_from_angles(theta_o, 0.4)
        terms = model.eval(wi, wo, h)[:, 1] * 4 * np.pi
        albedo, stderr = terms.mean(), terms.std() / np.sqrt(n)
        assert stderr < 0.02, (name, theta_o, stderr)
        assert abs(albedo - 1.0) < 4 * stderr + 1e-3, (name, theta_o, albedo, stderr)


@pytest.mark.parametrize("name", sorted(set(MODEL_PARAMS) - {"specular"}))
def test_sample_agrees_with_eval_and_pdf(name):
    model = fl.load_dict({"type": name, **MODEL_PARAMS[name]})
    rng = np.random.default_rng(11)
    n = 2000
    wo = fl.directions_from_angles(rng.uniform(-1.3, 1.3, n), rng.uniform(-np.pi, np.pi, n))
    h = rng.uniform(-1, 1, n)
    s = model.sample(wo, rng.uniform(0, 1, (n, 4)), h)
    ok = s.pdf > 0
    assert ok.mean() > 0.5
    np.testing.assert_allclose(np.linalg.norm(s.wi[ok], axis=-1), 1.0, rtol=1e-9)
    np.testing.assert_allclose(s.pdf[ok], model.pdf(s.wi[ok], wo[ok], h[ok]), rtol=1e-6)
    value = model.eval(s.wi[ok], wo[ok], h[ok])
    np.testing.assert_allclose(s.weight[ok], value / s.pdf[ok][:, None], rtol=1e-6, atol=1e-12)
    assert s.lobe.dtype == np.int32
    assert ((s.lobe[ok] >= 0) & (s.lobe[ok] < len(model.lobes))).all()
    assert (s.lobe[~ok] == -1).all()
    assert not model.is_delta(s.lobe).any()


def test_the_specular_fiber_samples_a_delta_lobe():
    m = fl.Specular()
    s = m.sample(fl.directions_from_angles(0.3, 0.2), [0.1, 0.2, 0.3, 0.4])
    assert m.lobes == ("specular",) and m.lobe_delta == (True,)
    assert int(s.lobe) == 0 and bool(m.is_delta(s.lobe))
    np.testing.assert_allclose(np.arcsin(s.wi[0]), -0.3, atol=1e-12)


def test_sample_returns_the_lobe_by_its_attenuation_share():
    """chiang picks lobe p with probability Y(A_p)/Σ Y(A_q) (Chiang 2016), A_p computed here
    from Fresnel and the chord absorption: the lobe counts of 4·10⁵ samples match it."""
    eta, beta_m, h, theta_o = 1.55, 0.3, 0.3, 0.4
    m = fl.Chiang(eta=eta, sigma_a=[0.3, 0.6, 1.2], beta_m=beta_m, alpha=0)
    assert m.lobes == ("R", "TT", "TRT", "TRRT+")
    assert fl.KajiyaKay().lobes == ("diffuse", "specular")
    n = 400_000
    rng = np.random.default_rng(3)
    s = m.sample(fl.directions_from_angles(theta_o, 0.2), rng.uniform(0, 1, (n, 4)), h)
    # Attenuations of a hit at offset h seen from inclination θ_o (Chiang 2016, eqs. 3–5 with
    # the Bravais index η' for the azimuthal refraction).
    cos_o = np.cos(theta_o)
    eta_p = np.sqrt(eta**2 - np.sin(theta_o) ** 2) / cos_o
    sin_gamma_t = h / eta_p
    cos_theta_t = np.sqrt(1 - (np.sin(theta_o) / eta) ** 2)
    t = np.exp(-np.array([0.3, 0.6, 1.2]) * 2 * np.sqrt(1 - sin_gamma_t**2) / cos_theta_t)
    c = cos_o * np.sqrt(1 - h * h)  # cosine of the incidence angle on the surface
    st = np.sqrt(1 - c * c) / eta
    ct = np.sqrt(1 - st * st)
    rs = (c - eta * ct) / (c + eta * ct)
    rp = (eta * c - ct) / (eta * c + ct)
    f = 0.5 * (rs * rs + rp * rp)
    a = [np.full(3, f), (1 - f) ** 2 * t]
    a.append(a[1] * f * t)
    a.append(a[2] * f * t / (1 - f * t))
    y = np.array([0.2126 * x[0] + 0.7152 * x[1] + 0.0722 * x[2] for x in a])
    share = y / y.sum()
    ok = s.pdf > 0
    counts = np.bincount(s.lobe[ok], minlength=4)
    n_ok = ok.sum()
    assert n_ok > 0.999 * n
    sd = np.sqrt(n_ok * share * (1 - share))
    assert (np.abs(counts - n_ok * share) < 5 * sd).all(), (counts, n_ok * share, sd)


def test_shapes_broadcast_like_numpy():
    m = fl.Chiang()
    wi = fl.directions_from_angles(np.linspace(-1, 1, 4)[:, None, None], np.linspace(0, 3, 5)[None, :, None])
    wo = fl.directions_from_angles(0.2, np.linspace(-3, 3, 6))
    h = np.linspace(-1, 1, 6)
    f = m.eval_fs(wi, wo, h)
    assert f.shape == (4, 5, 6, 3)
    # Each element equals the unbroadcast evaluation.
    np.testing.assert_array_equal(f[2, 3, 4], m.eval_fs(wi[2, 3, 0], wo[4], h[4]))
    assert m.pdf(wi, wo, h).shape == (4, 5, 6)
    assert m.eval_fs(wi[0, 0, 0], wo[0]).shape == (3,)
    assert m.pdf(wi[0, 0, 0], wo[0]).shape == ()
    v, p = m.eval_pdf(wi, wo[0])
    assert v.shape == (4, 5, 1, 3) and p.shape == (4, 5, 1)
    assert m.eval_angles(0.1, 0.2, np.zeros((2, 3)), 0.5).shape == (2, 3, 3)
    s = m.sample(wo, np.full((2, 1, 4), 0.5), h)
    assert s.wi.shape == (2, 6, 3) and s.pdf.shape == (2, 6) and s.lobe.shape == (2, 6)
    assert m.is_delta(s.lobe).shape == (2, 6)
    # Non-contiguous and integer inputs are accepted (converted once).
    np.testing.assert_array_equal(m.eval_fs(wi[:, ::2, 0], wo[0]), m.eval_fs(np.ascontiguousarray(wi[:, ::2, 0]), wo[0]))
    np.testing.assert_array_equal(m.eval_fs([[0, 1, 0]], [0, 0, 1]), m.eval_fs([[0.0, 1.0, 0.0]], [0.0, 0.0, 1.0]))


def test_bad_input_raises_value_error_with_the_place():
    m = fl.Chiang()
    wo = np.array([0.0, 0.0, 1.0])
    cases = [
        (lambda: m.eval_fs(np.zeros((2, 2)), wo), "wi: expected an array of shape (..., 3)"),
        (lambda: m.eval_fs(np.zeros((2, 3)), np.zeros((3, 3))), "do not broadcast"),
        (lambda: m.eval_fs([[0, 1, 0], [0, np.nan, 1]], wo), "wi[1] = (0, NaN, 1)"),
        (lambda: m.eval_fs(np.tile([0.0, 2.0, 0.0], (2, 2, 1)), wo), "wi[0, 0] = (0, 2, 0)"),
        (lambda: m.pdf(wo, [0, 0, np.inf]), "wo = (0, 0, inf)"),
        (lambda: m.eval_fs(wo, wo, 1.5), "h = 1.5: expected a value in [-1, 1]"),
        (lambda: m.sample(wo, [0.1, 0.2, 0.3]), "u: expected an array of shape (..., 4)"),
        (lambda: m.sample(wo, [0.1, 0.2, 1.0, 0.3]), "u[0, 2] = 1: expected a uniform in [0, 1)"),
        (lambda: m.is_delta([0, 4]), "lobe indices must be in [-1, 3]"),
        (lambda: m.is_delta([0.5]), "expected integer lobe indices"),
        (lambda: fl.Model("nope"), "nope"),
        (lambda: fl.Chiang(beta_m=7), "`beta_m` = 7 is out of range"),
        (lambda: fl.Chiang(nope=1), "nope"),
        (lambda: fl.Chiang(beta_m=float("nan")), "beta_m"),
        (lambda: fl.Chiang(beta_m={"a": 1}), "parameter `beta_m`: expected a number"),
        (lambda: fl.load_dict({"beta_m": 0.3}), "needs a 'type' key"),
        (lambda: fl.Measured(table="/nonexistent/t.csv"), "/nonexistent/t.csv"),
    ]
    for call, says in cases:
        with pytest.raises(ValueError) as e:
            call()
        assert says in str(e.value), (says, str(e.value))


def test_parameters_and_flags_describe_the_model():
    m = fl.Chiang(eumelanin=1.3)
    p = m.params
    assert p["eumelanin"]["value"] == 1.3 and p["beta_m"]["value"] is None
    assert p["beta_m"]["kind"] == "number" and p["beta_m"]["range"][1] == 1.0
    assert m.flags["field"] == "near" and fl.Deon().flags["field"] == "far"
    assert fl.Specular().flags["lobes"] == "delta"
    assert repr(m) == 'fiberlab.Model("chiang", eumelanin=1.3)'
    # Booleans and lists mean what they mean in a scene file.
    a = fl.Marschner(glints=False, lobes=["r", "tt"])
    b = fl.Marschner(glints="off", lobes="r,tt")
    d = grid_directions(3, 4)
    np.testing.assert_array_equal(a.eval_fs(d[:, None], d[None]), b.eval_fs(d[:, None], d[None]))
