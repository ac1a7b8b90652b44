//! Every registered fiber-model configuration passes the harness, and the harness can fail.

use fiberlab_check::chi2::{Chi2Config, chi2_test};
use fiberlab_check::tolerance::CHI2_SIGNIFICANCE;
use fiberlab_check::{Effort, check_cases, default_cases};
use fiberlab_math::frame::{direction, phi, theta};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::kajiya_kay_1989::{KajiyaKay, KajiyaKayParams};
use fiberlab_scatter::{Model, Properties, Sample, ScatteringFunction, build};

#[test]
fn every_default_fiber_case_passes() {
    // The surface cases run in `surface_harness.rs`.
    let fibers: Vec<_> = default_cases()
        .into_iter()
        .filter(|c| fiberlab_scatter::lookup(&c.model).unwrap().kind() == fiberlab_scatter::ModelKind::Fiber)
        .collect();
    let rows = check_cases(&fibers, &Effort::default());
    let failed: Vec<_> = rows.iter().filter(|r| !r.pass).collect();
    for r in &failed {
        eprintln!("FAIL {} | {} | value {} expected {} tol {}", r.model, r.test, r.value, r.expected, r.tolerance);
    }
    assert!(failed.is_empty(), "{} failing rows", failed.len());
    assert!(rows.len() > 100);
}

/// Samples from one Kajiya–Kay lobe but reports the pdf of a slightly different one: both
/// pdfs integrate to 1, so only the χ² test can notice.
struct WrongPdf {
    sampler: KajiyaKay,
    claimed: KajiyaKay,
}

impl ScatteringFunction for WrongPdf {
    fn properties(&self) -> Properties {
        self.sampler.properties()
    }
    fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
        self.claimed.eval(wi, wo, h)
    }
    fn pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> f64 {
        self.claimed.pdf(wi, wo, h)
    }
    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        self.sampler.sample(wo, h, u)
    }
}

#[test]
fn chi2_rejects_a_wrong_pdf_and_accepts_the_right_one() {
    let kk = |p: f64| KajiyaKay::new(KajiyaKayParams { k_d: Rgb::splat(0.02), k_s: Rgb::splat(0.3), p }).unwrap();
    let wo = direction(0.4, 0.0);
    let cfg = Chi2Config { samples: 300_000, ..Default::default() };
    let wrong = WrongPdf { sampler: kk(30.0), claimed: kk(36.0) };
    let outcome = chi2_test(&wrong, wo, 0.0, &cfg);
    assert!(!outcome.passes(CHI2_SIGNIFICANCE), "χ² failed to reject a wrong pdf: {outcome:?}");
    let right = WrongPdf { sampler: kk(30.0), claimed: kk(30.0) };
    let outcome = chi2_test(&right, wo, 0.0, &cfg);
    assert!(outcome.passes(CHI2_SIGNIFICANCE), "χ² rejected a correct pdf: {outcome:?}");
}

/// Samples from one model but claims another model's pdf, optionally mirrored in azimuth
/// about the viewer (`φ_i − φ_o → φ_o − φ_i`, a sign error of the relative azimuth).
struct Claims {
    sampler: Model,
    claimed: Model,
    mirrored: bool,
}

impl Claims {
    fn claimed_direction(&self, wi: DVec3, wo: DVec3) -> DVec3 {
        if self.mirrored { direction(theta(wi), 2.0 * phi(wo) - phi(wi)) } else { wi }
    }
}

impl ScatteringFunction for Claims {
    fn properties(&self) -> Properties {
        self.sampler.properties()
    }
    fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
        self.claimed.eval(self.claimed_direction(wi, wo), wo, h)
    }
    fn pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> f64 {
        self.claimed.pdf(self.claimed_direction(wi, wo), wo, h)
    }
    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        self.sampler.sample(wo, h, u)
    }
}

/// The χ² as the hair-model tests run it (narrow Chiang lobes, β = 0.1, on their grid and
/// sample count) still rejects small errors of the pdf: a 3% wider azimuthal lobe, a 3%
/// wider longitudinal lobe, a mirrored azimuth. (That the same χ² accepts the right pdf is
/// the first case of `chi2_goodness_of_fit_down_to_beta_0_1` in `fiberlab-scatter`'s
/// `tests/chiang_2016.rs`.)
#[test]
fn chi2_of_the_hair_tests_rejects_small_pdf_errors_of_narrow_lobes() {
    let chiang = |beta_m: &str, beta_n: &str| build("chiang", &[("beta_m", beta_m), ("beta_n", beta_n)]).unwrap();
    let cfg = Chi2Config { bins_theta: 160, bins_phi: 640, sub: 2, samples: 500_000, seed: 11, ..Default::default() };
    let (wo, h) = (direction(0.4, 0.3), 0.37);
    let sampler = || chiang("0.1", "0.1");
    for (what, claimed, mirrored) in [
        ("β_n 0.1 claimed 0.103", chiang("0.1", "0.103"), false),
        ("β_m 0.1 claimed 0.103", chiang("0.103", "0.1"), false),
        ("mirrored azimuth", chiang("0.1", "0.1"), true),
    ] {
        let wrong = Claims { sampler: sampler(), claimed, mirrored };
        let outcome = chi2_test(&wrong, wo, h, &cfg);
        println!("{what}: χ² = {:.0}, dof {}, p = {:.1e}", outcome.statistic, outcome.dof, outcome.p_value);
        assert!(!outcome.passes(CHI2_SIGNIFICANCE), "χ² failed to reject {what}: {outcome:?}");
    }
}

/// A measured table (here tabulated from Kajiya–Kay, smooth but anisotropic in θ) used as a
/// scattering function passes every generic test that applies to it.
#[test]
fn tabulated_measured_model_passes_the_harness() {
    use fiberlab_scatter::measured::{Measured, MeasuredTable};
    let kk = KajiyaKay::new(KajiyaKayParams { k_d: Rgb::splat(0.03), k_s: Rgb::splat(0.2), p: 8.0 }).unwrap();
    let (nt, np) = (90, 72);
    let theta_in: Vec<f64> = (-7..=7).map(|k| k as f64 * 0.2).collect();
    let m: fiberlab_scatter::Model = Measured::new(MeasuredTable::of_function(&kk, theta_in, nt, np)).unwrap().into();
    let rows = fiberlab_check::check_model("measured (tabulated KK)", &m, &Effort::default());
    let failed: Vec<_> = rows.iter().filter(|r| !r.pass).collect();
    for r in &failed {
        eprintln!("FAIL {} | value {} expected {} tol {}", r.test, r.value, r.expected, r.tolerance);
    }
    assert!(failed.is_empty());
}
