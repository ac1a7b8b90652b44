//! Tests of the `yan-fur` model (Yan et al. 2015/2017) against independent computations:
//! the single-cylinder Gaussian-lobe fiber written out from its formulas, the hair core's
//! attenuation, the medulla half-chords, quadratures of the furnace and of the far field, the
//! χ² test of the sampler, and the parameter checks.

use fiberlab_check::chi2::{Chi2Config, chi2_test};
use fiberlab_check::rng::TestRng;
use fiberlab_math::frame::direction;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::hair::attenuation::hit_attenuation;
use fiberlab_scatter::yan_2017::{
    CortexAbsorption, YanFur, YanFurError, YanFurParams, cuticle_reflectance, interfaces_from_slab_layers,
    sigma_c_a_from_color, slab_layers_reflectance,
};
use fiberlab_scatter::{ModelError, ScatteringFunction, build};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

fn fur(f: impl FnOnce(&mut YanFurParams)) -> YanFur {
    let mut p = YanFurParams::default();
    f(&mut p);
    YanFur::new(p).unwrap()
}

/// Unpolarized Fresnel reflectance of index `eta` at incidence cosine `c`, written out.
fn fresnel(eta: f64, c: f64) -> f64 {
    let s2 = (1.0 - c * c) / (eta * eta);
    let ct = (1.0 - s2).sqrt();
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    0.5 * (rs * rs + rp * rp)
}

fn gauss(s: f64, x: f64) -> f64 {
    (-0.5 * (x / s).powi(2)).exp() / (s * TAU.sqrt())
}

/// Mass of the Gaussian N(c, b²) on [−π/2, π/2] by composite Simpson (no erf).
fn truncated_mass(c: f64, b: f64) -> f64 {
    let n = 20_000;
    let d = PI / n as f64;
    let f = |k: usize| gauss(b, -FRAC_PI_2 + k as f64 * d - c);
    let mut s = f(0) + f(n);
    for k in 1..n {
        s += f(k) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * d / 3.0
}

/// The single-cylinder (κ = 0, one interface) near-field fiber with Gaussian lobes, written
/// out from its formulas: Fresnel at cosθ_o cosγ_o, Bravais' η′, the chord 2cosγ_t/cosθ_t,
/// `A_p`, Gaussians in θ_i centred at −θ_o − 2α, −θ_o + α, −θ_o + 3α with widths β, β/2, 3β/2
/// (renormalized on [−π/2, π/2]), wrapped Gaussians in φ of widths β_n√(p+1), and
/// `f_s = Σ A_p M_p N_p / cos²θ_i`. Gray absorption σ. Valid when no tilted centre passes a pole.
fn gaussian_lobe_fiber(
    wi: DVec3,
    wo: DVec3,
    h: f64,
    (eta, sigma, alpha, beta, beta_n): (f64, f64, f64, f64, f64),
) -> f64 {
    let (ti, to) = (wi.x.asin(), wo.x.asin());
    let phi = wi.z.atan2(wi.y) - wo.z.atan2(wo.y);
    let go = h.asin();
    let f = fresnel(eta, to.cos() * go.cos());
    let eta_p = (eta * eta - to.sin().powi(2)).sqrt() / to.cos();
    let gt = (h / eta_p).asin();
    let cos_tt = (1.0 - (to.sin() / eta).powi(2)).sqrt();
    let t = (-sigma * 2.0 * gt.cos() / cos_tt).exp();
    let a = [f, (1.0 - f).powi(2) * t, (1.0 - f).powi(2) * f * t * t];
    let centre = [-to - 2.0 * alpha, -to + alpha, -to + 3.0 * alpha];
    let width = [beta, 0.5 * beta, 1.5 * beta];
    let mut sum = 0.0;
    for p in 0..3 {
        let m = gauss(width[p], ti - centre[p]) / truncated_mass(centre[p], width[p]);
        let big_phi = 2.0 * p as f64 * gt - 2.0 * go + p as f64 * PI;
        let sn = beta_n * (p as f64 + 1.0).sqrt();
        let n: f64 = (-6..=6).map(|k| gauss(sn, phi - big_phi + TAU * k as f64)).sum();
        sum += a[p] * m * n;
    }
    sum / ti.cos().powi(2)
}

fn single_cylinder(sigma: f64, alpha_deg: f64, beta_deg: f64, beta_n_deg: f64) -> YanFur {
    fur(|p| {
        p.kappa = 0.0;
        p.sigma_m_s = 0.0;
        p.sigma_m_a = 0.0;
        p.layers = 1.0;
        p.absorption = CortexAbsorption::SigmaA(Rgb::splat(sigma));
        p.alpha = alpha_deg.to_radians();
        p.beta_m = beta_deg.to_radians();
        p.beta_n = beta_n_deg.to_radians();
    })
}

#[test]
fn without_medulla_and_with_one_interface_it_is_the_gaussian_lobe_fiber() {
    let mut rng = TestRng::new(3);
    let mut compared = 0;
    for &(sigma, alpha, beta, beta_n) in &[(0.0, 0.0, 10.0, 10.0), (0.7, 3.0, 6.0, 15.0), (2.0, -5.0, 20.0, 4.0)] {
        let m = single_cylinder(sigma, alpha, beta, beta_n);
        let consts = (1.55, sigma, f64::to_radians(alpha), f64::to_radians(beta), f64::to_radians(beta_n));
        for _ in 0..300 {
            // θ within ±1.1 rad so that no tilted centre reaches a pole.
            let wo = direction(rng.uniform_in(-1.1, 1.1), rng.uniform_in(-PI, PI));
            let wi = direction(rng.uniform_in(-1.1, 1.1), rng.uniform_in(-PI, PI));
            let h = rng.uniform_in(-0.999, 0.999);
            let want = gaussian_lobe_fiber(wi, wo, h, consts);
            let got = m.eval(wi, wo, h);
            assert!(got[0] == got[1] && got[1] == got[2]);
            assert!((got[0] - want).abs() <= 1e-9 * want + 1e-300, "{got:?} vs {want}");
            compared += usize::from(want > 1e-3);
        }
        // The attenuations are the hair core's (Chiang's) A_0..A_2 exactly.
        for &(theta, h) in &[(0.0, 0.0), (0.7, 0.5), (-1.3, -0.9), (1.5, 0.99)] {
            let (s, c) = f64::sin_cos(theta);
            let core = hit_attenuation(1.55, Rgb::splat(sigma), s, c, h).a;
            let ours = m.attenuation(theta, h);
            for p in 0..3 {
                assert!((ours[p][0] - core[p][0]).abs() <= 1e-15 * core[p][0].max(1e-300), "p {p}");
            }
        }
    }
    assert!(compared > 100, "the cases exercise the lobes ({compared})");
}

#[test]
fn a_vanishing_medulla_is_the_single_cylinder() {
    let base = single_cylinder(0.5, 3.0, 10.0, 10.0);
    let thin = fur(|p| {
        p.kappa = 1e-9;
        p.sigma_m_s = 40.0;
        p.sigma_m_a = 50.0;
        p.lobes = [true, true, true, false, false];
        p.absorption = CortexAbsorption::SigmaA(Rgb::splat(0.5));
    });
    let mut rng = TestRng::new(4);
    for _ in 0..200 {
        let (wi, wo, h) = (rng.sphere_direction(), rng.sphere_direction(), rng.offset());
        let (a, b) = (base.eval(wi, wo, h)[0], thin.eval(wi, wo, h)[0]);
        assert!((a - b).abs() <= 1e-6 * a.max(1e-300), "{a} vs {b}");
    }
}

/// `A_1` and `A_2` with a medulla against the half-chord formulas `d_m = √(κ² − h′²)`,
/// `d_c = cosγ_t − d_m`, `σ′ = σ/cosθ_t`, `A_p = (1 − F)²F^{p−1}exp(−2d_cσ_c′ − 2d_m σ_m^e′)^p`.
#[test]
fn medulla_attenuation_follows_the_half_chords() {
    let (eta, kappa, sc, ss, sa) = (1.55, 0.7, 0.4, 2.0, 0.3);
    let m = fur(|p| {
        p.kappa = kappa;
        p.sigma_m_s = ss;
        p.sigma_m_a = sa;
        p.absorption = CortexAbsorption::SigmaA(Rgb::splat(sc));
    });
    let mut inside = 0;
    for &theta in &[0.0, 0.5, -1.0, 1.4] {
        for k in 0..=40 {
            let h = -1.0 + k as f64 / 20.0;
            let f = fresnel(eta, f64::cos(theta) * (1.0 - h * h).sqrt());
            let eta_p = (eta * eta - f64::sin(theta).powi(2)).sqrt() / f64::cos(theta);
            let hp = h / eta_p;
            let d_m = if hp.abs() < kappa { (kappa * kappa - hp * hp).sqrt() } else { 0.0 };
            let d_c = (1.0 - hp * hp).sqrt() - d_m;
            let cos_tt = (1.0 - (f64::sin(theta) / eta).powi(2)).sqrt();
            let t = (-(2.0 * d_c * sc + 2.0 * d_m * (ss + sa)) / cos_tt).exp();
            let want = [f, (1.0 - f).powi(2) * t, (1.0 - f).powi(2) * f * t * t];
            let got = m.attenuation(theta, h);
            for p in 0..3 {
                assert!((got[p][0] - want[p]).abs() <= 1e-13, "θ {theta} h {h} p {p}: {} vs {}", got[p][0], want[p]);
            }
            inside += usize::from(d_m > 0.0);
        }
    }
    assert!(inside > 40);
}

/// ∫ f_s cosθ_i dω_i by midpoint quadrature in (θ_i, φ_i).
fn furnace(m: &YanFur, wo: DVec3, h: f64) -> Rgb {
    let (nt, np) = (1200, 1200);
    let (dt, dp) = (PI / nt as f64, TAU / np as f64);
    let mut sum = Rgb::ZERO;
    for i in 0..nt {
        let t = -FRAC_PI_2 + (i as f64 + 0.5) * dt;
        for j in 0..np {
            let wi = direction(t, -PI + (j as f64 + 0.5) * dp);
            sum += m.eval(wi, wo, h) * (t.cos() * t.cos() * dt * dp);
        }
    }
    sum
}

/// With every absorption zero and σ_m^s > 0, the camera-side furnace is `A_0 + A_1 + A_2` and
/// the deficit is exactly the light scattered in the medulla plus the unscattered orders p ≥ 3:
/// `S = (1 − F)(1 − T_m)/(1 − F T_m)`, `U = (1 − F)²F²T_m³/(1 − F T_m)`, T_m = exp(−σ_m^s ℓ_m).
#[test]
fn lossless_furnace_deficit_is_the_scattered_light_and_the_higher_orders() {
    let (eta, kappa, ss) = (1.55, 0.8, 2.0);
    let m = fur(|p| {
        p.kappa = kappa;
        p.sigma_m_s = ss;
        p.absorption = CortexAbsorption::SigmaA(Rgb::ZERO);
        p.beta_m = 8f64.to_radians();
        p.beta_n = 12f64.to_radians();
        p.lobes = [true, true, true, false, false];
    });
    for &(theta, h) in &[(0.0, 0.0), (0.6, 0.5), (-1.1, -0.9), (0.3, 0.95)] {
        let wo = direction(theta, 0.7);
        let quad = furnace(&m, wo, h)[0];
        let b = m.energy_budget(theta, h);
        let lobes: f64 = b.lobes.iter().map(|a| a[0]).sum();
        assert!((quad - lobes).abs() <= 1e-3 * lobes, "θ {theta} h {h}: furnace {quad} vs Σ A_p {lobes}");
        // Independent energy split.
        let f = fresnel(eta, theta.cos() * (1.0 - h * h).sqrt());
        let eta_p = (eta * eta - theta.sin().powi(2)).sqrt() / theta.cos();
        let hp = h / eta_p;
        let cos_tt = (1.0 - (theta.sin() / eta).powi(2)).sqrt();
        let l_m = if hp.abs() < kappa { 2.0 * (kappa * kappa - hp * hp).sqrt() / cos_tt } else { 0.0 };
        let tm = (-ss * l_m).exp();
        let s = (1.0 - f) * (1.0 - tm) / (1.0 - f * tm);
        let u = (1.0 - f).powi(2) * f * f * tm.powi(3) / (1.0 - f * tm);
        assert!((b.scattered[0] - s).abs() < 1e-14 && (b.higher_orders[0] - u).abs() < 1e-14);
        assert!((1.0 - lobes - s - u).abs() < 1e-14 && b.absorbed[0] < 1e-14, "lossless: nothing absorbed");
        println!(
            "θ_o {theta:5.2} h {h:5.2}: furnace {quad:.6}, deficit {:.6} = scattered {s:.6} + orders p≥3 {u:.6}",
            1.0 - quad
        );
    }
}

#[test]
fn far_field_equals_brute_force_h_integration() {
    let m = fur(|p| {
        p.kappa = 0.7;
        p.sigma_m_s = 1.5;
        p.sigma_m_a = 0.2;
        p.beta_n = 6f64.to_radians();
    });
    let n = 200_000;
    let mut rng = TestRng::new(8);
    let (mut compared, mut worst) = (0, 0.0f64);
    for _ in 0..12 {
        let wo = direction(rng.uniform_in(-1.3, 1.3), rng.uniform_in(-PI, PI));
        // Light near the specular cone, so that the value is not negligible.
        let wi = direction(-fiberlab_math::frame::theta(wo) + rng.uniform_in(-0.1, 0.1), rng.uniform_in(-PI, PI));
        let far = m.eval_far(wi, wo);
        let mut brute = Rgb::ZERO;
        for k in 0..n {
            let h = -1.0 + (k as f64 + 0.5) * 2.0 / n as f64;
            brute += m.eval(wi, wo, h) / n as f64;
        }
        for c in 0..3 {
            assert!((far[c] - brute[c]).abs() <= 1e-3 * brute[c] + 1e-12, "{far:?} vs {brute:?}");
            if brute[c] > 1e-3 {
                worst = worst.max((far[c] - brute[c]).abs() / brute[c]);
            }
        }
        compared += usize::from(brute[1] > 1e-3);
    }
    assert!(compared >= 6, "{compared}");
    println!("far field vs brute force: worst relative difference {worst:.2e}");
    // The far-field model of the registry is the same average, and ignores h.
    let far = build(
        "yan-fur",
        &[("field", "far"), ("kappa", "0.7"), ("sigma_m_s", "1.5"), ("sigma_m_a", "0.2"), ("beta_n", "6")],
    )
    .unwrap();
    let (wi, wo) = (direction(-0.3, 1.0), direction(0.35, -1.2));
    assert_eq!(far.eval(wi, wo, 0.3), m.eval_far(wi, wo));
    assert_eq!(far.eval(wi, wo, -0.8), m.eval_far(wi, wo));
}

#[test]
fn sampler_passes_chi2_at_low_and_high_roughness_and_weights_are_the_lobe_masses() {
    let cases: [&[(&str, &str)]; 3] = [
        &[("beta_m", "3"), ("beta_n", "4"), ("kappa", "0.9"), ("sigma_m_s", "4"), ("sigma_c_a", "0.2")],
        &[("beta_m", "40"), ("beta_n", "50"), ("alpha", "-8"), ("layers", "2.5"), ("sigma_c_a", "0.5")],
        &[("lobes", "tt,trt"), ("beta_m", "12"), ("beta_n", "20"), ("sigma_c_a", "0")],
    ];
    for (k, params) in cases.iter().enumerate() {
        let m = build("yan-fur", params).unwrap();
        let fiberlab_scatter::Model::YanFur(fur) = &m else { panic!() };
        for &(theta, h) in &[(0.2, 0.1), (-1.2, 0.85), (1.0, -0.6)] {
            let wo = direction(theta, 0.4);
            let cfg = Chi2Config { samples: 300_000, seed: 11 + k as u64, ..Default::default() };
            let outcome = chi2_test(&m, wo, h, &cfg);
            assert!(outcome.passes(1e-3), "{params:?} θ {theta} h {h}: {outcome:?}");
            let a = fur.attenuation(theta, h);
            let enabled = fur.params().lobes;
            let mass: f64 = (0..3).filter(|&p| enabled[p]).map(|p| a[p][0]).sum();
            let mut rng = TestRng::new(5);
            for _ in 0..200 {
                if let Some(s) = m.sample(wo, h, rng.u4()) {
                    // Away from the fiber axis (within the pole taper's band the sampling density
                    // in θ_i is reshaped, so the weight is no longer the mass there).
                    let off_axis = fiberlab_math::frame::theta(s.wi).abs()
                        < std::f64::consts::FRAC_PI_2 - fiberlab_scatter::hair::pole_taper::POLE_TAPER_WIDTH;
                    if off_axis && params.iter().any(|&(k, v)| k == "sigma_c_a" && v == "0") {
                        assert!((s.weight[0] - mass).abs() < 1e-12 * mass, "{} vs {mass}", s.weight[0]);
                    }
                    assert!(s.weight.is_finite() && s.pdf > 0.0);
                }
            }
        }
    }
}

#[test]
fn finite_and_non_negative_at_the_poles_and_the_edges() {
    let poles = [DVec3::X, -DVec3::X, direction(FRAC_PI_2 - 1e-9, 1.0), direction(-FRAC_PI_2 + 1e-12, -2.0)];
    let others = [direction(0.0, 0.0), direction(0.9, 2.5), direction(-1.4, -1.0)];
    let mut rng = TestRng::new(9);
    for params in [
        YanFurParams::default(),
        YanFurParams { alpha: 20f64.to_radians(), beta_m: 0.5f64.to_radians(), ..YanFurParams::default() },
        YanFurParams { beta_m: 60f64.to_radians(), beta_n: 60f64.to_radians(), kappa: 0.99, ..YanFurParams::default() },
        YanFurParams { layers: 1000.0, sigma_m_s: 40.0, sigma_m_a: 1e6, ..YanFurParams::default() },
    ] {
        let m = YanFur::new(params).unwrap();
        let dirs: Vec<DVec3> = poles.iter().chain(&others).copied().collect();
        for &wi in &dirs {
            for &wo in &dirs {
                for h in [-1.0, -0.999_999, 0.0, 0.5, 1.0] {
                    let (f, pdf) = m.eval_and_pdf(wi, wo, h);
                    assert!(f.is_finite() && f.min_component() >= 0.0 && pdf.is_finite() && pdf >= 0.0, "{f:?} {pdf}");
                    if let Some(s) = m.sample(wo, h, rng.u4()) {
                        assert!(s.weight.is_finite() && s.weight.min_component() >= 0.0 && s.pdf.is_finite());
                        assert!(s.wi.is_finite() && (s.wi.length() - 1.0).abs() < 1e-12);
                    }
                    let far = m.eval_far(wi, wo);
                    assert!(far.is_finite() && far.min_component() >= 0.0);
                }
            }
        }
        for u in [[0.0; 4], [1.0 - 1e-16; 4], [0.5, 0.0, 0.0, 1.0 - 1e-16]] {
            for &wo in &dirs {
                if let Some(s) = m.sample(wo, 1.0, u) {
                    assert!(s.weight.is_finite() && s.pdf.is_finite());
                }
            }
        }
    }
}

/// The two meanings of the cuticle `layers` (interfaces here, slabs in Yan 2017's code): the
/// values at η = 1.55, normal incidence, and the exact correspondence per polarization.
#[test]
fn cuticle_layers_in_both_definitions() {
    let f0 = ((1.55f64 - 1.0) / 2.55).powi(2);
    assert!((cuticle_reflectance(1.0, f0) - 0.0465).abs() < 5e-5);
    assert!((cuticle_reflectance(0.47, f0) - 0.0224).abs() < 5e-5);
    assert!((slab_layers_reflectance(1.0, 1.55, 1.0) - 0.0889).abs() < 5e-5);
    assert!((slab_layers_reflectance(0.47, 1.55, 1.0) - 0.0439).abs() < 5e-5);
    // Stokes' stack of n layers of reflectance r, from its recursion R_{k+1} = R_k + (1 − R_k)² r/(1 − R_k r)
    // (integer n only).
    let stack = |n: usize, r: f64| (1..n).fold(r, |acc, _| acc + (1.0 - acc).powi(2) * r / (1.0 - acc * r));
    for &r in &[0.01, 0.2, 0.7] {
        for n in 1..6 {
            assert!((cuticle_reflectance(n as f64, r) - stack(n, r)).abs() < 1e-14);
        }
    }
    // Slabs l = interfaces 2l per polarization, at any incidence.
    for &(l, c) in &[(0.47, 1.0), (1.0, 0.6), (2.0, 0.2), (0.3, 0.05)] {
        let eta: f64 = 1.55;
        let ct = (1.0 - (1.0 - c * c) / (eta * eta)).sqrt();
        let rs = ((c - eta * ct) / (c + eta * ct)).powi(2);
        let rp = ((eta * c - ct) / (eta * c + ct)).powi(2);
        let two_l = interfaces_from_slab_layers(l);
        let want = 0.5 * (cuticle_reflectance(two_l, rs) + cuticle_reflectance(two_l, rp));
        assert!((slab_layers_reflectance(l, eta, c) - want).abs() < 1e-14);
        if c == 1.0 {
            assert!((slab_layers_reflectance(l, eta, c) - cuticle_reflectance(two_l, fresnel(eta, c))).abs() < 1e-14);
        }
    }
}

#[test]
fn colour_maps_to_absorption_and_refuses_what_it_cannot_reach() {
    let (kappa, sigma_m_a) = (0.6, 0.3);
    let c = Rgb::new(0.5, 0.3, 0.1);
    let s = sigma_c_a_from_color(c, kappa, sigma_m_a).unwrap();
    let m = kappa * kappa.sqrt();
    for i in 0..3 {
        // −ln C = 4(1 − m)σ_c^a + 4mσ_m^a
        assert!((-c[i].ln() - (4.0 * (1.0 - m) * s[i] + 4.0 * m * sigma_m_a)).abs() < 1e-14);
    }
    let too_bright = sigma_c_a_from_color(Rgb::new(0.5, 0.95, 0.1), kappa, sigma_m_a).unwrap_err();
    assert_eq!(too_bright.key(), "color");
    let e = build("yan-fur", &[("color", "0.99"), ("sigma_m_a", "1"), ("kappa", "0.8")]).unwrap_err();
    assert!(e.to_string().contains("`color`"), "{e}");
    assert!(build("yan-fur", &[("color", "0.6,0.4,0.2")]).is_ok());
    assert!(matches!(build("yan-fur", &[("color", "0.5"), ("sigma_c_a", "1")]), Err(ModelError::Inconsistent(_))));
}

#[test]
fn bad_parameters_are_refused_naming_the_parameter() {
    for (key, value) in [
        ("kappa", "1"),
        ("kappa", "-0.1"),
        ("sigma_m_s", "-1"),
        ("sigma_m_a", "nan"),
        ("g", "1"),
        ("g", "-1"),
        ("layers", "0"),
        ("beta_m", "0"),
        ("beta_n", "61"),
        ("alpha", "25"),
        ("eta", "1"),
        ("sigma_c_a", "0.1,-0.2,0.3"),
        ("color", "0"),
    ] {
        let e = build("yan-fur", &[(key, value)]).unwrap_err();
        assert!(e.to_string().contains(&format!("`{key}`")), "{key}={value}: {e}");
    }
    // Typed construction checks the same ranges.
    let bad = YanFurParams { kappa: f64::NAN, ..YanFurParams::default() };
    assert!(matches!(YanFur::new(bad), Err(YanFurError::Parameter(p)) if p.key() == "kappa"));
    let none = YanFurParams { lobes: [false; 5], ..YanFurParams::default() };
    assert_eq!(YanFur::new(none).unwrap_err(), YanFurError::NoLobe);
    let e = build("yan-fur", &[("lobes", "r,trs")]).unwrap_err();
    assert!(e.to_string().contains("`lobes`"), "{e}");
}

/// With the medulla-scattered lobes, the lossless camera-side furnace is the sum of all five
/// lobe masses (the tables' densities integrate to their escaping fraction and to 1), and what
/// is missing is the light the model does not return: scattered on later passes and the
/// unscattered orders p ≥ 3 (both of order F²).
#[test]
fn lossless_furnace_with_the_scattered_lobes() {
    let m = fur(|p| {
        p.kappa = 0.8;
        p.sigma_m_s = 2.0;
        p.absorption = CortexAbsorption::SigmaA(Rgb::ZERO);
        p.beta_m = 8f64.to_radians();
        p.beta_n = 12f64.to_radians();
    });
    for &(theta, h) in &[(0.0, 0.0), (0.6, 0.5), (-1.1, -0.9), (0.3, 0.95)] {
        let wo = direction(theta, 0.7);
        let quad = furnace(&m, wo, h)[0];
        let b = m.energy_budget(theta, h);
        let lobes: f64 = b.lobes.iter().chain(&b.scattered_lobes).map(|a| a[0]).sum();
        assert!((quad - lobes).abs() <= 3e-3 * lobes, "θ {theta} h {h}: furnace {quad} vs Σ masses {lobes}");
        let returned: f64 = b.scattered_lobes.iter().map(|a| a[0]).sum();
        assert!(returned <= b.scattered[0] * (1.0 + 0.02), "{returned} vs {}", b.scattered[0]);
        println!(
            "θ_o {theta:5.2} h {h:5.2}: furnace {quad:.6} (1 − {:.2e}); scattered {:.6}, returned by TTs+TRTs {returned:.6}",
            1.0 - quad,
            b.scattered[0]
        );
    }
}
