//! PROSPECT-D: Féret, Gitelson, Noble & Jacquemoud 2017, *PROSPECT-D: Towards modeling leaf
//! optical properties through a complete lifecycle* (Remote Sensing of Environment 193), the
//! plate model of Jacquemoud & Baret 1990 (*PROSPECT: a model of leaf optical properties
//! spectra*, RSE 34) with the pigments of a whole leaf lifecycle: a leaf's hemispherical
//! reflectance and transmittance spectra from its structure and pigment contents. The specific
//! absorption spectra are the published data (`data/prospect_d_400_800.txt`, 400–800 nm, with
//! its source); the rest is computed here.
//!
//! The contents ([`LeafContents`]: structure `n`; chlorophyll a+b `cab`, carotenoids `car`,
//! anthocyanins `anth` in µg cm⁻²; brown pigments `cbrown`; water `cw` in cm; dry matter `cm` in
//! g cm⁻²) are the `leaf` model's parameters, with their units and ranges in its registry entry
//! (`fiberlab models --model leaf`); the defaults are a healthy green leaf.
//!
//! # The plate model, in our words
//! A leaf is N identical *plates* of leaf material (index n(λ)) in air, each absorbing with
//! `k(λ) = Σ_i C_i k_i(λ)/N` (contents × specific absorption, shared by the plates). Light inside
//! a plate is taken to be isotropic, so one crossing transmits
//! `τ = (1 − k)e^{−k} + k²E₁(k)` (the mean of `e^{−k/cosθ}` over an isotropic hemisphere, E₁ the
//! exponential integral). A plate face transmits isotropic light from air with
//! `t₁₂ = t_av(90°, n)` and from inside with `t₂₁ = t₁₂/n²`; `t_av(α, n)`, the transmissivity of
//! the face averaged over the directions within α of its normal, weighted by the projected solid
//! angle, is `(1/sin²α)∫_{cos α}^{1} (1 − F(c, n))·2c dc` with F the dielectric Fresnel reflectance
//! (Stern 1964; Allen 1973). Here it is integrated numerically (Simpson, 2048 intervals in c),
//! not by its closed form. Summing the reflections between the two faces,
//! * one plate under isotropic light: `t = t₁₂τt₂₁/(1 − r₂₁²τ²)`, `r = r₁₂ + r₂₁τt` (r = 1 − t);
//! * the top plate under light within α of the normal (PROSPECT uses α = 40°, the hemisphere
//!   seen by a spectrophotometer's integrating sphere): the same with `t_av(α, n)` for `t₁₂`;
//! * a pile of m plates (r, t each) by Stokes' solution for non-integer m: with `a + 1/a =
//!   (1 + r² − t²)/r`, `b + 1/b = (1 − r² + t²)/t` (a, b ≥ 1) and `x = b^{−2m}`,
//!   `R_m = a(1 − x)/(a² − x)`, `T_m = b^{−m}(a² − 1)/(a² − x)`; without absorption
//!   (`r + t = 1`) `T_m = t/(t + (1 − t)m)`, `R_m = 1 − T_m`;
//! * the leaf: the top plate over a pile of N − 1, `R = r_α + t_α t R_m/(1 − r R_m)`,
//!   `T = t_α T_m/(1 − r R_m)`.
//!
//! # The body of the leaf
//! Every term of R(α) but the top face's own reflection `1 − t_av(α)` passes through the top
//! face, and light that entered is isotropic whatever α it came from, so
//! `R(α) = (1 − t_av(α)) + t_av(α)·R_b` and `T(α) = t_av(α)·T_b` with the *body* reflectance
//! and transmittance `R_b = 1 − (1 − R_90)/t₁₂`, `T_b = T_90/t₁₂` (R_90, T_90 the leaf under
//! isotropic light) independent of α. `R_b + T_b ≤ 1`. The `leaf` surface model puts these under
//! its own rough cuticle ([`crate::leaf`]).

use fiberlab_math::colorimetry::reflectance_to_rgb;
use fiberlab_math::{Rgb, fresnel};
use std::sync::OnceLock;

/// The published specific absorption spectra (see the module docs for the source).
const DATA: &str = include_str!("../data/prospect_d_400_800.txt");
/// First wavelength of the data, nm.
pub const START_NM: f64 = 400.0;
/// Wavelengths in the data (400 … 800 nm, 1 nm apart).
pub const WAVELENGTHS: usize = 401;
/// PROSPECT's acceptance angle of the measured reflectance and transmittance, degrees.
pub const MEASURED_ALPHA_DEGREES: f64 = 40.0;
/// Simpson intervals of the `t_av` integral.
const TAV_INTERVALS: usize = 2048;

/// A leaf's structure and contents (PROSPECT-D's inputs; units in the module table).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafContents {
    /// Structure parameter N ≥ 1 (number of plates).
    pub n: f64,
    /// Chlorophyll a + b, µg cm⁻².
    pub cab: f64,
    /// Carotenoids, µg cm⁻².
    pub car: f64,
    /// Anthocyanins, µg cm⁻².
    pub anth: f64,
    /// Brown pigments, arbitrary units.
    pub cbrown: f64,
    /// Equivalent water thickness, cm.
    pub cw: f64,
    /// Dry matter per area, g cm⁻².
    pub cm: f64,
}

impl Default for LeafContents {
    /// A healthy green leaf: N 1.5, Cab 40, Car 8, no anthocyanins nor brown pigments, Cw 0.01,
    /// Cm 0.009 (the customary PROSAIL defaults).
    fn default() -> Self {
        Self { n: 1.5, cab: 40.0, car: 8.0, anth: 0.0, cbrown: 0.0, cw: 0.01, cm: 0.009 }
    }
}

/// One wavelength of the data.
#[derive(Clone, Copy, Debug)]
struct Row {
    /// Refractive index of the leaf material.
    n: f64,
    /// Specific absorption of cab, car, anth, cbrown, cw, cm.
    k: [f64; 6],
    /// `t_av(90°, n)`.
    t12: f64,
    /// `t_av(40°, n)`.
    t40: f64,
}

/// The data with the face transmissivities of each wavelength, parsed once per process.
fn rows() -> &'static [Row; WAVELENGTHS] {
    static ROWS: OnceLock<[Row; WAVELENGTHS]> = OnceLock::new();
    ROWS.get_or_init(|| {
        let mut rows = [Row { n: 1.0, k: [0.0; 6], t12: 1.0, t40: 1.0 }; WAVELENGTHS];
        let mut count = 0;
        for (line_no, line) in DATA.lines().enumerate() {
            if line.starts_with('#') || line.trim().is_empty() {
                continue;
            }
            let v: Vec<f64> = line
                .split_whitespace()
                .map(|x| x.parse().unwrap_or_else(|_| panic!("prospect_d_400_800.txt line {}: `{x}`", line_no + 1)))
                .collect();
            assert!(v.len() == 8 && v[0] == START_NM + count as f64, "prospect_d_400_800.txt line {}", line_no + 1);
            let n = v[1];
            rows[count] = Row { n, k: [v[2], v[3], v[4], v[5], v[6], v[7]], t12: tav(90.0, n), t40: tav(40.0, n) };
            count += 1;
        }
        assert_eq!(count, WAVELENGTHS, "prospect_d_400_800.txt: rows");
        rows
    })
}

/// `t_av(α, n)`: transmissivity of a face of index `n` (from air) for light within `alpha_deg`
/// of its normal, weighted by the projected solid angle: `(1/sin²α)∫_{cos α}^1 (1 − F(c))·2c dc`
/// by Simpson's rule.
#[must_use]
pub fn tav(alpha_deg: f64, n: f64) -> f64 {
    let a = alpha_deg.to_radians();
    let lo = a.cos().max(0.0);
    let m = TAV_INTERVALS;
    let step = (1.0 - lo) / m as f64;
    let g = |c: f64| (1.0 - fresnel::dielectric(c, n)) * 2.0 * c;
    let mut sum = g(lo) + g(1.0);
    for j in 1..m {
        sum += g(lo + j as f64 * step) * if j % 2 == 1 { 4.0 } else { 2.0 };
    }
    sum * step / 3.0 / (a.sin() * a.sin())
}

/// The exponential integral `E₁(x) = ∫_x^∞ e^{−t}/t dt` for x > 0: its power series below 1,
/// a continued fraction (modified Lentz) above.
#[must_use]
pub fn exponential_integral(x: f64) -> f64 {
    const EULER_GAMMA: f64 = 0.577_215_664_901_532_9;
    if x <= 1.0 {
        // E₁(x) = −γ − ln x − Σ_{k≥1} (−x)^k/(k·k!)
        let (mut sum, mut term) = (0.0, 1.0);
        for k in 1..60 {
            term *= -x / k as f64;
            let add = term / k as f64;
            sum += add;
            if add.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        -EULER_GAMMA - x.ln() - sum
    } else {
        // E₁(x) = e^{−x}·1/(x + 1 − 1²/(x + 3 − 2²/(x + 5 − …)))
        let tiny = 1e-300;
        let mut b = x + 1.0;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..200 {
            let a = -((i * i) as f64);
            b += 2.0;
            d = 1.0 / (a * d + b);
            c = b + a / c;
            let delta = c * d;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        h * (-x).exp()
    }
}

/// One crossing of a plate absorbing `k`: `τ = (1 − k)e^{−k} + k²E₁(k)` (1 at k = 0).
#[must_use]
pub fn plate_transmission(k: f64) -> f64 {
    if k <= 0.0 { 1.0 } else { (1.0 - k) * (-k).exp() + k * k * exponential_integral(k) }
}

/// Reflectance and transmittance of a pile of `m ≥ 0` plates of reflectance `r` and
/// transmittance `t` each (Stokes; non-integer m by the closed form of the module docs).
#[must_use]
pub fn pile(r: f64, t: f64, m: f64) -> (f64, f64) {
    if m == 0.0 {
        return (0.0, 1.0);
    }
    if t <= 0.0 {
        return (r, 0.0);
    }
    if 1.0 - r - t < 1e-9 {
        let tm = t / (t + (1.0 - t) * m);
        return (1.0 - tm, tm);
    }
    let d = ((1.0 + r + t) * (1.0 + r - t) * (1.0 - r + t) * (1.0 - r - t)).max(0.0).sqrt();
    let a = (1.0 + r * r - t * t + d) / (2.0 * r);
    let b = (1.0 - r * r + t * t + d) / (2.0 * t);
    let x = b.powf(-2.0 * m);
    (a * (1.0 - x) / (a * a - x), b.powf(-m) * (a * a - 1.0) / (a * a - x))
}

/// A leaf at one wavelength: `(R(α), T(α))` for light within `t_alpha = t_av(α, n)` and the body
/// `(R_b, T_b)`.
fn leaf_at(row: &Row, c: &LeafContents, t_alpha: f64) -> ([f64; 2], [f64; 2]) {
    let conc = [c.cab, c.car, c.anth, c.cbrown, c.cw, c.cm];
    let k = conc.iter().zip(row.k).map(|(c, k)| c * k).sum::<f64>() / c.n;
    let tau = plate_transmission(k);
    let t12 = row.t12;
    let t21 = t12 / (row.n * row.n);
    let r21 = 1.0 - t21;
    let denom = 1.0 - r21 * r21 * tau * tau;
    // One plate under isotropic light, and the top plate under light within α.
    let t = t12 * tau * t21 / denom;
    let r = (1.0 - t12) + r21 * tau * t;
    let t_a = t_alpha * tau * t21 / denom;
    let r_a = (1.0 - t_alpha) + r21 * tau * t_a;
    let (rm, tm) = pile(r, t, c.n - 1.0);
    let below = 1.0 - r * rm;
    let leaf = [r_a + t_a * t * rm / below, t_a * tm / below];
    let r90 = r + t * t * rm / below;
    let t90 = t * tm / below;
    (leaf, [1.0 - (1.0 - r90) / t12, t90 / t12])
}

/// The leaf's hemispherical reflectance and transmittance for light within
/// [`MEASURED_ALPHA_DEGREES`] of the normal (what PROSPECT reports), 400 … 800 nm at 1 nm.
#[must_use]
pub fn leaf_spectra(c: &LeafContents) -> ([f64; WAVELENGTHS], [f64; WAVELENGTHS]) {
    let (mut r, mut t) = ([0.0; WAVELENGTHS], [0.0; WAVELENGTHS]);
    for (j, row) in rows().iter().enumerate() {
        let ([rl, tl], _) = leaf_at(row, c, row.t40);
        r[j] = rl;
        t[j] = tl;
    }
    (r, t)
}

/// The body's reflectance and transmittance spectra `R_b`, `T_b` (see the module docs),
/// 400 … 800 nm at 1 nm.
#[must_use]
pub fn body_spectra(c: &LeafContents) -> ([f64; WAVELENGTHS], [f64; WAVELENGTHS]) {
    let (mut r, mut t) = ([0.0; WAVELENGTHS], [0.0; WAVELENGTHS]);
    for (j, row) in rows().iter().enumerate() {
        let (_, [rb, tb]) = leaf_at(row, c, row.t40);
        r[j] = rb;
        t[j] = tb;
    }
    (r, t)
}

/// The body's reflectance and transmittance in fiberlab's RGB (D65, CIE 1931,
/// [`fiberlab_math::colorimetry`]), each channel clamped at 0: a leaf's saturated green lies
/// outside the Rec. 709 gamut, where the conversion gives a slightly negative blue or red.
#[must_use]
pub fn body_rgb(c: &LeafContents) -> (Rgb, Rgb) {
    let (r, t) = body_spectra(c);
    let rgb = |s: &[f64]| reflectance_to_rgb(START_NM, 1.0, s).map(|x| x.max(0.0));
    (rgb(&r), rgb(&t))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// E₁ against values from its defining integral (independent: Simpson on e^{−t}/t after
    /// t = x/u, u ∈ (0, 1]).
    #[test]
    fn exponential_integral_matches_its_integral() {
        for x in [1e-3, 0.1, 0.5, 1.0, 1.5, 4.0, 20.0] {
            // E₁(x) = ∫_0^1 e^{−x/u}/u du
            let n = 200_000;
            let integral: f64 = (0..n)
                .map(|j| {
                    let u = (j as f64 + 0.5) / n as f64;
                    (-x / u).exp() / u
                })
                .sum::<f64>()
                / n as f64;
            let got = exponential_integral(x);
            assert!((got - integral).abs() < 2e-5 * integral.max(1e-300) + 1e-12, "E1({x}) = {got} vs {integral}");
        }
        assert!((exponential_integral(1.0) - 0.219_383_934_395_520_3).abs() < 1e-15);
    }

    /// The transmissivity of a face from inside, by the same quadrature of the internal
    /// Fresnel reflectance (total reflection included), is `t_av(90°, n)/n²`, the identity the
    /// plate model uses; at normal incidence only, `t_av → 1 − ((n − 1)/(n + 1))²`.
    #[test]
    fn face_transmissivities_obey_the_reciprocity_identity() {
        for n in [1.33, 1.47, 1.5115] {
            let m = 200_000;
            let inside: f64 = (0..m)
                .map(|j| {
                    let c = (j as f64 + 0.5) / m as f64;
                    (1.0 - fresnel::dielectric(c, 1.0 / n)) * 2.0 * c
                })
                .sum::<f64>()
                / m as f64;
            assert!((inside - tav(90.0, n) / (n * n)).abs() < 1e-6, "n {n}: {inside} vs {}", tav(90.0, n) / (n * n));
            let normal = 1.0 - ((n - 1.0) / (n + 1.0)).powi(2);
            assert!((tav(0.5, n) - normal).abs() < 1e-6);
        }
    }

    /// Stokes' closed form against piling plates one by one (adding), for integer counts; a
    /// pile of one is the plate; without absorption nothing is lost.
    #[test]
    fn piles_match_adding_plates_one_by_one() {
        for &(r, t) in &[(0.1, 0.7), (0.3, 0.3), (0.05, 0.94), (0.2, 0.0)] {
            let (mut rm, mut tm) = (r, t);
            for m in 1..6 {
                let (a, b) = pile(r, t, m as f64);
                assert!((a - rm).abs() < 1e-12 && (b - tm).abs() < 1e-12, "m {m}: ({a}, {b}) vs ({rm}, {tm})");
                // Add one more plate below: R' = R + T²r/(1 − Rr), T' = Tt/(1 − Rr).
                let below = 1.0 - rm * r;
                (rm, tm) = (rm + tm * tm * r / below, tm * t / below);
            }
        }
        let (a, b) = pile(0.2, 0.8, 2.5);
        assert!((a + b - 1.0).abs() < 1e-12);
    }

    /// The healthy default leaf: green (reflects and transmits more green than red or blue),
    /// every value in [0, 1] with R + T ≤ 1, and the body relation `R(40°) = 1 − t_av(40°) +
    /// t_av(40°)R_b` holds at every wavelength.
    #[test]
    fn the_default_leaf_is_green_and_conserves_energy() {
        let c = LeafContents::default();
        let (r, t) = leaf_spectra(&c);
        let (rb, tb) = body_spectra(&c);
        for (j, row) in rows().iter().enumerate() {
            assert!(r[j] > 0.0 && t[j] >= 0.0 && r[j] + t[j] <= 1.0, "{j}");
            assert!(rb[j] >= 0.0 && tb[j] >= 0.0 && rb[j] + tb[j] <= 1.0, "{j}");
            assert!((r[j] - (1.0 - row.t40 + row.t40 * rb[j])).abs() < 1e-12);
            assert!((t[j] - row.t40 * tb[j]).abs() < 1e-12);
        }
        let (r_rgb, t_rgb) = body_rgb(&c);
        assert!(r_rgb.min_component() >= 0.0 && t_rgb.min_component() >= 0.0, "{r_rgb:?} {t_rgb:?}");
        assert!(r_rgb[1] > r_rgb[0] && r_rgb[1] > r_rgb[2], "{r_rgb:?}");
        assert!(t_rgb[1] > t_rgb[0] && t_rgb[1] > t_rgb[2], "{t_rgb:?}");
        // Chlorophyll absorbs most at 430 and 660 nm, least near 550 nm.
        assert!(r[150] > 2.0 * r[260] && r[150] > 2.0 * r[30], "{} {} {}", r[30], r[150], r[260]);
    }
}
