//! Finished wood and chatoyant minerals: Marschner, Westin, Arbree and Moon, *Measuring and
//! modeling the appearance of finished wood* (SIGGRAPH 2005): the subsurface fiber highlight
//! seen through a clear finish.
//!
//! Parameters: the registry entry (the `params` of `Registered::INFO` below) is the one table of
//! keys, units, defaults and valid ranges; `fiberlab models --model wood` prints it and the book's
//! page `docs/book/src/models/wood.md` shows it. The formulas below write `eta` as η, `roughness`
//! as α, `beta` as β.
//!
//! # Geometry
//! A clear finish of index η lies over a matrix of aligned fibers whose unit axis, in the
//! local frame (`z` = normal, `x` = tangent), is
//! `u = (cos δ·cos a, cos δ·sin a, −sin δ)` with `a` = `fiber_angle` (in the tangent plane,
//! from +x toward +y) and δ = `fiber_dip` (the axis descends below the surface toward `a`;
//! the dip is what makes curly and quilted figure).
//!
//! # Formula
//! Both directions point away from the surface. Each is refracted through the finish into
//! the wood, `ω′ = (ω_x/η, ω_y/η, √(1 − (ω_x² + ω_y²)/η²))` (pointing back up), and loses
//! the Fresnel reflectance on the way: `T = 1 − F(η, cosθ)`. The fiber angles are
//! `ψ = asin(ω′·u)`, with `ψ_h = ψ_i + ψ_o` (the sum: 0 on the specular cone of the fiber)
//! and `ψ_d = ψ_o − ψ_i`. Below the finish (the paper's subsurface model)
//!
//! `f_ss(ω_i′, ω_o′) = k_d/π + k_f·g(β; ψ_h)/cos²(ψ_d/2)`,
//!
//! `g` a unit-area Gaussian of standard deviation β. Seen from outside,
//!
//! `f_r(ω_i, ω_o) = f_finish(ω_i, ω_o) + (T_i·T_o/η²)·f_ss(ω_i′, ω_o′)`.
//!
//! The `1/η²`: radiance entering a medium of index η is multiplied by `η²T` and leaving it
//! by `T/η²`, while `cosθ dω = η² cosθ′ dω′`; carrying `L_r = ∫ f_r L_i cosθ_i dω_i` through
//! both crossings leaves one factor `1/η²` on the subsurface BRDF (our derivation). Over
//! exit directions the factor cancels the solid-angle compression:
//! `∫ f_r cosθ_o dω_o = T_i ∫ T_o f_ss cosθ_o′ dω_o′` for the subsurface part.
//!
//! The fiber term is an ideal specular fiber with uniform azimuthal scattering, smoothed in
//! `ψ_i + ψ_o` by the Gaussian, evaluated on the refracted directions: written with
//! `cos²(ψ_d/2)` (which equals `cos²ψ_i` on the cone) it is `2π·k_f` times that fiber's
//! `f_s = g(β; θ_i + θ_r)/(2π cos²θ_d)` (`docs/theory/radiometry.md`, "Ideal specular
//! fiber"; tested). Every factor is symmetric in the two directions, so the model is
//! reciprocal (tested exactly).
//!
//! The finish: `roughness = 0` is a smooth interface, a mirror delta lobe of weight
//! `F(η, cosθ_o)` that `eval` and `pdf` leave out and `sample` returns with `pdf = 0`;
//! `roughness = α > 0` is a GGX (Trowbridge–Reitz) dielectric reflection lobe
//! `F(η, ω_i·h)·D(h)·G₂(ω_i, ω_o)/(4 cosθ_i cosθ_o)` with the height-correlated Smith
//! shadowing (Walter et al. 2007; Heitz 2014), while light entering the wood is still
//! refracted by the mean surface (the paper's smooth-coat approximation).
//!
//! # Energy
//! Below the finish the diffuse term returns at most `k_d` and the fiber term at most `2π·k_f`
//! of what enters (the delta fiber's bound; the Gaussian smoothing keeps it within rounding
//! for the widths allowed), so the model claims energy conservation when
//! `k_d + 2π·k_f ≤ 1` in every channel (checked by `fiberlab check`).
//!
//! # Sampling
//! Exact, a mixture chosen from `ω_o` alone with weights `F(cosθ_o)` (finish),
//! `T_o·mean(k_d)` (diffuse) and `T_o·2π·mean(k_f)` (fiber): the finish by its mirror
//! direction or by GGX visible normals (Heitz 2018); the diffuse lobe cosine-weighted over
//! the hemisphere; the fiber lobe inside the wood, `ψ_h` from the Gaussian truncated to
//! `|ψ_h − ψ_o| ≤ π/2` (mass Z), then the azimuth about `u` uniform on the arc of that cone
//! that can leave through the finish (inside the critical angle: an arc of length `L(ψ_i)`
//! in closed form), then refracted out; only a cone with no such arc drops the sample
//! (`None`). The density of a fiber sample is `g(β; ψ_h)/(Z·L(ψ_i)·cosψ_i)` per internal
//! steradian, times `dω′/dω = cosθ_i/(η² cosθ_i′)`.
//!
//! # Presets (`preset=`)
//! Chatoyant minerals: fibers in the surface plane under a polish, no separate finish.
//! `tigers-eye`: quartz η = 1.54, β = 3°, golden-brown `k_d` and `k_f`; `cats-eye`
//! (chrysoberyl with rutile needles): η = 1.75, β = 2°, honey-green. Keys given explicitly
//! override the preset's.

use crate::params::{ParamKind, ParamSet, ParamSpec, Range, parameter_error};
use crate::sampling::cosine_hemisphere;
use crate::surface::not_texturable;
use crate::{
    FiberHighlight, LobeInfo, MIN_COS, ModelError, ModelInfo, Registered, Sample, SurfaceProperties, SurfaceScattering,
};
use fiberlab_math::special::{gaussian, normal_mass, sample_truncated_normal};
use fiberlab_math::{DVec3, Rgb, fresnel};
use std::f64::consts::{FRAC_1_PI, FRAC_PI_2, PI, TAU};

const ETA: Range = Range::closed(1.0, 3.0);
const ROUGHNESS: Range = Range::UNIT;
const K_D: Range = Range::UNIT;
const K_F: Range = Range::closed(0.0, 10.0);
/// Degrees.
const BETA: Range = Range::closed(0.5, 45.0);
/// Degrees.
const ANGLE: Range = Range::closed(-360.0, 360.0);
/// Degrees.
const DIP: Range = Range::closed(-90.0, 90.0);

/// Registry entry: `wood`.
impl Registered for Wood {
    const INFO: ModelInfo = ModelInfo {
        name: "wood",
        summary: "finished wood / chatoyant minerals: fiber highlight under a dielectric finish",
        citation: "Marschner, Westin, Arbree, Moon 2005, Measuring and modeling the appearance of finished wood",
        params: &[
            ParamSpec {
                key: "preset",
                kind: ParamKind::Choice(&["none", "tigers-eye", "cats-eye"]),
                unit: "",
                default: "none",
                doc: "chatoyant-mineral preset; keys given explicitly override it",
            },
            ParamSpec {
                key: "eta",
                kind: ParamKind::Number(ETA),
                unit: "",
                default: "1.5",
                doc: "index of refraction of the finish (and of the matrix below it)",
            },
            ParamSpec {
                key: "roughness",
                kind: ParamKind::Number(ROUGHNESS),
                unit: "",
                default: "0",
                doc: "GGX α of the finish; 0 = smooth (a delta lobe)",
            },
            ParamSpec {
                key: "k_d",
                kind: ParamKind::Color(K_D),
                unit: "",
                default: "0.35,0.2,0.1",
                doc: "subsurface diffuse albedo (texturable)",
            },
            ParamSpec {
                key: "k_f",
                kind: ParamKind::Color(K_F),
                unit: "",
                default: "0.1,0.07,0.04",
                doc: "fiber highlight strength; 2π·k_f is its albedo (texturable)",
            },
            ParamSpec {
                key: "beta",
                kind: ParamKind::Number(BETA),
                unit: "degrees",
                default: "10",
                doc: "width (std) of the fiber highlight in ψ_h (texturable)",
            },
            ParamSpec {
                key: "fiber_angle",
                kind: ParamKind::Number(ANGLE),
                unit: "degrees",
                default: "0",
                doc: "fiber axis in the tangent plane, from +x toward +y (texturable)",
            },
            ParamSpec {
                key: "fiber_dip",
                kind: ParamKind::Number(DIP),
                unit: "degrees",
                default: "0",
                doc: "dip of the fiber axis below the surface (texturable)",
            },
        ],
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Wood::new(WoodParams::from_param_set(p)?)?)
    }
}

/// Parameters of [`Wood`] (angles in radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WoodParams {
    /// Index of refraction of the finish, in [1, 3].
    pub eta: f64,
    /// GGX α of the finish, in [0, 1] (0: smooth).
    pub roughness: f64,
    /// Subsurface diffuse albedo per channel, in [0, 1].
    pub k_d: Rgb,
    /// Fiber highlight strength per channel, in [0, 10].
    pub k_f: Rgb,
    /// Width β of the highlight (radians; [0.5°, 45°]).
    pub beta: f64,
    /// In-plane angle of the fiber axis from +x toward +y (radians).
    pub fiber_angle: f64,
    /// Dip of the fiber axis below the surface (radians; [−90°, 90°]).
    pub fiber_dip: f64,
}

impl Default for WoodParams {
    /// The registry defaults: η = 1.5, smooth finish, a brown wood with β = 10°, fibers along x.
    fn default() -> Self {
        Self {
            eta: 1.5,
            roughness: 0.0,
            k_d: Rgb::new(0.35, 0.2, 0.1),
            k_f: Rgb::new(0.1, 0.07, 0.04),
            beta: 10f64.to_radians(),
            fiber_angle: 0.0,
            fiber_dip: 0.0,
        }
    }
}

impl WoodParams {
    /// Tiger's eye: quartz (η = 1.54) with fibers in the surface plane, β = 3°, golden brown.
    #[must_use]
    pub fn tigers_eye() -> Self {
        Self {
            eta: 1.54,
            roughness: 0.0,
            k_d: Rgb::new(0.25, 0.13, 0.03),
            k_f: Rgb::new(0.11, 0.075, 0.025),
            beta: 3f64.to_radians(),
            fiber_angle: 0.0,
            fiber_dip: 0.0,
        }
    }

    /// Cat's-eye chrysoberyl: η = 1.75, fibers (rutile needles) in the plane, β = 2°, honey green.
    #[must_use]
    pub fn cats_eye() -> Self {
        Self {
            eta: 1.75,
            roughness: 0.0,
            k_d: Rgb::new(0.2, 0.18, 0.05),
            k_f: Rgb::new(0.12, 0.11, 0.05),
            beta: 2f64.to_radians(),
            fiber_angle: 0.0,
            fiber_dip: 0.0,
        }
    }

    /// Reads the registry parameters: the preset's values, overridden by keys given explicitly.
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        let base = match p.choice("preset")? {
            "tigers-eye" => Self::tigers_eye(),
            "cats-eye" => Self::cats_eye(),
            _ => return Self::read(p, None),
        };
        Self::read(p, Some(base))
    }

    fn read(p: &ParamSet, preset: Option<Self>) -> Result<Self, ModelError> {
        let given = |k: &str| preset.is_none() || p.is_given(k);
        let b = preset.unwrap_or_default();
        Ok(Self {
            eta: if given("eta") { p.number("eta")? } else { b.eta },
            roughness: if given("roughness") { p.number("roughness")? } else { b.roughness },
            k_d: if given("k_d") { p.color("k_d")? } else { b.k_d },
            k_f: if given("k_f") { p.color("k_f")? } else { b.k_f },
            beta: if given("beta") { p.degrees("beta")? } else { b.beta },
            fiber_angle: if given("fiber_angle") { p.degrees("fiber_angle")? } else { b.fiber_angle },
            fiber_dip: if given("fiber_dip") { p.degrees("fiber_dip")? } else { b.fiber_dip },
        })
    }
}

parameter_error! {
    /// Why a [`Wood`] surface cannot be built.
    WoodError
}

/// The fiber axis `u = (cos δ·cos a, cos δ·sin a, −sin δ)` in the local frame.
#[must_use]
pub fn fiber_axis(fiber_angle: f64, fiber_dip: f64) -> DVec3 {
    let (sa, ca) = fiber_angle.sin_cos();
    let (sd, cd) = fiber_dip.sin_cos();
    DVec3::new(cd * ca, cd * sa, -sd)
}

/// Finished wood (or a chatoyant mineral): a dielectric finish over a diffuse matrix with a
/// subsurface fiber highlight.
///
/// At normal incidence and exit the Fresnel transmittance is `1 − ((η − 1)/(η + 1))²` on
/// both crossings, so a purely diffuse wood gives `T²·k_d/(π η²)`:
/// ```
/// use fiberlab_scatter::SurfaceScattering;
/// use fiberlab_scatter::marschner_2005::{Wood, WoodParams};
/// use fiberlab_math::{DVec3, Rgb};
/// let p = WoodParams { k_d: Rgb::splat(0.5), k_f: Rgb::ZERO, ..WoodParams::default() };
/// let v = Wood::new(p).unwrap().eval(DVec3::Z, DVec3::Z);
/// let t = 1.0 - 0.04;
/// assert!((v[0] - t * t * 0.5 / (std::f64::consts::PI * 1.5 * 1.5)).abs() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Wood {
    eta: f64,
    /// GGX α (0: smooth finish).
    alpha: f64,
    k_d: Rgb,
    k_f: Rgb,
    beta: f64,
    fiber_angle: f64,
    fiber_dip: f64,
    /// Derived: the fiber axis.
    u: DVec3,
    /// Derived: two unit vectors completing `u` to an orthonormal basis.
    e1: DVec3,
    e2: DVec3,
}

impl Wood {
    /// A wood surface; every parameter is checked against its range.
    pub fn new(p: WoodParams) -> Result<Self, WoodError> {
        let mut w = Self {
            eta: ETA.check("eta", p.eta)?,
            alpha: ROUGHNESS.check("roughness", p.roughness)?,
            k_d: K_D.check_rgb("k_d", p.k_d)?,
            k_f: K_F.check_rgb("k_f", p.k_f)?,
            beta: BETA.check_degrees("beta", p.beta)?,
            fiber_angle: ANGLE.check_degrees("fiber_angle", p.fiber_angle)?,
            fiber_dip: DIP.check_degrees("fiber_dip", p.fiber_dip)?,
            u: DVec3::X,
            e1: DVec3::Y,
            e2: DVec3::Z,
        };
        w.update_axis();
        Ok(w)
    }

    fn update_axis(&mut self) {
        self.u = fiber_axis(self.fiber_angle, self.fiber_dip);
        let frame = fiberlab_math::FiberFrame::from_tangent(self.u);
        (self.e1, self.e2) = (frame.v, frame.w);
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> WoodParams {
        WoodParams {
            eta: self.eta,
            roughness: self.alpha,
            k_d: self.k_d,
            k_f: self.k_f,
            beta: self.beta,
            fiber_angle: self.fiber_angle,
            fiber_dip: self.fiber_dip,
        }
    }

    /// The fiber axis `u` in the local frame.
    #[must_use]
    pub fn axis(&self) -> DVec3 {
        self.u
    }

    /// `ω` refracted into the wood, pointing back up (`z > 0` for `z > 0` input).
    #[must_use]
    pub fn refract_in(&self, w: DVec3) -> DVec3 {
        let (x, y) = (w.x / self.eta, w.y / self.eta);
        DVec3::new(x, y, (1.0 - x * x - y * y).max(0.0).sqrt())
    }

    /// An internal direction refracted out (`None` beyond the critical angle).
    fn refract_out(&self, w: DVec3) -> Option<DVec3> {
        let (x, y) = (w.x * self.eta, w.y * self.eta);
        let z2 = 1.0 - x * x - y * y;
        (z2 > 0.0 && w.z > 0.0).then(|| DVec3::new(x, y, z2.sqrt()))
    }

    /// Fresnel transmittance of the finish for a direction outside with `cosθ`.
    fn transmittance(&self, cos_theta: f64) -> f64 {
        1.0 - fresnel::dielectric(cos_theta, self.eta)
    }

    /// `(ψ, cosψ)` of an internal direction about the fiber axis.
    fn fiber_angle_of(&self, w: DVec3) -> (f64, f64) {
        let s = w.dot(self.u).clamp(-1.0, 1.0);
        (s.asin(), (1.0 - s * s).sqrt())
    }

    /// `f_ss` below the finish for internal directions.
    fn subsurface(&self, wi: DVec3, wo: DVec3) -> Rgb {
        let (psi_i, _) = self.fiber_angle_of(wi);
        let (psi_o, _) = self.fiber_angle_of(wo);
        let c = (0.5 * (psi_o - psi_i)).cos();
        self.k_d * FRAC_1_PI + self.k_f * (gaussian(self.beta, psi_i + psi_o) / (c * c).max(MIN_COS * MIN_COS))
    }

    /// The subsurface part of `f_r` (transmissions, `1/η²`, `f_ss`); directions outside, `z > 0`.
    fn through_finish(&self, wi: DVec3, wo: DVec3) -> Rgb {
        let t = self.transmittance(wi.z) * self.transmittance(wo.z) / (self.eta * self.eta);
        self.subsurface(self.refract_in(wi), self.refract_in(wo)) * t
    }

    /// GGX `D(h)` for `cos θ_h`.
    fn ggx_d(&self, cos_h: f64) -> f64 {
        let a2 = self.alpha * self.alpha;
        let d = cos_h * cos_h * (a2 - 1.0) + 1.0;
        a2 / (PI * d * d)
    }

    /// Smith Λ of GGX for a direction with `cos θ = c`.
    fn ggx_lambda(&self, c: f64) -> f64 {
        let c2 = c * c;
        let tan2 = (1.0 - c2).max(0.0) / c2.max(MIN_COS * MIN_COS);
        0.5 * ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0)
    }

    /// The rough finish's `f_r` (0 for a smooth finish).
    fn finish(&self, wi: DVec3, wo: DVec3) -> f64 {
        if self.alpha == 0.0 {
            return 0.0;
        }
        let h = (wi + wo).normalize_or_zero();
        if h.z <= 0.0 {
            return 0.0;
        }
        let g2 = 1.0 / (1.0 + self.ggx_lambda(wi.z) + self.ggx_lambda(wo.z));
        fresnel::dielectric(wi.dot(h), self.eta) * self.ggx_d(h.z) * g2 / (4.0 * wi.z.max(MIN_COS) * wo.z.max(MIN_COS))
    }

    /// Density of the visible-normal sampler for `wi` given `wo` (rough finish).
    fn finish_pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        let h = (wi + wo).normalize_or_zero();
        if h.z <= 0.0 || wo.dot(h) <= 0.0 {
            return 0.0;
        }
        let g1 = 1.0 / (1.0 + self.ggx_lambda(wo.z));
        g1 * self.ggx_d(h.z) / (4.0 * wo.z.max(MIN_COS))
    }

    /// A GGX visible normal for `wo` from two uniforms (Heitz 2018, our own derivation order).
    fn sample_visible_normal(&self, wo: DVec3, u1: f64, u2: f64) -> DVec3 {
        let a = self.alpha;
        // Stretch to the configuration of unit roughness, where visible normals are the
        // projected hemisphere seen from `v`.
        let v = DVec3::new(a * wo.x, a * wo.y, wo.z).normalize();
        let len2 = v.x * v.x + v.y * v.y;
        let t1 = if len2 > 0.0 { DVec3::new(-v.y, v.x, 0.0) / len2.sqrt() } else { DVec3::X };
        let t2 = v.cross(t1);
        let r = u1.sqrt();
        let (sp, cp) = (TAU * u2).sin_cos();
        let p1 = r * cp;
        let s = 0.5 * (1.0 + v.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sp;
        let n = t1 * p1 + t2 * p2 + v * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        DVec3::new(a * n.x, a * n.y, n.z.max(0.0)).normalize()
    }

    /// Lobe probabilities (finish, diffuse, fiber) for a viewer with `cos θ_o`.
    fn lobe_weights(&self, cos_o: f64) -> [f64; 3] {
        let f = fresnel::dielectric(cos_o, self.eta);
        let t = 1.0 - f;
        let w = [f, t * self.k_d.average(), t * TAU * self.k_f.average()];
        let sum = w[0] + w[1] + w[2];
        if sum > 0.0 { w.map(|x| x / sum) } else { [0.0; 3] }
    }

    /// Density (outside sr⁻¹) of the fiber sampler for `wi` given `wo`, both outside, `z > 0`.
    fn fiber_pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        let (wi_in, wo_in) = (self.refract_in(wi), self.refract_in(wo));
        let (psi_i, cos_psi_i) = self.fiber_angle_of(wi_in);
        let (psi_o, _) = self.fiber_angle_of(wo_in);
        let mass = self.psi_h_mass(psi_o);
        if mass <= 0.0 {
            return 0.0;
        }
        let (_, half_width) = self.escape_arc(psi_i.sin(), cos_psi_i);
        if half_width <= 0.0 {
            return 0.0;
        }
        let internal = gaussian(self.beta, psi_i + psi_o) / (mass * 2.0 * half_width * cos_psi_i.max(MIN_COS));
        internal * wi.z / (self.eta * self.eta * wi_in.z.max(MIN_COS))
    }

    /// The arc of the cone `ω′·u = sinψ` (azimuth φ about `u`, from `e1` toward `e2`) whose
    /// directions leave through the finish (`z′ > cos θ_c`, `sin θ_c = 1/η`): its centre φ₀ and
    /// half-width in [0, π]. On the cone `z′ = sinψ·u_z + cosψ·cos δ·cos(φ − φ₀)`.
    fn escape_arc(&self, sin_psi: f64, cos_psi: f64) -> (f64, f64) {
        let z_c = (1.0 - 1.0 / (self.eta * self.eta)).max(0.0).sqrt();
        let (a, b) = (sin_psi * self.u.z, cos_psi * self.e1.z.hypot(self.e2.z));
        let phi0 = self.e2.z.atan2(self.e1.z);
        if b <= 1e-12 {
            return (phi0, if a > z_c { PI } else { 0.0 });
        }
        let c = (z_c - a) / b;
        (
            phi0,
            if c <= -1.0 {
                PI
            } else if c >= 1.0 {
                0.0
            } else {
                c.acos()
            },
        )
    }

    /// Mass of the Gaussian in ψ_h over `[ψ_o − π/2, ψ_o + π/2]` (so that ψ_i ∈ [−π/2, π/2]).
    fn psi_h_mass(&self, psi_o: f64) -> f64 {
        normal_mass((psi_o - FRAC_PI_2) / self.beta, (psi_o + FRAC_PI_2) / self.beta)
    }

    fn pdf_given(&self, wi: DVec3, wo: DVec3, w: [f64; 3]) -> f64 {
        let mut p = w[1] * wi.z * FRAC_1_PI;
        if w[0] > 0.0 && self.alpha > 0.0 {
            p += w[0] * self.finish_pdf(wi, wo);
        }
        if w[2] > 0.0 {
            p += w[2] * self.fiber_pdf(wi, wo);
        }
        p
    }

    /// Whether every channel satisfies `k_d + 2π·k_f ≤ 1`.
    fn bounded(&self) -> bool {
        (0..3).all(|c| self.k_d[c] + TAU * self.k_f[c] <= 1.0)
    }
}

impl FiberHighlight for Wood {
    fn axis(&self) -> DVec3 {
        self.u
    }

    fn refract_in(&self, w: DVec3) -> DVec3 {
        Wood::refract_in(self, w)
    }

    fn fiber_strength(&self) -> Rgb {
        self.k_f
    }

    /// The subsurface fiber lobe through the smooth finish (`k_d = 0`, no rough reflection).
    fn fiber_term(&self, wi: DVec3, wo: DVec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let fibers_only = Wood { k_d: Rgb::ZERO, ..*self };
        fibers_only.through_finish(wi, wo)
    }
}

impl SurfaceScattering for Wood {
    fn fiber_highlight(&self) -> Option<&dyn FiberHighlight> {
        Some(self)
    }

    fn properties(&self) -> SurfaceProperties {
        SurfaceProperties {
            reciprocal: true,
            energy_conserving: self.bounded(),
            has_delta: self.alpha == 0.0,
            transmits: false,
        }
    }

    fn eval(&self, wi: DVec3, wo: DVec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.through_finish(wi, wo) + Rgb::splat(self.finish(wi, wo))
    }

    fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        self.pdf_given(wi, wo, self.lobe_weights(wo.z))
    }

    fn sample(&self, wo: DVec3, u: [f64; 4]) -> Option<Sample> {
        if wo.z <= 0.0 {
            return None;
        }
        let w = self.lobe_weights(wo.z);
        let (lobe, wi) = if u[0] < w[0] {
            if self.alpha == 0.0 {
                let wi = DVec3::new(-wo.x, -wo.y, wo.z);
                let weight = Rgb::splat(fresnel::dielectric(wo.z, self.eta) / w[0]);
                return Some(Sample { wi, weight, pdf: 0.0, delta: true, lobe: 0 });
            }
            let h = self.sample_visible_normal(wo, u[1], u[2]);
            (0, 2.0 * wo.dot(h) * h - wo)
        } else if u[0] < w[0] + w[1] {
            (1, cosine_hemisphere(DVec3::Z, DVec3::X, u[1], u[2]))
        } else if w[2] > 0.0 {
            let wo_in = self.refract_in(wo);
            let (psi_o, _) = self.fiber_angle_of(wo_in);
            let (lo, hi) = ((psi_o - FRAC_PI_2) / self.beta, (psi_o + FRAC_PI_2) / self.beta);
            let psi_h = self.beta * sample_truncated_normal(u[1], lo, hi);
            let psi_i = (psi_h - psi_o).clamp(-FRAC_PI_2, FRAC_PI_2);
            let (sp, cp) = psi_i.sin_cos();
            let (phi0, half_width) = self.escape_arc(sp, cp);
            if half_width <= 0.0 {
                return None;
            }
            let (sf, cf) = (phi0 + half_width * (2.0 * u[2] - 1.0)).sin_cos();
            let wi_in = self.u * sp + (self.e1 * cf + self.e2 * sf) * cp;
            (2, self.refract_out(wi_in)?)
        } else {
            return None;
        };
        if wi.z <= 0.0 || !wi.is_finite() {
            return None;
        }
        let wi = wi.normalize();
        let pdf = self.pdf_given(wi, wo, w);
        if pdf <= 0.0 {
            return None;
        }
        let weight = self.eval(wi, wo) * (wi.z / pdf);
        Some(Sample { wi, weight, pdf, delta: false, lobe })
    }

    fn lobes(&self) -> Vec<LobeInfo> {
        vec![
            LobeInfo { name: "finish", delta: self.alpha == 0.0 },
            LobeInfo::smooth("diffuse"),
            LobeInfo::smooth("fiber"),
        ]
    }

    fn texturable_keys(&self) -> &'static [&'static str] {
        &["k_d", "k_f", "beta", "fiber_angle", "fiber_dip"]
    }

    fn set_parameter(&mut self, key: &str, value: Rgb) -> Result<(), ModelError> {
        match key {
            "k_d" => self.k_d = K_D.check_rgb("k_d", value)?,
            "k_f" => self.k_f = K_F.check_rgb("k_f", value)?,
            "beta" => self.beta = BETA.check_degrees("beta", value[0])?,
            "fiber_angle" => {
                self.fiber_angle = ANGLE.check_degrees("fiber_angle", value[0])?;
                self.update_axis();
            }
            "fiber_dip" => {
                self.fiber_dip = DIP.check_degrees("fiber_dip", value[0])?;
                self.update_axis();
            }
            _ => return Err(not_texturable(&Self::INFO, key)),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_check::rng::TestRng;
    use fiberlab_math::FiberFrame;
    use fiberlab_math::frame::half_difference;

    fn wood(p: WoodParams) -> Wood {
        Wood::new(p).unwrap()
    }

    fn dir(theta: f64, phi: f64) -> DVec3 {
        DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    }

    fn upper(rng: &mut TestRng) -> DVec3 {
        let w = rng.sphere_direction();
        DVec3::new(w.x, w.y, w.z.abs().max(1e-3)).normalize()
    }

    /// Snell's law written out: the tangential part shrinks by 1/η, the rest is the normal.
    fn snell(w: DVec3, eta: f64) -> DVec3 {
        let t = DVec3::new(w.x, w.y, 0.0) / eta;
        t + DVec3::Z * (1.0 - t.length_squared()).sqrt()
    }

    /// Unpolarised Fresnel reflectance from the s and p amplitudes, written out here.
    fn fresnel_by_hand(cos_i: f64, eta: f64) -> f64 {
        let sin_t = (1.0 - cos_i * cos_i).sqrt() / eta;
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
        let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
        0.5 * (rs * rs + rp * rp)
    }

    /// The identity with the ideal specular fiber: the fiber term is 2π·k_f times the
    /// Gaussian-smoothed ideal specular fiber with uniform azimuth,
    /// `g(β; θ_i + θ_r)/(2π cos²θ_d)`, in the fiber frame of `u`, evaluated on the refracted
    /// directions and carried through the finish.
    #[test]
    fn fiber_term_is_a_smoothed_ideal_specular_fiber_on_refracted_directions() {
        let mut rng = TestRng::new(3);
        for (angle, dip, beta, eta) in [(0.0, 0.0, 10.0, 1.5), (35.0, 25.0, 4.0, 1.54), (-120.0, -40.0, 20.0, 1.75)] {
            let p = WoodParams {
                eta,
                k_d: Rgb::ZERO,
                k_f: Rgb::new(0.1, 0.05, 0.02),
                beta: f64::to_radians(beta),
                fiber_angle: f64::to_radians(angle),
                fiber_dip: f64::to_radians(dip),
                ..WoodParams::default()
            };
            let m = wood(p);
            let frame = FiberFrame::from_tangent(m.axis());
            for _ in 0..2000 {
                let (wi, wo) = (upper(&mut rng), upper(&mut rng));
                let (fi, fo) = (frame.to_local(snell(wi, eta)), frame.to_local(snell(wo, eta)));
                let (theta_h, theta_d) = half_difference(fi, fo);
                let f_spec = gaussian(p.beta, 2.0 * theta_h) / (TAU * theta_d.cos().powi(2));
                let t = (1.0 - fresnel_by_hand(wi.z, eta)) * (1.0 - fresnel_by_hand(wo.z, eta)) / (eta * eta);
                let expected = p.k_f * (TAU * f_spec * t);
                let got = m.eval(wi, wo);
                for c in 0..3 {
                    assert!((got[c] - expected[c]).abs() <= 1e-12 * expected[c].max(1e-300), "{got} vs {expected}");
                }
            }
        }
    }

    #[test]
    fn reciprocal_for_every_finish_and_axis() {
        let mut rng = TestRng::new(4);
        for roughness in [0.0, 0.3] {
            let m =
                wood(WoodParams { roughness, fiber_angle: 0.7, fiber_dip: 0.4, beta: 0.1, ..WoodParams::default() });
            for _ in 0..5000 {
                let (a, b) = (upper(&mut rng), upper(&mut rng));
                let (x, y) = (m.eval(a, b), m.eval(b, a));
                for c in 0..3 {
                    assert!((x[c] - y[c]).abs() <= 1e-14 * x[c].abs().max(y[c].abs()), "{x} vs {y}");
                }
            }
        }
    }

    /// The highlight peaks where the refracted directions satisfy ψ_i + ψ_o = 0; with
    /// `u = cos δ·t − sin δ·n` that is, outside the finish,
    /// `cos δ·(ω_i + ω_o)·t = sin δ·(√(η² − |ω_i∥|²) + √(η² − |ω_o∥|²))` — solved here by
    /// bisection and compared with the maximum of `eval` along a scan in θ_o.
    #[test]
    fn highlight_lies_on_the_refracted_cone_locus() {
        let eta: f64 = 1.5;
        let (mut tested, mut dipped) = (0, 0);
        for (angle, dip) in [(0.0f64, 0.0f64), (0.0, 20.0), (30.0, -15.0), (-50.0, 35.0)] {
            let (a, d) = (angle.to_radians(), dip.to_radians());
            let t = DVec3::new(a.cos(), a.sin(), 0.0);
            let m = wood(WoodParams {
                eta,
                k_d: Rgb::ZERO,
                k_f: Rgb::splat(0.1),
                beta: 0.5f64.to_radians(),
                fiber_angle: a,
                fiber_dip: d,
                ..WoodParams::default()
            });
            for (wi, phi_o) in [dir(0.5, 0.3), dir(1.0, -0.8), dir(0.2, 2.0), dir(0.8, 1.0), dir(0.35, -2.5)]
                .into_iter()
                .flat_map(|wi| [PI, 2.6, -2.2, 0.5, -0.3, 1.4, -1.4].map(|p| (wi, p)))
            {
                let locus = |theta_o: f64| {
                    let wo = dir(theta_o, phi_o);
                    let par = |w: DVec3| (eta * eta - w.x * w.x - w.y * w.y).sqrt();
                    d.cos() * (wi + wo).dot(t) - d.sin() * (par(wi) + par(wo))
                };
                let (lo, hi) = (1e-3, 1.5);
                if locus(lo).signum() == locus(hi).signum() {
                    continue;
                }
                let (mut x0, mut x1) = (lo, hi);
                for _ in 0..100 {
                    let mid = 0.5 * (x0 + x1);
                    if locus(mid).signum() == locus(x0).signum() { x0 = mid } else { x1 = mid }
                }
                let root = 0.5 * (x0 + x1);
                if root > 1.2 {
                    // Near grazing the exit transmittance falls faster than the narrow
                    // Gaussian and moves the maximum off the locus.
                    continue;
                }
                let n = 75_000;
                let best = (0..n)
                    .map(|k| lo + (hi - lo) * (k as f64 + 0.5) / n as f64)
                    .max_by(|&x, &y| m.eval(wi, dir(x, phi_o))[0].total_cmp(&m.eval(wi, dir(y, phi_o))[0]))
                    .unwrap();
                assert!((best - root).abs() < 0.03f64.to_radians(), "dip {dip} φ_o {phi_o}: {best} vs {root}");
                tested += 1;
                dipped += usize::from(dip != 0.0);
            }
        }
        assert!(tested >= 20 && dipped >= 10, "{tested} {dipped}");
    }

    /// Diffuse only: `ρ(ω_i) = T_i·k_d·(1 − F̄)/η²`, F̄ the cosine-weighted hemispherical mean
    /// of the Fresnel reflectance (Simpson's rule in 1D) against a 2D quadrature of `eval`.
    #[test]
    fn diffuse_energy_matches_the_transmittance_closed_form() {
        let (eta, k_d) = (1.5, 0.8);
        let m = wood(WoodParams { eta, k_d: Rgb::splat(k_d), k_f: Rgb::ZERO, ..WoodParams::default() });
        let n = 2000;
        let h = FRAC_PI_2 / n as f64;
        let simpson: f64 = (0..=n)
            .map(|k| {
                let t = k as f64 * h;
                let w = if k == 0 || k == n {
                    1.0
                } else if k % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                w * fresnel_by_hand(t.cos().max(1e-300), eta) * t.cos() * t.sin()
            })
            .sum::<f64>()
            * h
            / 3.0;
        let f_mean = 2.0 * simpson;
        for theta_i in [0.0, 0.7, 1.3] {
            let wi = dir(theta_i, 0.2);
            let (nt, np) = (400, 64);
            let mut rho = 0.0;
            for i in 0..nt {
                let t = (i as f64 + 0.5) * FRAC_PI_2 / nt as f64;
                for j in 0..np {
                    let wo = dir(t, (j as f64 + 0.5) * TAU / np as f64);
                    rho += m.eval(wi, wo)[0] * t.cos() * t.sin() * (FRAC_PI_2 / nt as f64) * (TAU / np as f64);
                }
            }
            let expected = (1.0 - fresnel_by_hand(wi.z.min(1.0), eta)) * k_d * (1.0 - f_mean) / (eta * eta);
            assert!((rho - expected).abs() < 1e-5, "θ_i {theta_i}: {rho} vs {expected}");
        }
    }

    #[test]
    fn fresnel_transmissions_and_the_rough_finish_at_normal_incidence() {
        let eta = 1.6;
        let m = wood(WoodParams { eta, k_d: Rgb::splat(1.0), k_f: Rgb::ZERO, ..WoodParams::default() });
        let (wi, wo) = (dir(1.0, 0.0), dir(0.6, 2.0));
        let t = (1.0 - fresnel_by_hand(1f64.cos(), eta)) * (1.0 - fresnel_by_hand(0.6f64.cos(), eta));
        assert!((m.eval(wi, wo)[0] - t / (PI * eta * eta)).abs() < 1e-15);
        // GGX at the pole: D = 1/(πα²), G₂ = 1, so f = F(1)/(4πα²).
        let alpha = 0.3;
        let rough = wood(WoodParams { eta, roughness: alpha, k_d: Rgb::ZERO, k_f: Rgb::ZERO, ..WoodParams::default() });
        let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
        assert!((rough.eval(DVec3::Z, DVec3::Z)[0] - f0 / (4.0 * PI * alpha * alpha)).abs() < 1e-12);
    }

    /// The energy bound of the fiber term: no diffuse term and `k_f = 1/(2π)` keep
    /// `∫ f_r cosθ_o ≤ 1`.
    #[test]
    fn fiber_term_alone_conserves_energy_at_its_bound() {
        for (dip, beta) in [(0.0, 10.0), (30.0, 3.0), (-60.0, 25.0), (89.0, 10.0)] {
            let m = wood(WoodParams {
                k_d: Rgb::ZERO,
                k_f: Rgb::splat(1.0 / TAU),
                beta: f64::to_radians(beta),
                fiber_dip: f64::to_radians(dip),
                ..WoodParams::default()
            });
            assert!(m.properties().energy_conserving);
            for theta_i in [0.0, 0.8, 1.3, 1.55] {
                let wi = dir(theta_i, 0.4);
                let (nt, np) = (300, 600);
                let mut rho = fresnel_by_hand(wi.z, 1.5); // the smooth finish's mirror lobe
                for i in 0..nt {
                    let t = (i as f64 + 0.5) * FRAC_PI_2 / nt as f64;
                    for j in 0..np {
                        let wo = dir(t, (j as f64 + 0.5) * TAU / np as f64);
                        rho += m.eval(wi, wo)[0] * t.cos() * t.sin() * (FRAC_PI_2 / nt as f64) * (TAU / np as f64);
                    }
                }
                assert!(rho <= 1.0, "dip {dip} β {beta} θ_i {theta_i}: {rho}");
            }
        }
    }

    #[test]
    fn presets_apply_and_explicit_keys_override_them() {
        let spec = |pairs: &[(&str, &str)]| {
            ParamSet::parse(Wood::INFO.name, Wood::INFO.params, pairs).and_then(|p| WoodParams::from_param_set(&p))
        };
        assert_eq!(spec(&[("preset", "tigers-eye")]).unwrap(), WoodParams::tigers_eye());
        assert_eq!(spec(&[("preset", "cats-eye")]).unwrap(), WoodParams::cats_eye());
        assert_eq!(spec(&[]).unwrap(), WoodParams::default());
        let p = spec(&[("preset", "cats-eye"), ("eta", "1.7"), ("fiber_dip", "10")]).unwrap();
        assert_eq!((p.eta, p.beta), (1.7, WoodParams::cats_eye().beta));
        assert!((p.fiber_dip - 10f64.to_radians()).abs() < 1e-15);
        assert!(
            (WoodParams::tigers_eye().eta - 1.54).abs() < 1e-15 && (WoodParams::cats_eye().eta - 1.75).abs() < 1e-15
        );
        assert!(spec(&[("preset", "opal")]).is_err());
    }

    #[test]
    fn textured_parameters_match_built_ones_and_are_validated() {
        let mut m = wood(WoodParams::default());
        m.set_parameter("fiber_angle", Rgb::splat(1.2)).unwrap();
        m.set_parameter("fiber_dip", Rgb::splat(0.3)).unwrap();
        m.set_parameter("beta", Rgb::splat(0.05)).unwrap();
        m.set_parameter("k_f", Rgb::new(0.01, 0.02, 0.03)).unwrap();
        m.set_parameter("k_d", Rgb::new(0.3, 0.2, 0.1)).unwrap();
        let built = wood(WoodParams {
            fiber_angle: 1.2,
            fiber_dip: 0.3,
            beta: 0.05,
            k_f: Rgb::new(0.01, 0.02, 0.03),
            k_d: Rgb::new(0.3, 0.2, 0.1),
            ..WoodParams::default()
        });
        assert!((m.axis() - fiber_axis(1.2, 0.3)).length() < 1e-15);
        let (wi, wo) = (dir(0.4, 0.1), dir(0.9, 2.5));
        assert_eq!(m.eval(wi, wo), built.eval(wi, wo));
        assert_eq!(m.pdf(wi, wo), built.pdf(wi, wo));
        assert!(m.set_parameter("beta", Rgb::splat(0.0)).is_err());
        assert!(m.set_parameter("fiber_dip", Rgb::splat(2.0)).is_err());
        assert!(m.set_parameter("k_d", Rgb::splat(f64::NAN)).is_err());
        assert!(m.set_parameter("eta", Rgb::splat(1.3)).is_err());
    }

    #[test]
    fn axis_descends_toward_the_fiber_angle() {
        let u = fiber_axis(FRAC_PI_2, 0.5);
        assert!((u - DVec3::new(0.0, 0.5f64.cos(), -(0.5f64.sin()))).length() < 1e-15);
    }
}
