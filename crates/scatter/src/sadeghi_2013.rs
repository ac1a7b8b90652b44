//! Sadeghi, Bisker, De Deken & Jensen 2013, *A practical microcylinder appearance model for
//! cloth rendering* (ACM TOG 32(2)): the thread scattering function, registered as a fiber
//! model (`sadeghi-thread`), and the cloth BRDF built from it ([`Sadeghi2013`], a surface
//! model with the paper's six fabrics as presets).
//!
//! # Thread scattering function (`sadeghi-thread`)
//!
//! Parameters: the registry entry (`THREAD_PARAMS`; the cloth's are `SURFACE_PARAMS`) is the one
//! table of keys, units, defaults and valid ranges; `fiberlab models --model sadeghi-thread` prints
//! it and the book's page `docs/book/src/models/sadeghi-thread.md` shows it. The formulas below
//! write `eta` as η, `albedo` as A, `gamma_s` as γ_s, `gamma_v` as γ_v.
//!
//! In the fiber frame (θ from the thread's normal plane, φ about the thread from its normal,
//! `θ_h = (θ_i + θ_r)/2`, `θ_d = (θ_i − θ_r)/2`, `φ_d = φ_i − φ_r` wrapped to (−π, π]) the
//! light meets the microcylinder's specular facet at `cos ι = cosθ_d·cos(φ_d/2)`, and
//! (Sadeghi et al. 2013, eqs. 3–5)
//! * surface lobe `f_{r,s} = F_r(η, cos ι)·cos(φ_d/2)·g(γ_s; θ_h)`,
//! * volume lobe `f_{r,v} = F_t²·((1 − k_d)·g(γ_v; θ_h) + k_d)·A/(cosθ_i + cosθ_r)`,
//! * `f_s = (f_{r,s} + f_{r,v})/cos²θ_d`,
//!
//! with `g(γ; x)` the unit-area Gaussian. The paper writes the transmissions into and out of
//! the thread as `F_t·F_t′`; both are taken at the facet cosine, `F_t = F_t′ = 1 − F_r(η, cos ι)`
//! (Fresnel transmittance is the same from either side of an interface for a refracted pair).
//! `f_s` is symmetric in its two directions (reciprocal); it is not energy bounded in general
//! (the `1/(cosθ_i + cosθ_r)` of the volume lobe grows near grazing inclinations), so no
//! energy claim is made — `fiberlab check` reports its albedo.
//!
//! Sampling: a mixture of the surface lobe (θ_i from a normal of width γ_s about the mirror
//! inclination −θ_o truncated to [−π/2, π/2], φ uniform), the volume lobe (the same with γ_v)
//! and the diffuse-fiber density `cosθ_i/π²`, one third each; the two Gaussian lobes' θ_i goes
//! through the pole taper (`hair::pole_taper`), so that a grazing viewer's lobe, centred on
//! the thread's axis, has a density that is finite per steradian there. The pdf is the exact
//! mixture density.
//!
//! # Cloth BRDF (`sadeghi-2013`, surface)
//!
//! The surface frame is that of [`crate::SurfaceScattering`]: `z` the cloth normal, `x` the
//! tangent along `u`. Thread family 1 (warp) runs along `x`, family 2 (weft) along `y`. Each
//! family has a coverage `α_j` and a list of tangent offsets `ψ_k` (the thread's inclination
//! along its length as it bends over and under the crossing threads): the offset rotates the
//! thread's tangent **and** its normal about the family's in-plane binormal,
//! `t = cosψ·t₀ + sinψ·z`, `n = cosψ·z − sinψ·t₀`. For each offset the thread frame is
//! `(t, n, t × n)` and, with `m(x) = max(cos x, 0)`,
//! * masking/shadowing `M = (1 − u(φ_d))·m(φ_i)·m(φ_o) + u(φ_d)·min(m(φ_i), m(φ_o))`, φ the
//!   azimuth about the thread from `n`, `u(x) = exp(−x²/(2·(20°)²))`;
//! * projected-area weight `P`, the same expression in the angles ψ measured from `n` in the
//!   plane spanned by `t` and `n`.
//!
//! The BRDF is (Sadeghi et al. 2013, eq. 7)
//! `f_r(ω_i, ω_o) = Σ_j α_j ⟨P·M·f_s·cosθ_o⟩_j / Q`, `Q = Σ_j α_j ⟨P⟩_j + (1 − Σ_j α_j)·(ω_o·z)`,
//! ⟨·⟩ the mean over the family's offsets, θ_o the viewer's inclination from the thread's
//! normal plane.
//!
//! **Which direction is "incident".** The paper's formula names its reweighted direction
//! `ω_i`. The reweighting is a projected-area average — each visible thread element
//! contributes in proportion to the area it shows along that direction, and `Q` is the total
//! visible area along it — which only makes sense for the direction the surface is *seen*
//! from. We therefore read the paper's `ω_i` as the **viewer**: in fiberlab's arguments
//! `cosθ_o` and `ω_o·z` above belong to `ω_o` (toward the viewer), and the light enters only
//! through `f_s`, `M` and `P` and the renderer's `cosθ_i`. This is also how the publicly
//! available Rust port of the paper uses the formula (it calls the camera direction `ω_i`).
//! The BRDF is then **not reciprocal** (`cosθ_o/Q(ω_o)` is not symmetric); the model claims no
//! reciprocity and the test `non_reciprocity_is_measured` reports the asymmetry.
//!
//! Energy: `∫ f_r cosθ_o dω_o ≤ 1` for every light direction holds for every preset on a
//! grid of light directions (tested by quadrature), so the model claims it.
//!
//! Sampling `ω_i` given `ω_o`: half cosine-weighted hemisphere, half the thread lobes (a
//! family with probability `α_j/Σα`, an offset uniformly, then the thread sampler in that
//! offset's frame). The pdf is the exact mixture density over the whole sphere; directions
//! below the surface carry weight 0.
//!
//! # Presets
//! The paper's table of measured fabrics (thread 1 / thread 2): `linen-plain`,
//! `silk-crepe-de-chine`, `polyester-satin-charmeuse`, `polyester-satin-charmeuse-back`,
//! `silk-shot`, `velvet`; see [`Sadeghi2013::preset`].

use crate::function::MIN_COS;
use crate::hair::pole_taper::{taper, taper_derivative, untaper};
use crate::params::{ParamKind, ParamSet, ParamSpec, Range, parameter_error};
use crate::sampling::{cos_theta_direction, cos_theta_pdf, cosine_hemisphere};
use crate::{
    Field, LobeInfo, Lobes, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction,
    SurfaceProperties, SurfaceScattering,
};
use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, sin_theta, wrap_pi};
use fiberlab_math::fresnel::dielectric;
use fiberlab_math::special::{gaussian, normal_mass, sample_truncated_normal};
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

const ETA_RANGE: Range = Range::closed(1.0, 3.0);
/// Lobe widths, degrees.
const GAMMA_RANGE: Range = Range::closed(0.5, 90.0);
/// Tangent offsets, degrees.
const OFFSET_RANGE: Range = Range::closed(-90.0, 90.0);
/// Width of the blend between the independent and the correlated masking, 20°.
const MASK_BLEND: f64 = 20.0 * PI / 180.0;
/// Most tangent offsets one thread family can hold.
pub const MAX_OFFSETS: usize = 8;

/// Parameter table of `sadeghi-thread`.
const THREAD_PARAMS: [ParamSpec; 5] = [
    ParamSpec { key: "eta", kind: ParamKind::Number(ETA_RANGE), unit: "", default: "1.46", doc: "refractive index" },
    ParamSpec {
        key: "k_d",
        kind: ParamKind::Number(Range::UNIT),
        unit: "",
        default: "0.3",
        doc: "isotropic share of the volume lobe",
    },
    ParamSpec { key: "albedo", kind: ParamKind::Color(Range::UNIT), unit: "", default: "0.3", doc: "volume albedo A" },
    ParamSpec {
        key: "gamma_s",
        kind: ParamKind::Number(GAMMA_RANGE),
        unit: "degrees",
        default: "12",
        doc: "surface lobe width γ_s",
    },
    ParamSpec {
        key: "gamma_v",
        kind: ParamKind::Number(GAMMA_RANGE),
        unit: "degrees",
        default: "24",
        doc: "volume lobe width γ_v",
    },
];

parameter_error! {
    /// Why a Sadeghi thread or cloth cannot be built.
    SadeghiError
}

/// Parameters of one thread (radians for the widths).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThreadParams {
    /// Refractive index η ∈ [1, 3].
    pub eta: f64,
    /// Isotropic share of the volume lobe `k_d` ∈ [0, 1].
    pub k_d: f64,
    /// Volume albedo A ∈ [0, 1] per channel.
    pub albedo: Rgb,
    /// Surface lobe width γ_s (radians, 0.5°–90°).
    pub gamma_s: f64,
    /// Volume lobe width γ_v (radians, 0.5°–90°).
    pub gamma_v: f64,
}

impl Default for ThreadParams {
    /// The linen thread of the paper's table: η = 1.46, k_d = 0.3, A = 0.3, γ_s = 12°, γ_v = 24°.
    fn default() -> Self {
        Self { eta: 1.46, k_d: 0.3, albedo: Rgb::splat(0.3), gamma_s: 12f64.to_radians(), gamma_v: 24f64.to_radians() }
    }
}

impl ThreadParams {
    /// Reads the registry parameters of `sadeghi-thread`.
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Self {
            eta: p.number("eta")?,
            k_d: p.number("k_d")?,
            albedo: p.color("albedo")?,
            gamma_s: p.degrees("gamma_s")?,
            gamma_v: p.degrees("gamma_v")?,
        })
    }

    fn check(&self) -> Result<(), SadeghiError> {
        ETA_RANGE.check("eta", self.eta)?;
        Range::UNIT.check("k_d", self.k_d)?;
        Range::UNIT.check_rgb("albedo", self.albedo)?;
        GAMMA_RANGE.check_degrees("gamma_s", self.gamma_s)?;
        GAMMA_RANGE.check_degrees("gamma_v", self.gamma_v)?;
        Ok(())
    }
}

/// The thread scattering function of Sadeghi et al. 2013 as a fiber model.
///
/// At mirror inclinations (`θ_h = 0`) seen straight back (`φ_d = 0`, so `cos ι = cosθ_d`)
/// the surface lobe is `F_r(η, cosθ_d)·g(γ_s; 0)/cos²θ_d`:
/// ```
/// use fiberlab_scatter::ScatteringFunction;
/// use fiberlab_scatter::sadeghi_2013::{SadeghiThread, ThreadParams};
/// use fiberlab_math::{Rgb, frame::direction, fresnel::dielectric};
/// let p = ThreadParams { albedo: Rgb::ZERO, ..ThreadParams::default() };
/// let f = SadeghiThread::new(p).unwrap();
/// let value = f.eval(direction(0.0, 0.3), direction(0.0, 0.3), 0.0);
/// let peak = 1.0 / (p.gamma_s * (2.0 * std::f64::consts::PI).sqrt());
/// assert!((value[0] - dielectric(1.0, 1.46) * peak).abs() < 1e-12);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SadeghiThread {
    p: ThreadParams,
}

/// Registry entry: `sadeghi-thread`.
impl Registered for SadeghiThread {
    const INFO: ModelInfo = ModelInfo {
        name: "sadeghi-thread",
        summary: "cloth thread: microcylinder surface + volume lobes (the fiber part of sadeghi-2013)",
        citation: "Sadeghi, Bisker, De Deken & Jensen 2013, eqs. 3-5",
        params: &THREAD_PARAMS,
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(SadeghiThread::new(ThreadParams::from_param_set(p)?)?)
    }
}

/// The lobes of the thread sampler.
const THREAD_LOBES: [LobeInfo; 3] =
    [LobeInfo::smooth("surface"), LobeInfo::smooth("volume"), LobeInfo::smooth("diffuse")];

impl SadeghiThread {
    /// A thread with the given parameters (validated).
    pub fn new(p: ThreadParams) -> Result<Self, SadeghiError> {
        p.check()?;
        Ok(Self { p })
    }

    /// Its parameters.
    #[must_use]
    pub fn params(&self) -> ThreadParams {
        self.p
    }

    /// `f_s` for two directions in the thread's fiber frame (x = tangent, φ from y).
    #[must_use]
    pub fn value(&self, wi: DVec3, wo: DVec3) -> Rgb {
        let (si, ci, so, co) = (sin_theta(wi), cos_theta(wi), sin_theta(wo), cos_theta(wo));
        let (theta_i, theta_o) = (si.atan2(ci), so.atan2(co));
        let theta_h = 0.5 * (theta_i + theta_o);
        let cos_d = (0.5 * (theta_i - theta_o)).cos();
        let phi_d = wrap_pi(phi(wi) - phi(wo));
        let cos_half = (0.5 * phi_d).cos().max(0.0);
        let cos_iota = cos_d * cos_half;
        let fr = dielectric(cos_iota, self.p.eta);
        let surface = fr * cos_half * gaussian(self.p.gamma_s, theta_h);
        let ft = 1.0 - fr;
        let volume_scalar =
            ft * ft * ((1.0 - self.p.k_d) * gaussian(self.p.gamma_v, theta_h) + self.p.k_d) / (ci + co).max(1e-12);
        let inv = 1.0 / (cos_d * cos_d).max(1e-12);
        (Rgb::splat(surface) + self.p.albedo * volume_scalar) * inv
    }

    /// Probabilities of the surface, volume and diffuse sampling lobes.
    const LOBE_WEIGHTS: [f64; 3] = [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0];

    /// Density (per sr) of a Gaussian-in-θ lobe of width `sigma` about `−θ_o`, φ uniform, its
    /// θ drawn through the pole taper ([`crate::hair::pole_taper`]: finite per steradian on
    /// the thread's axis, where a grazing viewer's lobe is centred).
    fn lobe_pdf(sigma: f64, theta_o: f64, wi: DVec3) -> f64 {
        let (s, c) = (sin_theta(wi), cos_theta(wi));
        let theta_i = s.atan2(c);
        let mu = -theta_o;
        let mass = normal_mass((-FRAC_PI_2 - mu) / sigma, (FRAC_PI_2 - mu) / sigma);
        let slope = taper_derivative(theta_i);
        if mass <= 0.0 || slope <= 0.0 {
            return 0.0;
        }
        gaussian(sigma, taper(theta_i) - mu) / mass * slope / (TAU * c.max(MIN_COS))
    }

    /// Density (per sr) of [`SadeghiThread::sample_local`] in the thread frame.
    #[must_use]
    pub fn pdf_local(&self, wi: DVec3, wo: DVec3) -> f64 {
        let theta_o = sin_theta(wo).atan2(cos_theta(wo));
        let [a, b, c] = Self::LOBE_WEIGHTS;
        a * Self::lobe_pdf(self.p.gamma_s, theta_o, wi)
            + b * Self::lobe_pdf(self.p.gamma_v, theta_o, wi)
            + c * cos_theta_pdf(cos_theta(wi))
    }

    /// Draws a direction in the thread frame given `wo` from four uniforms; returns it and
    /// the lobe index.
    #[must_use]
    pub fn sample_local(&self, wo: DVec3, u: [f64; 4]) -> (DVec3, u8) {
        let [a, b, _] = Self::LOBE_WEIGHTS;
        let phi_i = phi(wo) + PI * (2.0 * u[3] - 1.0);
        if u[0] < a + b {
            let (sigma, lobe) = if u[0] < a { (self.p.gamma_s, 0) } else { (self.p.gamma_v, 1) };
            let mu = -(sin_theta(wo).atan2(cos_theta(wo)));
            let z = sample_truncated_normal(u[1], (-FRAC_PI_2 - mu) / sigma, (FRAC_PI_2 - mu) / sigma);
            let theta = untaper((mu + sigma * z).clamp(-FRAC_PI_2, FRAC_PI_2));
            let (s, c) = theta.sin_cos();
            (direction_from_sin_cos(s, c, phi_i), lobe)
        } else {
            (cos_theta_direction(u[1], u[2], phi_i), 2)
        }
    }
}

impl ScatteringFunction for SadeghiThread {
    fn properties(&self) -> Properties {
        Properties { reciprocal: true, energy_conserving: false, field: Field::Far, lobes: Lobes::Smooth }
    }

    fn eval(&self, wi: DVec3, wo: DVec3, _h: f64) -> Rgb {
        self.value(wi, wo)
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, _h: f64) -> f64 {
        self.pdf_local(wi, wo)
    }

    fn sample(&self, wo: DVec3, _h: f64, u: [f64; 4]) -> Option<Sample> {
        let (wi, lobe) = self.sample_local(wo, u);
        let pdf = self.pdf_local(wi, wo);
        if pdf.is_nan() || pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        let weight = self.value(wi, wo) * (cos_theta(wi) / pdf);
        Some(Sample { wi, weight, pdf, delta: false, lobe })
    }

    fn lobes(&self) -> Vec<LobeInfo> {
        THREAD_LOBES.to_vec()
    }
}

// ---------------------------------------------------------------------------------------
// The cloth BRDF.

/// One family of parallel threads (warp or weft) of the cloth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThreadFamily {
    /// The thread's scattering parameters.
    pub thread: ThreadParams,
    /// Coverage α_j ∈ [0, 1]: the share of the cloth's area this family covers.
    pub coverage: f64,
    /// Tangent offsets ψ_k (radians, in [−π/2, π/2]); the first `count` are used.
    pub offsets: [f64; MAX_OFFSETS],
    /// Number of offsets in use (1..=[`MAX_OFFSETS`]).
    pub count: usize,
}

impl ThreadFamily {
    /// A family from its thread, coverage and offsets in **degrees** (table edge).
    #[must_use]
    pub fn from_degrees(thread: ThreadParams, coverage: f64, offsets_deg: &[f64]) -> Self {
        let mut offsets = [0.0; MAX_OFFSETS];
        for (o, d) in offsets.iter_mut().zip(offsets_deg) {
            *o = d.to_radians();
        }
        Self { thread, coverage, offsets, count: offsets_deg.len().min(MAX_OFFSETS) }
    }

    /// The offsets in use.
    #[must_use]
    pub fn offsets(&self) -> &[f64] {
        &self.offsets[..self.count]
    }
}

/// The preset names of [`Sadeghi2013::preset`], in the paper's table order.
pub const SADEGHI_PRESETS: [&str; 6] = [
    "linen-plain",
    "silk-crepe-de-chine",
    "polyester-satin-charmeuse",
    "polyester-satin-charmeuse-back",
    "silk-shot",
    "velvet",
];

fn thread(eta: f64, albedo: Rgb, k_d: f64, gamma_s_deg: f64, gamma_v_deg: f64) -> ThreadParams {
    ThreadParams { eta, k_d, albedo, gamma_s: gamma_s_deg.to_radians(), gamma_v: gamma_v_deg.to_radians() }
}

/// The keys `set_parameter` (and the registry) accept per family, suffixed `_1` / `_2`.
const TEXTURABLE: [&str; 10] =
    ["eta_1", "eta_2", "k_d_1", "k_d_2", "albedo_1", "albedo_2", "gamma_s_1", "gamma_s_2", "gamma_v_1", "gamma_v_2"];

macro_rules! family_override {
    ($key:literal, $kind:expr, $unit:literal, $doc:literal) => {
        ParamSpec { key: $key, kind: $kind, unit: $unit, default: "", doc: $doc }
    };
}

/// Parameter table of `sadeghi-2013`: the preset and optional per-family overrides.
pub const SURFACE_PARAMS: [ParamSpec; 11] = [
    ParamSpec {
        key: "preset",
        kind: ParamKind::Choice(&SADEGHI_PRESETS),
        unit: "",
        default: "linen-plain",
        doc: "fabric of the paper's table",
    },
    family_override!("eta_1", ParamKind::Number(ETA_RANGE), "", "thread 1 refractive index (overrides the preset)"),
    family_override!("eta_2", ParamKind::Number(ETA_RANGE), "", "thread 2 refractive index (overrides the preset)"),
    family_override!("k_d_1", ParamKind::Number(Range::UNIT), "", "thread 1 k_d (overrides the preset)"),
    family_override!("k_d_2", ParamKind::Number(Range::UNIT), "", "thread 2 k_d (overrides the preset)"),
    family_override!("albedo_1", ParamKind::Color(Range::UNIT), "", "thread 1 volume albedo (overrides the preset)"),
    family_override!("albedo_2", ParamKind::Color(Range::UNIT), "", "thread 2 volume albedo (overrides the preset)"),
    family_override!("gamma_s_1", ParamKind::Number(GAMMA_RANGE), "degrees", "thread 1 γ_s (overrides the preset)"),
    family_override!("gamma_s_2", ParamKind::Number(GAMMA_RANGE), "degrees", "thread 2 γ_s (overrides the preset)"),
    family_override!("gamma_v_1", ParamKind::Number(GAMMA_RANGE), "degrees", "thread 1 γ_v (overrides the preset)"),
    family_override!("gamma_v_2", ParamKind::Number(GAMMA_RANGE), "degrees", "thread 2 γ_v (overrides the preset)"),
];

/// The Sadeghi et al. 2013 cloth BRDF: two thread families (warp along `x`, weft along `y`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sadeghi2013 {
    families: [ThreadFamily; 2],
}

/// The lobes of [`Sadeghi2013`]'s sampler.
const SURFACE_LOBES: [LobeInfo; 4] = [
    LobeInfo::smooth("cosine"),
    LobeInfo::smooth("thread-surface"),
    LobeInfo::smooth("thread-volume"),
    LobeInfo::smooth("thread-diffuse"),
];

/// Probability of the cosine-weighted part of the sampler.
const COSINE_SHARE: f64 = 0.5;

/// The masking/shadowing blend of two angles measured from a thread's normal.
fn masking(a: f64, b: f64) -> f64 {
    let d = wrap_pi(a - b);
    let u = (-d * d / (2.0 * MASK_BLEND * MASK_BLEND)).exp();
    let (ma, mb) = (a.cos().max(0.0), b.cos().max(0.0));
    (1.0 - u) * ma * mb + u * ma.min(mb)
}

/// The frame of one thread segment: tangent `t`, normal `n` and `w = t × n`.
#[derive(Clone, Copy, Debug)]
struct SegmentFrame {
    t: DVec3,
    n: DVec3,
    w: DVec3,
}

impl SegmentFrame {
    /// Family `j` (0: along x, 1: along y) tilted by the offset `psi`, which rotates both the
    /// tangent and the normal about the family's in-plane binormal.
    fn new(j: usize, psi: f64) -> Self {
        let t0 = if j == 0 { DVec3::X } else { DVec3::Y };
        let (s, c) = psi.sin_cos();
        let t = t0 * c + DVec3::Z * s;
        let n = DVec3::Z * c - t0 * s;
        Self { t, n, w: t.cross(n) }
    }
    fn to_local(self, d: DVec3) -> DVec3 {
        DVec3::new(d.dot(self.t), d.dot(self.n), d.dot(self.w))
    }
    fn to_world(self, d: DVec3) -> DVec3 {
        self.t * d.x + self.n * d.y + self.w * d.z
    }
}

impl Sadeghi2013 {
    /// A cloth from two families (validated: coverages in [0, 1] summing to at most 1, at
    /// least one offset each, offsets in [−90°, 90°], thread parameters in range).
    pub fn new(families: [ThreadFamily; 2]) -> Result<Self, SadeghiError> {
        for f in &families {
            f.thread.check()?;
            Range::UNIT.check("coverage", f.coverage)?;
            Range::closed(1.0, MAX_OFFSETS as f64).check("offsets", f.count as f64)?;
            for &o in f.offsets() {
                OFFSET_RANGE.check_degrees("offsets", o)?;
            }
        }
        Range::open_closed(0.0, 1.0 + 1e-12).check("coverage", families[0].coverage + families[1].coverage)?;
        Ok(Self { families })
    }

    /// The families.
    #[must_use]
    pub fn families(&self) -> &[ThreadFamily; 2] {
        &self.families
    }

    /// One of the fabrics of the paper's table ([`SADEGHI_PRESETS`]), or `None`.
    #[must_use]
    pub fn preset(name: &str) -> Option<Self> {
        let fam = ThreadFamily::from_degrees;
        let families = match name {
            "linen-plain" => {
                let t = thread(1.46, Rgb::new(0.2, 0.8, 1.0) * 0.3, 0.3, 12.0, 24.0);
                [fam(t, 0.33, &[-25.0, 25.0]), fam(t, 0.33, &[-25.0, 25.0])]
            }
            "silk-crepe-de-chine" => {
                let c = Rgb::new(1.0, 0.95, 0.05);
                [
                    fam(thread(1.345, c * 0.12, 0.2, 5.0, 10.0), 0.75, &[-35.0, -35.0, 35.0, 35.0]),
                    fam(thread(1.345, c * 0.16, 0.3, 18.0, 32.0), 0.25, &[0.0]),
                ]
            }
            "polyester-satin-charmeuse" | "polyester-satin-charmeuse-back" => {
                let c = Rgb::new(1.0, 0.37, 0.3);
                let (t1, t2) = (thread(1.539, c * 0.035, 0.1, 2.5, 5.0), thread(1.539, c * 0.02, 0.7, 30.0, 60.0));
                if name == "polyester-satin-charmeuse" {
                    [fam(t1, 0.9, &[-32.0, -32.0, -18.0, 0.0, 0.0, 18.0, 32.0, 32.0]), fam(t2, 0.1, &[0.0])]
                } else {
                    [fam(t1, 0.67, &[-30.0, -30.0, 30.0, 30.0, -5.0, -5.0, 5.0, 5.0]), fam(t2, 0.33, &[0.0])]
                }
            }
            "silk-shot" => [
                fam(thread(1.345, Rgb::new(0.1, 1.0, 0.4) * 0.2, 0.1, 4.0, 8.0), 0.86, &[-25.0, -25.0, 25.0, 25.0]),
                fam(thread(1.345, Rgb::new(1.0, 0.0, 0.1) * 0.6, 0.1, 5.0, 10.0), 0.14, &[0.0]),
            ],
            "velvet" => {
                let t = thread(1.46, Rgb::new(0.05, 0.02, 0.0) * 0.3, 0.1, 6.0, 12.0);
                [fam(t, 0.5, &[-90.0, -50.0]), fam(t, 0.5, &[-90.0, -55.0, 55.0, 90.0])]
            }
            _ => return None,
        };
        Some(Self { families })
    }

    /// Builds from registry parameters: the preset, then any per-family overrides.
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        let name = p.choice("preset")?;
        let mut cloth = Self::preset(name).ok_or_else(|| ModelError::BadValue {
            key: "preset".into(),
            value: name.into(),
            expected: SADEGHI_PRESETS.join(", "),
        })?;
        for key in TEXTURABLE {
            if !p.is_given(key) {
                continue;
            }
            let value = if key.starts_with("albedo") {
                p.color(key)?
            } else if key.starts_with("gamma") {
                Rgb::splat(p.degrees(key)?)
            } else {
                Rgb::splat(p.number(key)?)
            };
            cloth.set_parameter(key, value)?;
        }
        Ok(Self::new(cloth.families)?)
    }

    /// `Σ_j α_j ⟨P M f_s cosθ_o⟩_j` and `Q`, the numerator and the denominator of `f_r`.
    fn numerator_and_area(&self, wi: DVec3, wo: DVec3) -> (Rgb, f64) {
        let (mut num, mut area, mut covered) = (Rgb::ZERO, 0.0, 0.0);
        for (j, fam) in self.families.iter().enumerate() {
            if fam.coverage <= 0.0 {
                continue;
            }
            let thread = SadeghiThread { p: fam.thread };
            let (mut sum, mut sum_p) = (Rgb::ZERO, 0.0);
            for &psi in fam.offsets() {
                let frame = SegmentFrame::new(j, psi);
                let (li, lo) = (frame.to_local(wi), frame.to_local(wo));
                // ψ: angle from n in the (t, n) plane; φ: azimuth about t from n.
                let p = masking(li.x.atan2(li.y), lo.x.atan2(lo.y));
                let m = masking(phi(li), phi(lo));
                sum_p += p;
                if p * m > 0.0 {
                    sum += thread.value(li, lo) * (p * m * cos_theta(lo));
                }
            }
            let k = fam.count as f64;
            num += sum * (fam.coverage / k);
            area += fam.coverage * sum_p / k;
            covered += fam.coverage;
        }
        (num, area + (1.0 - covered).max(0.0) * wo.z)
    }

    /// Total coverage Σα_j.
    fn covered(&self) -> f64 {
        self.families.iter().map(|f| f.coverage).sum()
    }

    /// Density of the thread-lobe part of the sampler.
    fn thread_pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        let total = self.covered();
        let mut pdf = 0.0;
        for (j, fam) in self.families.iter().enumerate() {
            if fam.coverage <= 0.0 {
                continue;
            }
            let thread = SadeghiThread { p: fam.thread };
            let share = fam.coverage / total / fam.count as f64;
            for &psi in fam.offsets() {
                let frame = SegmentFrame::new(j, psi);
                pdf += share * thread.pdf_local(frame.to_local(wi), frame.to_local(wo));
            }
        }
        pdf
    }
}

/// Registry entry: `sadeghi-2013` (a surface model).
impl Registered for Sadeghi2013 {
    const INFO: ModelInfo = ModelInfo {
        name: "sadeghi-2013",
        summary: "microcylinder cloth: two thread families with tangent offsets (Sadeghi et al. 2013)",
        citation: "Sadeghi, Bisker, De Deken & Jensen 2013, eqs. 3-7 and table of fabrics",
        params: &SURFACE_PARAMS,
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Sadeghi2013::from_param_set(p)
    }
}

impl SurfaceScattering for Sadeghi2013 {
    fn properties(&self) -> SurfaceProperties {
        SurfaceProperties { reciprocal: false, energy_conserving: true, has_delta: false, transmits: false }
    }

    fn eval(&self, wi: DVec3, wo: DVec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let (num, area) = self.numerator_and_area(wi, wo);
        if area > 0.0 { num * (1.0 / area) } else { Rgb::ZERO }
    }

    fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        let cosine = if wi.z > 0.0 { wi.z / PI } else { 0.0 };
        COSINE_SHARE * cosine + (1.0 - COSINE_SHARE) * self.thread_pdf(wi, wo)
    }

    fn sample(&self, wo: DVec3, u: [f64; 4]) -> Option<Sample> {
        if wo.z <= 0.0 {
            return None;
        }
        let (wi, lobe) = if u[0] < COSINE_SHARE {
            (cosine_hemisphere(DVec3::Z, DVec3::X, u[1], u[2]), 0)
        } else {
            // Reuse u[0] to pick the family, the offset and the thread lobe.
            let mut x = (u[0] - COSINE_SHARE) / (1.0 - COSINE_SHARE);
            let total = self.covered();
            let j = if x * total < self.families[0].coverage || self.families[1].coverage <= 0.0 {
                x = (x * total / self.families[0].coverage).min(1.0 - f64::EPSILON);
                0
            } else {
                x = ((x * total - self.families[0].coverage) / self.families[1].coverage).min(1.0 - f64::EPSILON);
                1
            };
            let fam = &self.families[j];
            let k = ((x * fam.count as f64) as usize).min(fam.count - 1);
            let x = x * fam.count as f64 - k as f64;
            let frame = SegmentFrame::new(j, fam.offsets[k]);
            let thread = SadeghiThread { p: fam.thread };
            let (local, lobe) = thread.sample_local(frame.to_local(wo), [x, u[1], u[2], u[3]]);
            (frame.to_world(local).normalize(), lobe + 1)
        };
        let pdf = self.pdf(wi, wo);
        if pdf.is_nan() || pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        let weight = if wi.z > 0.0 { self.eval(wi, wo) * (wi.z / pdf) } else { Rgb::ZERO };
        Some(Sample { wi, weight, pdf, delta: false, lobe })
    }

    fn lobes(&self) -> Vec<LobeInfo> {
        SURFACE_LOBES.to_vec()
    }

    fn texturable_keys(&self) -> &'static [&'static str] {
        &TEXTURABLE
    }

    fn set_parameter(&mut self, key: &str, value: Rgb) -> Result<(), ModelError> {
        let unknown = || ModelError::UnknownParameter {
            model: "sadeghi-2013".into(),
            key: key.into(),
            known: TEXTURABLE.join(", "),
        };
        let (name, family) = key.rsplit_once('_').ok_or_else(unknown)?;
        let j = match family {
            "1" => 0,
            "2" => 1,
            _ => return Err(unknown()),
        };
        let t = &mut self.families[j].thread;
        match name {
            "eta" => t.eta = value[0],
            "k_d" => t.k_d = value[0],
            "albedo" => t.albedo = value,
            "gamma_s" => t.gamma_s = value[0],
            "gamma_v" => t.gamma_v = value[0],
            _ => return Err(unknown()),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_check::rng::TestRng;
    use fiberlab_math::frame::direction;

    fn hemisphere(theta: f64, phi: f64) -> DVec3 {
        let (s, c) = theta.sin_cos();
        DVec3::new(s * phi.cos(), s * phi.sin(), c)
    }

    /// The thread's surface lobe at a general configuration, from the formula written with
    /// the angles themselves (not through the fiber frame).
    #[test]
    fn thread_value_matches_the_formula_at_a_configuration() {
        let p = ThreadParams { eta: 1.5, k_d: 0.25, albedo: Rgb::new(0.2, 0.5, 0.9), ..ThreadParams::default() };
        let f = SadeghiThread::new(p).unwrap();
        let (ti, pi, tr, pr) = (0.4_f64, 0.3_f64, -0.1_f64, 1.2_f64);
        let v = f.value(direction(ti, pi), direction(tr, pr));
        let (th, td, pd) = ((ti + tr) / 2.0, (ti - tr) / 2.0, pi - pr);
        let g = |s: f64, x: f64| (-x * x / (2.0 * s * s)).exp() / (s * (2.0 * PI).sqrt());
        let cos_iota = td.cos() * (pd / 2.0).cos();
        // Fresnel written out (Snell + both polarisations).
        let sin_t = (1.0 - cos_iota * cos_iota).sqrt() / 1.5;
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        let rs = (cos_iota - 1.5 * cos_t) / (cos_iota + 1.5 * cos_t);
        let rp = (1.5 * cos_iota - cos_t) / (1.5 * cos_iota + cos_t);
        let fr = 0.5 * (rs * rs + rp * rp);
        let surf = fr * (pd / 2.0).cos() * g(p.gamma_s, th);
        let vol = (1.0 - fr).powi(2) * (0.75 * g(p.gamma_v, th) + 0.25) / (ti.cos() + tr.cos());
        for c in 0..3 {
            let expected = (surf + vol * p.albedo[c]) / (td.cos() * td.cos());
            assert!((v[c] - expected).abs() < 1e-12 * expected, "{c}: {} vs {expected}", v[c]);
        }
    }

    #[test]
    fn thread_is_symmetric() {
        let f = SadeghiThread::new(ThreadParams::default()).unwrap();
        let mut rng = TestRng::new(3);
        for _ in 0..1000 {
            let (a, b) = (rng.sphere_direction(), rng.sphere_direction());
            let (x, y) = (f.value(a, b), f.value(b, a));
            assert!((x[0] - y[0]).abs() <= 1e-12 * x[0].abs().max(1e-300), "{x} vs {y}");
        }
    }

    /// With one offset ψ the cloth equals the untilted cloth seen in directions rotated by
    /// −ψ about the binormal: the offset must turn both the tangent and the normal. (The
    /// gap term ω_o·z is removed by full coverage.)
    #[test]
    fn an_offset_rotates_tangent_and_normal_together() {
        let t = ThreadParams::default();
        let make = |psi: f64| {
            Sadeghi2013::new([ThreadFamily::from_degrees(t, 1.0, &[psi]), ThreadFamily::from_degrees(t, 0.0, &[0.0])])
                .unwrap()
        };
        let (tilted, flat) = (make(20.0), make(0.0));
        let psi = 20f64.to_radians();
        // Rotation taking the tilted frame (t, n) to the flat one (x, z): about y by ψ.
        let rot = |d: DVec3| DVec3::new(d.x * psi.cos() + d.z * psi.sin(), d.y, d.z * psi.cos() - d.x * psi.sin());
        let mut checked = 0;
        for &(a, b, c, d) in &[(0.5, 0.2, 0.8, 2.5), (0.3, -1.0, 0.6, 0.4), (1.0, 3.0, 0.2, 0.1)] {
            let (wi, wo) = (hemisphere(a, b), hemisphere(c, d));
            let (ri, ro) = (rot(wi), rot(wo));
            if ri.z <= 0.0 || ro.z <= 0.0 {
                continue;
            }
            let (x, y) = (tilted.numerator_and_area(wi, wo), flat.numerator_and_area(ri, ro));
            assert!((x.0[0] - y.0[0]).abs() <= 1e-12 * y.0[0].abs().max(1e-300));
            assert!((x.1 - y.1).abs() <= 1e-12);
            checked += 1;
        }
        assert!(checked >= 2);
    }

    /// ∫ f_r cosθ_o dω_o by a product midpoint rule over the viewer hemisphere.
    fn albedo(m: &Sadeghi2013, wi: DVec3) -> Rgb {
        let (nt, np) = (90, 180);
        let (dt, dp) = (FRAC_PI_2 / nt as f64, TAU / np as f64);
        let mut sum = Rgb::ZERO;
        for a in 0..nt {
            let t = (a as f64 + 0.5) * dt;
            for b in 0..np {
                let wo = hemisphere(t, (b as f64 + 0.5) * dp);
                sum += m.eval(wi, wo) * (t.cos() * t.sin() * dt * dp);
            }
        }
        sum
    }

    #[test]
    fn every_preset_conserves_energy_on_a_grid() {
        for name in SADEGHI_PRESETS {
            let m = Sadeghi2013::preset(name).unwrap();
            let mut worst: f64 = 0.0;
            for &t in &[0.0, 0.4, 0.8, 1.2, 1.45] {
                for &p in &[0.0, 0.7, 1.6, 2.9] {
                    let a = albedo(&m, hemisphere(t, p)).max_component();
                    worst = worst.max(a);
                }
            }
            eprintln!("{name}: largest albedo {worst:.4}");
            assert!(worst <= 1.0, "{name}: albedo {worst}");
            assert!(worst > 0.0, "{name}");
        }
    }

    #[test]
    fn non_reciprocity_is_measured() {
        let mut rng = TestRng::new(11);
        for name in SADEGHI_PRESETS {
            let m = Sadeghi2013::preset(name).unwrap();
            assert!(!m.properties().reciprocal);
            let mut worst: f64 = 0.0;
            for _ in 0..4000 {
                let (mut a, mut b) = (rng.sphere_direction(), rng.sphere_direction());
                a.z = a.z.abs();
                b.z = b.z.abs();
                let (x, y) = (m.eval(a, b).max_component(), m.eval(b, a).max_component());
                if x.max(y) > 1e-6 {
                    worst = worst.max((x - y).abs() / x.max(y));
                }
            }
            eprintln!("{name}: largest relative asymmetry |f(i,o) − f(o,i)|/max = {worst:.3}");
            assert!(worst > 1e-3, "{name}");
        }
    }

    #[test]
    fn set_parameter_replaces_and_refuses_unknown_keys() {
        let mut m = Sadeghi2013::preset("silk-shot").unwrap();
        m.set_parameter("albedo_2", Rgb::splat(0.5)).unwrap();
        assert_eq!(m.families()[1].thread.albedo, Rgb::splat(0.5));
        assert!(m.set_parameter("albedo_3", Rgb::ONE).is_err());
        assert!(m.set_parameter("preset", Rgb::ONE).is_err());
        let spec = <Sadeghi2013 as Registered>::INFO;
        let p = ParamSet::parse(spec.name, spec.params, &[("preset", "velvet"), ("gamma_s_1", "10")]).unwrap();
        let v = Sadeghi2013::from_param_set(&p).unwrap();
        assert!((v.families()[0].thread.gamma_s - 10f64.to_radians()).abs() < 1e-15);
        let bad = ParamSet::parse(spec.name, spec.params, &[("preset", "denim")]);
        assert!(bad.is_err());
    }
}
