//! Finished wood and chatoyant minerals: Marschner, Westin, Arbree and Moon, *Measuring and
//! modeling the appearance of finished wood* (SIGGRAPH 2005), §4–5.
//!
//! | parameter | unit | default | range |
//! |---|---|---|---|
//! | `preset` | — | none | `none` \| `tigers-eye` \| `cats-eye` |
//! | `eta` η | — | 1.5 | [1, 3] |
//! | `roughness` α | — | 0 | [0, 1] |
//! | `k_d` | — | 0.35,0.2,0.1 | [0, 1] per channel |
//! | `k_f` | — | 0.1,0.07,0.04 | [0, 10] per channel |
//! | `beta` β | degrees | 10 | [0.5, 45] |
//! | `fiber_angle` | degrees | 0 | [−360, 360] |
//! | `fiber_dip` | degrees | 0 | [−90, 90] |
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
//! and `ψ_d = ψ_o − ψ_i`. Below the finish (the paper's eq. 4 and 5)
//!
//! `f_ss(ω_i′, ω_o′) = k_d/π + k_f·g(β; ψ_h)/cos²(ψ_d/2)`,
//!
//! `g` a unit-area Gaussian of standard deviation β. Seen from outside,
//!
//! `f_r(ω_i, ω_o) = f_finish(ω_i, ω_o) + (T_i·T_o/η²)·f_ss(ω_i′, ω_o′)`.
//!
//! The `1/η²`: radiance entering a medium of index η is multiplied by `η²T` and leaving it
//! by `T/η²`, while `cosθ dω = η² cosθ′ dω′`; carrying `L_r = ∫ f_r L_i cosθ_i dω_i` through
//! both crossings leaves one factor `1/η²` on the subsurface BRDF (our derivation; the paper
//! writes the transfer with the same transmittances). Over exit directions the factor
//! cancels the solid-angle compression: `∫ f_r cosθ_o dω_o = T_i ∫ T_o f_ss cosθ_o′ dω_o′`
//! for the subsurface part.
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
//! `|ψ_h − ψ_o| ≤ π/2` and the azimuth about `u` uniform, then refracted out (samples below
//! the surface or beyond the critical angle are dropped: `None`). The density of a fiber
//! sample is `g(β; ψ_h)/(Z·2π cosψ_i)` per internal steradian, times
//! `dω′/dω = cosθ_i/(η² cosθ_i′)`.
//!
//! # Presets (`preset=`)
//! Chatoyant minerals: fibers in the surface plane under a polish, no separate finish.
//! `tigers-eye`: quartz η = 1.54, β = 3°, golden-brown `k_d` and `k_f`; `cats-eye`
//! (chrysoberyl with rutile needles): η = 1.75, β = 2°, honey-green. Keys given explicitly
//! override the preset's.

use crate::params::{ParamKind, ParamSet, ParamSpec, Range, parameter_error};
use crate::sampling::cosine_hemisphere;
use crate::surface_model::not_texturable;
use crate::{LobeInfo, MIN_COS, ModelError, ModelInfo, Registered, Sample, SurfaceProperties, SurfaceScattering};
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
        let internal = gaussian(self.beta, psi_i + psi_o) / (mass * TAU * cos_psi_i.max(MIN_COS));
        internal * wi.z / (self.eta * self.eta * wi_in.z.max(MIN_COS))
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

impl SurfaceScattering for Wood {
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
            let (sf, cf) = (TAU * u[2]).sin_cos();
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
            _ => return Err(not_texturable(Self::INFO, key)),
        }
        Ok(())
    }
}
