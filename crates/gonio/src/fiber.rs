//! The simulated fiber: an infinite straight dielectric cylinder along `x` (the fiber
//! frame's tangent, root → tip) with an elliptical cross-section, optional cuticle scales,
//! a smooth or rough (GGX) interface, absorbing interior and an optional scattering medulla. Lengths are in units of the
//! major semi-axis (the "radius"), so absorption coefficients are per unit radius, as in
//! the analytic models.

use fiberlab_math::Rgb;
use fiberlab_scatter::ModelError;
use fiberlab_scatter::params::{ParamKind, ParamSet, ParamSpec, Range, RawValue};
use thiserror::Error;

/// Invalid fiber description; the message names the key and its valid range.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum FiberError {
    /// A value outside its range, or not finite.
    #[error("fiber parameter `{key}` = {} is invalid; valid range {range}", shown(*.value))]
    OutOfRange {
        /// Key.
        key: &'static str,
        /// Value given, in the unit of `range` (degrees for angles, as the user writes them).
        value: f64,
        /// Valid range, with its unit.
        range: &'static str,
    },
    /// Two parts that cannot be combined.
    #[error("fiber: give {keys}, not both")]
    Exclusive {
        /// The keys that exclude each other.
        keys: &'static str,
    },
    /// More bins than the measurement's 32-bit bin indices address.
    #[error("bins: {bins_theta} × {bins_phi} = {bins} bins per table; at most 4294967295 (32-bit bin indices)")]
    TooManyBins {
        /// Bins in θ_r.
        bins_theta: usize,
        /// Bins in φ.
        bins_phi: usize,
        /// Their product.
        bins: u128,
    },
}

/// A number as a person reads it in an error: rounded to twelve significant digits (so that
/// a radian → degree round trip shows 3, not 2.9999999999999996) in its shortest form, with
/// an exponent for huge or tiny magnitudes (1e308, not 309 digits).
fn shown(x: f64) -> String {
    let rounded = if x.is_finite() { format!("{x:.11e}").parse().unwrap_or(x) } else { x };
    let text = format!("{rounded:?}");
    text.strip_suffix(".0").map_or(text.clone(), str::to_string)
}

/// How the ellipse is oriented about the fiber axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Orientation {
    /// Major axis at this angle (radians) from the frame's `y` axis toward `z`.
    Fixed(f64),
    /// A uniformly random orientation per ray (fibers in an assembly).
    Average,
}

/// A concentric scattering medulla (fur), same refractive index as the cortex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medulla {
    /// Radius relative to the cortex (0, 1).
    pub radius: f64,
    /// Scattering coefficient, per unit radius.
    pub sigma_s: f64,
    /// Absorption coefficient, per unit radius.
    pub sigma_a: Rgb,
    /// Henyey–Greenstein asymmetry g ∈ (−1, 1).
    pub g: f64,
}

/// A concentric clear lumen (plant fibers, hollow hairs): a core of another index that
/// refracts and reflects at its boundary (Fresnel, total internal reflection) and neither
/// absorbs nor scatters. Its boundary is the medulla's with an index step: with `eta` equal to
/// the fiber's, light crosses it unchanged, as it crosses a medulla's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lumen {
    /// Radius relative to the fiber (0, 1) (the cross-section's shape scaled).
    pub radius: f64,
    /// Refractive index of the lumen (1 for air).
    pub eta: f64,
}

/// What happens where a ray meets the fiber surface from outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SurfaceKind {
    /// A smooth dielectric interface (Fresnel reflection and refraction).
    Dielectric,
    /// An opaque Lambertian surface of the given albedo (reproduces the
    /// `lambertian-cylinder` model exactly; used to validate the normalization).
    Lambertian(Rgb),
}

/// The explicit fiber.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fiber {
    /// Refractive index η of the cortex (and medulla).
    pub eta: f64,
    /// GGX roughness α of the interface (0: smooth), about the local surface normal (the
    /// tilted scale normal where there are scales), at every crossing from either side.
    pub roughness: f64,
    /// Cortex absorption per unit radius.
    pub sigma_a: Rgb,
    /// Axis ratio a = minor/major ∈ (0, 1].
    pub aspect: f64,
    /// Orientation of the major axis.
    pub orientation: Orientation,
    /// Cuticle scale angle α (radians): the tilt of the scale surfaces toward the root.
    pub scale_angle: f64,
    /// Length of one scale along the axis (radii).
    pub scale_length: f64,
    /// Optional medulla.
    pub medulla: Option<Medulla>,
    /// Optional lumen (exclusive with a medulla).
    pub lumen: Option<Lumen>,
    /// Dielectric (default) or opaque Lambertian surface.
    pub surface: SurfaceKind,
}

impl Default for Fiber {
    /// A smooth, circular, non-absorbing fiber of index 1.55.
    fn default() -> Self {
        Self {
            eta: 1.55,
            roughness: 0.0,
            sigma_a: Rgb::ZERO,
            aspect: 1.0,
            orientation: Orientation::Fixed(0.0),
            scale_angle: 0.0,
            scale_length: 0.5,
            medulla: None,
            lumen: None,
            surface: SurfaceKind::Dielectric,
        }
    }
}

fn check(key: &'static str, value: f64, ok: bool, range: &'static str) -> Result<(), FiberError> {
    if value.is_finite() && ok { Ok(()) } else { Err(FiberError::OutOfRange { key, value, range }) }
}

impl Fiber {
    /// Validates every field.
    pub fn validate(&self) -> Result<(), FiberError> {
        check("eta", self.eta, self.eta > 1.0 && self.eta <= 4.0, "(1, 4]")?;
        check("roughness", self.roughness, (0.0..=1.0).contains(&self.roughness), "[0, 1]")?;
        for c in 0..3 {
            check("sigma_a", self.sigma_a[c], self.sigma_a[c] >= 0.0, "[0, ∞)")?;
        }
        check("aspect", self.aspect, self.aspect > 0.0 && self.aspect <= 1.0, "(0, 1]")?;
        // Angles are checked and reported in degrees, the unit they are written in.
        if let Orientation::Fixed(o) = self.orientation {
            check("orientation", o.to_degrees(), true, "finite degrees")?;
        }
        let scale_degrees = self.scale_angle.to_degrees();
        check("scale_angle", scale_degrees, scale_degrees.abs() < 20.0, "(−20, 20) degrees")?;
        check("scale_length", self.scale_length, self.scale_length > 0.0, "(0, ∞)")?;
        // The sawtooth must not cut the fiber: its height L·tanα stays below the radius.
        let height = self.scale_length * self.scale_angle.tan().abs();
        check("scale_length", self.scale_length, height < 0.5, "L·tan α < 0.5 radii")?;
        if let Some(m) = self.medulla {
            check("medulla_radius", m.radius, m.radius > 0.0 && m.radius < 1.0 - height, "(0, 1 − L·tan α)")?;
            check("medulla_sigma_s", m.sigma_s, m.sigma_s >= 0.0, "[0, ∞)")?;
            for c in 0..3 {
                check("medulla_sigma_a", m.sigma_a[c], m.sigma_a[c] >= 0.0, "[0, ∞)")?;
            }
            check("medulla_g", m.g, m.g.abs() < 1.0, "(−1, 1)")?;
        }
        if let Some(l) = self.lumen {
            check("lumen_radius", l.radius, l.radius > 0.0 && l.radius < 1.0 - height, "(0, 1 − L·tan α)")?;
            check("lumen_eta", l.eta, (1.0..=4.0).contains(&l.eta), "[1, 4]")?;
            if self.medulla.is_some() {
                return Err(FiberError::Exclusive { keys: "medulla_radius and lumen_radius" });
            }
        }
        if let SurfaceKind::Lambertian(a) = self.surface {
            for c in 0..3 {
                check("albedo", a[c], (0.0..=1.0).contains(&a[c]), "[0, 1]")?;
            }
        }
        Ok(())
    }

    /// True when the surface carries cuticle scales.
    #[must_use]
    pub fn has_scales(&self) -> bool {
        self.scale_angle != 0.0
    }
}

/// The fiber's parameters as `fiberlab measure` takes them (`--param key=value`, a
/// `--fiber` TOML file), converted and checked by the same [`ParamSet`] as every model's
/// parameters: angles in degrees, colours as one number or `r,g,b` (or a TOML array).
pub const FIBER_PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "eta",
        kind: ParamKind::Number(Range::open_closed(1.0, 4.0)),
        unit: "",
        default: "1.55",
        doc: "refractive index of the cortex (and medulla)",
    },
    ParamSpec {
        key: "roughness",
        kind: ParamKind::Number(Range::UNIT),
        unit: "",
        default: "0",
        doc: "GGX roughness α of the interface (0: smooth), visible normals sampled at every crossing",
    },
    ParamSpec {
        key: "sigma_a",
        kind: ParamKind::Color(NON_NEGATIVE),
        unit: "1/radius",
        default: "0",
        doc: "cortex absorption coefficient",
    },
    ParamSpec {
        key: "aspect",
        kind: ParamKind::Number(Range::open_closed(0.0, 1.0)),
        unit: "",
        default: "1",
        doc: "axis ratio minor/major of the elliptical cross-section",
    },
    ParamSpec {
        key: "orientation",
        kind: ParamKind::Text,
        unit: "degrees or `average`",
        default: "0",
        doc: "major axis from the frame's y axis toward z; `average`: uniformly random per ray",
    },
    ParamSpec {
        key: "scale_angle",
        kind: ParamKind::Number(Range::open(-20.0, 20.0)),
        unit: "degrees",
        default: "0",
        doc: "cuticle scale tilt toward the root",
    },
    ParamSpec {
        key: "scale_length",
        kind: ParamKind::Number(Range::open(0.0, f64::INFINITY)),
        unit: "radii",
        default: "0.5",
        doc: "length of one cuticle scale along the axis",
    },
    ParamSpec {
        key: "medulla_radius",
        kind: ParamKind::Number(Range::open(0.0, 1.0)),
        unit: "radii",
        default: "",
        doc: "radius of a concentric scattering medulla (giving it adds the medulla)",
    },
    ParamSpec {
        key: "medulla_sigma_s",
        kind: ParamKind::Number(NON_NEGATIVE),
        unit: "1/radius",
        default: "0",
        doc: "medulla scattering coefficient",
    },
    ParamSpec {
        key: "medulla_sigma_a",
        kind: ParamKind::Color(NON_NEGATIVE),
        unit: "1/radius",
        default: "0",
        doc: "medulla absorption coefficient",
    },
    ParamSpec {
        key: "medulla_g",
        kind: ParamKind::Number(Range::open(-1.0, 1.0)),
        unit: "",
        default: "0",
        doc: "Henyey–Greenstein asymmetry of the medulla",
    },
    ParamSpec {
        key: "lumen_radius",
        kind: ParamKind::Number(Range::open(0.0, 1.0)),
        unit: "radii",
        default: "",
        doc: "radius of a concentric clear lumen (giving it adds the lumen; not with a medulla)",
    },
    ParamSpec {
        key: "lumen_eta",
        kind: ParamKind::Number(Range::closed(1.0, 4.0)),
        unit: "",
        default: "1",
        doc: "refractive index of the lumen (1 air; the fiber's eta: index-matched)",
    },
    ParamSpec {
        key: "surface",
        kind: ParamKind::Choice(&["dielectric", "lambertian"]),
        unit: "",
        default: "dielectric",
        doc: "smooth dielectric interface, or an opaque Lambertian surface",
    },
    ParamSpec {
        key: "albedo",
        kind: ParamKind::Color(Range::UNIT),
        unit: "",
        default: "0.8",
        doc: "albedo of a lambertian surface",
    },
];

/// `[0, ∞)`.
const NON_NEGATIVE: Range = Range::closed_open(0.0, f64::INFINITY);

/// Fiber parameters that could not be used.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum FiberKeyError {
    /// Not a fiber key.
    #[error("unknown fiber parameter `{key}`; valid keys: {known}")]
    UnknownKey {
        /// The key given.
        key: String,
        /// Comma-separated valid keys.
        known: String,
    },
    /// Unreadable or out-of-range value, or a key given twice (the message names the key).
    /// The model error is shown, not chained as a source, so that it is printed once.
    #[error("fiber: {0}")]
    Parameter(ModelError),
    /// `orientation` neither degrees nor `average`.
    #[error("fiber parameter `orientation`: cannot read `{0}` as degrees or `average`")]
    Orientation(String),
    /// Values individually valid but not together.
    #[error(transparent)]
    Invalid(#[from] FiberError),
}

impl From<ModelError> for FiberKeyError {
    fn from(e: ModelError) -> Self {
        FiberKeyError::Parameter(e)
    }
}

impl Fiber {
    /// Builds a fiber from `(key, value)` pairs of any edge (see [`RawValue`]), starting from
    /// the defaults of [`FIBER_PARAMS`] (those of [`Fiber::default`]). Giving
    /// `medulla_radius` adds the medulla. A number given for a text key (`orientation = 30`
    /// in TOML) is read as its text.
    pub fn from_raw<K: AsRef<str>>(pairs: &[(K, RawValue)]) -> Result<Self, FiberKeyError> {
        let is_text = |k: &str| FIBER_PARAMS.iter().any(|s| s.key == k.trim() && matches!(s.kind, ParamKind::Text));
        let pairs: Vec<(&str, RawValue)> = pairs
            .iter()
            .map(|(k, v)| match v {
                RawValue::Number(x) if is_text(k.as_ref()) => (k.as_ref(), RawValue::Text(x.to_string())),
                _ => (k.as_ref(), v.clone()),
            })
            .collect();
        let p = ParamSet::from_raw("fiber", FIBER_PARAMS, &pairs).map_err(|e| match e {
            ModelError::UnknownParameter { key, known, .. } => FiberKeyError::UnknownKey { key, known },
            e => FiberKeyError::Parameter(e),
        })?;
        let orientation = match p.text("orientation").unwrap_or("0") {
            t if t.eq_ignore_ascii_case("average") => Orientation::Average,
            t => Orientation::Fixed(
                t.parse::<f64>()
                    .ok()
                    .filter(|d| d.is_finite())
                    .ok_or_else(|| FiberKeyError::Orientation(t.into()))?
                    .to_radians(),
            ),
        };
        let medulla = match p.number_opt("medulla_radius") {
            Some(radius) => Some(Medulla {
                radius,
                sigma_s: p.number("medulla_sigma_s")?,
                sigma_a: p.color("medulla_sigma_a")?,
                g: p.number("medulla_g")?,
            }),
            None => None,
        };
        let lumen = match p.number_opt("lumen_radius") {
            Some(radius) => Some(Lumen { radius, eta: p.number("lumen_eta")? }),
            None => None,
        };
        let surface = match p.choice("surface")? {
            "lambertian" => SurfaceKind::Lambertian(p.color("albedo")?),
            _ => SurfaceKind::Dielectric,
        };
        let f = Fiber {
            eta: p.number("eta")?,
            roughness: p.number("roughness")?,
            sigma_a: p.color("sigma_a")?,
            aspect: p.number("aspect")?,
            orientation,
            scale_angle: p.degrees("scale_angle")?,
            scale_length: p.number("scale_length")?,
            medulla,
            lumen,
            surface,
        };
        f.validate()?;
        Ok(f)
    }

    /// [`Fiber::from_raw`] for textual `key=value` pairs.
    pub fn from_pairs<K: AsRef<str>, V: AsRef<str>>(pairs: &[(K, V)]) -> Result<Self, FiberKeyError> {
        let raw: Vec<(&str, RawValue)> = pairs.iter().map(|(k, v)| (k.as_ref(), RawValue::from(v.as_ref()))).collect();
        Self::from_raw(&raw)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_parse_and_errors_name_the_key() {
        let f = Fiber::from_pairs(&[("aspect", "0.8"), ("orientation", "average"), ("scale_angle", "3")]).unwrap();
        assert_eq!(f.orientation, Orientation::Average);
        assert!((f.scale_angle - 3f64.to_radians()).abs() < 1e-15);
        let e = Fiber::from_pairs(&[("aspect", "1.5")]).unwrap_err().to_string();
        assert!(e.contains("`aspect`") && e.contains("(0, 1]"), "{e}");
        let e = Fiber::from_pairs(&[("eta", "NaN")]).unwrap_err().to_string();
        assert!(e.contains("`eta`"), "{e}");
        let e = Fiber::from_pairs(&[("colour", "1")]).unwrap_err();
        assert!(matches!(e, FiberKeyError::UnknownKey { .. }), "{e}");
        assert!(e.to_string().contains("eta, roughness, sigma_a, aspect"), "{e}");
        let rough = Fiber::from_pairs(&[("roughness", "0.3")]).unwrap();
        assert_eq!(rough.roughness, 0.3);
        let e = Fiber::from_pairs(&[("roughness", "1.5")]).unwrap_err().to_string();
        assert!(e.contains("`roughness`"), "{e}");
        assert!(matches!(Fiber::from_pairs(&[("orientation", "sideways")]), Err(FiberKeyError::Orientation(_))));
        assert_eq!(Fiber::from_pairs::<&str, &str>(&[]).unwrap(), Fiber::default());
        let m = Fiber::from_pairs(&[("medulla_radius", "0.3"), ("medulla_sigma_s", "5")]).unwrap();
        assert_eq!(m.medulla.unwrap().sigma_s, 5.0);
        let l = Fiber::from_pairs(&[("lumen_radius", "0.5")]).unwrap();
        assert_eq!(l.lumen, Some(Lumen { radius: 0.5, eta: 1.0 }));
        let l = Fiber::from_pairs(&[("lumen_radius", "0.5"), ("lumen_eta", "1.33")]).unwrap();
        assert_eq!(l.lumen.unwrap().eta, 1.33);
        let e = Fiber::from_pairs(&[("lumen_radius", "0.5"), ("medulla_radius", "0.3")]).unwrap_err().to_string();
        assert!(e.contains("medulla_radius and lumen_radius"), "{e}");
        let e = Fiber::from_pairs(&[("lumen_radius", "1")]).unwrap_err().to_string();
        assert!(e.contains("`lumen_radius`"), "{e}");
    }

    /// Angles are reported in degrees (the unit they are written in), huge values in exponent
    /// form, and a parameter error once, not repeated by an error chain.
    #[test]
    fn errors_show_values_in_the_unit_given_once() {
        let e = Fiber::from_pairs(&[("scale_angle", "25")]).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("`scale_angle` = 25 is out of range") && text.contains("degrees"), "{text}");
        assert!(std::error::Error::source(&e).is_none(), "the message is not chained twice: {e:?}");
        // Valid alone, too high together: scale_length is reported, the angle in degrees.
        let e = Fiber::from_pairs(&[("scale_angle", "19"), ("scale_length", "1e308")]).unwrap_err().to_string();
        assert!(e.contains("`scale_length` = 1e308 is invalid"), "{e}");
        // A fiber built in Rust with an angle in radians out of range: shown in degrees.
        let f = Fiber { scale_angle: 0.5, ..Fiber::default() };
        let e = f.validate().unwrap_err().to_string();
        assert!(e.contains(&format!("`scale_angle` = {} is invalid", shown(0.5f64.to_degrees()))), "{e}");
        assert!(e.contains("28.6478897565") && e.contains("(−20, 20) degrees"), "{e}");
        let f = Fiber { scale_angle: 3f64.to_radians(), scale_length: 20.0, ..Fiber::default() };
        assert!(f.validate().unwrap_err().to_string().contains("`scale_length` = 20 is invalid"));
        assert_eq!(shown(3f64.to_radians().to_degrees()), "3");
    }

    /// TOML arrays, numbers and booleans mean what the same values written as text mean.
    #[test]
    fn raw_values_convert_like_text() {
        let list = RawValue::List(vec![RawValue::Number(0.1), RawValue::Number(0.2), RawValue::Number(0.3)]);
        let raw = Fiber::from_raw(&[
            ("sigma_a", list),
            ("orientation", RawValue::Number(30.0)),
            ("surface", RawValue::from("lambertian")),
            ("albedo", RawValue::Number(0.5)),
        ])
        .unwrap();
        let text = Fiber::from_pairs(&[
            ("sigma_a", "0.1,0.2,0.3"),
            ("orientation", "30"),
            ("surface", "lambertian"),
            ("albedo", "0.5"),
        ])
        .unwrap();
        assert_eq!(raw, text);
        assert_eq!(raw.sigma_a, Rgb::new(0.1, 0.2, 0.3));
        assert_eq!(raw.orientation, Orientation::Fixed(30f64.to_radians()));
        assert_eq!(raw.surface, SurfaceKind::Lambertian(Rgb::splat(0.5)));
        assert!(Fiber::from_raw(&[("eta", RawValue::Bool(true))]).is_err());
    }
}
