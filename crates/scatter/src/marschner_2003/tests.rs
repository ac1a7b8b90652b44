use super::*;
use crate::ScatteringFunction;
use crate::build;
use crate::hair::attenuation::PathLength;
use crate::hair::normal_plane::{NormalPlane, RootMode};
use crate::radiometry::Quadrature;
use approx::assert_relative_eq;
use fiberlab_math::frame::direction;
use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, sin_theta, wrap_pi};
use fiberlab_math::fresnel;
use fiberlab_math::{DVec3, Rgb};
use proptest::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

use fiberlab_check::rng::TestRng;

fn model(edit: impl FnOnce(&mut MarschnerParams)) -> Marschner {
    let mut p = MarschnerParams::default();
    edit(&mut p);
    Marschner::new(p).unwrap()
}

fn random_direction(rng: &mut impl FnMut() -> f64) -> DVec3 {
    let s: f64 = 2.0 * rng() - 1.0;
    direction_from_sin_cos(s, (1.0 - s * s).sqrt(), TAU * rng())
}

/// Tanh–sinh quadrature of `f` on [a, b] (handles integrable end-point singularities).
fn tanh_sinh(f: &impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    let half = 0.5 * (b - a);
    let h = 1.0 / 32.0;
    let mut sum = 0.0;
    for k in -100i32..=100 {
        let t = k as f64 * h;
        let u = FRAC_PI_2 * t.sinh();
        // distance of the node from the nearer end, in units of `half`: 1 − tanh|u|
        let comp = 2.0 / ((2.0 * u.abs()).exp() + 1.0);
        let x = if t >= 0.0 { b - half * comp } else { a + half * comp };
        // Nodes closer than 1e−12·half to an end are dropped: there the two roots merging at a
        // caustic are not resolvable in double precision (the neglected mass is O(1e−6)·N).
        if comp < 1e-12 || x <= a || x >= b {
            continue;
        }
        let w = FRAC_PI_2 * t.cosh() / u.cosh().powi(2);
        sum += w * f(x);
    }
    half * h * sum
}

/// Exact exit azimuth, written independently of the model: Φ = 2p·asin(h/η′) − 2asin h + pπ.
fn phi_exact(p: usize, h: f64, eta_prime: f64) -> f64 {
    2.0 * p as f64 * (h / eta_prime).asin() - 2.0 * h.asin() + p as f64 * PI
}

/// The paper's cubic: γ_t ≈ (3c/π)γ − (4c/π³)γ³, c = asin(1/η′).
fn phi_cubic(p: usize, h: f64, eta_prime: f64) -> f64 {
    let c = (1.0 / eta_prime).asin();
    let g = h.asin();
    let gt = 3.0 * c / PI * g - 4.0 * c / PI.powi(3) * g.powi(3);
    2.0 * p as f64 * gt - 2.0 * g + p as f64 * PI
}

fn eta_prime_of(eta: f64, theta_d: f64) -> f64 {
    (eta * eta - theta_d.sin().powi(2)).sqrt() / theta_d.cos()
}

#[test]
fn registry_builds_and_rejects_bad_parameters() {
    build("marschner", &[("roots", "cubic"), ("lobes", "tt,trt"), ("eccentricity", "0.85")]).unwrap();
    let e = build("marschner", &[("eta", "NaN")]).unwrap_err();
    assert!(e.to_string().contains("`eta`"), "{e}");
    let e = build("marschner", &[("eccentricity", "0.5")]).unwrap_err();
    assert!(e.to_string().contains("`eccentricity`") && e.to_string().contains("[0.75, 1]"), "{e}");
    assert!(build("marschner", &[("lobes", "r,xx")]).is_err());
    assert!(build("marschner", &[("beta_r", "0")]).is_err());
    for (k, v) in
        [("beta_r", "1"), ("beta_r", "20"), ("alpha_r", "20"), ("alpha_r", "-20"), ("w_c", "1"), ("w_c", "45")]
    {
        build("marschner", &[(k, v)]).unwrap_or_else(|e| panic!("{k}={v}: {e}"));
    }
    assert!(Marschner::new(MarschnerParams { lobes: [false; 3], ..Default::default() }).is_err());
    assert!(
        Marschner::new(MarschnerParams { sigma_a: Rgb::new(0.1, f64::INFINITY, 0.1), ..Default::default() }).is_err()
    );
}

#[test]
fn reciprocity_on_random_pairs() {
    let variants = [
        model(|_| {}),
        model(|p| p.eccentricity = 0.85),
        model(|p| {
            p.eccentricity = 0.9;
            p.roots = RootMode::Cubic;
            p.absorption = PathLength::Paper;
        }),
        model(|p| p.glints = false),
    ];
    let mut rng = TestRng::new(11).into_uniforms();
    for m in &variants {
        for _ in 0..3000 {
            let (wi, wr) = (random_direction(&mut rng), random_direction(&mut rng));
            let (a, b) = (m.eval(wi, wr, 0.0), m.eval(wr, wi, 0.0));
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-9 * a[c].abs().max(b[c].abs()) + 1e-300, "{a:?} vs {b:?}");
            }
        }
    }
    // The eccentric correction really changes TRT (so the test above exercised it).
    let (circ, ecc) = (
        model(|p| p.lobes = [false, false, true]),
        model(|p| {
            p.lobes = [false, false, true];
            p.eccentricity = 0.85;
        }),
    );
    let (wi, wr) = (direction(0.2, 0.3), direction(-0.1, 0.5));
    assert!((circ.eval(wi, wr, 0.0)[0] - ecc.eval(wi, wr, 0.0)[0]).abs() > 1e-3 * circ.eval(wi, wr, 0.0)[0]);
}

#[test]
fn azimuthal_integral_equals_half_attenuation_integral() {
    for mode in [RootMode::Exact, RootMode::Cubic] {
        let m = model(|p| {
            p.glints = false;
            p.roots = mode;
        });
        for &theta_d in &[0.0, 0.5, 1.2, 1.55] {
            let ep = eta_prime_of(1.55, theta_d);
            let phi_of = |p: usize, h: f64| {
                wrap_pi(if mode == RootMode::Exact { phi_exact(p, h, ep) } else { phi_cubic(p, h, ep) })
            };
            for lobe in Lobe::ALL {
                let p = lobe.p();
                // Break points: image ends and the stationary point of Φ (found on a grid).
                let mut breaks = vec![-PI, 0.0, PI];
                let e = phi_of(p, 1.0);
                breaks.extend([e, -e]);
                let (mut best, mut hs) = (f64::MIN, 0.0);
                for k in 0..=200_000 {
                    let h = k as f64 / 200_000.0;
                    let v = phi_of(p, h);
                    if p == 2 && v > best {
                        best = v;
                        hs = h;
                    }
                }
                if p == 2 && hs > 0.0 && hs < 1.0 {
                    // refine the maximum by golden-section search
                    let (mut a, mut b) = ((hs - 1e-5).max(0.0), (hs + 1e-5).min(1.0));
                    for _ in 0..100 {
                        let (c, d) = (b - 0.618 * (b - a), a + 0.618 * (b - a));
                        if phi_of(p, c) > phi_of(p, d) { b = d } else { a = c }
                    }
                    let pc = phi_of(p, 0.5 * (a + b));
                    breaks.extend([pc, -pc]);
                }
                breaks.sort_by(|a, b| a.partial_cmp(b).unwrap());
                breaks.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
                let n = |x: f64| m.azimuthal(lobe, theta_d, x, 1.0).luminance();
                let integral: f64 = breaks.windows(2).map(|w| tanh_sinh(&n, w[0], w[1])).sum();
                // Direct h-integration of ½∫A dh (midpoint, 400 000 cells).
                let cells = 400_000;
                let dh = 2.0 / cells as f64;
                let direct: f64 = (0..cells)
                    .map(|k| m.attenuation(lobe, -1.0 + (k as f64 + 0.5) * dh, theta_d).luminance() * dh)
                    .sum::<f64>()
                    * 0.5;
                assert_relative_eq!(integral, direct, max_relative = 1e-5);
            }
        }
    }
}

#[test]
fn r_lobe_without_fresnel_is_cos_half_phi_over_four() {
    for mode in [RootMode::Exact, RootMode::Cubic] {
        let mut m = model(|p| p.roots = mode);
        m.fresnel = false;
        for &theta_d in &[0.0, 0.7, -1.3, FRAC_PI_2] {
            for k in 0..=40 {
                let phi = -PI + TAU * k as f64 / 40.0;
                let n = m.azimuthal(Lobe::R, theta_d, phi, 1.0);
                assert_relative_eq!(n[1], (0.5 * phi).cos().abs() / 4.0, epsilon = 1e-14);
            }
        }
    }
}

/// 3D ray tracing of TRT through a unit cylinder along x (vector Snell, no Bravais):
/// returns the relative exit azimuths |φ| for `n` stratified offsets.
fn trace_trt(eta: f64, theta_d: f64, n: usize) -> Vec<f64> {
    let refract = |d: DVec3, normal: DVec3, ratio: f64| -> DVec3 {
        // `normal` faces against d; ratio = n_from/n_to
        let cos_i = -d.dot(normal);
        let k = 1.0 - ratio * ratio * (1.0 - cos_i * cos_i);
        assert!(k >= 0.0);
        d * ratio + normal * (ratio * cos_i - k.sqrt())
    };
    let chord = |p: DVec3, d: DVec3| -> DVec3 {
        // next intersection with y² + z² = 1 from a point on it
        let s = -2.0 * (p.y * d.y + p.z * d.z) / (d.y * d.y + d.z * d.z);
        p + d * s
    };
    let radial = |p: DVec3| DVec3::new(0.0, p.y, p.z).normalize();
    // Light at inclination θ_i = −θ_d, azimuth 0; the ray travels along −ω_i.
    let wi = direction(-theta_d, 0.0);
    let d0 = -wi;
    (0..n)
        .map(|k| {
            let h = -1.0 + 2.0 * (k as f64 + 0.5) / n as f64;
            let p0 = DVec3::new(0.0, (1.0 - h * h).sqrt(), h);
            let d1 = refract(d0, radial(p0), 1.0 / eta);
            let p1 = chord(p0, d1);
            let nr = radial(p1);
            let d2 = d1 - nr * (2.0 * d1.dot(nr));
            let p2 = chord(p1, d2);
            let d3 = refract(d2, -radial(p2), eta);
            assert!((d3.x - d0.x).abs() < 1e-12, "axial component is conserved");
            wrap_pi(phi(d3) - phi(wi)).abs()
        })
        .collect()
}

#[test]
fn exact_caustic_matches_ray_traced_histogram() {
    // Worked values (η = 1.55, from the closed forms of the caustic): exact φ_c 18.62° (θ_d = 0), 10.02° (0.5);
    // cubic 20.49°, 11.07°.
    let rows = caustic_table(1.55, 0.3, &[0.0, 0.5]);
    assert!((rows[0].exact.phi_c.to_degrees() - 18.62).abs() < 0.006);
    assert!((rows[0].exact.h_c - 0.7297).abs() < 1e-4);
    assert!((rows[0].exact.d2phi_dh2 + 3.424).abs() < 1e-3);
    assert!((rows[0].cubic.phi_c.to_degrees() - 20.49).abs() < 0.006);
    assert!((rows[0].cubic.h_c - 0.7108).abs() < 1e-4);
    assert!((rows[0].cubic.d2phi_dh2 + 3.469).abs() < 1e-3);
    assert!((rows[1].exact.phi_c.to_degrees() - 10.02).abs() < 0.006);
    assert!((rows[1].exact.h_c - 0.6269).abs() < 1e-4);
    assert!((rows[1].cubic.phi_c.to_degrees() - 11.07).abs() < 0.006);
    assert!((rows[1].cubic.h_c - 0.6167).abs() < 1e-4);

    let m = model(|p| p.glints = false);
    for (row, &theta_d) in rows.iter().zip(&[0.0, 0.5]) {
        let exits = trace_trt(1.55, theta_d, 2_000_000);
        let bin = 0.05f64.to_radians();
        let bins = (PI / bin) as usize + 1;
        let mut hist = vec![0usize; bins];
        for x in &exits {
            hist[(x / bin) as usize] += 1;
        }
        let peak = (0..bins).max_by_key(|&i| hist[i]).unwrap();
        let centre = (peak as f64 + 0.5) * bin;
        assert!(
            (centre - row.exact.phi_c).abs() <= bin,
            "peak {} vs {}",
            centre.to_degrees(),
            row.exact.phi_c.to_degrees()
        );
        // Away from the caustic, the histogram density equals the model's h-map density
        // (N_TRT with A ≡ 1), summed over ±φ.
        let (s, c) = theta_d.sin_cos();
        let plane = NormalPlane::new(1.55, s, c, RootMode::Exact);
        for (i, &count) in hist.iter().enumerate() {
            let x = (i as f64 + 0.5) * bin;
            if x > row.exact.phi_c - 1f64.to_radians() {
                break;
            }
            let model_density =
                Marschner::h_map_density(&plane, Lobe::TRT, x) + Marschner::h_map_density(&plane, Lobe::TRT, -x);
            let hist_density = count as f64 / (exits.len() as f64 * bin);
            assert!(
                (hist_density - model_density).abs() < 0.01 * model_density + 2e-3,
                "{x} {hist_density} {model_density}"
            );
        }
        let _ = &m;
    }
}

#[test]
fn cubic_versus_exact_azimuth_table() {
    let eps = [1.55, 1.8, 2.5, 10.0, 1e6];
    let hs: Vec<f64> = (0..=20).map(|k| -1.0 + 0.1 * k as f64).collect();
    let table = cubic_azimuth_error_table(&eps, &hs);
    assert_eq!(table.len(), 2 * eps.len() * hs.len());
    let mut worst = [0.0f64; 3];
    for r in &table {
        assert_relative_eq!(r.phi_exact, wrap_pi(phi_exact(r.p, r.h, r.eta_prime)), epsilon = 1e-12);
        assert_relative_eq!(r.phi_cubic, wrap_pi(phi_cubic(r.p, r.h, r.eta_prime)), epsilon = 1e-12);
        if r.h.abs() < 1e-12 || (r.h.abs() - 1.0).abs() < 1e-12 {
            // the cubic interpolates γ_t at γ = 0 and ±π/2
            assert!(r.error.abs() < 1e-12, "{r:?}");
        }
        worst[r.p] = worst[r.p].max(r.error.abs());
    }
    eprintln!("max |cubic − exact| (deg): TT {:.3}, TRT {:.3}", worst[1].to_degrees(), worst[2].to_degrees());
    assert!(worst[1] > 0.0 && worst[2] > 0.0 && worst[2].to_degrees() < 10.0);
}

/// Points where the sampling density in φ (relative azimuth) may be singular or kinked
/// for the circular index η at θ_d, from the test's own Φ: 0, ±π, the ends of the TT and
/// TRT images and the TRT caustic ±φ_c.
fn phi_breaks(eta: f64, theta_d: f64, mode: RootMode) -> Vec<f64> {
    let ep = eta_prime_of(eta, theta_d);
    let phi_of =
        |p: usize, h: f64| wrap_pi(if mode == RootMode::Exact { phi_exact(p, h, ep) } else { phi_cubic(p, h, ep) });
    let mut b = vec![-PI, 0.0, PI];
    for p in 1..=2 {
        let e = phi_of(p, 1.0);
        b.extend([e, -e]);
    }
    if ep < 2.0 {
        let h_c = match mode {
            RootMode::Exact => ((4.0 - ep * ep) / 3.0).sqrt(),
            RootMode::Cubic => {
                let c = (1.0 / ep).asin();
                ((12.0 * c / PI - 2.0) / (48.0 * c / PI.powi(3))).sqrt().sin()
            }
        };
        let pc = phi_of(2, h_c);
        b.extend([pc, -pc]);
    }
    b.retain(|x| x.is_finite());
    b.sort_by(|a, b| a.partial_cmp(b).unwrap());
    b
}

/// `∫_a^b f` by tanh–sinh on the pieces of [a, b] cut at `breaks`.
fn piecewise_integral(f: &impl Fn(f64) -> f64, a: f64, b: f64, breaks: &[f64]) -> f64 {
    let mut lo = a;
    let mut sum = 0.0;
    for &x in breaks.iter().filter(|&&x| x > a + 1e-12 && x < b - 1e-12) {
        sum += tanh_sinh(f, lo, x);
        lo = x;
    }
    sum + tanh_sinh(f, lo, b)
}

/// Gauss–Legendre nodes and weights on [−1, 1], 8 points (positive half).
const GAUSS_LEGENDRE_8: [(f64, f64); 4] = [
    (0.1834346424956498, 0.362683783378362),
    (0.525532409916329, 0.3137066458778873),
    (0.7966664774136267, 0.2223810344533745),
    (0.9602898564975363, 0.1012285362903763),
];

/// `∫∫ pdf·cosθ_i dθ_i dφ` over the bins of `theta_edges × phi_edges` (row-major):
/// 8-point Gauss–Legendre on each of `sub` equal parts of a θ_i bin, piecewise tanh–sinh
/// in φ.
fn binned_pdf_mass(m: &Marschner, wo: DVec3, theta_edges: &[f64], sub: usize, phi_edges: &[f64]) -> Vec<f64> {
    let theta_r = sin_theta(wo).atan2(cos_theta(wo));
    let np = phi_edges.len() - 1;
    let mut out = vec![0.0; (theta_edges.len() - 1) * np];
    let nodes: Vec<(f64, f64)> = GAUSS_LEGENDRE_8.iter().flat_map(|&(x, w)| [(-x, w), (x, w)]).collect();
    for (i, te) in theta_edges.windows(2).enumerate() {
        let part = (te[1] - te[0]) / sub as f64;
        for (r, &(x, w)) in (0..sub).flat_map(|r| nodes.iter().map(move |n| (r, n))) {
            let t = te[0] + part * (r as f64 + 0.5 + 0.5 * x);
            let dt = 0.5 * part * w;
            let (s, c) = t.sin_cos();
            let breaks = phi_breaks(m.params.eta, 0.5 * (theta_r - t), m.params.roots);
            let q = |x: f64| m.pdf(direction_from_sin_cos(s, c, phi(wo) - x), wo, 0.0) * c;
            for (k, e) in phi_edges.windows(2).enumerate() {
                out[i * np + k] += piecewise_integral(&q, e[0], e[1], &breaks) * dt;
            }
        }
    }
    out
}

fn sampling_variants() -> [Marschner; 3] {
    [
        model(|_| {}),
        model(|p| {
            p.eccentricity = 0.8;
            p.roots = RootMode::Cubic;
            p.sigma_a = Rgb::ZERO;
        }),
        model(|p| {
            p.glints = false;
            p.lobes = [false, true, true];
            p.beta_r = 3f64.to_radians();
        }),
    ]
}

/// The TRT pdf integrates to 1 on a plain grid that knows nothing of the caustic (midpoint
/// rule in φ; Gauss–Legendre in θ_i as in [`binned_pdf_mass`]), as Mitsuba's χ² harness
/// integrates it: fails if the sampling density is infinite on the caustic (a node near
/// ±φ_c then over- or under-counts by ~1e−2, measured before the sampler smoothed it).
#[test]
fn trt_pdf_integrates_to_one_on_a_plain_grid() {
    let nodes: Vec<(f64, f64)> = GAUSS_LEGENDRE_8.iter().flat_map(|&(x, w)| [(-x, w), (x, w)]).collect();
    for glints in [false, true] {
        let m = model(|p| {
            p.lobes = [false, false, true];
            p.glints = glints;
        });
        for &t in &[0.0, 0.6, -1.0, 1.45, 1.56] {
            let wo = direction(t, 0.7);
            let (parts, n_phi) = (24, 720);
            let part = PI / parts as f64;
            let mut total = 0.0;
            for (r, &(x, w)) in (0..parts).flat_map(|r| nodes.iter().map(move |n| (r, n))) {
                let ti = -FRAC_PI_2 + part * (r as f64 + 0.5 + 0.5 * x);
                let (s, c) = ti.sin_cos();
                let row: f64 = (0..n_phi)
                    .map(|k| {
                        let x = -PI + TAU * (k as f64 + 0.5) / n_phi as f64;
                        m.pdf(direction_from_sin_cos(s, c, phi(wo) - x), wo, 0.0) * c
                    })
                    .sum();
                total += row * TAU / n_phi as f64 * 0.5 * part * w;
            }
            assert!((total - 1.0).abs() < 1e-3, "glints {glints}, θ_r = {t}: ∫pdf on the grid = {total}");
        }
    }
}

#[test]
fn pdf_integrates_to_one() {
    for m in sampling_variants() {
        for &t in &[0.3, -1.0, 1.45] {
            let wo = direction(t, 0.7);
            let total: f64 = binned_pdf_mass(&m, wo, &[-FRAC_PI_2, FRAC_PI_2], 24, &[-PI, PI]).iter().sum();
            assert!((total - 1.0).abs() < 1e-3, "θ_r = {t}: ∫pdf = {total}");
        }
    }
}

#[test]
fn albedo_for_both_normalizations() {
    let q = Quadrature { theta: 360, phi: 720, h: 1 };
    // Narrow lobes, no shift, σ_a = 0, no glints: ρ_energy(θ_i) ≈ Σ_p ½∫A_p(h; θ_d = θ_i) dh
    // (direct h-integration), and ρ_paper ≈ twice that (k_M = 1 vs ½).
    let narrow = MarschnerParams {
        sigma_a: Rgb::ZERO,
        glints: false,
        beta_r: 2f64.to_radians(),
        alpha_r: 0.0,
        ..Default::default()
    };
    let reference = Marschner::new(narrow.clone()).unwrap();
    let thetas = [0.0, 0.3, 0.6, 0.9, 1.2, 1.45, 1.52];
    for row in albedo_table(&narrow, &thetas, &q).unwrap() {
        let cells = 20_000;
        let dh = 2.0 / cells as f64;
        let expected: f64 = Lobe::ALL
            .iter()
            .map(|&l| {
                (0..cells)
                    .map(|k| reference.attenuation(l, -1.0 + (k as f64 + 0.5) * dh, row.theta_i)[0] * dh)
                    .sum::<f64>()
                    * 0.5
            })
            .sum();
        assert!(row.energy[0] <= 1.0 + 5e-3, "{row:?}");
        if row.theta_i <= 0.95 {
            assert_relative_eq!(row.energy[0], expected, max_relative = 0.015);
            assert_relative_eq!(row.paper[0], 2.0 * expected, max_relative = 0.015);
        }
    }
    // Table 1 widths and shifts: the shifted lobes leave the cone θ_r = −θ_i, where
    // cos²θ_r/cos²θ_d ≠ 1, so ρ_energy exceeds 1 by a few percent (measured 1.05 at
    // θ_i ≈ 1 rad); bounded here with tolerance 0.07 up to θ_i = 1.55.
    let default = MarschnerParams { sigma_a: Rgb::ZERO, glints: false, ..Default::default() };
    for row in albedo_table(&default, &[0.0, 1.0, 1.55], &q).unwrap() {
        assert!(row.energy[0] <= 1.07 && row.energy[0] > 0.85, "{row:?}");
    }
}

#[test]
fn sample_agrees_with_pdf_and_eval() {
    let mut rng = TestRng::new(5).into_uniforms();
    for m in sampling_variants() {
        let mut produced = 0;
        for _ in 0..20_000 {
            let wo = random_direction(&mut rng);
            let u = [rng(), rng(), rng(), rng()];
            let Some(s) = m.sample(wo, 0.0, u) else { continue };
            produced += 1;
            assert!((s.wi.length() - 1.0).abs() < 1e-12 && !s.delta);
            let pdf = m.pdf(s.wi, wo, 0.0);
            assert_relative_eq!(s.pdf, pdf, max_relative = 1e-12);
            let expected = m.eval(s.wi, wo, 0.0) * (cos_theta(s.wi) / pdf);
            for c in 0..3 {
                assert!(
                    (s.weight[c] - expected[c]).abs() <= 1e-9 * expected[c].abs() + 1e-300,
                    "{:?} {:?} wo {wo:?} wi {:?} pdf {} cos {}",
                    s.weight,
                    expected,
                    s.wi,
                    pdf,
                    cos_theta(s.wi)
                );
            }
        }
        assert!(produced > 19_900, "{produced}");
    }
}

#[test]
fn glint_fade_is_continuous_across_eta_prime_two() {
    // η′ = 2 at sin²θ_d = (4 − η²)/3 (θ_d ≈ 46.9° for η = 1.55).
    let theta_2 = ((4.0 - 1.55f64.powi(2)) / 3.0).sqrt().asin();
    assert_relative_eq!(eta_prime_of(1.55, theta_2), 2.0, epsilon = 1e-12);
    let m = model(|p| p.lobes = [false, false, true]);
    for &phi in &[0.0, 0.05, 0.2, 0.5, -1.0] {
        let below = m.azimuthal(Lobe::TRT, theta_2 - 1e-7, phi, 1.0)[0];
        let above = m.azimuthal(Lobe::TRT, theta_2 + 1e-7, phi, 1.0)[0];
        assert!((below - above).abs() < 1e-3 * below.abs().max(above.abs()) + 1e-9, "{phi}: {below} {above}");
    }
    // Far above, t = 0: the glint term is gone and N_TRT equals N_P.
    // η′ = 2.35 > 2 + Δη′ at sin²θ_d = (η′² − η²)/(η′² − 1).
    let td = ((2.35f64.powi(2) - 1.55f64.powi(2)) / (2.35f64.powi(2) - 1.0)).sqrt().asin();
    let no_glints = model(|p| {
        p.lobes = [false, false, true];
        p.glints = false;
    });
    assert_relative_eq!(eta_prime_of(1.55, td), 2.35, epsilon = 1e-12);
    assert_relative_eq!(m.azimuthal(Lobe::TRT, td, 0.1, 1.0)[1], no_glints.azimuthal(Lobe::TRT, td, 0.1, 1.0)[1]);
}

#[test]
fn r_lobe_peaks_toward_the_root() {
    // θ_i = 0, φ = 0 (backscatter), R only: S peaks at θ_r = 2α_R = −15° (toward the root).
    let m = model(|p| p.lobes = [true, false, false]);
    let wi = direction(0.0, 0.0);
    let (best, _) = (0..=1800)
        .map(|k| -0.5 + k as f64 * 1e-3 / 1.8)
        .map(|t| (t, m.eval(wi, direction(t, 0.0), 0.0)[0]))
        .fold((0.0, f64::MIN), |a, b| if b.1 > a.1 { b } else { a });
    // cos²θ_d and N_R(θ_d) also vary with θ_r, so allow 1°.
    assert!((best - (-15f64).to_radians()).abs() < 1f64.to_radians(), "{}", best.to_degrees());
}

/// Prints `∫pdf dω` for the sampling variants (the tables are printed by `cargo run -p
/// fiberlab-scatter --release --example marschner_report`): `cargo test -p fiberlab-scatter
/// --release pdf_mass_report -- --ignored --nocapture`.
#[test]
#[ignore]
fn pdf_mass_report() {
    for (i, m) in sampling_variants().iter().enumerate() {
        for &t in &[0.3, -1.0, 1.45] {
            let total: f64 =
                binned_pdf_mass(m, direction(t, 0.7), &[-FRAC_PI_2, FRAC_PI_2], 24, &[-PI, PI]).iter().sum();
            eprintln!("∫pdf dω, variant {i}, θ_r = {t}: {total:.6}");
        }
    }
}

#[test]
fn attenuation_matches_chord_and_printed_path_lengths() {
    // Independent 3D computation at θ_d = 0.6, h = 0.4: the refracted ray's internal
    // chord between the two surface hits, and the paper's printed 2(1 + cos2γ_t)/cosθ_t.
    let (eta, theta_d, h) = (1.55, 0.6f64, 0.4f64);
    let sigma = Rgb::new(0.3, 0.7, 1.1);
    let d0 = -direction(-theta_d, 0.0);
    let n0 = DVec3::new(0.0, (1.0 - h * h).sqrt(), h);
    let cos_i = -d0.dot(n0);
    let r = 1.0 / eta;
    let d1 = d0 * r + n0 * (r * cos_i - (1.0 - r * r * (1.0 - cos_i * cos_i)).sqrt());
    let chord = -2.0 * (n0.y * d1.y + n0.z * d1.z) / (d1.y * d1.y + d1.z * d1.z); // |d1| = 1
    let f = fresnel::dielectric(cos_i, eta);
    let gamma_t = (h * theta_d.cos() / (eta * eta - theta_d.sin().powi(2)).sqrt()).asin();
    let cos_theta_t = (1.0 - (theta_d.sin() / eta).powi(2)).sqrt();
    let printed = 2.0 * (1.0 + (2.0 * gamma_t).cos()) / cos_theta_t;
    for (absorption, length) in [(PathLength::Chord, chord), (PathLength::Paper, printed)] {
        let m = model(|p| {
            p.sigma_a = sigma;
            p.absorption = absorption;
        });
        let t = (sigma * -length).exp();
        let expected = [Rgb::splat(f), t * (1.0 - f).powi(2), t * t * (1.0 - f).powi(2) * f];
        for lobe in Lobe::ALL {
            let a = m.attenuation(lobe, h, theta_d);
            for c in 0..3 {
                assert_relative_eq!(a[c], expected[lobe.p()][c], max_relative = 1e-12);
            }
        }
    }
    assert!((printed - chord).abs() > 0.1, "the two path lengths differ: {printed} vs {chord}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]
    #[test]
    fn finite_and_non_negative_everywhere(
        ti in prop_oneof![Just(FRAC_PI_2), Just(-FRAC_PI_2), Just(0.0), -FRAC_PI_2..FRAC_PI_2],
        tr in prop_oneof![Just(FRAC_PI_2), Just(-FRAC_PI_2), Just(FRAC_PI_2 - 1e-9), -FRAC_PI_2..FRAC_PI_2],
        pi in -PI..PI,
        pr in prop_oneof![Just(0.0), -PI..PI],
        a in prop_oneof![Just(1.0), 0.75..1.0],
        zero_sigma in any::<bool>(),
        cubic in any::<bool>(),
        glints in any::<bool>(),
        u in prop::array::uniform4(0.0..1.0f64),
    ) {
        let m = model(|p| {
            p.eccentricity = a;
            if zero_sigma { p.sigma_a = Rgb::ZERO; }
            if cubic { p.roots = RootMode::Cubic; }
            p.glints = glints;
        });
        let (wi, wo) = (direction(ti, pi), direction(tr, pi + pr));
        let f = m.eval(wi, wo, 0.0);
        prop_assert!(f.is_finite() && f.min_component() >= 0.0, "{f:?}");
        let pdf = m.pdf(wi, wo, 0.0);
        prop_assert!(pdf.is_finite() && pdf >= 0.0, "{pdf}");
        if let Some(s) = m.sample(wo, 0.0, u) {
            prop_assert!(s.weight.is_finite() && s.weight.min_component() >= 0.0 && s.pdf.is_finite() && s.pdf > 0.0);
        }
    }

    #[test]
    fn finite_and_consistent_over_the_parameter_ranges(
        eta in 1.001f64..4.0,
        alpha in -20.0f64..20.0,
        beta in 1.0f64..20.0,
        w_c in 1.0f64..45.0,
        k_g in 0.0f64..10.0,
        a in 0.75f64..1.0,
        sigma in 0.0f64..50.0,
        cubic in any::<bool>(),
        ti in -FRAC_PI_2..FRAC_PI_2,
        tr in -FRAC_PI_2..FRAC_PI_2,
        dphi in -PI..PI,
        u in prop::array::uniform4(0.0..1.0f64),
    ) {
        let m = model(|p| {
            p.eta = eta;
            p.alpha_r = alpha.to_radians();
            p.beta_r = beta.to_radians();
            p.w_c = w_c.to_radians();
            p.k_g = k_g;
            p.eccentricity = a;
            p.sigma_a = Rgb::new(sigma, 0.5 * sigma, 0.0);
            if cubic { p.roots = RootMode::Cubic; }
        });
        let (wi, wo) = (direction(ti, 0.4), direction(tr, 0.4 + dphi));
        let f = m.eval(wi, wo, 0.0);
        prop_assert!(f.is_finite() && f.min_component() >= 0.0, "{f:?}");
        let pdf = m.pdf(wi, wo, 0.0);
        prop_assert!(pdf.is_finite() && pdf >= 0.0);
        if let Some(s) = m.sample(wo, 0.0, u) {
            prop_assert!(s.weight.is_finite() && s.weight.min_component() >= 0.0);
            let p2 = m.pdf(s.wi, wo, 0.0);
            prop_assert!((s.pdf - p2).abs() <= 1e-12 * p2, "{} vs {}", s.pdf, p2);
        }
    }
}
