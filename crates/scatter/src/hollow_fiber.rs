//! A hollow fiber: a dielectric tube (wall index η, absorption σ_a, radius 1) around a
//! concentric lumen of relative radius κ and index η_l (air by default), as plant fibers
//! (cotton, flax, hemp, kapok, the tracheids of wood), polar-bear guard hairs and hollow
//! synthetics are built. Our model: Chiang et al. 2016's near-field lobes
//! ([`crate::chiang_2016`], built from the same hair core) with the unscattered paths through
//! wall *and* lumen followed exactly in the normal plane ([`crate::hair::tube`]). Saarinen &
//! Muinonen (Applied Optics 40(28), 2001) traced hollow wood fibres with ray optics; Linder et
//! al. (Optics Express 21(6), 2013) found that paper's sideways scattering needs the lumen.
//!
//! Parameters: the registry entry below (`PARAMS`); `fiberlab models --model hollow-fiber` and the
//! book's page `docs/book/src/models/hollow-fiber.md` show it as a table.
//!
//! # Formula
//! As `chiang`, a backward near-field form: the camera ray ω_o hits at offset h (γ_o = asin h)
//! and `f_s(ω_i, ω_o; h) = Σ_q A_q·M_{p(q)}(θ_i, θ_o^{(p)})·N_q(φ) / cosθ_i`, a sum over
//! *sub-lobes* q, grouped into the lobes p = number of wall passes (R: p = 0, TT: 1, TRT: 2,
//! `residual`: every longer path):
//! * The wall and the lumen are cylinders parallel to the axis, so θ is unchanged along any
//!   path: every path with p passes has Chiang's longitudinal lobe `M_p` (d'Eon's, variances
//!   `v_0, v_0/4, 4v_0, 4v_0`) and tilt.
//! * Each wall pass misses the lumen, reflects off it, or crosses it along j chords
//!   ([`crate::hair::tube::Tube::passes`]: exact angles with Bravais' indices, the exact 3D
//!   Fresnel factor `F_l` of the index ratio η_l/η, total internal reflection where it occurs).
//!   A pass of kind k has probability `w_k` and turns the ray by `τ_k`; every pass of a path
//!   crosses the same wall length ℓ (`T = exp(−σ_a ℓ)`), and the lumen is clear.
//! * Sub-lobes: R, `A = f`, `Φ = Φ(0, h)`; for p = 1, each kind k: `A = (1 − f)²T·w_k`,
//!   `Φ = Φ(1, h) + τ_k`; for p = 2, each pair k ≤ k′: `A = (1 − f)²f T²·w_k w_k′` (twice for
//!   k ≠ k′: the order of the passes does not change the exit), `Φ = Φ(2, h) + τ_k + τ_k′`
//!   (`Φ(p, h) = 2pγ_t − 2γ_o + pπ`, f Fresnel at `cosθ_o cosγ_o` as in `chiang`).
//!   `N_q` is Chiang's trimmed logistic about Φ with scale s(β_n).
//! * The residual takes everything else, with `N = 1/(2π)`: passes through the lumen along
//!   more than [`crate::hair::tube::MAX_CORE_CHORDS`] chords (probability b per pass) in
//!   p = 1, 2 and all paths with p ≥ 3. With `P = T` (a pass's total mass) and
//!   `P_e = T(1 − b)` (the listed kinds): `A_res = (1 − f)²[(P − P_e) + f(P² − P_e²) +
//!   f²P³/(1 − fP)]`, so that `Σ A = f + (1 − f)²P/(1 − fP)`, which is exactly 1 without
//!   absorption (the camera-side furnace; tested).
//! * κ = 0, or a lumen that does not meet the pass, or `lumen_eta = eta` without absorption,
//!   reduces every lobe to `chiang`'s exactly (tested).
//!
//! # Sampling
//! A sub-lobe from `u[0]` with probability ∝ the luminance of its A (over the enabled lobes),
//! θ_i from `M_p` with `u[1], u[2]`, φ from the trimmed logistic about its Φ (uniform for the
//! residual) with `u[3]`; the pdf is `Σ_q w_q M_p N_q` per steradian, exactly the density of
//! the samples, and the weight `f_s cosθ_i/pdf` is `Σ A_q` when the A are gray.
//!
//! # Far field
//! `field = far` averages the near field over h: `½∫ f_s dh` by the midpoint rule in ψ on the
//! pieces between the breakpoints c of [`crate::hair::tube::Tube::breakpoints`] (total internal
//! reflection at the lumen, the lumen's edge, 1), with `h = c·sinψ` on each piece so that the
//! square-root ends of chords and angles at c are smooth in ψ; `⌈4π/s⌉` nodes per piece
//! (16 … 2048). The weights are normalized to sum to 1, and sampling draws the node and the
//! sub-lobe jointly from `u[0]` (one discrete inverse CDF), so the far pdf is exactly the
//! weighted mean of the near pdfs. This form is for comparisons with measurements (each value
//! costs hundreds of near-field values), not for rendering.
//!
//! # Caveats
//! * Like `chiang`, the backward form conserves energy on the camera side only and is not
//!   reciprocal; `properties()` claims neither.
//! * The lumen is clear (no absorption, no scattering); a scattering core is `yan-fur`.
//! * `color` inverts with Chiang's polynomial for a solid fiber: a hollow fiber of that σ_a is
//!   lighter than the colour asked for (less wall to cross).

use crate::hair::absorption::Absorption;
use crate::hair::attenuation::surface_fresnel;
use crate::hair::longitudinal::Longitudinal;
use crate::hair::normal_plane::exit_azimuth;
use crate::hair::parameters::{self, ALPHA_RANGE, BETA_RANGE, ETA_RANGE};
use crate::hair::roughness::{lobe_variances, logistic_scale};
use crate::hair::tilt::{lobe_tilts, rotate};
use crate::hair::tube::{MAX_CORE_CHORDS, MAX_PASS_KINDS, Tube};
use crate::params::{ParamKind, ParamSet, ParamSpec, ParameterError, Range};
use crate::{
    Field, LobeInfo, Lobes, MIN_COS, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction,
};
use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, sin_theta, wrap_pi};
use fiberlab_math::special::{logistic, logistic_cdf, safe_sqrt};
use fiberlab_math::{DVec3, Rgb, bravais};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use thiserror::Error;

/// Lobe names of `lobes=`, by number of wall passes: R (0), TT (1), TRT (2), and the residual.
pub const LOBE_NAMES: [&str; 4] = ["r", "tt", "trt", "residual"];
/// Valid relative lumen radius κ.
pub const KAPPA_RANGE: Range = Range::closed_open(0.0, 1.0);
/// Valid lumen index.
pub const LUMEN_ETA_RANGE: Range = Range::closed(1.0, 4.0);
/// Most sub-lobes at one hit: R, one per pass kind (p = 1), one per unordered pair (p = 2),
/// the residual.
const MAX_SUBLOBES: usize = 2 + MAX_PASS_KINDS + MAX_PASS_KINDS * (MAX_PASS_KINDS + 1) / 2;
/// Far field: midpoint nodes per piece are `⌈FAR_NODES_PER_SCALE·π/s⌉`, clamped to
/// [`FAR_NODES`].
const FAR_NODES_PER_SCALE: f64 = 4.0;
/// Far field: the fewest and most midpoint nodes per piece.
const FAR_NODES: (usize, usize) = (16, 2048);

const PARAMS: [ParamSpec; 12] = [
    parameters::ETA,
    ParamSpec {
        key: "kappa",
        kind: ParamKind::Number(KAPPA_RANGE),
        unit: "",
        default: "0.5",
        doc: "lumen radius / fiber radius",
    },
    ParamSpec {
        key: "lumen_eta",
        kind: ParamKind::Number(LUMEN_ETA_RANGE),
        unit: "",
        default: "1",
        doc: "index of the lumen (1 air, 1.33 water; equal to eta: index-matched)",
    },
    parameters::BETA_M,
    parameters::BETA_N,
    ParamSpec {
        key: "alpha",
        kind: ParamKind::Number(ALPHA_RANGE),
        unit: "degrees",
        default: "0",
        doc: "surface tilt (cuticle scales of hollow hairs); > 0 moves the R lobe toward the root",
    },
    ParamSpec {
        key: "sigma_a",
        kind: ParamKind::Color(parameters::SIGMA_A_RANGE),
        unit: "1/radius",
        default: "",
        doc: "wall absorption (0 when no absorption key is given; exclusive with melanin and color)",
    },
    ParamSpec {
        key: "eumelanin",
        kind: ParamKind::Number(parameters::MELANIN_RANGE),
        unit: "",
        default: "",
        doc: "eumelanin concentration of the wall (hollow hairs)",
    },
    parameters::PHEOMELANIN,
    ParamSpec {
        key: "color",
        kind: ParamKind::Color(parameters::COLOR_RANGE),
        unit: "",
        default: "",
        doc: "desired colour; σ_a by Chiang's inversion for a solid fiber (a hollow one comes out lighter)",
    },
    ParamSpec {
        key: "lobes",
        kind: ParamKind::Subset(&LOBE_NAMES),
        unit: "",
        default: "r,tt,trt,residual",
        doc: "lobes by number of wall passes (0, 1, 2, more)",
    },
    ParamSpec {
        key: "field",
        kind: ParamKind::Choice(&["near", "far"]),
        unit: "",
        default: "near",
        doc: "near: value at offset h; far: averaged over h (midpoint rule, for comparisons)",
    },
];

/// Registry entry: `hollow-fiber`.
impl Registered for HollowFiber {
    const INFO: ModelInfo = ModelInfo {
        name: "hollow-fiber",
        summary: "hollow (lumen) fiber: Chiang-style lobes with exact paths through wall and lumen",
        citation: "ours (docs: hollow fiber); Chiang et al. 2016 lobes; Saarinen & Muinonen 2001",
        params: &PARAMS,
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(HollowFiber::new(HollowFiberParams::from_param_set(p)?)?)
    }
}

/// Parameters of [`HollowFiber`] (tilt in **radians**; the registry takes degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HollowFiberParams {
    /// Wall index η ∈ (1, 4].
    pub eta: f64,
    /// Lumen radius / fiber radius κ ∈ [0, 1).
    pub kappa: f64,
    /// Lumen index η_l ∈ [1, 4].
    pub lumen_eta: f64,
    /// Longitudinal roughness β_m ∈ (0, 1].
    pub beta_m: f64,
    /// Azimuthal roughness β_n ∈ (0, 1].
    pub beta_n: f64,
    /// Surface tilt α (radians) in [−20°, 20°].
    pub alpha: f64,
    /// Wall absorption.
    pub absorption: Absorption,
    /// Enabled lobes, in the order of [`LOBE_NAMES`].
    pub lobes: [bool; 4],
    /// Near field (value at h) or far field (average over h).
    pub field: Field,
}

impl Default for HollowFiberParams {
    /// A clear cellulose fiber (η = 1.55, no absorption) with an air lumen of half the radius,
    /// Chiang's moderate roughness (β_m = β_n = 0.3), no tilt, every lobe, near field.
    fn default() -> Self {
        Self {
            eta: 1.55,
            kappa: 0.5,
            lumen_eta: 1.0,
            beta_m: 0.3,
            beta_n: 0.3,
            alpha: 0.0,
            absorption: Absorption::NONE,
            lobes: [true; 4],
            field: Field::Near,
        }
    }
}

impl HollowFiberParams {
    /// Reads the registry parameters (`alpha` degrees → radians).
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        let lobes = p.subset("lobes")?;
        Ok(Self {
            eta: p.number("eta")?,
            kappa: p.number("kappa")?,
            lumen_eta: p.number("lumen_eta")?,
            beta_m: p.number("beta_m")?,
            beta_n: p.number("beta_n")?,
            alpha: p.degrees("alpha")?,
            absorption: Absorption::from_param_set_or(p, Absorption::NONE)?,
            lobes: LOBE_NAMES.map(|n| lobes.contains(&n)),
            field: if p.choice("field")? == "far" { Field::Far } else { Field::Near },
        })
    }

    /// Checks every value against its range (the error names the parameter; α in degrees).
    pub fn validate(&self) -> Result<(), HollowFiberError> {
        ETA_RANGE.check("eta", self.eta)?;
        KAPPA_RANGE.check("kappa", self.kappa)?;
        LUMEN_ETA_RANGE.check("lumen_eta", self.lumen_eta)?;
        BETA_RANGE.check("beta_m", self.beta_m)?;
        BETA_RANGE.check("beta_n", self.beta_n)?;
        ALPHA_RANGE.check_degrees("alpha", self.alpha)?;
        self.absorption.validate()?;
        if !self.lobes.iter().any(|&l| l) {
            return Err(HollowFiberError::NoLobe);
        }
        Ok(())
    }
}

/// Why a [`HollowFiber`] cannot be built.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum HollowFiberError {
    /// A parameter outside its range.
    #[error(transparent)]
    Parameter(#[from] ParameterError),
    /// `lobes` is empty.
    #[error("hollow-fiber: `lobes` must name at least one of r, tt, trt, residual")]
    NoLobe,
}

impl From<HollowFiberError> for ModelError {
    fn from(e: HollowFiberError) -> Self {
        match e {
            HollowFiberError::Parameter(p) => p.into(),
            HollowFiberError::NoLobe => ModelError::Inconsistent(e.to_string()),
        }
    }
}

/// The hollow fiber (see the module docs).
#[derive(Clone, Debug)]
pub struct HollowFiber {
    params: HollowFiberParams,
    /// σ_a per unit radius of the wall.
    sigma_a: Rgb,
    longitudinal: [Longitudinal; 4],
    tilt: [(f64, f64); 4],
    s: f64,
    /// `1/(F_ℓ(π) − F_ℓ(−π))`.
    logistic_norm: f64,
    /// `(F_ℓ(−π), F_ℓ(π))`.
    logistic_cdf_ends: (f64, f64),
    /// Far field: midpoint nodes per piece.
    far_nodes: usize,
}

/// One sub-lobe at a hit: its lobe p (wall passes; 3 = residual), attenuation and exit azimuth.
#[derive(Clone, Copy, Debug, Default)]
struct SubLobe {
    p: usize,
    a: Rgb,
    exit: f64,
}

impl HollowFiber {
    /// A hollow fiber; the error names the parameter out of range.
    pub fn new(params: HollowFiberParams) -> Result<Self, HollowFiberError> {
        params.validate()?;
        let s = logistic_scale(params.beta_n);
        let far_nodes = ((FAR_NODES_PER_SCALE * PI / s).ceil() as usize).clamp(FAR_NODES.0, FAR_NODES.1);
        Ok(Self {
            params,
            sigma_a: params.absorption.sigma_a(params.beta_n),
            longitudinal: lobe_variances(params.beta_m).map(Longitudinal::new),
            tilt: lobe_tilts(params.alpha),
            s,
            logistic_norm: 1.0 / (logistic_cdf(PI, s) - logistic_cdf(-PI, s)),
            logistic_cdf_ends: (logistic_cdf(-PI, s), logistic_cdf(PI, s)),
            far_nodes,
        })
    }

    /// The parameters (radians).
    #[must_use]
    pub fn params(&self) -> &HollowFiberParams {
        &self.params
    }

    /// σ_a per unit radius of the wall.
    #[must_use]
    pub fn sigma_a(&self) -> Rgb {
        self.sigma_a
    }

    /// The lobe masses `Σ_{q in p} A_q` of R, TT, TRT and the residual for a camera at
    /// inclination `theta_o` and offset `h` (all lobes, enabled or not).
    #[must_use]
    pub fn lobe_masses(&self, theta_o: f64, h: f64) -> [Rgb; 4] {
        let (s, c) = theta_o.sin_cos();
        let v = self.at_vertex_all(s, c.abs(), 0.0, h, [true; 4]);
        let mut m = [Rgb::ZERO; 4];
        for q in &v.subs[..v.n] {
            m[q.p] += q.a;
        }
        m
    }

    /// The hit prepared for evaluation and sampling (enabled lobes only).
    fn at_vertex(&self, wo: DVec3, h: f64) -> Vertex<'_> {
        self.at_vertex_all(sin_theta(wo), cos_theta(wo), phi(wo), h, self.params.lobes)
    }

    fn at_vertex_all(&self, sin_o: f64, cos_o: f64, phi_o: f64, h: f64, lobes: [bool; 4]) -> Vertex<'_> {
        let HollowFiberParams { eta, kappa, lumen_eta, .. } = self.params;
        let h = h.clamp(-1.0, 1.0);
        let f = surface_fresnel(eta, cos_o, safe_sqrt(1.0 - h * h));
        let gamma_o = h.asin();
        let gamma_t = bravais::sin_gamma_t(h, eta, sin_o, cos_o).asin();
        let passes = Tube::new(eta, kappa, lumen_eta, sin_o, cos_o).passes(h);
        let t = (self.sigma_a * -passes.wall_length).exp();
        let mut v = Vertex {
            fiber: self,
            phi_o,
            tilted: self.tilt.map(|tau| rotate(sin_o, cos_o, tau)),
            subs: [SubLobe::default(); MAX_SUBLOBES],
            n: 0,
            weights: [0.0; MAX_SUBLOBES],
            total: 0.0,
        };
        let mut push = |p: usize, a: Rgb, exit: f64| {
            if lobes[p] && a.max_component() > 0.0 {
                v.subs[v.n] = SubLobe { p, a, exit };
                v.n += 1;
            }
        };
        let one_minus_f2 = (1.0 - f) * (1.0 - f);
        push(0, Rgb::splat(f), exit_azimuth(0, gamma_o, gamma_t));
        let (phi1, phi2) = (exit_azimuth(1, gamma_o, gamma_t), exit_azimuth(2, gamma_o, gamma_t));
        let a1 = t * one_minus_f2;
        let a2 = a1 * t * f;
        for k in 0..passes.n {
            push(1, a1 * passes.weight[k], phi1 + passes.turn[k]);
        }
        for k in 0..passes.n {
            for k2 in k..passes.n {
                let twice = if k == k2 { 1.0 } else { 2.0 };
                push(2, a2 * (passes.weight[k] * passes.weight[k2] * twice), phi2 + passes.turn[k] + passes.turn[k2]);
            }
        }
        // Residual: crossings beyond the listed ones in p = 1, 2, and every p ≥ 3.
        let (pe, beyond) = (t * (1.0 - passes.beyond), t * passes.beyond);
        let ft = t * f;
        let tail = Rgb::new(
            if ft[0] < 1.0 { f * f * t[0].powi(3) / (1.0 - ft[0]) } else { 0.0 },
            if ft[1] < 1.0 { f * f * t[1].powi(3) / (1.0 - ft[1]) } else { 0.0 },
            if ft[2] < 1.0 { f * f * t[2].powi(3) / (1.0 - ft[2]) } else { 0.0 },
        );
        push(3, (beyond + beyond * (t + pe) * f + tail) * one_minus_f2, 0.0);
        let n = v.n;
        let y: [f64; MAX_SUBLOBES] = std::array::from_fn(|q| if q < n { v.subs[q].a.luminance() } else { 0.0 });
        let total: f64 = y.iter().sum();
        if total > 0.0 {
            v.weights = y.map(|x| x / total);
            v.total = total;
        }
        v
    }

    /// Far field: calls `g(h, weight)` at every node of the h-quadrature seen from `wo`
    /// (weights sum to 1), stopping early when `g` returns false.
    fn for_each_node(&self, wo: DVec3, mut g: impl FnMut(f64, f64) -> bool) {
        let tube = Tube::new(self.params.eta, self.params.kappa, self.params.lumen_eta, sin_theta(wo), cos_theta(wo));
        let [c1, c2] = tube.breakpoints();
        let ends = [c1, c2, 1.0];
        let n = self.far_nodes;
        // The raw weights ½·c·cosψ·Δψ on both sides, then normalized.
        let mut total = 0.0;
        let mut lo = 0.0;
        let mut pieces = [(0.0, 0.0, 0.0); 3];
        for (k, &c) in ends.iter().enumerate() {
            if c > lo {
                let psi0 = (lo / c).min(1.0).asin();
                let dpsi = (FRAC_PI_2 - psi0) / n as f64;
                pieces[k] = (c, psi0, dpsi);
                total += (0..n).map(|j| c * (psi0 + (j as f64 + 0.5) * dpsi).cos() * dpsi).sum::<f64>();
                lo = c;
            }
        }
        for &(c, psi0, dpsi) in &pieces {
            if c == 0.0 {
                continue;
            }
            for j in 0..n {
                let psi = psi0 + (j as f64 + 0.5) * dpsi;
                let (h, w) = (c * psi.sin(), 0.5 * c * psi.cos() * dpsi / total);
                if !g(h, w) || !g(-h, w) {
                    return;
                }
            }
        }
    }

    fn far_eval_and_pdf(&self, wi: DVec3, wo: DVec3) -> (Rgb, f64) {
        let (mut f, mut pdf) = (Rgb::ZERO, 0.0);
        self.for_each_node(wo, |h, w| {
            let (fh, ph) = self.at_vertex(wo, h).eval_and_pdf(wi);
            f += fh * w;
            pdf += ph * w;
            true
        });
        (f, pdf)
    }

    fn far_sample(&self, wo: DVec3, u: [f64; 4]) -> Option<Sample> {
        // The node and the sub-lobe as one discrete draw from u[0]: node j with probability
        // w_j, then within it the near sampler's choice from the rest of u[0].
        let mut acc = 0.0;
        let mut chosen = None;
        self.for_each_node(wo, |h, w| {
            if u[0] < acc + w {
                chosen = Some((h, ((u[0] - acc) / w).clamp(0.0, 1.0 - f64::EPSILON)));
                return false;
            }
            acc += w;
            true
        });
        let (h, u0) = chosen?;
        let s = self.at_vertex(wo, h).sample([u0, u[1], u[2], u[3]])?;
        let (f, pdf) = self.far_eval_and_pdf(s.wi, wo);
        (pdf > 0.0).then(|| Sample { weight: f * (cos_theta(s.wi) / pdf), pdf, ..s })
    }
}

/// A [`HollowFiber`] prepared at one hit (fixed `ω_o`, h): its sub-lobes and their selection
/// probabilities.
#[derive(Clone, Copy, Debug)]
struct Vertex<'a> {
    fiber: &'a HollowFiber,
    phi_o: f64,
    /// `(sinθ_o^(p), cosθ_o^(p))`, the camera-side direction rotated by lobe p's tilt.
    tilted: [(f64, f64); 4],
    subs: [SubLobe; MAX_SUBLOBES],
    n: usize,
    /// Selection probabilities ∝ luminance of A (zero beyond `n`).
    weights: [f64; MAX_SUBLOBES],
    /// Σ luminance (0: nothing to sample).
    total: f64,
}

impl Vertex<'_> {
    /// `N_q` at relative azimuth `dphi`.
    #[inline]
    fn azimuthal(&self, q: &SubLobe, dphi: f64) -> f64 {
        if q.p == 3 { 1.0 / TAU } else { logistic(wrap_pi(dphi - q.exit), self.fiber.s) * self.fiber.logistic_norm }
    }

    /// `M_p` of every lobe at the light inclination.
    #[inline]
    fn longitudinal(&self, sin_i: f64, cos_i: f64) -> [f64; 4] {
        std::array::from_fn(|p| {
            let (so, co) = self.tilted[p];
            self.fiber.longitudinal[p].eval(sin_i, cos_i, so, co)
        })
    }

    /// `(Σ A_q M N, Σ w_q M N)`: the per-h integrand (sr⁻¹ before the 1/cosθ_i) and the pdf.
    fn integrand_and_pdf_at(&self, sin_i: f64, cos_i: f64, dphi: f64) -> (Rgb, f64) {
        if self.total <= 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let m = self.longitudinal(sin_i, cos_i);
        let (mut g, mut pdf) = (Rgb::ZERO, 0.0);
        for (q, w) in self.subs[..self.n].iter().zip(&self.weights) {
            let mn = m[q.p] * self.azimuthal(q, dphi);
            g += q.a * mn;
            pdf += w * mn;
        }
        (g, pdf)
    }

    fn eval_and_pdf(&self, wi: DVec3) -> (Rgb, f64) {
        let (g, pdf) = self.integrand_and_pdf_at(sin_theta(wi), cos_theta(wi), phi(wi) - self.phi_o);
        (g / cos_theta(wi).max(MIN_COS), pdf)
    }

    fn sample(&self, u: [f64; 4]) -> Option<Sample> {
        if self.total <= 0.0 {
            return None;
        }
        let mut q = 0;
        let mut acc = self.weights[0];
        while q + 1 < self.n && u[0] >= acc {
            q += 1;
            acc += self.weights[q];
        }
        while self.weights[q] == 0.0 && q > 0 {
            q -= 1;
        }
        let lobe = self.subs[q];
        let (so, co) = self.tilted[lobe.p];
        let sin_i = self.fiber.longitudinal[lobe.p].sample_sin_theta(so, co, u[1], u[2]);
        let cos_i = safe_sqrt(1.0 - sin_i * sin_i);
        let dphi = if lobe.p < 3 {
            let (lo, hi) = self.fiber.logistic_cdf_ends;
            let c = lo + u[3] * (hi - lo);
            let x = self.fiber.s * (c.ln() - (-c).ln_1p());
            lobe.exit + if x.is_nan() { 0.0 } else { x.clamp(-PI, PI) }
        } else {
            TAU * u[3]
        };
        let wi = direction_from_sin_cos(sin_i, cos_i, self.phi_o + dphi);
        // Evaluated at the angles of the direction returned, as `pdf` reads them, not at the
        // drawn ones: a draw at a pole (sinθ_i = ±1, which M_p gives for u[1] = 0 when the
        // viewer is on the axis) makes `wi` the pole itself, whose azimuth reads back as
        // atan2(0, 0) instead of the drawn φ. Several sub-lobes with different exits then
        // disagree at the pole (issue 41's on-axis defect); elsewhere the two differ by rounding.
        let (g, pdf) = self.integrand_and_pdf_at(sin_theta(wi), cos_theta(wi), phi(wi) - self.phi_o);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        Some(Sample { wi, weight: g / pdf, pdf, delta: false, lobe: lobe.p as u8 })
    }
}

impl ScatteringFunction for HollowFiber {
    fn properties(&self) -> Properties {
        Properties { reciprocal: false, energy_conserving: false, field: self.params.field, lobes: Lobes::Smooth }
    }

    fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
        self.eval_and_pdf(wi, wo, h).0
    }

    /// The narrowest azimuthal feature across the width, in γ = asin h: the trimmed
    /// logistic's standard deviation `πs/√3` over the fastest rate `|dΦ/dγ|` at which a
    /// sub-lobe's exit azimuth moves at the fiber's centre. The wall alone moves the R lobe at 2
    /// (Chiang's feature, `πs/(2√3)`). A lumen adds each pass's turn: with `b = h/η′`,
    /// reflection off it turns by `π − 2 asin(b/κ)` (rate `2/(η′κ)` in h), j chords through it
    /// by `2(γ_c − γ_k) + (j − 1)(2γ_c − π)` (rate `2j/(η′_lκ) − 2/(η′κ)`), and a TRT path
    /// makes two passes; `η′ ≥ η` and `η′_l ≥ η_l`, so θ = 0 is the fastest. An index-matched
    /// or absent lumen turns nothing: Chiang's feature. Near the lumen's edge the turn's rate
    /// grows without bound (a square-root end at the breakpoints): equal panels blur it, which
    /// is why [`ScatteringFunction::eval_far`] here uses the model's own far-field rule.
    fn width_feature(&self) -> f64 {
        let std = PI * self.s / 3f64.sqrt();
        let HollowFiberParams { eta, kappa, lumen_eta, .. } = self.params;
        if kappa == 0.0 || lumen_eta == eta {
            return 0.5 * std;
        }
        let reflect = 2.0 / (eta * kappa);
        let chords = (1..=MAX_CORE_CHORDS)
            .map(|j| (2.0 * j as f64 / (lumen_eta * kappa) - reflect).abs())
            .fold(reflect, f64::max);
        // Two passes (TRT) at the fastest turn, on top of the wall's |2p/η − 2| ≤ 2.
        std / (2.0 + 2.0 * chords)
    }

    /// The width average `½∫ f_s dh` by the model's own rule (the `field = far` pieces between
    /// the lumen's breakpoints with `h = c·sinψ`), which resolves the square-root ends that
    /// equal panels in γ blur.
    fn eval_far(&self, wi: DVec3, wo: DVec3) -> Rgb {
        self.far_eval_and_pdf(wi, wo).0
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> f64 {
        self.eval_and_pdf(wi, wo, h).1
    }

    fn eval_and_pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> (Rgb, f64) {
        match self.params.field {
            Field::Near => self.at_vertex(wo, h).eval_and_pdf(wi),
            Field::Far => self.far_eval_and_pdf(wi, wo),
        }
    }

    /// R, TT, TRT (every sub-lobe with 0, 1, 2 wall passes) and the residual.
    fn eval_lobes(&self, wi: DVec3, wo: DVec3, h: f64, out: &mut [Rgb]) -> bool {
        for slot in out.iter_mut().take(4) {
            *slot = Rgb::ZERO;
        }
        let (sin_i, cos_i, dphi) = (sin_theta(wi), cos_theta(wi), phi(wi) - phi(wo));
        let mut add = |v: &Vertex, w: f64| {
            let m = v.longitudinal(sin_i, cos_i);
            for q in &v.subs[..v.n] {
                if let Some(slot) = out.get_mut(q.p) {
                    *slot += q.a * (w * m[q.p] * v.azimuthal(q, dphi) / cos_i.max(MIN_COS));
                }
            }
        };
        match self.params.field {
            Field::Near => add(&self.at_vertex(wo, h), 1.0),
            Field::Far => self.for_each_node(wo, |h, w| {
                add(&self.at_vertex(wo, h), w);
                true
            }),
        }
        true
    }

    fn lobes(&self) -> Vec<LobeInfo> {
        ["R", "TT", "TRT", "residual"].map(LobeInfo::smooth).to_vec()
    }

    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        match self.params.field {
            Field::Near => self.at_vertex(wo, h).sample(u),
            Field::Far => self.far_sample(wo, u),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_math::frame::direction;

    /// The lobe masses sum to `f + (1 − f)²T/(1 − fT)`-like totals: exactly 1 without
    /// absorption, at every inclination and offset, for lumens that are missed, totally
    /// reflecting, crossed, water-filled or denser than the wall.
    #[test]
    fn lossless_masses_sum_to_one() {
        for &(kappa, lumen_eta) in &[(0.0, 1.0), (0.5, 1.0), (0.9, 1.0), (0.6, 1.33), (0.7, 2.0)] {
            let fiber =
                HollowFiber::new(HollowFiberParams { kappa, lumen_eta, ..HollowFiberParams::default() }).unwrap();
            for &theta in &[0.0, 0.5, -1.2, 1.55] {
                for k in 0..=40 {
                    let h = -1.0 + k as f64 / 20.0;
                    let total: f64 = fiber.lobe_masses(theta, h).iter().map(|a| a[1]).sum();
                    assert!(
                        (total - 1.0).abs() < 1e-12 || (h.abs() == 1.0 && total <= 1.0),
                        "κ {kappa} θ {theta} h {h}: {total}"
                    );
                }
            }
        }
    }

    /// The far field is the h-average of the near field: against a plain midpoint rule in h
    /// with many nodes (independent of the pieces and substitutions), for eval, pdf and lobes.
    #[test]
    fn far_field_is_the_average_of_the_near_field() {
        let base = HollowFiberParams {
            beta_n: 0.6,
            beta_m: 0.4,
            kappa: 0.6,
            absorption: Absorption::SigmaA(Rgb::new(0.2, 0.5, 0.9)),
            ..HollowFiberParams::default()
        };
        let near = HollowFiber::new(base).unwrap();
        let far = HollowFiber::new(HollowFiberParams { field: Field::Far, ..base }).unwrap();
        let n = 20_000;
        for &(ti, to, dphi) in &[(0.1, -0.2, 2.5), (0.5, -0.4, 0.3), (-0.9, 1.0, -2.0)] {
            let (wi, wo) = (direction(ti, dphi), direction(to, 0.0));
            let (mut f, mut pdf) = (Rgb::ZERO, 0.0);
            for j in 0..n {
                let h = -1.0 + (j as f64 + 0.5) * 2.0 / n as f64;
                let (a, b) = near.eval_and_pdf(wi, wo, h);
                f += a / n as f64;
                pdf += b / n as f64;
            }
            let (g, q) = far.eval_and_pdf(wi, wo, 0.7);
            for c in 0..3 {
                assert!((g[c] - f[c]).abs() < 2e-4 * f[c].max(1e-3), "{g:?} vs {f:?}");
            }
            assert!((q - pdf).abs() < 2e-4 * pdf.max(1e-3), "{q} vs {pdf}");
            let mut lobes = [Rgb::ZERO; 4];
            assert!(far.eval_lobes(wi, wo, 0.0, &mut lobes));
            let sum = lobes.iter().fold(Rgb::ZERO, |s, &l| s + l);
            assert!((sum - g).max_component().abs() < 1e-12 * g.max_component());
        }
    }

    /// Without a lumen that turns anything the feature is Chiang's; with one it is narrower,
    /// and equal panels of that width (the trait's default width average) come closer to the
    /// model's own far field (pieces between the breakpoints, checked against a 20,000-point
    /// midpoint rule above) than panels of Chiang's width do.
    #[test]
    fn width_feature_resolves_the_lumen_turns() {
        use fiberlab_math::quadrature::{width_average, width_panels};
        let chiang = crate::build("chiang", &[("beta_n", "0.3")]).unwrap();
        for (kappa, lumen_eta) in [(0.0, 1.0), (0.5, 1.55)] {
            let fiber =
                HollowFiber::new(HollowFiberParams { kappa, lumen_eta, ..HollowFiberParams::default() }).unwrap();
            assert!((fiber.width_feature() - chiang.width_feature()).abs() < 1e-15);
        }
        let mut worse = 0.0;
        for kappa in [0.3, 0.5, 0.7] {
            let fiber = HollowFiber::new(HollowFiberParams { kappa, ..HollowFiberParams::default() }).unwrap();
            assert!(fiber.width_feature() < 0.5 * chiang.width_feature());
            let (mut err_own, mut err_chiang) = (0.0_f64, 0.0_f64);
            for &(ti, to, dphi) in &[(0.1, -0.2, 2.5), (0.5, -0.4, 0.3), (-0.3, 0.2, -1.2), (0.0, 0.05, 3.0)] {
                let (wi, wo) = (direction(ti, dphi), direction(to, 0.0));
                let reference = fiber.eval_far(wi, wo);
                let by_panels = |feature: f64| width_average(width_panels(feature), |h| fiber.eval(wi, wo, h));
                let rel = |g: Rgb| {
                    ((g - reference).max_component().abs()).max((reference - g).max_component().abs())
                        / reference.max_component()
                };
                err_own = err_own.max(rel(by_panels(fiber.width_feature())));
                err_chiang = err_chiang.max(rel(by_panels(chiang.width_feature())));
            }
            eprintln!(
                "κ {kappa}: feature {:.4}, worst relative error {err_own:.2e} (Chiang's feature: {err_chiang:.2e})",
                fiber.width_feature()
            );
            assert!(err_own <= err_chiang, "κ {kappa}: {err_own} vs {err_chiang}");
            assert!(err_own < 1e-3, "κ {kappa}: {err_own}");
            worse = f64::max(worse, err_chiang);
        }
        eprintln!("worst with Chiang's feature: {worse:.2e}");
    }

    /// A viewer exactly on the axis (θ_o = ±π/2) and draws at the pole (u[1] = 0 puts θ_i at
    /// −θ_o exactly): each sample's pdf is the pdf of its direction and its weight is
    /// `f_s cosθ_i / pdf` (before the fix, the pole's azimuth read back as atan2(0, 0) and the
    /// two pdfs differed by up to 10⁴×).
    #[test]
    fn on_axis_samples_have_the_pdf_of_their_direction() {
        for params in [
            HollowFiberParams::default(),
            HollowFiberParams { beta_m: 1.0, beta_n: 1.0, kappa: 0.7, ..HollowFiberParams::default() },
            HollowFiberParams { alpha: 0.2, kappa: 0.3, ..HollowFiberParams::default() },
        ] {
            let fiber = HollowFiber::new(params).unwrap();
            for wo in [direction(FRAC_PI_2, 0.0), direction(-FRAC_PI_2, 2.0), DVec3::X, -DVec3::X] {
                for h in [-1.0, -0.4, 0.0, 0.3, 1.0] {
                    for u in [[0.0; 4], [0.5; 4], [0.999_999, 0.0, 0.7, 0.999_999], [0.3, 1e-300, 0.2, 0.0]] {
                        let Some(s) = fiber.sample(wo, h, u) else { continue };
                        let (f, q) = fiber.eval_and_pdf(s.wi, wo, h);
                        assert!((s.pdf - q).abs() <= 1e-12 * q, "{params:?} ωo {wo} h {h} u {u:?}: {} vs {q}", s.pdf);
                        let w = f * (cos_theta(s.wi).max(MIN_COS) / q);
                        assert!((s.weight - w).max_component().abs() <= 1e-9 * w.max_component().max(1e-300));
                    }
                }
            }
        }
    }

    #[test]
    fn sub_lobe_count_fits() {
        let fiber = HollowFiber::new(HollowFiberParams::default()).unwrap();
        let v = fiber.at_vertex(direction(0.2, 0.0), 0.1);
        assert!(v.n <= MAX_SUBLOBES && v.n > 4, "{}", v.n);
    }
}
