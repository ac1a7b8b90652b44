//! Tests of the medulla tables (`hair::medulla`): the walk against the closed-form scattered
//! fraction, energy without absorption, slice integrals, the (h', φ) symmetry, the effect of
//! the phase function's anisotropy, the thin-medium limit (exit azimuths and inclinations)
//! against an independent single-scattering quadrature, the plain analog walk against the
//! tables (escape, azimuths, inclination profiles), determinism across thread counts, χ² of
//! the samplers against their densities, and bad input.

use fiberlab_check::chi2::{Chi2Config, chi2_test};
use fiberlab_math::frame::{direction_from_sin_cos, phi, theta};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::hair::medulla::{
    MedullaError, MedullaParams, MedullaTables, Resolution, SMALL_DEPOSIT, trace_walks,
};
use fiberlab_scatter::params::ParameterError;
use fiberlab_scatter::{Field, Lobes, Properties, Sample, ScatteringFunction};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::Arc;

fn params(sigma_s: f64, sigma_a: f64, g: f64) -> MedullaParams {
    MedullaParams::new(sigma_s, Rgb::new(sigma_a, 2.0 * sigma_a, 3.0 * sigma_a), g).unwrap()
}

fn small(walks: usize) -> Resolution {
    Resolution { inclinations: 3, offsets: 9, walks: Some(walks), ..Resolution::default() }
}

/// `1 − exp(−σ_s·2√(1 − h²)/cosθ)`, written out here.
fn closed_form_scattered(sigma_s: f64, theta_t: f64, h: f64) -> f64 {
    1.0 - (-sigma_s * 2.0 * (1.0 - h * h).sqrt() / theta_t.cos()).exp()
}

#[test]
fn analog_walk_scatters_with_the_closed_form_probability() {
    let p = params(1.3, 0.0, 0.3);
    let rays = 40_000;
    for (theta_t, h) in [(0.0, 0.0), (0.4, 0.5), (-0.7, -0.9), (0.2, 0.99)] {
        let mut exits = 0u64;
        let counts = trace_walks(&p, theta_t, h, rays, 11, |_| exits += 1);
        let s = closed_form_scattered(1.3, theta_t, h);
        let measured = counts.scattered as f64 / rays as f64;
        let sd = (s * (1.0 - s) / rays as f64).sqrt();
        assert!((measured - s).abs() < 4.0 * sd + 1e-12, "θ_t {theta_t} h {h}: {measured} vs {s} (σ {sd})");
        assert_eq!(counts.scattered, exits);
        assert_eq!(counts.scattered + counts.unscattered, rays as u64, "{counts:?}");
    }
    let t = MedullaTables::new(&p, &small(64)).unwrap();
    for (theta_t, h) in [(0.0, 0.0), (0.4, 0.5), (1.2, -0.3)] {
        let (a, b) = (t.scattered_fraction(theta_t, h), closed_form_scattered(1.3, theta_t, h));
        assert!((a - b).abs() < 1e-14, "{a} {b}");
    }
    assert_eq!(t.scattered_fraction(0.3, 1.0), 0.0);
}

#[test]
fn without_absorption_all_scattered_light_escapes() {
    for (sigma_s, g) in [(0.3, 0.0), (2.0, 0.5), (8.0, -0.3)] {
        let t = MedullaTables::new(&params(sigma_s, 0.0, g), &small(2048)).unwrap();
        // The only randomness in the total is the roulette of parts below ε: its variance
        // per walk is at most ε times the walk's weight (1).
        let sd = (SMALL_DEPOSIT / (2.0 * t.walks_per_node() as f64)).sqrt();
        for (theta_t, h) in [(0.0, 0.0), (0.3, 0.6), (0.9, -0.95), (0.1, 1.0)] {
            let e = t.escaping_fraction(theta_t, h);
            let s = closed_form_scattered(sigma_s, theta_t, h);
            for c in 0..3 {
                assert!((e[c] - s).abs() <= 5.0 * sd * s + 1e-15, "σ_s {sigma_s} θ {theta_t} h {h}: {} vs {s}", e[c]);
            }
        }
    }
}

#[test]
fn absorbed_escape_matches_the_analog_walk() {
    // Independent estimator: the plain analog walk with exp(−σ_a L) per exit.
    let (sigma_s, sigma_a, g) = (2.0, 0.4, 0.4);
    let t = MedullaTables::new(&params(sigma_s, sigma_a, g), &small(8192)).unwrap();
    let (theta_t, h) = (t.inclination_node(1), t.offset_node(6));
    let rays = 200_000;
    let (mut sum, mut sum2) = ([0.0; 3], [0.0; 3]);
    trace_walks(&params(sigma_s, 0.0, g), theta_t, h, rays, 5, |e| {
        for c in 0..3 {
            let w = (-(c as f64 + 1.0) * sigma_a * e.path_length).exp();
            sum[c] += w;
            sum2[c] += w * w;
        }
    });
    let escaping = t.escaping_fraction(theta_t, h);
    for c in 0..3 {
        let mean = sum[c] / rays as f64;
        let sd = ((sum2[c] / rays as f64 - mean * mean) / rays as f64).sqrt();
        // The tables' own error is smaller than the analog one (more walks' worth of deposits).
        assert!((escaping[c] - mean).abs() < 5.0 * sd, "channel {c}: tables {} walk {mean} ± {sd}", escaping[c]);
        assert!(escaping[c] < t.scattered_fraction(theta_t, h));
    }
}

#[test]
fn slices_integrate_to_the_escaping_fraction_and_densities_to_one() {
    let t = MedullaTables::shared(&params(1.7, 0.2, 0.44), &Resolution::default()).unwrap();
    let n = 7200;
    for (theta_t, h) in [(0.0, 0.0), (0.25, 0.37), (-0.5, -0.81), (0.8, 0.999), (1.3, 0.2)] {
        let d = TAU / n as f64;
        let phis = (0..n).map(|k| -PI + (k as f64 + 0.5) * d);
        let mut integral = Rgb::ZERO;
        let mut pdf_integral = 0.0;
        for p in phis {
            integral += t.azimuthal(theta_t, h, p) * d;
            pdf_integral += t.azimuth_pdf(theta_t, h, p) * d;
        }
        let e = t.escaping_fraction(theta_t, h);
        for c in 0..3 {
            assert!((integral[c] - e[c]).abs() <= 1e-6 * e[c].max(1e-9), "θ {theta_t} h {h}: {integral} vs {e}");
        }
        assert!((pdf_integral - 1.0).abs() < 1e-6, "{pdf_integral}");
        for phi_q in [0.0, 1.0, -2.5, PI] {
            let d = PI / n as f64;
            let mut m = Rgb::ZERO;
            let mut pdf = 0.0;
            for k in 0..n {
                let x = -FRAC_PI_2 + (k as f64 + 0.5) * d;
                m += t.longitudinal(theta_t, phi_q, x) * d;
                pdf += t.inclination_pdf(theta_t, phi_q, x) * d;
            }
            for c in 0..3 {
                assert!((m[c] - 1.0).abs() < 1e-6, "θ {theta_t} φ {phi_q}: {m}");
            }
            assert!((pdf - 1.0).abs() < 1e-6, "{pdf}");
        }
    }
}

#[test]
fn symmetric_under_mirroring_the_offset_and_azimuth() {
    let t = MedullaTables::shared(&params(1.7, 0.2, 0.44), &Resolution::default()).unwrap();
    let mut asymmetric = 0.0f64;
    for (theta_t, h) in [(0.0, 0.5), (0.3, 0.123), (0.6, 0.9), (0.2, 1.0 / 16.0)] {
        for k in 0..97 {
            let phi_q = -PI + TAU * (k as f64 + 0.31) / 97.0;
            let (a, b) = (t.azimuthal(theta_t, h, phi_q), t.azimuthal(theta_t, -h, -phi_q));
            asymmetric = asymmetric
                .max((a - b).max_component().abs().max((b - a).max_component().abs()) / a.max_component().max(1e-300));
            let (pa, pb) = (t.azimuth_pdf(theta_t, h, phi_q), t.azimuth_pdf(theta_t, -h, -phi_q));
            assert!((pa - pb).abs() <= 1e-9 * pa, "{pa} {pb}");
        }
    }
    assert!(asymmetric < 1e-9, "{asymmetric}");
    // And the tables are not trivially symmetric in φ alone: at h' = 0.5 light turns one way.
    let (a, b) = (t.azimuthal(0.0, 0.5, 1.2).average(), t.azimuthal(0.0, 0.5, -1.2).average());
    assert!((a - b).abs() > 0.01 * a.max(b), "{a} {b}");
}

/// `∫ |φ_q| N dφ_q / ∫ N dφ_q`, averaged over h' with the scattered fraction.
fn mean_abs_azimuth(t: &MedullaTables, theta_t: f64) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..64 {
        let h = -1.0 + (i as f64 + 0.5) / 32.0;
        for k in 0..720 {
            let p = -PI + (k as f64 + 0.5) * TAU / 720.0;
            let n = t.azimuthal(theta_t, h, p).average();
            num += p.abs() * n;
            den += n;
        }
    }
    num / den
}

#[test]
fn forward_phase_moves_the_exit_forward() {
    // φ_q = π is the entry direction (forward), 0 straight back; isotropic scattering sends
    // light everywhere, forward HG keeps it near π, backward HG sends it back.
    let means: Vec<f64> = [-0.5, 0.0, 0.5, 0.9]
        .iter()
        .map(|&g| mean_abs_azimuth(&MedullaTables::new(&params(1.5, 0.0, g), &small(2048)).unwrap(), 0.2))
        .collect();
    for w in means.windows(2) {
        assert!(w[1] > w[0] + 0.05, "{means:?}");
    }
    assert!(means[3] > 2.5 && means[0] < FRAC_PI_2, "{means:?}");
}

/// Distance from `p` inside the unit cylinder about z to its wall along unit `d`, written
/// out independently (the larger root of |p + t d|² = 1 in the cross-section).
fn wall(p: DVec3, d: DVec3) -> f64 {
    let (a, b, c) = (d.x * d.x + d.y * d.y, p.x * d.x + p.y * d.y, p.x * p.x + p.y * p.y - 1.0);
    (-b + (b * b - a * c).sqrt()) / a
}

fn hg(g: f64, mu: f64) -> f64 {
    (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * mu).powf(1.5))
}

/// Single scattering: light entering at (θ_t, h) scatters once at distance t along the
/// chord (density σ_s e^{−σ_s t}), into ω with the HG phase, and leaves unscattered; the
/// density per unit exit azimuth φ_q, with dω = cosθ_o dθ_o dψ, ψ = φ_q − π.
fn single_scattering_density(sigma_s: f64, sigma_a: f64, g: f64, theta_t: f64, h: f64, phi_q: f64) -> f64 {
    single_scattering_moment(sigma_s, sigma_a, g, theta_t, h, phi_q, 0)
}

/// [`single_scattering_density`] weighted by the path length to the power `moment`.
fn single_scattering_moment(sigma_s: f64, sigma_a: f64, g: f64, theta_t: f64, h: f64, phi_q: f64, moment: i32) -> f64 {
    let half = (1.0 - h * h).sqrt();
    let start = DVec3::new(-half, h, 0.0);
    let dir = DVec3::new(theta_t.cos(), 0.0, theta_t.sin());
    let chord = 2.0 * half / theta_t.cos();
    let (nt, no) = (48, 96);
    let psi = phi_q - PI;
    let mut sum = 0.0;
    for a in 0..nt {
        let t = (a as f64 + 0.5) * chord / nt as f64;
        let p = start + dir * t;
        for b in 0..no {
            let th = -FRAC_PI_2 + (b as f64 + 0.5) * PI / no as f64;
            let w = DVec3::new(th.cos() * psi.cos(), th.cos() * psi.sin(), th.sin());
            let l = wall(p, w);
            sum += sigma_s
                * (-sigma_s * t).exp()
                * hg(g, w.dot(dir))
                * th.cos()
                * (-sigma_s * l).exp()
                * (-sigma_a * (t + l)).exp()
                * (t + l).powi(moment);
        }
    }
    sum * (chord / nt as f64) * (PI / no as f64)
}

#[test]
fn thin_medium_matches_single_scattering_quadrature() {
    // σ_s = 0.01: light that scatters twice is ~1.5 % of the scattered light; sectors of 30°.
    let (sigma_s, sigma_a, g) = (0.01, 0.3, 0.5);
    let res = Resolution { inclinations: 2, offsets: 5, walks: Some(1 << 17), ..Resolution::default() };
    let t = MedullaTables::new(&params(sigma_s, sigma_a, g), &res).unwrap();
    let nodes = res.azimuths;
    let per_sector = nodes / 12;
    let d = TAU / nodes as f64;
    for (a, i) in [(0, 2), (1, 3), (0, 1)] {
        let (theta_t, h) = (t.inclination_node(a), t.offset_node(i));
        for sector in 0..12 {
            let nodes_here: Vec<usize> = (sector * per_sector..(sector + 1) * per_sector).collect();
            // Table: Σ N(φ_j)·Δ over the sector's nodes = ∫ N(φ) Σ tent_j(φ) dφ.
            let table: f64 = nodes_here.iter().map(|&j| t.azimuthal(theta_t, h, t.azimuth_node(j))[0] * d).sum();
            let sub = 8;
            let mut quad = 0.0;
            for &j in &nodes_here {
                let centre = t.azimuth_node(j);
                for k in 0..2 * sub {
                    let x = -1.0 + (k as f64 + 0.5) / sub as f64;
                    quad += (1.0 - x.abs())
                        * single_scattering_density(sigma_s, sigma_a, g, theta_t, h, centre + x * d)
                        * d
                        / sub as f64;
                }
            }
            // Walk noise: the sector holds ~1/12 of ~2·2^17 walks' deposits.
            let s = t.scattered_fraction(theta_t, h);
            let noise = 4.0 * (quad * s / (2.0 * (1 << 17) as f64)).sqrt();
            assert!(
                (table - quad).abs() < 0.03 * quad + noise,
                "θ {theta_t} h {h} sector {sector}: table {table} quadrature {quad} (noise {noise})"
            );
        }
    }
}

#[test]
fn tables_agree_with_the_analog_walk_azimuth_by_azimuth() {
    let (sigma_s, g) = (3.0, 0.6);
    let t = MedullaTables::shared(&params(sigma_s, 0.0, g), &Resolution::default()).unwrap();
    let (a, i) = (2, 11);
    let (theta_t, h) = (t.inclination_node(a), t.offset_node(i));
    let sectors = 18;
    let rays = 300_000;
    let mut hist = vec![0.0; sectors];
    let nodes = t.resolution().azimuths;
    let d = TAU / nodes as f64;
    // Deposit each exit to its nearest nodes with tent weights, then sum nodes per sector,
    // exactly as the table is binned.
    trace_walks(&params(sigma_s, 0.0, g), theta_t, h, rays, 9, |e| {
        let x = (e.phi_q + PI) / d;
        let j = x.floor();
        let f = x - j;
        let j0 = (j as usize) % nodes;
        hist[j0 * sectors / nodes] += 1.0 - f;
        hist[((j0 + 1) % nodes) * sectors / nodes] += f;
    });
    for (s, &count) in hist.iter().enumerate() {
        let walk = count / rays as f64;
        let table: f64 = (s * nodes / sectors..(s + 1) * nodes / sectors)
            .map(|j| t.azimuthal(theta_t, h, t.azimuth_node(j))[0] * d)
            .sum();
        let noise = (walk / rays as f64).sqrt() + (table / (2.0 * t.walks_per_node() as f64)).sqrt();
        assert!((walk - table).abs() < 4.0 * noise, "sector {s}: walk {walk} table {table} noise {noise}");
    }
}

#[test]
fn deterministic_across_runs_and_thread_counts() {
    let p = params(2.5, 0.1, 0.3);
    let res = small(256);
    let build = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| MedullaTables::new(&p, &res).unwrap())
    };
    let one = build(1);
    assert_eq!(one, build(2));
    assert_eq!(one, build(3));
    assert_eq!(one, MedullaTables::new(&p, &res).unwrap());
    let (a, b) = (MedullaTables::shared(&p, &res).unwrap(), MedullaTables::shared(&p, &res).unwrap());
    assert!(Arc::ptr_eq(&a, &b));
    assert_eq!(*a, one);
}

/// The two samplers as a scattering function over the sphere, for the harness's χ²:
/// `ω = (sinθ_o, cosθ_o cosφ_q, cosθ_o sinφ_q)` in the fiber frame, pdf per steradian
/// `p(φ_q)·p(θ_o | φ_q)/cosθ_o`.
struct Samplers {
    tables: Arc<MedullaTables>,
    theta_t: f64,
}

impl ScatteringFunction for Samplers {
    fn properties(&self) -> Properties {
        Properties { reciprocal: false, energy_conserving: true, field: Field::Near, lobes: Lobes::Smooth }
    }
    fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
        Rgb::splat(self.pdf(wi, wo, h))
    }
    fn pdf(&self, wi: DVec3, _wo: DVec3, h: f64) -> f64 {
        let (p, th) = (phi(wi), theta(wi));
        self.tables.azimuth_pdf(self.theta_t, h, p) * self.tables.inclination_pdf(self.theta_t, p, th)
            / th.cos().max(1e-300)
    }
    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        let (p, _) = self.tables.sample_azimuth(self.theta_t, h, u[0])?;
        let (th, _) = self.tables.sample_inclination(self.theta_t, p, u[1])?;
        let wi = direction_from_sin_cos(th.sin(), th.cos(), p);
        Some(Sample { wi, weight: Rgb::ONE, pdf: self.pdf(wi, wo, h), delta: false, lobe: 0 })
    }
}

#[test]
fn samplers_pass_chi2_and_return_their_densities() {
    for (sigma_s, g, theta_t, h) in [(1.7, 0.44, 0.3, 0.37), (0.4, -0.2, -0.6, -0.8), (12.0, 0.8, 0.05, 0.0)] {
        let tables = MedullaTables::shared(&params(sigma_s, 0.3, g), &Resolution::default()).unwrap();
        for k in 0..200 {
            let u = (k as f64 + 0.5) / 200.0;
            let (p, pdf) = tables.sample_azimuth(theta_t, h, u).unwrap();
            assert_eq!(pdf, tables.azimuth_pdf(theta_t, h, p));
            let (th, pdf_o) = tables.sample_inclination(theta_t, p, 1.0 - u).unwrap();
            assert_eq!(pdf_o, tables.inclination_pdf(theta_t, p, th));
        }
        let f = Samplers { tables, theta_t };
        let cfg = Chi2Config { samples: 300_000, ..Chi2Config::default() };
        let out = chi2_test(&f, DVec3::X, h, &cfg);
        assert!(out.passes(1e-4), "σ_s {sigma_s} g {g} θ {theta_t} h {h}: {out:?}");
        assert!((out.pdf_integral - 1.0).abs() < 2e-3, "{out:?}");
    }
    // Off the cylinder and without scattering there is nothing to sample.
    let t = MedullaTables::shared(&params(1.7, 0.3, 0.44), &Resolution::default()).unwrap();
    assert!(t.sample_azimuth(0.1, 1.5, 0.5).is_none());
    let none = MedullaTables::new(&params(0.0, 0.0, 0.0), &small(16)).unwrap();
    assert!(none.sample_azimuth(0.1, 0.0, 0.5).is_none());
    assert_eq!(none.azimuthal(0.1, 0.0, 0.5), Rgb::ZERO);
    assert_eq!(none.azimuth_pdf(0.1, 0.0, 0.5), 0.0);
}

#[test]
fn mean_path_length_grows_with_the_chord_in_a_thin_medium() {
    // Thin medium: the walk scatters once, uniformly along the chord, and leaves: the mean
    // length is at least half the chord and about half the chord plus a mean exit distance.
    let t = MedullaTables::new(&params(0.01, 0.0, 0.0), &small(4096)).unwrap();
    let (l0, l1) = (t.mean_path_length(0.0, 0.0), t.mean_path_length(0.0, 0.75));
    assert!(l0 > 1.0 && l0 < 3.0 && l1 < l0, "{l0} {l1}");
}

#[test]
fn bad_input_is_rejected_naming_the_parameter() {
    let key = |e: MedullaError| match e {
        MedullaError::Parameter(p) => p.key(),
        MedullaError::Resolution { key, .. } => key,
        other => panic!("{other:?}"),
    };
    let rgb = Rgb::splat(0.1);
    assert_eq!(key(MedullaParams::new(f64::NAN, rgb, 0.0).unwrap_err()), "sigma_s");
    assert_eq!(key(MedullaParams::new(-1.0, rgb, 0.0).unwrap_err()), "sigma_s");
    assert_eq!(key(MedullaParams::new(1e3, rgb, 0.0).unwrap_err()), "sigma_s");
    assert_eq!(key(MedullaParams::new(1.0, Rgb::new(0.1, -0.1, 0.0), 0.0).unwrap_err()), "sigma_a");
    assert_eq!(key(MedullaParams::new(1.0, Rgb::new(0.1, f64::NAN, 0.0), 0.0).unwrap_err()), "sigma_a");
    for g in [1.0, -1.0, 1.5, f64::NAN, f64::INFINITY] {
        let e = MedullaParams::new(1.0, rgb, g).unwrap_err();
        assert!(matches!(
            &e,
            MedullaError::Parameter(ParameterError::NotFinite { .. } | ParameterError::OutOfRange { .. })
        ));
        assert!(e.to_string().contains("`g`"), "{e}");
        assert_eq!(key(e), "g");
    }
    let p = params(1.0, 0.1, 0.0);
    let d = Resolution::default();
    for (r, k) in [
        (Resolution { inclinations: 1, ..d }, "inclinations"),
        (Resolution { offsets: 100_000, ..d }, "offsets"),
        (Resolution { azimuths: 2, ..d }, "azimuths"),
        (Resolution { exit_inclinations: 1_000_000, ..d }, "exit_inclinations"),
        (Resolution { walks: Some(1 << 40), ..d }, "walks"),
        (Resolution { walks: Some(1 << 22), inclinations: 65, offsets: 257, ..d }, "walks"),
        (Resolution { max_sin_theta_t: 1.0, ..d }, "max_sin_theta_t"),
        (Resolution { max_sin_theta_t: f64::NAN, ..d }, "max_sin_theta_t"),
    ] {
        let e = MedullaTables::new(&p, &r).unwrap_err();
        assert!(e.to_string().contains(k), "{e}");
        assert_eq!(key(e.clone()), k);
        assert_eq!(key(MedullaTables::shared(&p, &r).unwrap_err()), k);
    }
}

#[test]
fn finite_everywhere_including_grazing_and_the_rim() {
    let t = MedullaTables::shared(&params(1.7, 0.2, 0.44), &Resolution::default()).unwrap();
    for theta_t in [-FRAC_PI_2, -1.2, 0.0, 0.7, 1.4, FRAC_PI_2] {
        for h in [-1.0, -0.999, 0.0, 0.5, 1.0] {
            for phi_q in [-PI, -1.0, 0.0, 2.0, PI] {
                let n = t.azimuthal(theta_t, h, phi_q);
                let m = t.longitudinal(theta_t, phi_q, 0.3);
                let p = t.azimuth_pdf(theta_t, h, phi_q) + t.inclination_pdf(theta_t, phi_q, -0.3);
                assert!(n.is_finite() && m.is_finite() && p.is_finite(), "{theta_t} {h} {phi_q}");
                assert!(n.min_component() >= 0.0 && m.min_component() >= 0.0 && p >= 0.0);
            }
        }
    }
    assert_eq!(t.azimuthal(0.2, f64::NAN, 0.0), Rgb::ZERO);
    assert_eq!(t.azimuth_pdf(f64::NAN, 0.2, 0.0), 0.0);
}

#[test]
fn longitudinal_marginal_agrees_with_the_analog_walk() {
    // Averaged over h' (each offset weighted by its scattered fraction, trapezoid in h'),
    // the profiles weighted by N have the walk's marginal exit profile.
    let (sigma_s, sigma_a, g) = (2.0, 0.3, 0.5);
    let t = MedullaTables::shared(&params(sigma_s, sigma_a, g), &Resolution::default()).unwrap();
    let res = *t.resolution();
    let a = 3;
    let theta_t = t.inclination_node(a);
    let sectors = 12;
    let nth = res.exit_inclinations;
    let dth = PI / (nth - 1) as f64;
    let rays = 60_000;
    let (mut walk, mut table) = (vec![0.0; sectors], vec![0.0; sectors]);
    let sector_of = |k: usize| (k * sectors / nth).min(sectors - 1);
    for i in 0..res.offsets {
        let h = t.offset_node(i);
        let weight = if i == 0 || i == res.offsets - 1 { 0.5 } else { 1.0 };
        let s = t.scattered_fraction(theta_t, h);
        if s == 0.0 {
            continue;
        }
        // The analog walk scatters with probability S by itself.
        let per_ray = weight / rays as f64;
        trace_walks(&params(sigma_s, 0.0, g), theta_t, h, rays, 100 + i as u64, |e| {
            let w = per_ray * (-sigma_a * e.path_length).exp();
            let y = (e.theta_o + FRAC_PI_2) / dth;
            let k = (y as usize).min(nth - 2);
            let f = y - k as f64;
            walk[sector_of(k)] += w * (1.0 - f);
            walk[sector_of(k + 1)] += w * f;
        });
        // Table: ∫ N(φ) M(θ_o | φ) dφ at the θ_o nodes, times the node's trapezoid width.
        let nphi = 144;
        for k in 0..nth {
            let x = t.exit_inclination_node(k);
            let width = if k == 0 || k == nth - 1 { 0.5 * dth } else { dth };
            let joint: f64 = (0..nphi)
                .map(|j| {
                    let p = -PI + (j as f64 + 0.5) * TAU / nphi as f64;
                    t.azimuthal(theta_t, h, p)[0] * t.longitudinal(theta_t, p, x)[0] * TAU / nphi as f64
                })
                .sum();
            table[sector_of(k)] += weight * joint * width;
        }
    }
    let total: f64 = walk.iter().sum();
    for (s, (&w, &m)) in walk.iter().zip(&table).enumerate() {
        // Walk noise (≈ Poisson in the sector's share of 15 × 60 000 rays) plus a 3 % margin
        // of the total for the tables' own noise and the φ-blend's tent smoothing.
        let noise = 4.0 * (w * total / (15.0 * rays as f64)).sqrt() + 0.03 * total / sectors as f64;
        assert!((w - m).abs() < noise, "sector {s}: walk {w} tables {m} (allowed {noise}); {walk:?} {table:?}");
    }
}

#[test]
fn backward_and_forward_profiles_follow_the_walk() {
    // The profiles tabulated at several |φ_q| carry the correlation of exit azimuth and
    // inclination: in a thin medium light sent back (|φ_q| < π/3) leaves with θ_o far from
    // forward light's (|φ_q| > 2π/3). Mean θ_o of each group, h'-averaged over the offset
    // nodes, tables against the analog walk.
    for (sigma_s, g) in [(1.5, 0.3), (0.3, 0.7), (0.3, -0.5)] {
        let t = MedullaTables::shared(&params(sigma_s, 0.0, g), &Resolution::default()).unwrap();
        let res = *t.resolution();
        let theta_t = t.inclination_node(5);
        let groups = |phi: f64| {
            if phi.abs() < PI / 3.0 {
                Some(0)
            } else if phi.abs() > 2.0 * PI / 3.0 {
                Some(1)
            } else {
                None
            }
        };
        let (mut walk, mut table) = ([[0.0; 2]; 2], [[0.0; 2]; 2]);
        let nphi = 144;
        let nth = 180;
        for i in 1..res.offsets - 1 {
            let h = t.offset_node(i);
            trace_walks(&params(sigma_s, 0.0, g), theta_t, h, 40_000, 300 + i as u64, |e| {
                if let Some(k) = groups(e.phi_q) {
                    walk[k][0] += e.theta_o;
                    walk[k][1] += 1.0;
                }
            });
            for j in 0..nphi {
                let p = -PI + (j as f64 + 0.5) * TAU / nphi as f64;
                let Some(k) = groups(p) else { continue };
                let n = t.azimuthal(theta_t, h, p)[0];
                for m in 0..nth {
                    let x = -FRAC_PI_2 + (m as f64 + 0.5) * PI / nth as f64;
                    let w = n * t.longitudinal(theta_t, p, x)[0];
                    table[k][0] += w * x;
                    table[k][1] += w;
                }
            }
        }
        let mean = |a: [f64; 2]| a[0] / a[1];
        let (wb, wf, tb, tf) = (mean(walk[0]), mean(walk[1]), mean(table[0]), mean(table[1]));
        let what = format!("σ_s {sigma_s} g {g} θ_t {theta_t}: walk {wb} {wf} tables {tb} {tf}");
        // Walk noise of a group mean: ≲ 0.6/√(15·40 000 / 3) ≈ 1.3e-3 rad.
        assert!((wb - tb).abs() < 0.02 && (wf - tf).abs() < 0.02, "{what}");
        if sigma_s < 1.0 {
            // Thin media: a clear difference between the groups, which the tables keep.
            assert!((wf - wb).abs() > 0.15 && (tf - tb) * (wf - wb) > 0.0, "{what}");
        }
    }
}

/// Single scattering as a joint density in (φ_q, θ_o) per unit φ_q and unit θ_o.
fn single_scattering_joint(sigma_s: f64, g: f64, theta_t: f64, h: f64, phi_q: f64, theta_o: f64) -> f64 {
    let half = (1.0 - h * h).sqrt();
    let start = DVec3::new(-half, h, 0.0);
    let dir = DVec3::new(theta_t.cos(), 0.0, theta_t.sin());
    let chord = 2.0 * half / theta_t.cos();
    let psi = phi_q - PI;
    let w = DVec3::new(theta_o.cos() * psi.cos(), theta_o.cos() * psi.sin(), theta_o.sin());
    let nt = 32;
    let mut sum = 0.0;
    for a in 0..nt {
        let t = (a as f64 + 0.5) * chord / nt as f64;
        let l = wall(start + dir * t, w);
        sum += sigma_s * (-sigma_s * t).exp() * hg(g, w.dot(dir)) * theta_o.cos() * (-sigma_s * l).exp();
    }
    sum * chord / nt as f64
}

#[test]
fn thin_medium_exit_inclinations_match_single_scattering_quadrature() {
    // h'-averaged exit-inclination profile (weights as the tables': trapezoid over the
    // offset nodes times the scattered fraction), in 6 sectors of θ_o, against quadrature.
    let (sigma_s, g) = (0.01, 0.7);
    let res = Resolution { walks: Some(1 << 14), ..Resolution::default() };
    let t = MedullaTables::new(&params(sigma_s, 0.0, g), &res).unwrap();
    let theta_t = t.inclination_node(5);
    let (nth, nphi) = (res.exit_inclinations, 72);
    let dth = PI / (nth - 1) as f64;
    let sectors = 6;
    let sector_of = |k: usize| (k * sectors / nth).min(sectors - 1);
    let (mut table, mut quad) = (vec![0.0; sectors], vec![0.0; sectors]);
    for i in 1..res.offsets - 1 {
        let h = t.offset_node(i);
        for k in 0..nth {
            let x = t.exit_inclination_node(k);
            let width = if k == 0 || k == nth - 1 { 0.5 * dth } else { dth };
            for j in 0..nphi {
                let p = -PI + (j as f64 + 0.5) * TAU / nphi as f64;
                table[sector_of(k)] +=
                    t.azimuthal(theta_t, h, p)[0] * t.longitudinal(theta_t, p, x)[0] * width * TAU / nphi as f64;
            }
            // Quadrature of the tent around node k (what the node's value stands for).
            let sub = 6;
            for m in 0..2 * sub {
                let y = x + (-1.0 + (m as f64 + 0.5) / sub as f64) * dth;
                if y.abs() >= FRAC_PI_2 {
                    continue;
                }
                let tent = 1.0 - ((y - x) / dth).abs();
                for j in 0..nphi {
                    let p = -PI + (j as f64 + 0.5) * TAU / nphi as f64;
                    quad[sector_of(k)] +=
                        tent * single_scattering_joint(sigma_s, g, theta_t, h, p, y) * (dth / sub as f64) * TAU
                            / nphi as f64;
                }
            }
        }
    }
    let total: f64 = quad.iter().sum();
    for s in 0..sectors {
        assert!(
            (table[s] - quad[s]).abs() < 0.03 * quad[s] + 0.01 * total,
            "θ_t {theta_t}, sector {s}: tables {table:?} quadrature {quad:?}"
        );
    }
    // Forward scattering keeps the inclination: most light leaves on the side of θ_t.
    assert!(quad[3..].iter().sum::<f64>() > 0.7 * total, "{quad:?}");
}

#[test]
fn thin_medium_path_lengths_match_single_scattering_quadrature() {
    // Mean path length of the light leaving toward each 30° sector: Σ_j N_j L̄_j / Σ_j N_j
    // over the sector's nodes against the ratio of quadratures of L·density and density.
    let (sigma_s, g) = (0.01, 0.3);
    let res = Resolution { inclinations: 2, offsets: 5, walks: Some(1 << 16), ..Resolution::default() };
    let t = MedullaTables::new(&params(sigma_s, 0.0, g), &res).unwrap();
    let per_sector = res.azimuths / 12;
    for (a, i) in [(0, 2), (1, 3)] {
        let (theta_t, h) = (t.inclination_node(a), t.offset_node(i));
        let mut overall = (0.0, 0.0);
        for sector in 0..12 {
            let (mut tn, mut tl, mut q0, mut q1) = (0.0, 0.0, 0.0, 0.0);
            for j in sector * per_sector..(sector + 1) * per_sector {
                let p = t.azimuth_node(j);
                let n = t.azimuthal(theta_t, h, p)[0];
                tn += n;
                tl += n * t.mean_path_length_toward(theta_t, h, p);
                q0 += single_scattering_moment(sigma_s, 0.0, g, theta_t, h, p, 0);
                q1 += single_scattering_moment(sigma_s, 0.0, g, theta_t, h, p, 1);
            }
            let (table, quad) = (tl / tn, q1 / q0);
            overall = (overall.0 + tl, overall.1 + tn);
            assert!((table - quad).abs() < 0.05 * quad, "θ {theta_t} h {h} sector {sector}: {table} vs {quad}");
        }
        let mean = t.mean_path_length(theta_t, h);
        assert!((overall.0 / overall.1 - mean).abs() < 0.02 * mean, "{} {mean}", overall.0 / overall.1);
    }
}
