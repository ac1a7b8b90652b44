//! The validation harness for surface models ([`SurfaceScattering`]): the claims of
//! [`fiberlab_scatter::SurfaceProperties`] tested the way [`crate::check_model`] tests a
//! fiber's.
//!
//! Directions are in the surface's local frame (`z` = normal); integrals are midpoint
//! quadratures in (θ, φ) with θ from the normal (`dω = sinθ dθ dφ`), fine enough near the
//! pole for narrow lobes. Delta lobes (a smooth finish) are handled as the fiber harness
//! handles the ideal specular fiber: `eval`/`pdf` leave them out, so the quadratures cover the
//! smooth part and the delta part is measured from the samples flagged [`Sample::delta`]:
//! the energy bound adds their mean weight (the lobe's throughput), `∫ pdf dω` is compared
//! with the fraction of samples that are neither delta nor dropped, and the χ² test counts
//! delta samples with the dropped ones (the rest cell, whose expected mass is `1 − ∫ pdf`).
//!
//! Tests: finiteness and non-negativity (random pairs, the pole, exactly grazing and
//! below-surface arguments), the light-side albedo on a grid of `ω_i` (against a closed form
//! where one is known: [`expected_albedo`]; the furnace where lossless), the energy bound
//! when claimed, the camera-side integral of `eval` against the mean sample weight,
//! reciprocity (tested when claimed, else reported), `∫ pdf dω` against the samples, `sample`
//! against `eval`/`pdf`, and χ² of `sample` against `pdf`.

use crate::Row;
use crate::chi2::{Chi2Config, chi2_test};
use crate::rng::TestRng;
use crate::tolerance::*;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::{
    ConeValue, Field, LobeInfo, Lobes, Properties, Sample, ScatteringFunction, SurfaceModel, SurfaceScattering,
};
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Light and viewer inclinations (from the normal) of the per-direction tests: the pole,
/// oblique, steep and near grazing.
pub const SURFACE_THETAS: [f64; 5] = [0.0, 0.5, 1.0, 1.4, 1.55];

/// Relative difference, robust to zeros.
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(1e-300)
}

fn max_rel(a: Rgb, b: Rgb) -> f64 {
    (0..3).map(|c| if a[c] == b[c] { 0.0 } else { rel(a[c], b[c]) }).fold(0.0, f64::max)
}

/// Unit direction at inclination `theta` from the normal and azimuth `phi`.
#[must_use]
pub fn surface_direction(theta: f64, phi: f64) -> DVec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    DVec3::new(st * cp, st * sp, ct)
}

/// Calls `g(ω, dω)` at the midpoints of an (θ, φ) grid over the upper hemisphere (and the
/// lower one when `sphere`): `n_theta` cells per hemisphere in θ, `n_phi` in φ.
pub fn for_each_direction(n_theta: usize, n_phi: usize, sphere: bool, mut g: impl FnMut(DVec3, f64)) {
    let (dt, dp) = (FRAC_PI_2 / n_theta as f64, TAU / n_phi as f64);
    let rows = if sphere { 2 * n_theta } else { n_theta };
    for i in 0..rows {
        let t = (i as f64 + 0.5) * dt;
        let st = t.sin();
        for j in 0..n_phi {
            let p = -PI + (j as f64 + 0.5) * dp;
            g(surface_direction(t, p), st * dt * dp);
        }
    }
}

/// Light-side albedo of the smooth lobes, `∫ f_r(ω_i, ω_o) cosθ_o dω_o`, by quadrature.
#[must_use]
pub fn smooth_albedo(f: &impl SurfaceScattering, wi: DVec3, n_theta: usize, n_phi: usize) -> Rgb {
    let mut sum = Rgb::ZERO;
    for_each_direction(n_theta, n_phi, f.properties().transmits, |wo, dw| sum += f.eval(wi, wo) * (wo.z.abs() * dw));
    sum
}

/// Camera-side integral of the smooth lobes, `∫ f_r(ω_i, ω_o) cosθ_i dω_i`, by quadrature.
#[must_use]
pub fn smooth_furnace(f: &impl SurfaceScattering, wo: DVec3, n_theta: usize, n_phi: usize) -> Rgb {
    let mut sum = Rgb::ZERO;
    for_each_direction(n_theta, n_phi, f.properties().transmits, |wi, dw| sum += f.eval(wi, wo) * (wi.z.abs() * dw));
    sum
}

/// `∫ pdf(ω_i | ω_o) dω_i` by quadrature.
#[must_use]
pub fn pdf_integral(f: &impl SurfaceScattering, wo: DVec3) -> f64 {
    let mut sum = 0.0;
    for_each_direction(512, 2048, true, |wi, dw| sum += f.pdf(wi, wo) * dw);
    sum
}

/// Monte Carlo over `sample(wo)`: (mean weight of the smooth samples, its standard error,
/// mean weight of the delta samples, fraction of smooth samples).
fn sample_means(f: &impl SurfaceScattering, wo: DVec3, n: usize, seed: u64) -> (Rgb, Rgb, Rgb, f64) {
    let mut rng = TestRng::new(seed);
    let (mut s, mut s2, mut d, mut smooth) = (Rgb::ZERO, Rgb::ZERO, Rgb::ZERO, 0usize);
    for _ in 0..n {
        let Some(x) = f.sample(wo, rng.u4()) else { continue };
        if x.delta {
            d += x.weight;
        } else {
            s += x.weight;
            s2 += x.weight * x.weight;
            smooth += 1;
        }
    }
    let nf = n as f64;
    let m = s / nf;
    let se = ((s2 / nf - m * m).map(|v| v.max(0.0)) / nf).map(f64::sqrt);
    (m, se, d / nf, smooth as f64 / nf)
}

/// The light-side albedo a surface model must have, when a closed form is known: `k_d` for
/// the Lambertian surface, and for `wood` without a finish (η = 1) nor fibers (`k_f = 0`).
#[must_use]
pub fn expected_albedo(model: &SurfaceModel) -> Option<Rgb> {
    match model {
        SurfaceModel::Lambertian(m) => Some(m.k_d()),
        SurfaceModel::Wood(m) => {
            let p = m.params();
            (p.eta == 1.0 && p.k_f == Rgb::ZERO && p.roughness == 0.0).then_some(p.k_d)
        }
        _ => None,
    }
}

/// Counts non-finite and negative results over random and extreme arguments.
pub fn finiteness(f: &impl SurfaceScattering, pairs: usize, rng: &mut TestRng) -> (usize, usize) {
    let extremes = [
        DVec3::Z,
        -DVec3::Z,
        DVec3::X,
        DVec3::Y,
        -DVec3::X,
        surface_direction(FRAC_PI_2 - 1e-12, 0.3),
        surface_direction(FRAC_PI_2 + 1e-12, -2.0),
        surface_direction(1e-12, 1.0),
    ];
    let (mut nonfinite, mut negative) = (0, 0);
    let mut test = |wi: DVec3, wo: DVec3, u: [f64; 4]| {
        let (v, p) = (f.eval(wi, wo), f.pdf(wi, wo));
        if !v.is_finite() || !p.is_finite() {
            nonfinite += 1;
        }
        if v.min_component() < 0.0 || p < 0.0 {
            negative += 1;
        }
        if let Some(s) = f.sample(wo, u) {
            if !s.weight.is_finite()
                || !s.pdf.is_finite()
                || !s.wi.is_finite()
                || (s.wi.length() - 1.0).abs() > UNIT_LENGTH_ABS
            {
                nonfinite += 1;
            }
            if s.weight.min_component() < 0.0 || s.pdf < 0.0 {
                negative += 1;
            }
        }
    };
    let corners = [[0.0; 4], [0.999_999_999; 4], [0.5, 0.0, 0.999_999, 0.25], [0.999_999, 0.5, 0.0, 0.5]];
    for &a in &extremes {
        for &b in &extremes {
            for u in corners {
                test(a, b, u);
            }
        }
    }
    for _ in 0..pairs {
        let (wi, wo) = (rng.sphere_direction(), rng.sphere_direction());
        let wo = if rng.uniform() < 0.8 { DVec3::new(wo.x, wo.y, wo.z.abs()) } else { wo };
        test(wi, wo, rng.u4());
    }
    (nonfinite, negative)
}

/// Max relative disagreement of smooth samples with `pdf()` and `eval()·|cosθ_i|/pdf`; delta
/// samples must have `pdf = 0` (a violation counts as 1).
pub fn sample_consistency(f: &impl SurfaceScattering, wo: DVec3, n: usize, seed: u64) -> f64 {
    let mut rng = TestRng::new(seed);
    let mut worst: f64 = 0.0;
    for _ in 0..n {
        let Some(s) = f.sample(wo, rng.u4()) else { continue };
        if s.delta {
            if s.pdf != 0.0 {
                worst = worst.max(1.0);
            }
            continue;
        }
        let pdf = f.pdf(s.wi, wo);
        worst = worst.max(rel(s.pdf, pdf));
        if pdf > 0.0 {
            worst = worst.max(max_rel(s.weight, f.eval(s.wi, wo) * (s.wi.z.abs() / pdf)));
        }
    }
    worst
}

/// Max relative reciprocity defect over random pairs above the surface (both sides when the
/// model transmits).
pub fn reciprocity(f: &impl SurfaceScattering, pairs: usize, rng: &mut TestRng) -> f64 {
    let transmits = f.properties().transmits;
    let mut worst: f64 = 0.0;
    for _ in 0..pairs {
        let (a, b) = (rng.sphere_direction(), rng.sphere_direction());
        let (a, b) =
            if transmits { (a, b) } else { (DVec3::new(a.x, a.y, a.z.abs()), DVec3::new(b.x, b.y, b.z.abs())) };
        let (x, y) = (f.eval(a, b), f.eval(b, a));
        if x.max_component() > 1e-12 || y.max_component() > 1e-12 {
            worst = worst.max(max_rel(x, y));
        }
    }
    worst
}

/// A surface model seen through the fiber interface so that [`chi2_test`] bins it: fiber
/// coordinates `(x, y, z)` are surface coordinates `(z, x, y)` (the χ² grid's pole, fiber `x`,
/// is the surface normal; its azimuth is the surface's). Delta samples are dropped (`None`),
/// so they fall in the test's rest cell with the samples the model itself drops.
pub struct AsFiberGrid<'a, S>(pub &'a S);

/// Fiber-grid coordinates to surface coordinates ([`AsFiberGrid`]).
#[must_use]
pub fn to_surface(w: DVec3) -> DVec3 {
    DVec3::new(w.y, w.z, w.x)
}

/// Surface coordinates to fiber-grid coordinates ([`AsFiberGrid`]).
#[must_use]
pub fn to_fiber(s: DVec3) -> DVec3 {
    DVec3::new(s.z, s.x, s.y)
}

impl<S: SurfaceScattering> ScatteringFunction for AsFiberGrid<'_, S> {
    fn properties(&self) -> Properties {
        let p = self.0.properties();
        Properties {
            reciprocal: p.reciprocal,
            energy_conserving: p.energy_conserving,
            field: Field::Far,
            lobes: Lobes::Smooth,
        }
    }
    fn eval(&self, wi: DVec3, wo: DVec3, _h: f64) -> Rgb {
        self.0.eval(to_surface(wi), to_surface(wo))
    }
    fn pdf(&self, wi: DVec3, wo: DVec3, _h: f64) -> f64 {
        self.0.pdf(to_surface(wi), to_surface(wo))
    }
    fn sample(&self, wo: DVec3, _h: f64, u: [f64; 4]) -> Option<Sample> {
        let s = self.0.sample(to_surface(wo), u)?;
        (!s.delta).then_some(Sample { wi: to_fiber(s.wi), ..s })
    }
    fn lobes(&self) -> Vec<LobeInfo> {
        self.0.lobes()
    }
    fn cone(&self, _theta_o: f64, _phi: f64) -> ConeValue {
        ConeValue { value: Rgb::ZERO, pdf: 0.0 }
    }
}

/// Runs every applicable test on a registered surface model, labelling rows with `label`.
pub fn check_surface_model(label: &str, f: &SurfaceModel, effort: &crate::Effort) -> Vec<Row> {
    check_surface(label, f, expected_albedo(f), effort)
}

/// Runs every applicable test on any surface model; `expected` is its light-side albedo
/// when a closed form is known (the same for every `ω_i`).
pub fn check_surface(
    label: &str,
    f: &impl SurfaceScattering,
    expected: Option<Rgb>,
    effort: &crate::Effort,
) -> Vec<Row> {
    let props = f.properties();
    let mut rows = Vec::new();
    let test = |rows: &mut Vec<Row>, test: String, value: f64, expected: f64, tolerance: f64, pass: bool| {
        rows.push(Row { model: label.into(), test, value, expected, tolerance, pass, report: false });
    };
    let report = |rows: &mut Vec<Row>, test: String, value: f64| {
        let nan = f64::NAN;
        rows.push(Row { model: label.into(), test, value, expected: nan, tolerance: nan, pass: true, report: true });
    };
    let mut rng = TestRng::new(0x5eed);
    let dirs: Vec<DVec3> =
        SURFACE_THETAS.iter().enumerate().map(|(k, &t)| surface_direction(t, 0.4 + 1.3 * k as f64)).collect();

    // 1. finiteness and non-negativity
    let (nonfinite, negative) = finiteness(f, effort.pairs, &mut rng);
    test(&mut rows, "finite eval/pdf/sample (bad count)".into(), nonfinite as f64, 0.0, 0.0, nonfinite == 0);
    test(&mut rows, "non-negative eval/pdf (bad count)".into(), negative as f64, 0.0, 0.0, negative == 0);

    // 2–3. light-side albedo (energy), camera-side integral vs sample weights, pdf mass
    let per_direction: Vec<_> = dirs
        .par_iter()
        .enumerate()
        .map(|(k, &w)| {
            let albedo = smooth_albedo(f, w, 384, 1536);
            let furnace = smooth_furnace(f, w, 384, 1536);
            let means = sample_means(f, w, effort.samples, 31 + k as u64);
            let integral = pdf_integral(f, w);
            let consistency = sample_consistency(f, w, effort.samples / 5, 17 + k as u64);
            let chi2 = chi2_test(
                &AsFiberGrid(f),
                to_fiber(w),
                0.0,
                &Chi2Config { samples: effort.chi2_samples, seed: 99 + k as u64, ..Default::default() },
            );
            (k, albedo, furnace, means, integral, consistency, chi2)
        })
        .collect();
    let mut max_albedo: f64 = 0.0;
    let alpha = CHI2_SIGNIFICANCE / dirs.len() as f64;
    let n = effort.samples as f64;
    for (k, albedo, furnace, (mc, se, delta, smooth_fraction), integral, consistency, chi2) in per_direction {
        let th = SURFACE_THETAS[k];
        // The delta lobe's throughput for light from ω_i (a mirror lobe is reciprocal).
        let total = albedo + delta;
        max_albedo = max_albedo.max(total.max_component());
        match expected {
            Some(e) => test(
                &mut rows,
                format!("light-side albedo θ_i={th:.2} (luminance)"),
                total.luminance(),
                e.luminance(),
                ALBEDO_REL,
                max_rel(total, e) <= ALBEDO_REL,
            ),
            None => report(&mut rows, format!("light-side albedo θ_i={th:.2} (luminance)"), total.luminance()),
        }
        let tol = MC_SIGMAS * se.luminance() + MC_QUADRATURE_REL * furnace.luminance().abs() + ROUNDING_REL;
        test(
            &mut rows,
            format!("smooth lobes θ_o={th:.2}: mean sample weight vs ∫f_r cosθ_i (quadrature)"),
            mc.luminance(),
            furnace.luminance(),
            tol,
            (mc.luminance() - furnace.luminance()).abs() <= tol,
        );
        // The pdf's mass is the probability of a smooth sample (delta and dropped ones aside).
        let tol = MC_SIGMAS * (smooth_fraction * (1.0 - smooth_fraction) / n).sqrt() + PDF_INTEGRAL_ABS;
        test(
            &mut rows,
            format!("∫pdf dω θ_o={th:.2} vs smooth-sample fraction"),
            integral,
            smooth_fraction,
            tol,
            (integral - smooth_fraction).abs() <= tol,
        );
        test(
            &mut rows,
            format!("sample vs eval/pdf θ_o={th:.2} (max rel.)"),
            consistency,
            0.0,
            SAMPLE_CONSISTENCY_REL,
            consistency <= SAMPLE_CONSISTENCY_REL,
        );
        test(
            &mut rows,
            format!(
                "χ² p-value θ_o={th:.2} (dof {}, impossible {}, unresolved cells {})",
                chi2.dof, chi2.impossible, chi2.untrusted
            ),
            chi2.p_value,
            alpha,
            alpha,
            chi2.passes(alpha),
        );
    }
    if props.energy_conserving {
        test(
            &mut rows,
            "energy bound max ρ ≤ 1".into(),
            max_albedo,
            1.0,
            ENERGY_BOUND_SLACK,
            max_albedo <= 1.0 + ENERGY_BOUND_SLACK,
        );
    } else {
        report(&mut rows, "max ρ (no energy claim)".into(), max_albedo);
    }

    // 4. reciprocity
    let recip = reciprocity(f, effort.pairs / 4, &mut rng);
    if props.reciprocal {
        test(
            &mut rows,
            "reciprocity max relative defect".into(),
            recip,
            0.0,
            RECIPROCITY_REL,
            recip <= RECIPROCITY_REL,
        );
    } else {
        report(&mut rows, "non-reciprocity max relative (report)".into(), recip);
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_frames_agree_and_the_quadrature_integrates_cosines() {
        let s = surface_direction(0.7, -2.1);
        assert!((to_surface(to_fiber(s)) - s).length() < 1e-15);
        assert!((fiberlab_math::frame::sin_theta(to_fiber(s)) - s.z).abs() < 1e-15);
        let mut cos = 0.0;
        for_each_direction(256, 64, false, |w, dw| cos += w.z * dw);
        assert!((cos - PI).abs() < 1e-4, "{cos}");
        let mut all = 0.0;
        for_each_direction(256, 64, true, |_, dw| all += dw);
        assert!((all - 4.0 * PI).abs() < 1e-4, "{all}");
    }
}
