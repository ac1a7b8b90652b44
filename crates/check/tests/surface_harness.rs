//! Every surface configuration of `fiberlab check` passes the surface harness, and the
//! surface harness can fail.

use fiberlab_check::surface::check_surface;
use fiberlab_check::{Effort, check_cases, default_cases};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::{
    LobeInfo, ModelError, ModelKind, Sample, SurfaceProperties, SurfaceScattering, build_surface, lookup,
};
use std::f64::consts::{PI, TAU};

#[test]
fn every_surface_case_passes() {
    // Sadeghi et al.'s other fabrics are covered preset by preset in the scatter crate's
    // `cloth_sampling.rs` (χ², sample weights) and energy tests; `fiberlab check` runs them all.
    let cases: Vec<_> = default_cases()
        .into_iter()
        .filter(|c| lookup(&c.model).unwrap().kind() == ModelKind::Surface)
        .filter(|c| !(c.model == "sadeghi-2013" && c.params.iter().any(|(k, _)| k == "preset")))
        .filter(|c| c.model != "leaf")
        .collect();
    assert!(cases.iter().any(|c| c.model == "wood") && cases.iter().any(|c| c.model == "lambertian"));
    let rows = check_cases(&cases, &Effort::default());
    let failed: Vec<_> = rows.iter().filter(|r| !r.pass).collect();
    for r in &rows {
        eprintln!(
            "{} {} | {} | value {} expected {} tol {}",
            if r.pass { "ok  " } else { "FAIL" },
            r.model,
            r.test,
            r.value,
            r.expected,
            r.tolerance
        );
    }
    assert!(failed.is_empty(), "{} failing rows", failed.len());
    assert!(rows.len() > 20 * cases.len());
}

/// A Lambertian sampler that claims a slightly different pdf (`cos^1.3`, normalized) and an
/// `f_r` with a small non-reciprocal tilt while claiming reciprocity: only χ² and
/// sample-consistency see the first, only the reciprocity row sees the second.
struct Broken {
    wrong_pdf: bool,
    tilt: f64,
}

impl SurfaceScattering for Broken {
    fn properties(&self) -> SurfaceProperties {
        SurfaceProperties { reciprocal: true, energy_conserving: true, has_delta: false, transmits: false }
    }
    fn eval(&self, wi: DVec3, wo: DVec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        Rgb::splat(0.5 * (1.0 + self.tilt * wi.x) / PI)
    }
    fn pdf(&self, wi: DVec3, _wo: DVec3) -> f64 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        if self.wrong_pdf { 2.3 * wi.z.powf(1.3) / TAU } else { wi.z / PI }
    }
    fn sample(&self, wo: DVec3, u: [f64; 4]) -> Option<Sample> {
        let wi = fiberlab_scatter::sampling::cosine_hemisphere(DVec3::Z, DVec3::X, u[0], u[1]);
        let pdf = self.pdf(wi, wo);
        (wi.z > 0.0 && pdf > 0.0).then(|| Sample {
            wi,
            weight: self.eval(wi, wo) * (wi.z / pdf),
            pdf,
            delta: false,
            lobe: 0,
        })
    }
    fn lobes(&self) -> Vec<LobeInfo> {
        vec![LobeInfo::smooth("all")]
    }
    fn texturable_keys(&self) -> &'static [&'static str] {
        &[]
    }
    fn set_parameter(&mut self, key: &str, _value: Rgb) -> Result<(), ModelError> {
        Err(ModelError::Inconsistent(format!("no parameter {key}")))
    }
}

#[test]
fn the_surface_harness_can_fail() {
    let effort = Effort { chi2_samples: 200_000, samples: 50_000, pairs: 4_000 };
    let failing = |m: &Broken| -> Vec<String> {
        check_surface("broken", m, None, &effort).into_iter().filter(|r| !r.pass).map(|r| r.test).collect()
    };
    assert!(failing(&Broken { wrong_pdf: false, tilt: 0.0 }).is_empty());
    let wrong_pdf = failing(&Broken { wrong_pdf: true, tilt: 0.0 });
    assert!(wrong_pdf.iter().any(|t| t.starts_with("χ²")), "{wrong_pdf:?}");
    let tilted = failing(&Broken { wrong_pdf: false, tilt: 0.1 });
    assert_eq!(tilted, vec!["reciprocity max relative defect".to_string()]);
    // The Lambertian closed form: a wrong expectation fails the albedo rows.
    let lambert = build_surface("lambertian", &[("k_d", "0.5")]).unwrap();
    let rows = check_surface("lambertian", &lambert, Some(Rgb::splat(0.55)), &effort);
    assert!(rows.iter().any(|r| !r.pass && r.test.starts_with("light-side albedo")));
}

/// The two-sided, transmitting `leaf` over the whole sphere: reciprocity, R + T ≤ 1, ∫pdf, sample
/// against eval/pdf and χ², its three configurations (a separate test so it can be run alone).
#[test]
fn leaf_cases_pass_the_surface_harness() {
    let cases: Vec<_> = default_cases().into_iter().filter(|c| c.model == "leaf").collect();
    assert_eq!(cases.len(), 3);
    let rows = check_cases(&cases, &Effort::default());
    let failed: Vec<_> = rows.iter().filter(|r| !r.pass).collect();
    for r in &failed {
        eprintln!("FAIL {} | {} | value {} expected {} tol {}", r.model, r.test, r.value, r.expected, r.tolerance);
    }
    assert!(failed.is_empty(), "{} failing rows", failed.len());
    assert!(rows.iter().any(|r| r.test == "reciprocity max relative defect" && r.pass));
    assert!(rows.iter().any(|r| r.test == "energy bound max ρ ≤ 1" && r.pass));
}
