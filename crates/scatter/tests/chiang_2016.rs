//! Model-specific tests of `chiang` (Chiang 2016 / pbrt-v4 hair): furnaces, sample weights,
//! sampling consistency, χ² at low roughness, tilt signs, edge cases. Models are built
//! through the registry; random numbers, the χ² and the tolerances come from
//! `fiberlab-check`.

use fiberlab_check::chi2::{Chi2Config, chi2_test};
use fiberlab_check::rng::TestRng;
use fiberlab_check::tolerance::*;
use fiberlab_math::frame::{cos_theta, direction, direction_from_sin_cos, phi};
use fiberlab_math::special::{logistic, sample_trimmed_logistic, trimmed_logistic, trimmed_logistic_cdf};
use fiberlab_math::{DVec3, Rgb, fresnel};
use fiberlab_scatter::chiang_2016::Chiang;
use fiberlab_scatter::hair::attenuation::hit_attenuation as attenuation;
use fiberlab_scatter::hair::roughness::{logistic_scale, longitudinal_variance};
use fiberlab_scatter::radiometry::{Quadrature, albedo};
use fiberlab_scatter::{Model, ModelError, ScatteringFunction, build};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

const BETAS: [f64; 5] = [0.1, 0.3, 0.5, 0.7, 0.9];

/// A `chiang` fiber from registry parameters (numbers as text, angles in degrees).
fn chiang(pairs: &[(&str, String)]) -> Chiang {
    match build("chiang", pairs) {
        Ok(Model::Chiang(c)) => c,
        other => panic!("chiang {pairs:?}: {other:?}"),
    }
}

/// `beta_m`, `beta_n` and the tilt `alpha` (degrees), plus further text pairs.
fn rough(beta_m: f64, beta_n: f64, alpha_deg: f64, more: &[(&str, &str)]) -> Chiang {
    let mut pairs =
        vec![("beta_m", beta_m.to_string()), ("beta_n", beta_n.to_string()), ("alpha", alpha_deg.to_string())];
    pairs.extend(more.iter().map(|&(k, v)| (k, v.to_string())));
    chiang(&pairs)
}

/// Without absorption (σ_a = 0).
fn lossless(beta_m: f64, beta_n: f64, alpha_deg: f64) -> Chiang {
    rough(beta_m, beta_n, alpha_deg, &[("sigma_a", "0")])
}

#[test]
fn white_furnace_uniform_sampling_of_the_sphere() {
    // pbrt-v3/v4 WhiteFurnace (σ_a = 0, 0.95 ≤ estimate ≤ 1.05), here with the default 2°
    // tilt, 4 random (ω_o, h) per roughness pair and ω_i uniform on the sphere, jittered-
    // stratified in (sinθ_i, φ_i) (160 × 320 strata, 400 × 480 when a β is 0.1), which
    // allows a tighter bound.
    let mut rng = TestRng::new(1);
    let mut table = String::new();
    for &bm in &BETAS {
        for &bn in &BETAS {
            let f = lossless(bm, bn, 2.0);
            let (n_s, n_phi) = if bm < 0.2 || bn < 0.2 { (400, 480) } else { (160, 320) };
            let mut row = Vec::new();
            for _ in 0..4 {
                let (wo, h) = (rng.sphere_direction(), rng.offset());
                let mut sum = 0.0;
                for i in 0..n_s {
                    for j in 0..n_phi {
                        let s = -1.0 + 2.0 * (i as f64 + rng.uniform()) / n_s as f64;
                        let wi = direction_from_sin_cos(
                            s,
                            (1.0 - s * s).sqrt(),
                            TAU * (j as f64 + rng.uniform()) / n_phi as f64,
                        );
                        sum += f.eval(wi, wo, h)[1] * cos_theta(wi);
                    }
                }
                let est = sum * 4.0 * PI / (n_s * n_phi) as f64;
                assert!(
                    (est - 1.0).abs() < STRATIFIED_FURNACE_ABS,
                    "uniform furnace β_m={bm} β_n={bn} ω_o={wo:?} h={h}: {est}"
                );
                row.push(format!("{est:.4}"));
            }
            table += &format!("β_m={bm} β_n={bn}: {}\n", row.join(" "));
        }
    }
    println!("{table}");
}

#[test]
fn white_furnace_importance_sampled_and_every_weight_is_one() {
    // pbrt WhiteFurnaceSampled (0.99…1.01) and SamplingWeights (each weight 1 ± 1e−3),
    // over the full β grid including β_n = 0.1 and the default tilt.
    let mut rng = TestRng::new(2);
    for &bm in &BETAS {
        for &bn in &BETAS {
            let f = lossless(bm, bn, 2.0);
            let n = 20_000;
            let mut sum = 0.0;
            for _ in 0..n {
                let (wo, h) = (rng.sphere_direction(), rng.offset());
                let s = f.sample(wo, h, rng.u4()).expect("lossless lobes never vanish");
                for c in 0..3 {
                    assert!(
                        (s.weight[c] - 1.0).abs() < LOSSLESS_WEIGHT_ABS,
                        "β_m={bm} β_n={bn}: weight {:?}",
                        s.weight
                    );
                }
                // weight = eval·cosθ_i/pdf and pdf agrees with pdf().
                let w = f.eval(s.wi, wo, h)[0] * cos_theta(s.wi) / s.pdf;
                assert!((w - s.weight[0]).abs() < ROUNDING_REL * w.max(1.0) || cos_theta(s.wi) < GRAZING_COS);
                assert!((f.pdf(s.wi, wo, h) - s.pdf).abs() <= ROUNDING_REL * s.pdf);
                sum += s.weight[1];
            }
            // pbrt's WhiteFurnaceSampled (mean within 0.01) follows from the weights.
            let est = sum / n as f64;
            assert!((est - 1.0).abs() < LOSSLESS_WEIGHT_ABS, "sampled furnace β_m={bm} β_n={bn}: {est}");
        }
    }
}

#[test]
fn importance_sampled_and_uniform_estimates_agree() {
    // pbrt SamplingConsistency (σ_a = 0.25, L_i(ω) = (ω·z)²), with the bound in standard
    // errors of the two estimates' difference instead of pbrt's fixed 5%.
    let mut rng = TestRng::new(3);
    let li = |w: DVec3| w.z * w.z;
    for &bm in &[0.2, 0.4, 0.6, 0.8] {
        for &bn in &[0.4, 0.6, 0.8] {
            let f = rough(bm, bn, 2.0, &[("sigma_a", "0.25")]);
            let n = 65_536;
            let (mut importance, mut uniform) = ([0.0; 3], [0.0; 3]);
            let (mut importance2, mut uniform2) = ([0.0; 3], [0.0; 3]);
            for _ in 0..n {
                let (wo, h) = (rng.sphere_direction(), rng.offset());
                let a = match f.sample(wo, h, rng.u4()) {
                    Some(s) => s.weight * li(s.wi),
                    None => Rgb::ZERO,
                };
                let wi = rng.sphere_direction();
                let b = f.eval(wi, wo, h) * (li(wi) * cos_theta(wi) * 4.0 * PI);
                for c in 0..3 {
                    importance[c] += a[c];
                    importance2[c] += a[c] * a[c];
                    uniform[c] += b[c];
                    uniform2[c] += b[c] * b[c];
                }
            }
            let nf = n as f64;
            for c in 0..3 {
                let (mi, mu) = (importance[c] / nf, uniform[c] / nf);
                let var = (importance2[c] / nf - mi * mi + uniform2[c] / nf - mu * mu) / nf;
                let rel = (mi - mu).abs() / mu;
                assert!(
                    (mi - mu).abs() <= MC_SIGMAS * var.sqrt(),
                    "β_m={bm} β_n={bn} channel {c}: {mi} vs {mu} (relative {rel:.4}, σ {:.2e})",
                    var.sqrt()
                );
            }
        }
    }
}

#[test]
fn chi2_goodness_of_fit_down_to_beta_0_1() {
    // Absorbing (default melanin) so that the lobe weights differ from 1/Σ; tilt 2°.
    let mut report = String::new();
    // (β_m, β_n, θ_o, h, sinθ bins, φ bins): fine bins for narrow lobes.
    const CASES: usize = 6;
    let cases: [(f64, f64, f64, f64, usize, usize); CASES] = [
        (0.1, 0.1, 0.4, 0.37, 160, 640),
        (0.1, 0.1, -1.2, -0.8, 160, 640),
        (0.3, 0.1, -1.2, -0.8, 160, 640),
        (0.1, 0.3, 0.4, 0.37, 160, 640),
        (0.6, 0.5, 0.4, 0.37, 100, 256),
        (0.9, 0.9, -1.2, -0.8, 64, 128),
    ];
    for (bm, bn, theta_o, h, n_s, n_phi) in cases {
        let f = rough(bm, bn, 2.0, &[]);
        let cfg =
            Chi2Config { bins_theta: n_s, bins_phi: n_phi, sub: 2, samples: 500_000, seed: 11, ..Default::default() };
        let r = chi2_test(&f, direction(theta_o, 0.3), h, &cfg);
        report += &format!(
            "β_m={bm} β_n={bn} θ_o={theta_o} h={h}: χ²={:.0} dof={} p={:.3} unresolved mass {:.1e}\n",
            r.statistic, r.dof, r.p_value, r.untrusted_mass
        );
        assert!((r.pdf_integral - 1.0).abs() < CHI2_GRID_PDF_INTEGRAL_ABS, "pdf integrates to {}", r.pdf_integral);
        assert!(r.dof >= CHI2_MIN_DOF && r.untrusted_mass <= CHI2_MAX_UNTRUSTED_MASS, "χ² without power: {r:?}");
        assert!(r.passes(CHI2_SIGNIFICANCE / CASES as f64), "χ² rejects β_m={bm} β_n={bn} θ_o={theta_o} h={h}: {r:?}");
    }
    println!("{report}");
}

/// 2D exit azimuth computed in the test from Snell's law with Bravais' index.
fn exit_azimuth_2d(p: usize, eta: f64, theta_o: f64, h: f64) -> f64 {
    let eta_prime = (eta * eta - theta_o.sin().powi(2)).sqrt() / theta_o.cos();
    let (gamma_o, gamma_t) = (h.asin(), (h / eta_prime).asin());
    2.0 * p as f64 * gamma_t - 2.0 * gamma_o + p as f64 * PI
}

#[test]
fn roughness_maps_match_the_published_values() {
    // Chiang et al. 2016's maps β_m → v and β_n → s, evaluated independently:
    // β = 0.1/0.3/0.5/1.0 → v_0 = 0.00652/0.0846/0.320/27.44, s = 0.0241/0.1172/0.2701/4.281.
    let table = [(0.1, 0.00652, 0.0241), (0.3, 0.0846, 0.1172), (0.5, 0.320, 0.2701), (1.0, 27.44, 4.281)];
    for (beta, v0, s) in table {
        assert!((longitudinal_variance(beta) - v0).abs() < PUBLISHED_VALUE_REL * v0, "v_0({beta})");
        assert!((logistic_scale(beta) - s).abs() < PUBLISHED_VALUE_REL * s, "s({beta})");
    }
}

#[test]
fn attenuation_matches_an_independent_bravais_computation() {
    // A_p from Marschner's Bravais-index Fresnel (a different formula) and Snell's law in
    // the normal plane, against the model's exact 3D Fresnel and chord absorption.
    let sigma_a = Rgb::new(0.3, 0.8, 1.9);
    let mut rng = TestRng::new(4);
    for _ in 0..2000 {
        let theta_o = rng.uniform_in(-1.5, 1.5);
        let h = rng.offset();
        let (s, c) = theta_o.sin_cos();
        let eta: f64 = 1.55;
        let eta_prime = (eta * eta - s * s).sqrt() / c;
        let eta_double_prime = eta * eta / eta_prime;
        let (gamma_o, gamma_t) = (h.asin(), (h / eta_prime).asin());
        let f = fresnel::bravais(eta_prime, eta_double_prime, gamma_o);
        let cos_theta_t = (1.0 - (s / eta).powi(2)).sqrt();
        let t = (sigma_a * (-2.0 * gamma_t.cos() / cos_theta_t)).exp();
        let want = [Rgb::splat(f), t * (1.0 - f).powi(2), t * t * ((1.0 - f).powi(2) * f)];
        let residual = t * t * t * ((1.0 - f).powi(2) * f * f) / (Rgb::ONE - t * f);
        let hit = attenuation(eta, sigma_a, s, c, h);
        for (p, w) in want.iter().chain(std::iter::once(&residual)).enumerate() {
            for ch in 0..3 {
                assert!(
                    (hit.a[p][ch] - w[ch]).abs() < ROUNDING_REL,
                    "p={p} θo={theta_o} h={h}: {:?} vs {w:?}",
                    hit.a[p]
                );
            }
        }
        assert!((hit.gamma_t - gamma_t).abs() < ROUNDING_REL && (hit.gamma_o - gamma_o).abs() < ROUNDING_REL);
    }
}

#[test]
fn tilt_moves_r_toward_the_root_and_tt_trt_toward_the_tip() {
    // α = 5°, narrow lobes; at each lobe's exit azimuth scan θ_i for the maximum of g_h.
    let alpha = 5f64.to_radians();
    let f = lossless(0.1, 0.1, 5.0);
    let untilted = lossless(0.1, 0.1, 0.0);
    let (theta_o, h) = (0.2, 0.5);
    let wo = direction(theta_o, 0.0);
    for (p, expected) in [(0usize, -2.0 * alpha), (1, alpha), (2, 4.0 * alpha)] {
        let phi_i = exit_azimuth_2d(p, 1.55, theta_o, h);
        let centre = |m: &Chiang| {
            let (mut best, mut arg) = (0.0, 0.0);
            for k in 0..20_000 {
                let ti = -FRAC_PI_2 + (k as f64 + 0.5) * PI / 20_000.0;
                let g = m.eval(direction(ti, phi_i), wo, h)[0] * ti.cos();
                if g > best {
                    best = g;
                    arg = ti;
                }
            }
            arg + theta_o
        };
        let (tilted, flat) = (centre(&f), centre(&untilted));
        // The untilted lobe is centred on the mirror cone up to the vMF-marginal skew.
        assert!(flat.abs() < UNTILTED_PEAK_ALPHAS * alpha, "p={p}: untilted centre θi+θo = {flat}");
        let shift = tilted - flat;
        println!(
            "p={p}: lobe centre θi+θo untilted {flat:.5}, tilted {tilted:.5}, shift {shift:.5} (want {expected:.5})"
        );
        assert!(shift * expected > 0.0, "p={p}: shift {shift} has the wrong sign (want {expected})");
        assert!((shift - expected).abs() < TILT_SHIFT_REL * expected.abs(), "p={p}: shift {shift} vs {expected}");
    }
}

#[test]
fn no_nan_at_silhouette_grazing_angles_and_extreme_roughness() {
    let angles = [-FRAC_PI_2, -FRAC_PI_2 + 1e-9, -1.0, 0.0, 0.7, FRAC_PI_2 - 1e-9, FRAC_PI_2];
    let hs = [-1.0, -0.999999, 0.0, 0.5, 0.999999, 1.0, 1.0 + 1e-9];
    let mut rng = TestRng::new(5);
    for &(bm, bn) in &[(0.01, 0.01), (0.1, 0.1), (1.0, 1.0), (0.01, 1.0)] {
        let absorptions: [&[(&str, &str)]; 3] = [&[("sigma_a", "0")], &[], &[("sigma_a", "50")]];
        for absorption in absorptions {
            let f = rough(bm, bn, 2.0, absorption);
            for &to in &angles {
                for &ti in &angles {
                    for &h in &hs {
                        let (wo, wi) = (direction(to, 0.2), direction(ti, 2.1));
                        let v = f.eval(wi, wo, h);
                        let p = f.pdf(wi, wo, h);
                        assert!(v.is_finite() && v.min_component() >= 0.0, "eval {v:?} at θo={to} θi={ti} h={h}");
                        assert!(p.is_finite() && p >= 0.0, "pdf {p} at θo={to} θi={ti} h={h}");
                    }
                }
                for &h in &hs {
                    for u in [[0.0; 4], [0.999_999_999_999; 4], rng.u4()] {
                        if let Some(s) = f.sample(direction(to, 0.2), h, u) {
                            assert!(s.weight.is_finite() && s.pdf.is_finite() && s.pdf > 0.0, "{s:?}");
                            assert!((s.wi.length() - 1.0).abs() < UNIT_LENGTH_ABS);
                        }
                    }
                }
            }
        }
    }
    // pbrt-v4 HOnTheEdge: h = −1, β = 0.1.
    let f = lossless(0.1, 0.1, 0.0);
    let v = f.eval(direction(0.2, 1.0), direction(-0.3, 0.1), -1.0);
    assert!(v.is_finite());
}

#[test]
fn logistic_sampler_matches_a_tabulated_inversion() {
    // pbrt-v4 Sampling.Logistic, plus the scales Chiang's β_n map produces.
    let mut cases = vec![(1.0, -PI, PI), (5.0, 0.0, 3.0), (0.25, -5.0, -3.0)];
    cases.extend(BETAS.iter().map(|&b| (logistic_scale(b), -PI, PI)));
    for (s, a, b) in cases {
        let bins = 8192;
        let dx = (b - a) / bins as f64;
        let mut cdf = vec![0.0; bins + 1];
        for k in 0..bins {
            let x = a + (k as f64 + 0.5) * dx;
            cdf[k + 1] = cdf[k] + logistic(x, s) * dx;
        }
        let total = cdf[bins];
        for i in 0..200 {
            let u = (i as f64 + 0.5) / 200.0;
            let x = sample_trimmed_logistic(u, s, a, b);
            let k = cdf.partition_point(|&c| c <= u * total).clamp(1, bins) - 1;
            let frac = (u * total - cdf[k]) / (cdf[k + 1] - cdf[k]);
            let tabulated = a + (k as f64 + frac) * dx;
            assert!((x - tabulated).abs() < TABULATED_INVERSION_ABS, "s={s}: x={x} vs tabulated {tabulated}");
            let pdf_tab = (cdf[k + 1] - cdf[k]) / (dx * total);
            let pdf = trimmed_logistic(x, s, a, b);
            let tol =
                if s >= 0.25 { TABULATED_INVERSION_ABS * pdf.max(1.0) } else { TABULATED_NARROW_DENSITY_REL * pdf };
            assert!((pdf - pdf_tab).abs() < tol, "s={s}: pdf {pdf} vs {pdf_tab}");
            assert!((trimmed_logistic_cdf(x, s, a, b) - u).abs() < TABULATED_CDF_REL * u);
        }
    }
}

#[test]
fn light_side_albedo_exceeds_one_at_grazing_and_matches_direct_quadrature() {
    let f = lossless(0.3, 0.3, 0.0);
    let rho0 = f.light_side_albedo(0.0)[1];
    let rho_grazing = f.light_side_albedo(1.55)[1];
    println!(
        "chiang β=0.3 light-side albedo: θi=0 {rho0:.4}, θi=1.4 {:.4}, θi=1.55 {rho_grazing:.3}",
        f.light_side_albedo(1.4)[1]
    );
    assert!((0.85..1.0).contains(&rho0), "{rho0}");
    assert!(rho_grazing > 5.0, "{rho_grazing}");
    // The 1D formula equals the direct quadrature of eval over ω_r (and h).
    let g = lossless(0.5, 0.5, 2.0);
    let wi = direction(0.6, 0.4);
    let direct = albedo(&g, wi, &Quadrature { theta: 256, phi: 256, h: 16 })[0];
    let formula = g.light_side_albedo(0.6)[0];
    assert!((direct - formula).abs() < ALBEDO_FORMULA_REL * formula, "{direct} vs {formula}");
}

#[test]
fn model_is_measurably_non_reciprocal() {
    let f = lossless(0.3, 0.3, 2.0);
    let d = f.non_reciprocity(300, 7);
    println!("chiang β=0.3 max relative non-reciprocity over 300 pairs: {d:.3}");
    assert!(d > 0.1 && d <= 1.0, "{d}");
}

#[test]
fn absorption_keys_are_exclusive_and_color_inverts() {
    let e = build("chiang", &[("sigma_a", "0.2"), ("eumelanin", "1")]).unwrap_err();
    assert!(matches!(e, ModelError::Inconsistent(_)), "{e}");
    let e = build("chiang", &[("color", "0.5"), ("pheomelanin", "1")]).unwrap_err();
    assert!(matches!(e, ModelError::Inconsistent(_)), "{e}");
    assert!(build("chiang", &[("beta_m", "0")]).is_err());
    assert!(build("chiang", &[("beta_n", "1.01")]).is_err());
    assert!(build("chiang", &[("color", "0")]).is_err());
    assert!(build("chiang", &[("eta", "NaN")]).is_err());
    assert!(build("chiang", &[("pheomelanin", "0.5")]).is_ok());
    // Default: eumelanin 1.3.
    let d = rough(0.3, 0.3, 2.0, &[]);
    let want = Rgb::new(0.419, 0.697, 1.37) * 1.3;
    assert!((d.sigma_a() - want).max_component().abs() < ROUNDING_REL);
    // Colour inversion (Chiang Eq. 9) at β_n = 0.3: ln C / poly, squared.
    let c = rough(0.3, 0.3, 2.0, &[("color", "0.6,0.4,0.2")]);
    let b: f64 = 0.3;
    let poly = 5.969 - 0.215 * b + 2.532 * b * b - 10.73 * b.powi(3) + 5.574 * b.powi(4) + 0.245 * b.powi(5);
    assert!((c.sigma_a()[2] - (0.2f64.ln() / poly).powi(2)).abs() < ROUNDING_REL);
    // White colour means no absorption.
    let w = rough(0.3, 0.3, 2.0, &[("color", "1")]);
    assert_eq!(w.sigma_a(), Rgb::ZERO);
}

#[test]
fn r_lobe_leaves_by_mirror_reflection_at_the_hit_normal() {
    // Geometry in the normal plane: viewer at azimuth φ_o, hit offset h, surface normal at
    // azimuth φ_o − asin h; mirror the view direction about it and compare with the R peak.
    let f = lossless(0.1, 0.1, 0.0);
    for &(phi_o, h) in &[(FRAC_PI_2, 0.6), (0.3, -0.45), (-2.0, 0.2)] {
        let normal = phi_o - f64::asin(h);
        let (ny, nz) = (normal.cos(), normal.sin());
        let (dy, dz) = (phi_o.cos(), phi_o.sin());
        let dot = ny * dy + nz * dz;
        let (ry, rz) = (2.0 * dot * ny - dy, 2.0 * dot * nz - dz);
        let mirror = rz.atan2(ry);
        let wo = direction(0.0, phi_o);
        let (mut best, mut arg) = (0.0, 0.0);
        for k in 0..2000 {
            let ph = mirror - 0.5 + k as f64 * 0.0005;
            let g = f.eval(direction(0.0, ph), wo, h)[0];
            if g > best {
                best = g;
                arg = ph;
            }
        }
        assert!((arg - mirror).abs() < PEAK_SCAN_ABS, "φo={phi_o} h={h}: R peak at {arg}, mirror {mirror}");
    }
}

#[test]
fn azimuthal_lobe_is_centred_on_the_exit_azimuth() {
    // With β_m = 1 (nearly uniform M) and σ_a = 0, integrate g_h over θ_i at each φ: the
    // φ-profile must peak at Φ(p, h) for the dominant lobe (TT at h = 0.2).
    let f = lossless(0.3, 0.2, 0.0);
    let (theta_o, h) = (0.0, 0.2);
    let wo = direction(theta_o, 0.0);
    let want = exit_azimuth_2d(1, 1.55, theta_o, h);
    let (mut best, mut arg) = (0.0, 0.0);
    for k in 0..3600 {
        let ph = -PI + (k as f64 + 0.5) * TAU / 3600.0;
        let mut acc = 0.0;
        for j in 0..200 {
            let s = -1.0 + (j as f64 + 0.5) / 100.0;
            acc +=
                f.eval(direction_from_sin_cos(s, (1.0 - s * s).sqrt(), phi(wo) + ph), wo, h)[0] * (1.0 - s * s).sqrt();
        }
        if acc > best {
            best = acc;
            arg = ph;
        }
    }
    assert!((arg - want).abs() < AZIMUTHAL_PEAK_ABS, "TT peak at {arg}, Φ = {want}");
}

#[test]
fn pdf_integrates_to_one_at_extreme_configurations() {
    for &(bm, bn) in &[(0.3, 0.3), (0.9, 0.2)] {
        let f = rough(bm, bn, 5.0, &[]);
        for &(theta_o, h) in &[(FRAC_PI_2, 1.0), (-FRAC_PI_2 + 1e-9, -1.0), (0.0, 0.999_999), (1.4, -0.3)] {
            let integral = fiberlab_check::pdf_integral(&f, direction(theta_o, 1.0), h);
            assert!((integral - 1.0).abs() < PDF_INTEGRAL_ABS, "β=({bm},{bn}) θo={theta_o} h={h}: ∫pdf = {integral}");
        }
    }
}
