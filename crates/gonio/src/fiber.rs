//! The simulated fiber: an infinite straight dielectric cylinder along `x` (the fiber
//! frame's tangent, root → tip) with an elliptical cross-section, optional cuticle scales,
//! absorbing interior and an optional scattering medulla. Lengths are in units of the
//! major semi-axis (the "radius"), so absorption coefficients are per unit radius, as in
//! the analytic models.

use fiberlab_math::Rgb;
use thiserror::Error;

/// Invalid fiber description; the message names the key and its valid range.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum FiberError {
    /// A value outside its range, or not finite.
    #[error("fiber parameter `{key}` = {value} is invalid; valid range {range}")]
    OutOfRange {
        /// Key.
        key: &'static str,
        /// Value given.
        value: f64,
        /// Valid range.
        range: &'static str,
    },
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
    /// Dielectric (default) or opaque Lambertian surface.
    pub surface: SurfaceKind,
}

impl Default for Fiber {
    /// A smooth, circular, non-absorbing fiber of index 1.55.
    fn default() -> Self {
        Self {
            eta: 1.55,
            sigma_a: Rgb::ZERO,
            aspect: 1.0,
            orientation: Orientation::Fixed(0.0),
            scale_angle: 0.0,
            scale_length: 0.5,
            medulla: None,
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
        for c in 0..3 {
            check("sigma_a", self.sigma_a[c], self.sigma_a[c] >= 0.0, "[0, ∞)")?;
        }
        check("aspect", self.aspect, self.aspect > 0.0 && self.aspect <= 1.0, "(0, 1]")?;
        if let Orientation::Fixed(o) = self.orientation {
            check("orientation", o, true, "finite")?;
        }
        check("scale_angle", self.scale_angle, self.scale_angle.abs() < 0.35, "(−20°, 20°)")?;
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

/// Keys accepted by [`Fiber::from_pairs`], in documentation order.
pub const FIBER_KEYS: [&str; 12] = [
    "eta",
    "sigma_a",
    "aspect",
    "orientation",
    "scale_angle",
    "scale_length",
    "medulla_radius",
    "medulla_sigma_s",
    "medulla_sigma_a",
    "medulla_g",
    "surface",
    "albedo",
];

/// A `key=value` text that could not be used.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum FiberKeyError {
    /// Not a fiber key.
    #[error("unknown fiber parameter `{0}`; valid keys: {keys}", keys = FIBER_KEYS.join(", "))]
    UnknownKey(String),
    /// The value could not be read.
    #[error("fiber parameter `{key}`: cannot read `{value}` as {expected}")]
    BadValue {
        /// Key.
        key: String,
        /// Text given.
        value: String,
        /// What was expected.
        expected: &'static str,
    },
    /// Read but invalid.
    #[error(transparent)]
    Invalid(#[from] FiberError),
}

impl Fiber {
    /// Builds a fiber from `key=value` pairs (angles in degrees; `orientation` may be
    /// `average`; `sigma_a`, `medulla_sigma_a` take one number or `r,g,b`), starting from
    /// [`Fiber::default`]. Setting `medulla_radius` enables the medulla.
    pub fn from_pairs<K: AsRef<str>, V: AsRef<str>>(pairs: &[(K, V)]) -> Result<Self, FiberKeyError> {
        let mut f = Fiber::default();
        let mut medulla = Medulla { radius: 0.0, sigma_s: 0.0, sigma_a: Rgb::ZERO, g: 0.0 };
        let mut has_medulla = false;
        let mut lambertian = false;
        let mut albedo = Rgb::splat(0.8);
        for (k, v) in pairs {
            let (key, text) = (k.as_ref().trim(), v.as_ref().trim());
            let bad = |expected| FiberKeyError::BadValue { key: key.into(), value: text.into(), expected };
            let number = || text.parse::<f64>().map_err(|_| bad("a number"));
            let color = || -> Result<Rgb, FiberKeyError> {
                let parts: Vec<f64> = text
                    .split(',')
                    .map(|t| t.trim().parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| bad("one number or r,g,b"))?;
                match parts.as_slice() {
                    [x] => Ok(Rgb::splat(*x)),
                    [r, g, b] => Ok(Rgb::new(*r, *g, *b)),
                    _ => Err(bad("one number or r,g,b")),
                }
            };
            match key {
                "eta" => f.eta = number()?,
                "sigma_a" => f.sigma_a = color()?,
                "aspect" => f.aspect = number()?,
                "orientation" if text.eq_ignore_ascii_case("average") => f.orientation = Orientation::Average,
                "orientation" => f.orientation = Orientation::Fixed(number()?.to_radians()),
                "scale_angle" => f.scale_angle = number()?.to_radians(),
                "scale_length" => f.scale_length = number()?,
                "medulla_radius" => {
                    medulla.radius = number()?;
                    has_medulla = true;
                }
                "medulla_sigma_s" => medulla.sigma_s = number()?,
                "medulla_sigma_a" => medulla.sigma_a = color()?,
                "medulla_g" => medulla.g = number()?,
                "surface" if text.eq_ignore_ascii_case("lambertian") => lambertian = true,
                "surface" if text.eq_ignore_ascii_case("dielectric") => lambertian = false,
                "surface" => return Err(bad("dielectric or lambertian")),
                "albedo" => albedo = color()?,
                _ => return Err(FiberKeyError::UnknownKey(key.into())),
            }
        }
        if has_medulla {
            f.medulla = Some(medulla);
        }
        if lambertian {
            f.surface = SurfaceKind::Lambertian(albedo);
        }
        f.validate()?;
        Ok(f)
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
        assert!(matches!(Fiber::from_pairs(&[("colour", "1")]), Err(FiberKeyError::UnknownKey(_))));
        let m = Fiber::from_pairs(&[("medulla_radius", "0.3"), ("medulla_sigma_s", "5")]).unwrap();
        assert_eq!(m.medulla.unwrap().sigma_s, 5.0);
    }
}
