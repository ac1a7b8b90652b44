"""`fiberlab.measure`, `compare`, `hair`, `check` and `frames` against the command line and
independent computations (quadrature, ray–circle geometry, numpy)."""

import csv
import json
import math

import numpy as np
import pytest

import fiberlab as fl
from test_models import run_cli


def test_measure_equals_the_command_line_csv_bit_for_bit(tmp_path):
    fiber = {"eta": 1.6, "sigma_a": [0.2, 0.4, 0.8], "scale_angle": 3}
    prefix = tmp_path / "m"
    run_cli("measure", "--param", "eta=1.6", "--param", "sigma_a=0.2,0.4,0.8", "--param", "scale_angle=3",
            "--theta-i", "30,-20", "--phi-i", "10", "--rays", "30000", "--bins", "6,8", "--seed", "3",
            "--out", str(prefix))
    ours = fl.measure(fiber, theta_i=[math.radians(30), math.radians(-20)], phi_i=math.radians(10),
                      rays=30000, bins=(6, 8), seed=3)
    assert isinstance(ours, list) and len(ours) == 2
    with open(prefix.with_suffix(".csv")) as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2 * 6 * 6 * 8
    k = 0
    for m in ours:
        assert m["traced"] == 30000
        for lobe in ["r", "tt", "trt", "higher", "medulla", "all"]:
            f_s, std = m["lobes"][lobe]["f"], m["lobes"][lobe]["std"]
            assert f_s.shape == std.shape == (6, 8, 3)
            for i in range(6):
                for j in range(8):
                    row = rows[k]
                    k += 1
                    assert row["lobe"] == lobe
                    assert float(row["theta_i"]) == pytest.approx(math.degrees(m["theta_i"]), abs=1e-12)
                    assert float(row["theta_r"]) == pytest.approx(math.degrees(m["theta_r"][i]), abs=1e-12)
                    assert float(row["phi_r"]) == pytest.approx(math.degrees(m["phi"][j]), abs=1e-12)
                    assert [float(row[c]) for c in ("f_r", "f_g", "f_b")] == list(f_s[i, j])
                    assert [float(row[c]) for c in ("std_r", "std_g", "std_b")] == list(std[i, j])
    # Bin centres are the midpoints of equal bins.
    m = ours[0]
    np.testing.assert_allclose(m["theta_r"], -np.pi / 2 + (np.arange(6) + 0.5) * np.pi / 6, rtol=0, atol=1e-15)
    np.testing.assert_allclose(m["phi"], -np.pi + (np.arange(8) + 0.5) * 2 * np.pi / 8, rtol=0, atol=1e-15)
    # A scalar θ_i gives one dict; the lobes add up to `all`.
    one = fl.measure(fiber, theta_i=math.radians(30), phi_i=math.radians(10), rays=30000, bins=(6, 8), seed=3)
    np.testing.assert_array_equal(one["lobes"]["all"]["f"], ours[0]["lobes"]["all"]["f"])
    parts = sum(one["lobes"][n]["f"] for n in ["r", "tt", "trt", "higher", "medulla"])
    np.testing.assert_allclose(parts, one["lobes"]["all"]["f"], rtol=1e-12, atol=1e-300)


def test_measure_errors_raise_value_error():
    with pytest.raises(ValueError, match="unknown fiber parameter `etta`"):
        fl.measure({"etta": 1.5}, theta_i=0.3, rays=10, bins=(2, 2))
    with pytest.raises(ValueError, match="eta"):
        fl.measure({"eta": 0.5}, theta_i=0.3, rays=10, bins=(2, 2))
    with pytest.raises(ValueError, match="theta_i"):
        fl.measure({}, theta_i=1.6, rays=10, bins=(2, 2))
    with pytest.raises(ValueError, match="rays"):
        fl.measure({}, theta_i=0.3, rays=0, bins=(2, 2))
    with pytest.raises(ValueError, match="bins"):
        fl.measure({}, theta_i=0.3, rays=10, bins=(0, 2))


def test_compare_equals_the_command_line_json(tmp_path):
    # Two EXRs written by the command line (the goniophotometer's images of two seeds).
    for seed in (1, 2):
        run_cli("measure", "--param", "sigma_a=0.3", "--theta-i", "20", "--rays", "20000", "--bins", "24,32",
                "--seed", str(seed), "--out", str(tmp_path / f"m{seed}"))
    a, b = (tmp_path / "m1.exr", tmp_path / "m2.exr")
    ia, ib = fl.read_exr(a), fl.read_exr(b)
    assert ia.shape == (24, 32, 3) and not np.array_equal(ia, ib)
    cli = json.loads(run_cli("compare", str(a), str(b), "--json"))
    ours = fl.compare(ia, ib)
    assert set(ours) == {"rmse", "relmse", "ssim", "flip"}
    for key in ("rmse", "relmse", "ssim", "flip"):
        assert ours[key] == cli[key], key
    cli = json.loads(run_cli("compare", str(a), str(b), "--json", "--align"))
    ours = fl.compare(ia, ib, align=True)
    assert ours["scale"] == cli["scale"] and ours["rmse"] == cli["rmse"]
    # RMSE and relative MSE recomputed with numpy.
    d = ia.astype(np.float64) - ib.astype(np.float64)
    plain = fl.compare(ia, ib)
    assert plain["rmse"] == pytest.approx(np.sqrt(np.mean(d**2)), rel=1e-12)
    assert plain["relmse"] == pytest.approx(np.mean(d**2 / (ia.astype(np.float64) ** 2 + 1e-2)), rel=1e-12)
    assert fl.compare(ia, ia)["rmse"] == 0.0 and fl.compare(ia, ia)["ssim"] == pytest.approx(1.0, abs=1e-12)
    with pytest.raises(ValueError, match="size mismatch"):
        fl.compare(ia, ib[:-1])
    with pytest.raises(ValueError, match="NaN or infinite"):
        fl.compare(ia, np.full_like(ib, np.nan))
    with pytest.raises(ValueError, match="selects no pixel"):
        fl.compare(ia, ib, mask=np.zeros(ia.shape[:2]))
    with pytest.raises(ValueError, match=r"\(H, W, 3\)"):
        fl.compare(ia[..., 0], ib[..., 0])


def test_hair_round_trip_and_the_command_line_info(tmp_path):
    rng = np.random.default_rng(7)
    strands = [rng.normal(size=(n, 3)).astype(np.float32) for n in (2, 5, 1, 9)]
    thickness = [rng.uniform(0.01, 0.1, size=len(s)).astype(np.float32) for s in strands]
    path = tmp_path / "h.hair"
    fl.hair.write(path, strands, thickness)
    back = fl.hair.read(path)
    assert len(back.strands) == 4
    for s, t, bs, bt in zip(strands, thickness, back.strands, back.thickness):
        np.testing.assert_array_equal(bs, s)
        np.testing.assert_array_equal(bt, t)
    info = run_cli("hair", "info", str(path))
    fields = dict(line.split(None, 1) for line in info.strip().splitlines())
    allp = np.concatenate(strands)
    assert int(fields["strands"]) == 4 and int(fields["points"]) == len(allp)
    lo, hi = (np.array(json.loads(x.strip()), dtype=np.float32) for x in fields["bounds"].split("–"))
    np.testing.assert_array_equal(lo, allp.min(axis=0))
    np.testing.assert_array_equal(hi, allp.max(axis=0))
    tmin, tmax = (np.float32(float(x)) for x in fields["widths"].split("–"))
    allt = np.concatenate(thickness)
    assert (tmin, tmax) == (allt.min(), allt.max())
    # Without per-point thickness every point has the default.
    fl.hair.write(path, strands, default_thickness=0.25)
    back = fl.hair.read(path)
    assert back.thickness is None and back.default_thickness == 0.25
    with pytest.raises(ValueError, match="strand 1"):
        fl.hair.write(path, [strands[0], np.zeros((3, 2))])
    with pytest.raises(ValueError, match="thickness"):
        fl.hair.write(path, strands, thickness[:2])
    (tmp_path / "bad.hair").write_bytes(b"HAIR" + bytes(10))
    with pytest.raises(ValueError, match="bad.hair"):
        fl.hair.read(tmp_path / "bad.hair")


def test_hair_generate_equals_the_command_line(tmp_path):
    path = tmp_path / "g.hair"
    run_cli("hair", "generate", "--strands", "30", "--segments", "6", "--style", "curly", "--seed", "4",
            "--tip-ratio", "0.5", "--out", str(path))
    cli = fl.hair.read(path)
    ours = fl.hair.generate(strands=30, segments=6, style="curly", seed=4, tip_ratio=0.5)
    assert len(ours.strands) == len(cli.strands) == 30
    for a, b in zip(ours.strands, cli.strands):
        assert a.shape == (7, 3)
        np.testing.assert_array_equal(a, b)
    for a, b in zip(ours.thickness, cli.thickness):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="hair generator"):
        fl.hair.generate(strands=3, colour=2)


def test_check_passes_for_chiang():
    rows = fl.check(fl.Chiang(), chi2_samples=50_000, samples=10_000, pairs=2_000)
    assert len(rows) > 10
    assert {"model", "test", "value", "expected", "tolerance", "pass", "report"} <= set(rows[0])
    assert all(r["model"] == "chiang" for r in rows)
    tests = " ".join(r["test"] for r in rows)
    for name in ("finite", "albedo", "furnace", "χ²", "∫pdf"):
        assert name in tests
    failed = [r for r in rows if not r["pass"]]
    assert not failed, failed


def test_check_rows_equal_the_command_line_json():
    # The same harness and effort: the rows of `fiberlab check` for the default Kajiya–Kay
    # configuration (JSON writes NaN as null).
    cli = [r for r in json.loads(run_cli("check", "--model", "kajiya-kay", "--json")) if r["model"] == "kajiya-kay"]
    ours = fl.check(fl.KajiyaKay())

    def plain(row):
        return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in row.items()}

    assert len(cli) == len(ours) > 10
    assert [plain(r) for r in ours] == cli


def test_check_reports_kajiya_kay_albedo_above_one_without_claiming_conservation():
    # Kajiya–Kay with k_d = k_s = 0.9 reflects far more than it receives; the model does not
    # claim energy conservation, so the harness measures the albedo without failing it.
    m = fl.KajiyaKay(k_d=0.9, k_s=0.9)
    assert m.flags["energy_conserving"] is False
    rows = fl.check(m, chi2_samples=20_000, samples=5_000, pairs=1_000)
    assert rows[0]["model"] == "kajiya-kay k_d=0.9 k_s=0.9"
    albedo = next(r for r in rows if r["test"].startswith("light-side albedo θ_i=0.50"))
    # Independent midpoint quadrature of ∫ f_s cos θ_r dω_r (curve radiometry: cos² θ dθ dφ).
    n = 300
    t = (np.arange(n) + 0.5) / n * np.pi - np.pi / 2
    p = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi - np.pi
    tt, pp = np.meshgrid(t, p, indexing="ij")
    f = m.eval_fs(fl.directions_from_angles(0.5, 0.3), fl.directions_from_angles(tt, pp))
    lum = f @ np.array([0.2126, 0.7152, 0.0722])
    rho = np.sum(lum * np.cos(tt) ** 2) * (np.pi / n) * (np.pi / n)
    assert albedo["value"] == pytest.approx(rho, rel=1e-4)
    assert albedo["value"] > 5
    assert not any("energy" in r["test"] and not r["report"] for r in rows)


def test_frames_round_trip_and_map_angles_as_documented():
    rng = np.random.default_rng(3)
    w = rng.normal(size=(500, 3))
    w /= np.linalg.norm(w, axis=-1, keepdims=True)
    m = fl.frames.to_mitsuba(w)
    np.testing.assert_array_equal(fl.frames.from_mitsuba(m), w)
    # Right-handed: the map is a rotation.
    r = fl.frames.to_mitsuba(np.eye(3))
    assert np.linalg.det(r) == pytest.approx(1.0)
    # θ: Mitsuba's sin θ is the local y (tangent); fiberlab's is x.
    np.testing.assert_allclose(np.arcsin(m[:, 1]), np.arcsin(w[:, 0]), atol=1e-15)
    # φ: Mitsuba's atan2(z, x) and fiberlab's atan2(z, y) differ by φ_f = π − φ_M.
    phi_f = np.arctan2(w[:, 2], w[:, 1])
    phi_m = np.arctan2(m[:, 2], m[:, 0])
    np.testing.assert_allclose(np.angle(np.exp(1j * (phi_f - (np.pi - phi_m)))), 0, atol=1e-12)
    # h: a camera ray with fiberlab offset h hits the unit circle where the normal is +w
    # (Mitsuba's shading normal z); Mitsuba's offset from that viewer direction is −h.
    for h in (-0.9, -0.3, 0.0, 0.45, 0.8):
        for theta in (-0.7, 0.0, 1.1):
            d = np.array([-h, np.sqrt(1 - h * h)])  # viewer, projected on the normal plane (v, w)
            e = np.array([d[1], -d[0]])              # +v when the ray arrives from +w
            origin = 10 * d + h * e
            # Ray–circle intersection of origin − t d with |x| = 1 (nearest root).
            b = origin @ d
            t = b - np.sqrt(b * b - (origin @ origin - 1))
            hit = origin - t * d
            np.testing.assert_allclose(hit, [0.0, 1.0], atol=1e-12)
            wo = np.array([np.sin(theta), np.cos(theta) * d[0], np.cos(theta) * d[1]])
            h_m = fl.frames.mitsuba_offset(fl.frames.to_mitsuba(wo))
            assert h_m == pytest.approx(fl.frames.offset_to_mitsuba(h), abs=1e-12)
            assert fl.frames.offset_from_mitsuba(h_m) == pytest.approx(h, abs=1e-12)
    with pytest.raises(ValueError, match=r"\(\.\.\., 3\)"):
        fl.frames.to_mitsuba([1.0, 0.0])


def test_ctrl_c_stops_a_measurement():
    import _thread
    import signal
    import threading

    # A process started in the background by a non-interactive shell inherits SIGINT ignored,
    # and Python then installs no handler, so `interrupt_main` would do nothing: install
    # Python's own handler for the test (what an interactive session has).
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.5, _thread.interrupt_main)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            fl.measure({"sigma_a": 0.2}, theta_i=0.3, rays=200_000_000, bins=(4, 4))
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)


def test_fit_recovers_the_parameters_data_were_made_with():
    # Data from Kajiya–Kay at known parameters (an independent model instance), per channel
    # for its colour k_d: the fit must return them, and the model it returns must reproduce
    # the data.
    truth = fl.KajiyaKay(k_d=[0.3, 0.2, 0.1], k_s=0.2, p=30)
    rng = np.random.default_rng(3)
    n = 600
    wi = fl.directions_from_angles(rng.uniform(-1.2, 1.2, n), 0.0)
    wo = fl.directions_from_angles(rng.uniform(-1.2, 1.2, n), rng.uniform(-np.pi, np.pi, n))
    f = truth.eval_fs(wi, wo)
    channel = np.tile([0, 1, 2], n)
    r = fl.fit("kajiya-kay", np.repeat(wi, 3, axis=0), np.repeat(wo, 3, axis=0), f.reshape(-1),
               sigma=0.01, channel=channel, init={"k_d": [0.1, 0.1, 0.1], "k_s": 0.1, "p": 10})
    np.testing.assert_allclose(r["params"]["k_d"], [0.3, 0.2, 0.1], rtol=1e-4)
    # k_s is a colour too: with per-channel data it is fitted per channel (7 numbers).
    np.testing.assert_allclose(r["params"]["k_s"], [0.2, 0.2, 0.2], rtol=1e-4)
    np.testing.assert_allclose(r["params"]["p"], 30, rtol=1e-4)
    assert r["chi2"] < 1e-6 and r["dof"] == 3 * n - 7
    np.testing.assert_allclose(r["model"].eval_fs(wi, wo), f, rtol=1e-4, atol=1e-9)
    # Undefined uncertainties come with a reason, never NaN.
    for u in r["uncertainty"].values():
        assert isinstance(u, str) or np.isfinite(u)
    with pytest.raises(ValueError, match="init `p`"):
        fl.fit("kajiya-kay", wi, wo, f[:, 1], init={"p": "x"})
    with pytest.raises(ValueError, match="channel"):
        fl.fit("kajiya-kay", wi, wo, f[:, 1], channel=5, init={"p": 10})


def test_hair_read_takes_usda_and_pbrt_curves_written_by_their_grammars(tmp_path):
    # Linear USD BasisCurves, written here by string formatting (not by fiberlab's writer).
    usda = tmp_path / "c.usda"
    usda.write_text(
        "#usda 1.0\n"
        'def BasisCurves "hair" {\n'
        '    uniform token type = "linear"\n'
        "    int[] curveVertexCounts = [2, 3]\n"
        "    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 2, 0), (0, 3, 1)]\n"
        '    float[] widths = [0.1, 0.2, 0.3, 0.4, 0.5] (interpolation = "vertex")\n'
        "}\n"
    )
    back = fl.hair.read(usda)
    assert [len(s) for s in back.strands] == [2, 3]
    np.testing.assert_array_equal(np.concatenate(back.strands)[4], np.float32([0, 3, 1]))
    np.testing.assert_array_equal(np.concatenate(back.thickness), np.float32([0.1, 0.2, 0.3, 0.4, 0.5]))
    # One cubic Bézier span in pbrt-v4's grammar, under a translation: evaluated at 4 steps,
    # the polyline's points are the Bernstein blends of the control points, translated.
    pbrt = tmp_path / "c.pbrt"
    pbrt.write_text(
        'Translate 0 0 2\nShape "curve" "point3 P" [0 0 0 1 0 0 2 1 0 3 1 0] "float width" 0.25\n'
    )
    back = fl.hair.read(pbrt, segments_per_curve=4)
    (s,) = back.strands
    c = np.array([[0, 0, 0], [1, 0, 0], [2, 1, 0], [3, 1, 0]], float)
    t = np.linspace(0, 1, 5)[:, None]
    bez = (1 - t) ** 3 * c[0] + 3 * (1 - t) ** 2 * t * c[1] + 3 * (1 - t) * t**2 * c[2] + t**3 * c[3]
    np.testing.assert_allclose(s, bez + [0, 0, 2], atol=1e-6)
    info = run_cli("hair", "info", str(pbrt))
    assert dict(line.split(None, 1) for line in info.strip().splitlines())["strands"] == "1"
    with pytest.raises(ValueError, match="bad.pbrt"):
        (tmp_path / "bad.pbrt").write_text('Shape "curve" "point3 P" [0 0 0 1 0]\n')
        fl.hair.read(tmp_path / "bad.pbrt")
