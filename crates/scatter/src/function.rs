//! The scattering-function interface every fiber model implements.
//!
//! A fiber scattering function `f_s(ω_i, ω_r)` (sr⁻¹) is the 1D analogue of a BRDF: the
//! width-averaged outgoing radiance is `L_r(ω_r) = ∫ f_s(ω_i, ω_r) L_i(ω_i) cosθ_i dω_i`,
//! with θ measured from the fiber's normal plane (`docs/theory/conventions.md`, "Fiber scattering function versus renderer BSDF";
//! `docs/theory/radiometry.md`). Directions are in
//! the fiber frame of [`fiberlab_math`]; `ω_i` points toward the light, `ω_r` (`wo`) toward
//! the viewer; `h ∈ [−1, 1]` is the offset across the fiber.

use fiberlab_math::{DVec3, Rgb};

/// Smallest `cosθ_i` used where a model divides by `cosθ_i` (the convention's cosine, e.g.
/// `f_s = g/cosθ_i` of the backward-form hair models, Kajiya–Kay's specular term) at exactly
/// grazing light, so that the value stays finite; one constant for every model.
pub const MIN_COS: f64 = 1e-8;

/// Whether a model depends on the offset `h` across the fiber.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// `f_s` is already averaged over the fiber width; `h` is ignored.
    Far,
    /// `eval` returns the value at offset `h`; its average over `h ∈ [−1, 1]` is the
    /// far-field `f_s`.
    Near,
}

/// Whether a model's distribution has a density or is concentrated on a cone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobes {
    /// A density over the sphere: `eval`, `pdf` are pointwise values.
    Smooth,
    /// All light leaves on the specular cone θ_r = −θ_i (a Dirac delta in θ): `eval` and
    /// `pdf` return 0; `sample` returns the lobe and [`ScatteringFunction::cone`] its
    /// azimuthal distribution.
    Delta,
}

/// What a model claims about itself; the validation harness tests exactly these claims.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Properties {
    /// `f_s(ω_i, ω_r) = f_s(ω_r, ω_i)` (for near-field models: of the h-average).
    pub reciprocal: bool,
    /// Albedo `ρ(ω_i) = ∫ f_s cosθ_r dω_r ≤ 1` for every `ω_i`.
    pub energy_conserving: bool,
    /// Near- or far-field.
    pub field: Field,
    /// Smooth or delta.
    pub lobes: Lobes,
}

/// One importance sample of `ω_i` given `ω_o`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Sampled direction toward the light, unit length, fiber frame.
    pub wi: DVec3,
    /// `f_s(ω_i, ω_o)·cosθ_i / pdf` (for delta lobes: the lobe's throughput).
    pub weight: Rgb,
    /// Density of `wi` per steradian; 0 for delta lobes.
    pub pdf: f64,
    /// True when `wi` was drawn from a delta lobe (no MIS with light sampling).
    pub delta: bool,
    /// Which lobe drew `wi`: an index into [`ScatteringFunction::lobes`].
    pub lobe: u8,
}

/// One lobe a model's sampler chooses among (see [`ScatteringFunction::lobes`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LobeInfo {
    /// Short name, e.g. `R`, `TT`, `diffuse`.
    pub name: &'static str,
    /// Samples from this lobe have [`Sample::delta`] set.
    pub delta: bool,
}

impl LobeInfo {
    /// A lobe with a density (not delta).
    #[must_use]
    pub const fn smooth(name: &'static str) -> Self {
        Self { name, delta: false }
    }
}

/// Value of a delta lobe on its cone at relative azimuth φ, see [`ScatteringFunction::cone`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeValue {
    /// `n(φ)` times the lobe's attenuation: `f_s = δ(θ_i + θ_r)·value/cos²θ_i`.
    pub value: Rgb,
    /// Density in φ (rad⁻¹) with which `sample` draws the relative azimuth.
    pub pdf: f64,
}

/// A fiber scattering function: evaluation, importance sampling and its density.
pub trait ScatteringFunction: Send + Sync {
    /// What the model claims (reciprocity, energy, field, lobes).
    fn properties(&self) -> Properties;

    /// `f_s(ω_i, ω_o; h)` in sr⁻¹ per colour channel.
    fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb;

    /// The far-field `f_s(ω_i, ω_o)`: for a near-field model its average over the fiber's width,
    /// `½∫_{−1}^{1} f_s(ω_i, ω_o; h) dh`, by the one width-average rule of
    /// [`fiberlab_math::quadrature::width_average`] with panels as wide as
    /// [`ScatteringFunction::width_feature`]; for a far-field model `eval` itself. Every
    /// comparison of a model with a width-averaged quantity (a goniophotometer table, a fit, a
    /// plot, a reciprocity test) goes through this; models with an exact or cheaper far field
    /// override it.
    fn eval_far(&self, wi: DVec3, wo: DVec3) -> Rgb {
        match self.properties().field {
            Field::Far => self.eval(wi, wo, 0.0),
            Field::Near => {
                let panels = fiberlab_math::quadrature::width_panels(self.width_feature());
                fiberlab_math::quadrature::width_average(panels, |h| self.eval(wi, wo, h))
            }
        }
    }

    /// Width (radians of the angle of incidence γ = asin h) of the narrowest feature of a
    /// near-field `eval` across the fiber, e.g. an azimuthal lobe's standard deviation mapped
    /// to γ; [`ScatteringFunction::eval_far`] resolves it with one panel of four nodes. The
    /// default, π/16, suits lobes at least that wide.
    fn width_feature(&self) -> f64 {
        std::f64::consts::PI / fiberlab_math::quadrature::WIDTH_PANELS as f64
    }

    /// The fiber's absorption per unit radius in the chord convention — light crossing the fiber
    /// once at normal incidence is attenuated by `exp(−2σ_a)` — for models with an absorbing
    /// interior; `None` for models without one (the default). Lets one hair be given to every
    /// model in its own parametrization (`fiberlab evaluate`).
    fn chord_absorption(&self) -> Option<Rgb> {
        None
    }

    /// The value of this model's `sigma_a` parameter that gives it the chord-convention
    /// absorption `chord` ([`ScatteringFunction::chord_absorption`]): the identity (the default)
    /// for models whose `sigma_a` is in that convention.
    fn sigma_a_for_chord(&self, chord: Rgb) -> Rgb {
        chord
    }

    /// Density (sr⁻¹) with which [`ScatteringFunction::sample`] draws `wi` given `wo`, `h`.
    fn pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> f64;

    /// `eval` and `pdf` together (models that share the work between them override this;
    /// the renderer needs both for every light sample).
    fn eval_and_pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> (Rgb, f64) {
        (self.eval(wi, wo, h), self.pdf(wi, wo, h))
    }

    /// Draws `ω_i` given `ω_o` and `h` from four independent uniforms in [0, 1).
    /// `None` when no direction can be produced (zero-valued lobe).
    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample>;

    /// The lobes [`ScatteringFunction::sample`] chooses among, in the order of
    /// [`Sample::lobe`]. The default is one lobe, `all`, delta exactly when the model is
    /// [`Lobes::Delta`].
    fn lobes(&self) -> Vec<LobeInfo> {
        vec![LobeInfo { name: "all", delta: self.properties().lobes == Lobes::Delta }]
    }

    /// The terms of `f_s(ω_i, ω_o; h)` lobe by lobe, in the order of
    /// [`ScatteringFunction::lobes`], written to `out[..lobes().len()]` (sr⁻¹; they sum to
    /// `eval`). Returns `false`, leaving `out` alone, for models that do not separate their
    /// lobes (the default); the dual-scattering tables then treat the whole model as one lobe.
    fn eval_lobes(&self, _wi: DVec3, _wo: DVec3, _h: f64, _out: &mut [Rgb]) -> bool {
        false
    }

    /// For [`Lobes::Delta`] models: the lobe at relative azimuth `phi` (φ_o − φ_i) for a
    /// viewer at inclination `theta_o`. Smooth models return zero.
    fn cone(&self, _theta_o: f64, _phi: f64) -> ConeValue {
        ConeValue { value: Rgb::ZERO, pdf: 0.0 }
    }
}
