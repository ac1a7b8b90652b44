//! The lobe index every `sample` reports ([`Sample::lobe`]): in range of the model's
//! [`ScatteringFunction::lobes`], consistent with the delta flag, and — for the samplers that
//! pick a lobe first — drawn with the lobe-selection probabilities, which are recomputed here
//! from the models' published attenuations (a multinomial test on many samples).

use fiberlab_check::rng::TestRng;
use fiberlab_math::frame::direction;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::hair::attenuation::hit_attenuation;
use fiberlab_scatter::marschner_2003::{LOBE_FLOOR, Lobe};
use fiberlab_scatter::measured::{DEFENSIVE, Measured, MeasuredTable};
use fiberlab_scatter::{MODELS, Model, ScatteringFunction, build};
use std::f64::consts::PI;

/// Counts of `s.lobe` over `n` samples at fixed `wo`, `h` (failed samples are not counted),
/// and the number of successful samples.
fn lobe_counts(m: &impl ScatteringFunction, wo: DVec3, h: f64, n: usize, seed: u64) -> (Vec<usize>, usize) {
    let lobes = m.lobes();
    let mut counts = vec![0; lobes.len()];
    let mut rng = TestRng::new(seed);
    let mut ok = 0;
    for _ in 0..n {
        if let Some(s) = m.sample(wo, h, rng.u4()) {
            let l = usize::from(s.lobe);
            assert!(l < lobes.len(), "lobe {l} of {} lobes", lobes.len());
            counts[l] += 1;
            ok += 1;
        }
    }
    (counts, ok)
}

/// Each count against its binomial expectation `n·p` within 5 standard deviations (and a
/// zero count for a zero probability).
fn assert_multinomial(name: &str, counts: &[usize], n: usize, expected: &[f64]) {
    assert_eq!(counts.len(), expected.len(), "{name}");
    for (l, (&c, &p)) in counts.iter().zip(expected).enumerate() {
        let mean = n as f64 * p;
        let sd = (n as f64 * p * (1.0 - p)).sqrt();
        let z = (c as f64 - mean) / sd.max(1e-300);
        assert!(
            if p == 0.0 { c == 0 } else { z.abs() < 5.0 },
            "{name}: lobe {l} drawn {c} times of {n}, expected {mean:.1} ± {sd:.1} (p = {p:.5}, z = {z:.2})"
        );
    }
}

#[test]
fn every_model_reports_a_lobe_in_range_with_its_delta_flag() {
    let variants: &[(&str, &[(&str, &str)])] = &[
        ("deon", &[("p_max", "1")]),
        ("deon", &[("p_max", "5")]),
        ("marschner", &[("glints", "off"), ("lobes", "tt,trt")]),
        ("kajiya-kay", &[("k_d", "0")]),
    ];
    let mut models: Vec<(String, Model)> =
        MODELS.iter().map(|s| (s.name.to_string(), build::<&str, &str>(s.name, &[]).unwrap())).collect();
    for (name, pairs) in variants {
        if MODELS.iter().any(|s| s.name == *name) {
            models.push((format!("{name} {pairs:?}"), build(name, pairs).unwrap()));
        }
    }
    assert!(models.len() > MODELS.len(), "the variants name registered models");
    let mut rng = TestRng::new(11);
    for (name, m) in &models {
        let lobes = m.lobes();
        assert!(!lobes.is_empty(), "{name}");
        let mut seen = vec![false; lobes.len()];
        for _ in 0..4000 {
            let (wo, h) = (rng.sphere_direction(), rng.offset());
            if let Some(s) = m.sample(wo, h, rng.u4()) {
                let l = usize::from(s.lobe);
                assert!(l < lobes.len(), "{name}: lobe {l} of {lobes:?}");
                assert_eq!(s.delta, lobes[l].delta, "{name}: delta flag of lobe {}", lobes[l].name);
                seen[l] = true;
            }
        }
        assert!(seen.iter().any(|&s| s), "{name}: no sample at all");
    }
}

#[test]
fn lobe_names_are_the_documented_ones() {
    let names = |model: &str, pairs: &[(&str, &str)]| -> Vec<&'static str> {
        build(model, pairs).unwrap().lobes().iter().map(|l| l.name).collect()
    };
    assert_eq!(names("chiang", &[]), ["R", "TT", "TRT", "TRRT+"]);
    assert_eq!(names("marschner", &[]), ["R", "TT", "TRT"]);
    assert_eq!(names("deon", &[("p_max", "3")]), ["R", "TT", "TRT", "p≥3"]);
    assert_eq!(names("deon", &[("p_max", "1")]), ["R", "p≥1"]);
    assert_eq!(names("kajiya-kay", &[]), ["diffuse", "specular"]);
    let specular = build::<&str, &str>("specular", &[]).unwrap().lobes();
    assert!(specular.iter().all(|l| l.delta), "{specular:?}");
}

/// Chiang 2016 picks lobe p with probability `Y(A_p)/Σ_q Y(A_q)` (luminance of the hit's
/// attenuations at the sample's offset h).
#[test]
fn chiang_lobe_frequencies_match_the_attenuation_shares() {
    for (theta_o, h, params) in [
        (0.3, 0.2, vec![]),
        (-1.1, -0.7, vec![("eumelanin", "0.2")]),
        (0.0, 0.9, vec![("sigma_a", "0"), ("beta_m", "0.6")]),
    ] {
        let Model::Chiang(m) = build("chiang", &params).unwrap() else { panic!() };
        let wo = direction(theta_o, 0.4);
        let hit = hit_attenuation(m.params().eta, m.sigma_a(), theta_o.sin(), theta_o.cos(), h);
        let y = hit.a.map(Rgb::luminance);
        let total: f64 = y.iter().sum();
        let expected = y.map(|x| x / total);
        let (counts, n) = lobe_counts(&m, wo, h, 200_000, 3);
        assert!(n > 199_000, "chiang θ_o {theta_o}: {n} successful samples");
        assert_multinomial(&format!("chiang θ_o {theta_o} h {h} {params:?}"), &counts, n, &expected);
    }
}

/// Marschner 2003's sampler picks lobe p with probability proportional to the h-averaged
/// attenuation `½∫A_p(h, θ_r) dh` (luminance, floored at [`LOBE_FLOOR`] of the total), here
/// by a midpoint rule in h at a θ_r of its 64-interval table; glints off.
#[test]
fn marschner_lobe_frequencies_match_the_attenuation_shares() {
    for (k, pairs) in [(20, vec![("glints", "off")]), (45, vec![("glints", "off"), ("sigma_a", "0.1,0.2,0.4")])] {
        let Model::Marschner(m) = build("marschner", &pairs).unwrap() else { panic!() };
        let theta_r = PI / 2.0 * f64::from(k) / 64.0;
        let nodes = 4096;
        let mut w = [0.0; 3];
        for (p, lobe) in Lobe::ALL.into_iter().enumerate() {
            w[p] = (0..nodes)
                .map(|j| {
                    let h = -1.0 + (j as f64 + 0.5) * 2.0 / nodes as f64;
                    m.attenuation(lobe, h, theta_r).luminance()
                })
                .sum::<f64>()
                / nodes as f64;
        }
        let total: f64 = w.iter().sum();
        let w = w.map(|x| x.max(LOBE_FLOOR * total));
        let sum: f64 = w.iter().sum();
        let expected = w.map(|x| x / sum);
        let (counts, n) = lobe_counts(&m, direction(theta_r, 1.0), 0.0, 200_000, 4);
        assert!(n > 190_000, "marschner θ_r {theta_r}: {n} successful samples");
        assert_multinomial(&format!("marschner θ_r {theta_r:.3} {pairs:?}"), &counts, n, &expected);
    }
}

/// A measured table at normal incidence seen from θ_o = 0 has no bin beyond the pole, so the
/// ideal diffuse lobe is drawn exactly for the defensive fraction [`DEFENSIVE`].
#[test]
fn measured_draws_its_diffuse_lobe_for_the_defensive_fraction() {
    let (nt, np) = (16, 16);
    let f = (0..nt * np).map(|b| Rgb::splat(0.02 + 0.01 * (b % 7) as f64)).collect();
    let m = Measured::new(MeasuredTable { theta_in: vec![0.0], bins_theta: nt, bins_phi: np, f: vec![f] }).unwrap();
    let (counts, n) = lobe_counts(&m, direction(0.0, 0.5), 0.0, 100_000, 5);
    assert_multinomial("measured", &counts, n, &[1.0 - DEFENSIVE, DEFENSIVE]);
}
