//! [`Model`]: the closed set of models, dispatched statically (no virtual calls in the
//! renderer's hot loop), and the registry that builds them from `key=value` parameters.

use crate::params::{ParamSet, RawValue};
use crate::spec::{ModelInfo, Registered};
use crate::{ConeValue, LobeInfo, ModelError, Properties, Sample, ScatteringFunction};
use fiberlab_math::{DVec3, Rgb};

/// A registry entry: a model's [`ModelInfo`] (read through `Deref`: `spec.name`,
/// `spec.params`, …) with its constructor.
#[derive(Clone, Copy, Debug)]
pub struct ModelSpec {
    /// Name, summary, citation, parameter table and external data.
    pub info: ModelInfo,
    /// Builds the model from validated parameters (for models with [`ModelInfo::data`],
    /// [`ModelError::NeedsData`]: the caller loads the data and builds the model itself).
    pub build: fn(&ParamSet) -> Result<Model, ModelError>,
}

impl ModelSpec {
    /// The entry of a [`Registered`] model with its constructor.
    const fn of<T: Registered>(build: fn(&ParamSet) -> Result<Model, ModelError>) -> Self {
        Self { info: T::INFO, build }
    }
}

impl std::ops::Deref for ModelSpec {
    type Target = ModelInfo;
    fn deref(&self) -> &ModelInfo {
        &self.info
    }
}

macro_rules! models {
    (
        from_params: $($variant:ident($ty:ty)),* ;
        from_data: $($dvariant:ident($dty:ty)),* $(;)?
    ) => {
        models!(@enum $($variant($ty),)* $($dvariant($dty),)*);

        /// Every model the enum can hold, in the order `fiberlab models` lists them; those with
        /// [`ModelInfo::data`] cannot be built from parameters alone.
        pub const ALL_MODELS: &[ModelSpec] = &[
            $(ModelSpec::of::<$ty>(|p| Ok(Model::$variant(<$ty as Registered>::from_param_set(p)?))),)*
            $(ModelSpec::of::<$dty>(|p| Ok(Model::$dvariant(<$dty as Registered>::from_param_set(p)?))),)*
        ];

        /// The models that can be built from parameters alone (every entry of [`ALL_MODELS`]
        /// without [`ModelInfo::data`]), what code that builds every model from its defaults
        /// iterates.
        pub const MODELS: &[ModelSpec] = &[
            $(ModelSpec::of::<$ty>(|p| Ok(Model::$variant(<$ty as Registered>::from_param_set(p)?))),)*
        ];
    };
    (@enum $($variant:ident($ty:ty),)*) => {
        /// Every registered scattering model, as one enum for static dispatch.
        #[derive(Clone, Debug)]
        #[non_exhaustive]
        pub enum Model {
            $(
                #[doc = concat!("See [`", stringify!($ty), "`].")]
                $variant($ty),
            )*
        }

        impl Model {
            /// The registry name of the model (`fiberlab models` lists them).
            #[must_use]
            pub fn name(&self) -> &'static str {
                match self { $(Model::$variant(_) => <$ty as Registered>::INFO.name,)* }
            }
        }

        $(
            impl From<$ty> for Model {
                fn from(m: $ty) -> Self {
                    Model::$variant(m)
                }
            }
        )*

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
            fn eval_far(&self, wi: DVec3, wo: DVec3) -> Rgb {
                match self { $(Model::$variant(m) => m.eval_far(wi, wo),)* }
            }
            #[inline]
            fn width_feature(&self) -> f64 {
                match self { $(Model::$variant(m) => m.width_feature(),)* }
            }
            fn chord_absorption(&self) -> Option<Rgb> {
                match self { $(Model::$variant(m) => m.chord_absorption(),)* }
            }
            fn sigma_a_for_chord(&self, chord: Rgb) -> Rgb {
                match self { $(Model::$variant(m) => m.sigma_a_for_chord(chord),)* }
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
            fn lobes(&self) -> Vec<LobeInfo> {
                match self { $(Model::$variant(m) => m.lobes(),)* }
            }
            fn eval_lobes(&self, wi: DVec3, wo: DVec3, h: f64, out: &mut [Rgb]) -> bool {
                match self { $(Model::$variant(m) => m.eval_lobes(wi, wo, h, out),)* }
            }
            #[inline]
            fn cone(&self, theta_o: f64, phi: f64) -> ConeValue {
                match self { $(Model::$variant(m) => m.cone(theta_o, phi),)* }
            }
        }
    };
}

models! {
    from_params:
        Diffuse(crate::ideal_diffuse::IdealDiffuse),
        LambertianCylinder(crate::lambertian_cylinder::LambertianCylinder),
        Specular(crate::ideal_specular::IdealSpecular),
        KajiyaKay(crate::kajiya_kay_1989::KajiyaKay),
        Goldman(crate::goldman_1997::Goldman),
        Marschner(crate::marschner_2003::Marschner),
        Chiang(crate::chiang_2016::Chiang),
        Deon(crate::deon_2011::Deon),
        YanFur(crate::yan_2017::YanFur),
        SadeghiThread(crate::sadeghi_2013::SadeghiThread);
    from_data:
        Measured(crate::measured::Measured);
}

/// The registry entry called `name`.
pub fn find(name: &str) -> Result<&'static ModelSpec, ModelError> {
    ALL_MODELS.iter().find(|m| m.name == name).ok_or_else(|| ModelError::UnknownModel {
        name: name.into(),
        known: ALL_MODELS.iter().map(|m| m.name).collect::<Vec<_>>().join(", "),
    })
}

/// Builds model `name` from textual `key=value` pairs (unknown keys, bad values and
/// out-of-range values are errors naming the key).
pub fn build<K: AsRef<str>, V: AsRef<str>>(name: &str, pairs: &[(K, V)]) -> Result<Model, ModelError> {
    let spec = find(name)?;
    (spec.build)(&ParamSet::parse(spec.name, spec.params, pairs)?)
}

/// Builds model `name` from pairs of any edge (see [`RawValue`]).
pub fn build_raw<K: AsRef<str>>(name: &str, pairs: &[(K, RawValue)]) -> Result<Model, ModelError> {
    let spec = find(name)?;
    (spec.build)(&ParamSet::from_raw(spec.name, spec.params, pairs)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn models_lists_every_buildable_entry_of_all_models() {
        let buildable: Vec<&str> = ALL_MODELS.iter().filter(|m| m.data.is_none()).map(|m| m.name).collect();
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

    /// Each model's documented `Default` is what the registry builds without parameters.
    #[test]
    fn typed_defaults_match_the_registry_defaults() {
        use crate::lambertian_cylinder as l;
        use crate::{goldman_1997 as g, ideal_diffuse as d, ideal_specular as s, kajiya_kay_1989 as k};
        let defaults = |spec: &crate::ModelInfo| ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        assert_eq!(
            d::IdealDiffuseParams::from_param_set(&defaults(&d::IdealDiffuse::INFO)),
            Ok(d::IdealDiffuseParams::default())
        );
        assert_eq!(
            l::LambertianCylinderParams::from_param_set(&defaults(&l::LambertianCylinder::INFO)),
            Ok(l::LambertianCylinderParams::default())
        );
        assert_eq!(
            s::IdealSpecularParams::from_param_set(&defaults(&s::IdealSpecular::INFO)),
            Ok(s::IdealSpecularParams::default())
        );
        assert_eq!(
            k::KajiyaKayParams::from_param_set(&defaults(&k::KajiyaKay::INFO)),
            Ok(k::KajiyaKayParams::default())
        );
        assert_eq!(g::GoldmanParams::from_param_set(&defaults(&g::Goldman::INFO)), Ok(g::GoldmanParams::default()));
        use crate::{chiang_2016 as c, deon_2011 as e, marschner_2003 as m};
        assert_eq!(
            m::MarschnerParams::from_param_set(&defaults(&m::Marschner::INFO)),
            Ok(m::MarschnerParams::default())
        );
        assert_eq!(c::ChiangParams::from_param_set(&defaults(&c::Chiang::INFO)), Ok(c::ChiangParams::default()));
        assert_eq!(e::DeonParams::from_param_set(&defaults(&e::Deon::INFO)), Ok(e::DeonParams::default()));
        use crate::yan_2017 as y;
        assert_eq!(y::YanFurParams::from_param_set(&defaults(&y::YanFur::INFO)), Ok(y::YanFurParams::default()));
        use crate::sadeghi_2013 as sd;
        let thread = sd::ThreadParams::from_param_set(&defaults(&sd::SadeghiThread::INFO)).unwrap();
        let expected = sd::ThreadParams::default();
        assert!((thread.gamma_s - expected.gamma_s).abs() < 1e-15 && (thread.gamma_v - expected.gamma_v).abs() < 1e-15);
        assert_eq!((thread.eta, thread.k_d, thread.albedo), (expected.eta, expected.k_d, expected.albedo));
        // Goldman names Kajiya–Kay's entries by index: the indices must point at the keys.
        let kk = &k::KajiyaKay::INFO.params;
        assert_eq!([kk[k::K_D].key, kk[k::K_S].key, kk[k::P].key], ["k_d", "k_s", "p"]);
    }

    /// The fused `eval_and_pdf` of every model returns exactly what `eval` and `pdf` do.
    #[test]
    fn eval_and_pdf_agrees_with_eval_and_pdf() {
        let mut u = fiberlab_check::rng::TestRng::new(5).into_uniforms();
        let mut unit = || {
            let (x, phi) = (2.0 * u() - 1.0, std::f64::consts::TAU * u());
            let r = (1.0 - x * x).sqrt();
            DVec3::new(x, r * phi.cos(), r * phi.sin())
        };
        let mut u2 = fiberlab_check::rng::TestRng::new(6).into_uniforms();
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
