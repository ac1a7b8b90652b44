//! [`Model`]: the closed set of models, dispatched statically (no virtual calls in the
//! renderer's hot loop), and the registry that builds them from `key=value` parameters.

use crate::params::{ParamSet, ParamSpec};
use crate::{ConeValue, ModelError, Properties, Sample, ScatteringFunction};
use fiberlab_math::{DVec3, Rgb};

/// How a model appears on the command line: name, parameters and constructor.
#[derive(Clone, Copy, Debug)]
pub struct ModelSpec {
    /// Name used on the command line (`--model NAME`) and in scene files.
    pub name: &'static str,
    /// One-line description.
    pub summary: &'static str,
    /// Paper or section the model implements.
    pub citation: &'static str,
    /// Parameters with units, defaults and valid ranges.
    pub params: &'static [ParamSpec],
    /// Builds the model from validated parameters.
    pub build: fn(&ParamSet) -> Result<Model, ModelError>,
}

macro_rules! models {
    ($($variant:ident($ty:ty) = $spec:path),* $(,)?) => {
        /// Every registered scattering model, as one enum for static dispatch.
        #[derive(Clone, Debug)]
        #[non_exhaustive]
        pub enum Model {
            $(
                #[doc = concat!("See [`", stringify!($ty), "`].")]
                $variant($ty),
            )*
        }

        /// Every model the enum can hold, in the order `fiberlab models` lists them; those in
        /// [`EXTERNAL_DATA`] cannot be built from parameters alone.
        pub const ALL_MODELS: &[ModelSpec] = &[$($spec),*];

        impl ScatteringFunction for Model {
            #[inline]
            fn properties(&self) -> Properties {
                match self { $(Model::$variant(m) => m.properties(),)* }
            }
            #[inline]
            fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
                match self { $(Model::$variant(m) => m.eval(wi, wo, h),)* }
            }
            #[inline]
            fn pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> f64 {
                match self { $(Model::$variant(m) => m.pdf(wi, wo, h),)* }
            }
            #[inline]
            fn eval_and_pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> (Rgb, f64) {
                match self { $(Model::$variant(m) => m.eval_and_pdf(wi, wo, h),)* }
            }
            #[inline]
            fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
                match self { $(Model::$variant(m) => m.sample(wo, h, u),)* }
            }
            #[inline]
            fn cone(&self, theta_o: f64, phi: f64) -> ConeValue {
                match self { $(Model::$variant(m) => m.cone(theta_o, phi),)* }
            }
        }
    };
}

models! {
    Diffuse(crate::ideal_diffuse::IdealDiffuse) = crate::ideal_diffuse::SPEC,
    LambertianCylinder(crate::lambertian_cylinder::LambertianCylinder) = crate::lambertian_cylinder::SPEC,
    Specular(crate::ideal_specular::IdealSpecular) = crate::ideal_specular::SPEC,
    KajiyaKay(crate::kajiya_kay_1989::KajiyaKay) = crate::kajiya_kay_1989::SPEC,
    Goldman(crate::goldman_1997::Goldman) = crate::goldman_1997::SPEC,
    Marschner(crate::marschner_2003::Marschner) = crate::marschner_2003::SPEC,
    Chiang(crate::chiang_2016::Chiang) = crate::chiang_2016::SPEC,
    Deon(crate::deon_2011::Deon) = crate::deon_2011::SPEC,
    Measured(crate::measured::Measured) = crate::measured::SPEC,
}

/// Models that need data loaded by the caller (a table file): listed by `fiberlab models`
/// but skipped by code that builds every model from its defaults.
pub const EXTERNAL_DATA: &[&str] = &["measured"];

/// The models that can be built from parameters alone (every entry of [`ALL_MODELS`] not in
/// [`EXTERNAL_DATA`]).
pub const MODELS: &[ModelSpec] = &[
    crate::ideal_diffuse::SPEC,
    crate::lambertian_cylinder::SPEC,
    crate::ideal_specular::SPEC,
    crate::kajiya_kay_1989::SPEC,
    crate::goldman_1997::SPEC,
    crate::marschner_2003::SPEC,
    crate::chiang_2016::SPEC,
    crate::deon_2011::SPEC,
];

/// The registry entry called `name`.
pub fn find(name: &str) -> Result<&'static ModelSpec, ModelError> {
    ALL_MODELS.iter().find(|m| m.name == name).ok_or_else(|| ModelError::UnknownModel {
        name: name.into(),
        known: ALL_MODELS.iter().map(|m| m.name).collect::<Vec<_>>().join(", "),
    })
}

/// Builds model `name` from `key=value` pairs (unknown keys, bad values and out-of-range
/// values are errors naming the key).
pub fn build<K: AsRef<str>, V: AsRef<str>>(name: &str, pairs: &[(K, V)]) -> Result<Model, ModelError> {
    let spec = find(name)?;
    let params = ParamSet::parse(spec.name, spec.params, pairs)?;
    (spec.build)(&params)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn models_lists_every_buildable_entry_of_all_models() {
        let buildable: Vec<&str> = ALL_MODELS.iter().map(|m| m.name).filter(|n| !EXTERNAL_DATA.contains(n)).collect();
        assert_eq!(buildable, MODELS.iter().map(|m| m.name).collect::<Vec<_>>());
    }

    #[test]
    fn every_model_builds_with_defaults_and_names_are_unique() {
        for spec in MODELS {
            build::<&str, &str>(spec.name, &[]).unwrap_or_else(|e| panic!("{}: {e}", spec.name));
            assert_eq!(MODELS.iter().filter(|m| m.name == spec.name).count(), 1);
        }
        assert!(matches!(build::<&str, &str>("nope", &[]), Err(ModelError::UnknownModel { .. })));
    }

    /// The fused `eval_and_pdf` of every model returns exactly what `eval` and `pdf` do.
    #[test]
    fn eval_and_pdf_agrees_with_eval_and_pdf() {
        let mut u = crate::test_rng::lcg(5);
        let mut unit = || {
            let (x, phi) = (2.0 * u() - 1.0, std::f64::consts::TAU * u());
            let r = (1.0 - x * x).sqrt();
            DVec3::new(x, r * phi.cos(), r * phi.sin())
        };
        let mut u2 = crate::test_rng::lcg(6);
        for spec in MODELS {
            let m = build::<&str, &str>(spec.name, &[]).unwrap();
            for _ in 0..200 {
                let (wi, wo) = (unit(), unit());
                let h = 2.0 * u2() - 1.0;
                let (f, pdf) = m.eval_and_pdf(wi, wo, h);
                assert!(f.is_finite() && pdf.is_finite(), "{}", spec.name);
                assert_eq!((f, pdf), (m.eval(wi, wo, h), m.pdf(wi, wo, h)), "{}", spec.name);
            }
        }
    }
}
