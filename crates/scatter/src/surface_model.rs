//! [`SurfaceModel`]: the closed set of surface models, dispatched statically like [`crate::Model`],
//! the surface registry [`SURFACE_MODELS`] built from the same [`Registered`] / [`ModelInfo`]
//! / [`ParamSpec`](crate::params::ParamSpec) machinery, and [`lookup`], the one way to find a
//! name in either registry ([`ModelKind::Fiber`] or [`ModelKind::Surface`]).

use crate::params::{ParamSet, RawValue};
use crate::spec::{ModelInfo, Registered};
use crate::{ALL_MODELS, LobeInfo, ModelError, ModelSpec, Sample, SurfaceProperties, SurfaceScattering};
use fiberlab_math::{DVec3, Rgb};

/// A surface-registry entry: the model's [`ModelInfo`] (through `Deref`) and its constructor.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceModelSpec {
    /// Name, summary, citation, parameter table.
    pub info: ModelInfo,
    /// Builds the model from validated parameters.
    pub build: fn(&ParamSet) -> Result<SurfaceModel, ModelError>,
}

impl SurfaceModelSpec {
    const fn of<T: Registered>(build: fn(&ParamSet) -> Result<SurfaceModel, ModelError>) -> Self {
        Self { info: T::INFO, build }
    }
}

impl std::ops::Deref for SurfaceModelSpec {
    type Target = ModelInfo;
    fn deref(&self) -> &ModelInfo {
        &self.info
    }
}

macro_rules! surface_models {
    ($($variant:ident($ty:ty)),* $(,)?) => {
        /// Every registered surface model, as one enum for static dispatch.
        #[derive(Clone, Debug)]
        #[non_exhaustive]
        pub enum SurfaceModel {
            $(
                #[doc = concat!("See [`", stringify!($ty), "`].")]
                $variant($ty),
            )*
        }

        $(
            impl From<$ty> for SurfaceModel {
                fn from(m: $ty) -> Self {
                    SurfaceModel::$variant(m)
                }
            }
        )*

        /// Every surface model, in the order `fiberlab models` lists them (after the fibers).
        pub const SURFACE_MODELS: &[SurfaceModelSpec] = &[
            $(SurfaceModelSpec::of::<$ty>(|p| Ok(SurfaceModel::$variant(<$ty as Registered>::from_param_set(p)?))),)*
        ];

        impl SurfaceScattering for SurfaceModel {
            #[inline]
            fn properties(&self) -> SurfaceProperties {
                match self { $(SurfaceModel::$variant(m) => m.properties(),)* }
            }
            #[inline]
            fn eval(&self, wi: DVec3, wo: DVec3) -> Rgb {
                match self { $(SurfaceModel::$variant(m) => m.eval(wi, wo),)* }
            }
            #[inline]
            fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
                match self { $(SurfaceModel::$variant(m) => m.pdf(wi, wo),)* }
            }
            #[inline]
            fn eval_and_pdf(&self, wi: DVec3, wo: DVec3) -> (Rgb, f64) {
                match self { $(SurfaceModel::$variant(m) => m.eval_and_pdf(wi, wo),)* }
            }
            #[inline]
            fn sample(&self, wo: DVec3, u: [f64; 4]) -> Option<Sample> {
                match self { $(SurfaceModel::$variant(m) => m.sample(wo, u),)* }
            }
            fn lobes(&self) -> Vec<LobeInfo> {
                match self { $(SurfaceModel::$variant(m) => m.lobes(),)* }
            }
            fn texturable_keys(&self) -> &'static [&'static str] {
                match self { $(SurfaceModel::$variant(m) => m.texturable_keys(),)* }
            }
            #[inline]
            fn set_parameter(&mut self, key: &str, value: Rgb) -> Result<(), ModelError> {
                match self { $(SurfaceModel::$variant(m) => m.set_parameter(key, value),)* }
            }
            fn fiber_highlight(&self) -> Option<&dyn crate::FiberHighlight> {
                match self { $(SurfaceModel::$variant(m) => m.fiber_highlight(),)* }
            }
        }
    };
}

surface_models! {
    Lambertian(crate::lambert_1760::Lambertian),
    Wood(crate::marschner_2005::Wood),
    Sadeghi(crate::sadeghi_2013::Sadeghi2013),
    Irawan(crate::irawan_2012::Irawan2012),
}

/// Which registry a model belongs to, as `fiberlab models` prints it (`kind: fiber`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelKind {
    /// A fiber scattering function ([`crate::ScatteringFunction`], [`crate::Model`]).
    Fiber,
    /// A surface BRDF ([`SurfaceScattering`], [`SurfaceModel`]).
    Surface,
}

impl ModelKind {
    /// `fiber` or `surface`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Fiber => "fiber",
            ModelKind::Surface => "surface",
        }
    }
}

impl std::fmt::Display for ModelKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// An entry of either registry.
#[derive(Clone, Copy, Debug)]
pub enum RegistryEntry {
    /// A fiber model.
    Fiber(&'static ModelSpec),
    /// A surface model.
    Surface(&'static SurfaceModelSpec),
}

impl RegistryEntry {
    /// Which registry holds it.
    #[must_use]
    pub fn kind(&self) -> ModelKind {
        match self {
            RegistryEntry::Fiber(_) => ModelKind::Fiber,
            RegistryEntry::Surface(_) => ModelKind::Surface,
        }
    }

    /// Name, summary, citation and parameter table.
    #[must_use]
    pub fn info(&self) -> &'static ModelInfo {
        match self {
            RegistryEntry::Fiber(s) => &s.info,
            RegistryEntry::Surface(s) => &s.info,
        }
    }
}

/// Every entry of both registries: the fiber models ([`ALL_MODELS`]), then the surface models.
pub fn registry() -> impl Iterator<Item = RegistryEntry> {
    ALL_MODELS.iter().map(RegistryEntry::Fiber).chain(SURFACE_MODELS.iter().map(RegistryEntry::Surface))
}

fn unknown(name: &str) -> ModelError {
    ModelError::UnknownModel {
        name: name.into(),
        known: registry().map(|e| e.info().name).collect::<Vec<_>>().join(", "),
    }
}

/// The entry called `name` in either registry (names are unique across both; tested).
pub fn lookup(name: &str) -> Result<RegistryEntry, ModelError> {
    registry().find(|e| e.info().name == name).ok_or_else(|| unknown(name))
}

/// The surface-registry entry called `name` (a fiber model's name is an error saying so).
pub fn find_surface(name: &str) -> Result<&'static SurfaceModelSpec, ModelError> {
    match lookup(name)? {
        RegistryEntry::Surface(s) => Ok(s),
        RegistryEntry::Fiber(_) => Err(ModelError::Inconsistent(format!(
            "`{name}` is a fiber model; a surface model is needed here (surface models: {})",
            SURFACE_MODELS.iter().map(|m| m.name).collect::<Vec<_>>().join(", ")
        ))),
    }
}

/// Builds surface model `name` from textual `key=value` pairs.
pub fn build_surface<K: AsRef<str>, V: AsRef<str>>(name: &str, pairs: &[(K, V)]) -> Result<SurfaceModel, ModelError> {
    let spec = find_surface(name)?;
    (spec.build)(&ParamSet::parse(spec.name, spec.params, pairs)?)
}

/// Builds surface model `name` from pairs of any edge (see [`RawValue`]).
pub fn build_surface_raw<K: AsRef<str>>(name: &str, pairs: &[(K, RawValue)]) -> Result<SurfaceModel, ModelError> {
    let spec = find_surface(name)?;
    (spec.build)(&ParamSet::from_raw(spec.name, spec.params, pairs)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_across_both_registries_and_lookup_finds_the_kind() {
        let names: Vec<&str> = registry().map(|e| e.info().name).collect();
        for n in &names {
            assert_eq!(names.iter().filter(|m| *m == n).count(), 1, "{n}");
        }
        assert_eq!(lookup("lambertian").unwrap().kind(), ModelKind::Surface);
        assert_eq!(lookup("chiang").unwrap().kind(), ModelKind::Fiber);
        let e = lookup("nope").unwrap_err().to_string();
        assert!(e.contains("lambertian") && e.contains("chiang"), "{e}");
        let e = build_surface::<&str, &str>("chiang", &[]).unwrap_err().to_string();
        assert!(e.contains("fiber model"), "{e}");
    }

    #[test]
    fn every_surface_model_builds_with_defaults() {
        for spec in SURFACE_MODELS {
            build_surface::<&str, &str>(spec.name, &[]).unwrap_or_else(|e| panic!("{}: {e}", spec.name));
        }
    }

    #[test]
    fn set_parameter_validates_and_rejects_unknown_keys() {
        let mut m = build_surface("lambertian", &[("k_d", "0.5")]).unwrap();
        m.set_parameter("k_d", Rgb::new(0.1, 0.2, 0.3)).unwrap();
        let v = m.eval(DVec3::Z, DVec3::Z);
        assert!((v[2] - 0.3 / std::f64::consts::PI).abs() < 1e-15);
        assert!(m.set_parameter("k_d", Rgb::splat(f64::NAN)).is_err());
        assert!(m.set_parameter("k_d", Rgb::splat(1.5)).is_err());
        assert!(m.set_parameter("nope", Rgb::ONE).is_err());
    }

    /// Every texturable key is a parameter of the model's table and `set_parameter` takes it
    /// (at the parameter's default, in library units); every other table key is refused.
    #[test]
    fn texturable_keys_are_exactly_what_set_parameter_takes() {
        for spec in SURFACE_MODELS {
            let mut m = build_surface::<&str, &str>(spec.name, &[]).unwrap();
            let keys = m.texturable_keys();
            for p in spec.params {
                let value = match p.kind {
                    // Optional overrides (no default, e.g. a preset's per-thread values): any
                    // in-range value; 1 is in every such range.
                    crate::params::ParamKind::Color(_) | crate::params::ParamKind::Number(_)
                        if p.default.is_empty() =>
                    {
                        Rgb::ONE
                    }
                    crate::params::ParamKind::Color(_) | crate::params::ParamKind::Number(_) => {
                        let raw = p.parse(p.default).unwrap();
                        match raw {
                            crate::params::ParamValue::Color(c) => c,
                            crate::params::ParamValue::Number(x) if p.unit == "degrees" => Rgb::splat(x.to_radians()),
                            crate::params::ParamValue::Number(x) => Rgb::splat(x),
                            _ => unreachable!(),
                        }
                    }
                    _ => Rgb::ZERO,
                };
                let accepted = m.set_parameter(p.key, value).is_ok();
                assert_eq!(accepted, keys.contains(&p.key), "{}: {}", spec.name, p.key);
            }
            assert!(keys.iter().all(|k| spec.params.iter().any(|p| p.key == *k)), "{}", spec.name);
        }
    }
}
