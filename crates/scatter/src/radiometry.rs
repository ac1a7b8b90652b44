//! Curve radiometry (`docs/theory/radiometry.md`): the scattering integral, albedo, projected width of
//! circular and elliptical cross-sections, and conversions between curve radiance `L̄`
//! (W m⁻¹ sr⁻¹, integrated across the fiber's image width) and radiance `L = L̄/D(ω)`.
//!
//! # Formula
//! `L̄_r(ω_r) = ∫_{S²} f_s(ω_i, ω_r)·D(ω_i)·L_i(ω_i)·cosθ_i dω_i` (for a circular fiber
//! `D` is constant and this is `D ∫ f_s L_i cosθ_i dω_i`), `ρ(ω_i) = ∫ f_s cosθ_r dω_r`,
//! and the generalized reciprocity `D(ω_i) f_s(ω_i, ω_r) = D(ω_r) f_s(ω_r, ω_i)`.

use crate::{Field, Lobes, ModelError, ScatteringFunction, params::Range};
use fiberlab_math::frame::{cos_theta, direction, direction_from_sin_cos, phi, theta};
use fiberlab_math::quadrature::width_nodes;
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// A fiber cross-section, in the fiber frame (semi-axes along `v` = y and `w` = z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CrossSection {
    /// A circle of the given radius.
    Circular {
        /// Radius (scene units).
        radius: f64,
    },
    /// An ellipse with semi-axis `a_v` along `v` (y) and `a_w` along `w` (z).
    Elliptical {
        /// Semi-axis along `v`.
        a_v: f64,
        /// Semi-axis along `w`.
        a_w: f64,
    },
}

impl CrossSection {
    /// A circle; the radius must be finite and positive.
    pub fn circular(radius: f64) -> Result<Self, ModelError> {
        Ok(Self::Circular { radius: Range::open(0.0, f64::INFINITY).check("radius", radius)? })
    }

    /// An ellipse; both semi-axes must be finite and positive.
    pub fn elliptical(a_v: f64, a_w: f64) -> Result<Self, ModelError> {
        let r = Range::open(0.0, f64::INFINITY);
        Ok(Self::Elliptical { a_v: r.check("a_v", a_v)?, a_w: r.check("a_w", a_w)? })
    }

    /// Projected width `D(ω)` of the fiber seen from direction `w` (fiber frame), measured
    /// perpendicular to the fiber's image: `2r` for a circle and
    /// `2·sqrt(a_v² sin²φ + a_w² cos²φ)` for an ellipse (φ the azimuth of `w`).
    #[must_use]
    pub fn projected_width(&self, w: DVec3) -> f64 {
        match *self {
            Self::Circular { radius } => 2.0 * radius,
            Self::Elliptical { a_v, a_w } => {
                let (s, c) = phi(w).sin_cos();
                2.0 * (a_v * a_v * s * s + a_w * a_w * c * c).sqrt()
            }
        }
    }

    /// Apparent radiance `L = L̄/D(ω)` from curve radiance `L̄` seen from `w`.
    #[must_use]
    pub fn curve_to_radiance(&self, curve_radiance: Rgb, w: DVec3) -> Rgb {
        curve_radiance / self.projected_width(w)
    }

    /// Curve radiance `L̄ = L·D(ω)` from width-averaged radiance `L` seen from `w`.
    #[must_use]
    pub fn radiance_to_curve(&self, radiance: Rgb, w: DVec3) -> Rgb {
        radiance * self.projected_width(w)
    }
}

/// Resolution of the quadratures below: midpoint θ cells over [−π/2, π/2] and φ cells over
/// [−π, π], and `h` nodes of the width average (near-field models only).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quadrature {
    /// Cells in θ.
    pub theta: usize,
    /// Cells in φ.
    pub phi: usize,
    /// Nodes of the width average, rounded up to whole panels of four (near-field models
    /// only; [`fiberlab_math::quadrature::width_nodes`]).
    pub h: usize,
}

impl Default for Quadrature {
    fn default() -> Self {
        Self { theta: 256, phi: 512, h: 16 }
    }
}

impl Quadrature {
    /// Calls `g(ω, dω)` at the midpoint of every (θ, φ) cell, `dω = cosθ dθ dφ`.
    pub fn for_each_direction(&self, mut g: impl FnMut(DVec3, f64)) {
        let (dt, dp) = (PI / self.theta as f64, TAU / self.phi as f64);
        for i in 0..self.theta {
            let t = -FRAC_PI_2 + (i as f64 + 0.5) * dt;
            let (s, c) = t.sin_cos();
            for j in 0..self.phi {
                let p = -PI + (j as f64 + 0.5) * dp;
                g(direction_from_sin_cos(s, c, p), c * dt * dp);
            }
        }
    }

    /// The h nodes and weights (summing to 1) for `f`'s field: the width-average rule of
    /// [`fiberlab_math::quadrature::width_nodes`] with about `h` nodes (four per panel) for a
    /// near-field model, `h = 0` for a far-field one.
    fn h_nodes(&self, field: Field) -> Vec<(f64, f64)> {
        if field == Field::Near { width_nodes(self.h.max(1).div_ceil(4)) } else { vec![(0.0, 1.0)] }
    }
}

/// `∫ g(ω_i) dω_i` over a delta model's cone for viewer `wr`, as `Σ value(φ)·g(ω_i(φ))dφ`.
fn cone_integral(f: &impl ScatteringFunction, wr: DVec3, n_phi: usize, mut g: impl FnMut(DVec3) -> Rgb) -> Rgb {
    let theta_o = theta(wr);
    let dp = TAU / n_phi as f64;
    let mut sum = Rgb::ZERO;
    for j in 0..n_phi {
        let rel = -PI + (j as f64 + 0.5) * dp;
        let wi = direction(-theta_o, phi(wr) - rel);
        sum += f.cone(theta_o, rel).value * g(wi) * dp;
    }
    sum
}

/// Curve radiance `L̄_r(ω_r) = ∫ f_s(ω_i, ω_r) D(ω_i) L_i(ω_i) cosθ_i dω_i` by midpoint
/// quadrature (near-field models are averaged over h; delta models integrate their cone).
pub fn scattering_integral(
    f: &impl ScatteringFunction,
    section: &CrossSection,
    wr: DVec3,
    radiance: impl Fn(DVec3) -> Rgb,
    quadrature: &Quadrature,
) -> Rgb {
    let props = f.properties();
    if props.lobes == Lobes::Delta {
        // f_s cosθ_i dω_i = value(φ)·δ(θ_i + θ_r) dθ_i dφ
        return cone_integral(f, wr, quadrature.phi, |wi| radiance(wi) * section.projected_width(wi));
    }
    let mut sum = Rgb::ZERO;
    for (h, wh) in quadrature.h_nodes(props.field) {
        quadrature.for_each_direction(|wi, dw| {
            let li = radiance(wi);
            if !li.is_black() {
                sum += f.eval(wi, wr, h) * li * (section.projected_width(wi) * cos_theta(wi) * dw * wh);
            }
        });
    }
    sum
}

/// Monte Carlo estimate of [`scattering_integral`] with `n` samples of `f.sample`
/// (h uniform on [−1, 1] for near-field models). Returns `(estimate, standard error)`.
pub fn scattering_integral_monte_carlo(
    f: &impl ScatteringFunction,
    section: &CrossSection,
    wr: DVec3,
    radiance: impl Fn(DVec3) -> Rgb,
    n: usize,
    mut uniform: impl FnMut() -> f64,
) -> (Rgb, Rgb) {
    let near = f.properties().field == Field::Near;
    let (mut sum, mut sum2) = (Rgb::ZERO, Rgb::ZERO);
    for _ in 0..n {
        let h = if near { 2.0 * uniform() - 1.0 } else { 0.0 };
        let u = [uniform(), uniform(), uniform(), uniform()];
        if let Some(s) = f.sample(wr, h, u) {
            let x = s.weight * radiance(s.wi) * section.projected_width(s.wi);
            sum += x;
            sum2 += x * x;
        }
    }
    let nf = n as f64;
    let mean = sum / nf;
    let var = (sum2 / nf - mean * mean).map(|v| v.max(0.0));
    (mean, (var / nf).map(f64::sqrt))
}

/// Light-side albedo `ρ(ω_i) = ∫ f_s(ω_i, ω_r) cosθ_r dω_r` by quadrature over `ω_r`
/// (h-averaged for near-field models; delta models integrate their cone).
pub fn albedo(f: &impl ScatteringFunction, wi: DVec3, quadrature: &Quadrature) -> Rgb {
    let props = f.properties();
    if props.lobes == Lobes::Delta {
        // Symmetric cone: the outgoing cone of ω_i has the same φ-profile (θ_r = −θ_i).
        return cone_integral(f, wi, quadrature.phi, |_| Rgb::ONE);
    }
    let mut sum = Rgb::ZERO;
    for (h, wh) in quadrature.h_nodes(props.field) {
        quadrature.for_each_direction(|wr, dw| sum += f.eval(wi, wr, h) * (cos_theta(wr) * dw * wh));
    }
    sum
}

/// Light-side albedo of each lobe, `ρ_p(ω_i) = ∫ f_p(ω_i, ω_r) cosθ_r dω_r`, by the quadrature
/// of [`albedo`], for a model that separates its lobes ([`ScatteringFunction::eval_lobes`]);
/// in the order of [`ScatteringFunction::lobes`], summing to [`albedo`]. `None` for a model
/// that does not separate them (or a delta model).
pub fn lobe_albedos(f: &impl ScatteringFunction, wi: DVec3, quadrature: &Quadrature) -> Option<Vec<Rgb>> {
    let props = f.properties();
    let n = f.lobes().len();
    let mut values = vec![Rgb::ZERO; n];
    if props.lobes == Lobes::Delta || !f.eval_lobes(wi, wi, 0.0, &mut values) {
        return None;
    }
    let mut sums = vec![Rgb::ZERO; n];
    for (h, wh) in quadrature.h_nodes(props.field) {
        quadrature.for_each_direction(|wr, dw| {
            f.eval_lobes(wi, wr, h, &mut values);
            let w = cos_theta(wr) * dw * wh;
            for (s, v) in sums.iter_mut().zip(&values) {
                *s += *v * w;
            }
        });
    }
    Some(sums)
}

/// Camera-side albedo (white furnace) `∫ f_s(ω_i, ω_o) cosθ_i dω_i`: the radiance
/// leaving toward `wo` under uniform unit illumination.
pub fn furnace(f: &impl ScatteringFunction, wo: DVec3, quadrature: &Quadrature) -> Rgb {
    scattering_integral(f, &CrossSection::Circular { radius: 0.5 }, wo, |_| Rgb::ONE, quadrature)
}

/// Generalized reciprocity defect `D(ω_i) f_s(ω_i, ω_r) − D(ω_r) f_s(ω_r, ω_i)`, zero for a
/// reciprocal fiber of the given cross-section.
pub fn reciprocity_defect(f: &impl ScatteringFunction, section: &CrossSection, wi: DVec3, wr: DVec3, h: f64) -> Rgb {
    f.eval(wi, wr, h) * section.projected_width(wi) - f.eval(wr, wi, h) * section.projected_width(wr)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ideal_diffuse::{IdealDiffuse, IdealDiffuseParams};
    use crate::lambertian_cylinder::{LambertianCylinder, LambertianCylinderParams};
    use crate::{Properties, Sample};
    use approx::assert_relative_eq;

    use fiberlab_check::rng::TestRng;

    #[test]
    fn ellipse_width_matches_projected_points() {
        let e = CrossSection::elliptical(1.0, 0.6).unwrap();
        for k in 0..20 {
            let w = direction(0.3, -3.0 + 0.3 * k as f64);
            // Width of the ellipse projected on the normal-plane direction perpendicular to w.
            let perp = DVec3::new(0.0, -w.z, w.y).normalize();
            let (mut lo, mut hi) = (f64::MAX, f64::MIN);
            for j in 0..20000 {
                let a = TAU * j as f64 / 20000.0;
                let p = DVec3::new(0.0, a.cos(), 0.6 * a.sin()).dot(perp);
                lo = lo.min(p);
                hi = hi.max(p);
            }
            assert_relative_eq!(e.projected_width(w), hi - lo, max_relative = 1e-6);
        }
        let l = e.curve_to_radiance(Rgb::splat(3.0), DVec3::Y);
        assert_relative_eq!(e.radiance_to_curve(l, DVec3::Y)[0], 3.0);
    }

    /// The lobes' albedos sum to the model's albedo (Chiang, near field; Marschner, far
    /// field); a model that does not separate its lobes has none.
    #[test]
    fn lobe_albedos_sum_to_the_albedo() {
        let q = Quadrature { theta: 96, phi: 192, h: 6 };
        for name in ["chiang", "marschner"] {
            let f = crate::build::<&str, &str>(name, &[]).unwrap();
            let wi = direction(0.4, 0.2);
            let lobes = lobe_albedos(&f, wi, &q).unwrap();
            assert_eq!(lobes.len(), f.lobes().len());
            let sum = lobes.iter().fold(Rgb::ZERO, |a, &b| a + b);
            let total = albedo(&f, wi, &q);
            for c in 0..3 {
                assert_relative_eq!(sum[c], total[c], max_relative = 1e-12);
                assert!(lobes.iter().all(|l| l[c] >= 0.0));
            }
            assert!(lobes[0].luminance() > 0.0, "{name}: R carries energy");
        }
        let diffuse = crate::build::<&str, &str>("diffuse", &[]).unwrap();
        assert!(lobe_albedos(&diffuse, direction(0.1, 0.0), &q).is_none());
    }

    #[test]
    fn diffuse_fiber_in_a_furnace_returns_its_albedo() {
        let f = IdealDiffuse::new(IdealDiffuseParams { albedo: Rgb::new(0.2, 0.5, 0.9) }).unwrap();
        let c = CrossSection::circular(0.5).unwrap();
        let wr = direction(0.4, 1.0);
        let q = scattering_integral(&f, &c, wr, |_| Rgb::ONE, &Quadrature::default());
        assert_relative_eq!(q[2], 0.9, max_relative = 1e-4);
        assert_relative_eq!(albedo(&f, wr, &Quadrature::default())[1], 0.5, max_relative = 1e-4);
    }

    #[test]
    fn quadrature_and_monte_carlo_agree_for_a_nonuniform_field() {
        // L_i(ω) = (ω·z)² + 0.1·sinθ + 0.2, elliptical fiber, Lambertian cylinder.
        let f = LambertianCylinder::new(LambertianCylinderParams { albedo: Rgb::splat(0.7) }).unwrap();
        let c = CrossSection::elliptical(1.0, 0.5).unwrap();
        let field = |w: DVec3| Rgb::splat(w.z * w.z + 0.1 * w.x + 0.2);
        let wr = direction(-0.6, 0.3);
        let q = scattering_integral(&f, &c, wr, field, &Quadrature { theta: 256, phi: 512, h: 1 });
        let (m, se) = scattering_integral_monte_carlo(&f, &c, wr, field, 400_000, TestRng::new(7).into_uniforms());
        assert!((q[0] - m[0]).abs() < 4.0 * se[0] + 1e-4, "quadrature {q:?} vs MC {m:?} ± {se:?}");
    }

    /// A non-circular fiber whose `D(ω_i) f_s` is symmetric satisfies generalized
    /// reciprocity; the same kernel without the 1/D(ω_i) does not.
    struct Weighted {
        section: CrossSection,
        divide: bool,
    }
    impl ScatteringFunction for Weighted {
        fn properties(&self) -> Properties {
            Properties { reciprocal: true, energy_conserving: false, field: Field::Far, lobes: Lobes::Smooth }
        }
        fn eval(&self, wi: DVec3, wr: DVec3, _h: f64) -> Rgb {
            let k = 1.0 + (wi.dot(wr)).powi(2) + 0.3 * (wi.y * wr.y);
            Rgb::splat(if self.divide { k / self.section.projected_width(wi) } else { k })
        }
        fn pdf(&self, _: DVec3, _: DVec3, _: f64) -> f64 {
            0.0
        }
        fn sample(&self, _: DVec3, _: f64, _: [f64; 4]) -> Option<Sample> {
            None
        }
    }

    #[test]
    fn generalized_reciprocity_detects_width_weighting() {
        let section = CrossSection::elliptical(1.0, 0.7).unwrap();
        let good = Weighted { section, divide: true };
        let bad = Weighted { section, divide: false };
        let (wi, wr) = (direction(0.2, 0.1), direction(-0.5, 1.3));
        assert!(reciprocity_defect(&good, &section, wi, wr, 0.0)[0].abs() < 1e-12);
        assert!(reciprocity_defect(&bad, &section, wi, wr, 0.0)[0].abs() > 1e-3);
    }
}
