//! Every registered model configuration passes the harness, and the harness can fail.

use fiberlab_check::chi2::{Chi2Config, chi2_test};
use fiberlab_check::{Effort, check_cases, default_cases};
use fiberlab_math::frame::direction;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::kajiya_kay_1989::{KajiyaKay, KajiyaKayParams};
use fiberlab_scatter::{Properties, Sample, ScatteringFunction};

#[test]
fn every_default_case_passes() {
    let rows = check_cases(&default_cases(), &Effort::default());
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
    assert!(!outcome.passes(0.01), "χ² failed to reject a wrong pdf: {outcome:?}");
    let right = WrongPdf { sampler: kk(30.0), claimed: kk(30.0) };
    let outcome = chi2_test(&right, wo, 0.0, &cfg);
    assert!(outcome.passes(0.01), "χ² rejected a correct pdf: {outcome:?}");
}

/// A measured table (here tabulated from Kajiya–Kay, smooth but anisotropic in θ) used as a
/// scattering function passes every generic test that applies to it.
#[test]
fn tabulated_measured_model_passes_the_harness() {
    use fiberlab_scatter::measured::{Measured, MeasuredTable};
    use std::f64::consts::{FRAC_PI_2, PI, TAU};
    let kk = KajiyaKay::new(KajiyaKayParams { k_d: Rgb::splat(0.03), k_s: Rgb::splat(0.2), p: 8.0 }).unwrap();
    let (nt, np) = (36, 72);
    let theta_in: Vec<f64> = (-7..=7).map(|k| k as f64 * 0.2).collect();
    let f = theta_in
        .iter()
        .map(|&ti| {
            (0..nt * np)
                .map(|b| {
                    let tr = -FRAC_PI_2 + ((b / np) as f64 + 0.5) * PI / nt as f64;
                    let p = -PI + ((b % np) as f64 + 0.5) * TAU / np as f64;
                    kk.eval(direction(ti, 0.0), direction(tr, p), 0.0)
                })
                .collect()
        })
        .collect();
    let m: fiberlab_scatter::Model =
        Measured::new(MeasuredTable { theta_in, bins_theta: nt, bins_phi: np, f }).unwrap().into();
    let rows = fiberlab_check::check_model("measured (tabulated KK)", &m, &Effort::default());
    let failed: Vec<_> = rows.iter().filter(|r| !r.pass).collect();
    for r in &failed {
        eprintln!("FAIL {} | value {} expected {} tol {}", r.test, r.value, r.expected, r.tolerance);
    }
    assert!(failed.is_empty());
}
