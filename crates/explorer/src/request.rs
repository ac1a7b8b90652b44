//! What requests name — a model and its parameters, directions, angles — and their checks,
//! with the messages the command line gives for the same input. Parameters arrive as JSON
//! values and become the registry's [`RawValue`]s (string → text, number → number, boolean →
//! boolean, array → list; `null` leaves the parameter at its default), so that
//! `{"lobes": ["r", "tt"], "glints": false}` means what `--param lobes=r,tt --param
//! glints=off` means.

use crate::error::{ApiError, ApiResult};
use fiberlab_math::frame::direction;
use fiberlab_math::quadrature::{width_nodes, width_panels};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::params::{ParamKind, RawValue};
use fiberlab_scatter::{
    Field, LobeInfo, Model, ModelKind, ScatteringFunction, SurfaceModel, build_raw, build_surface_raw, lookup,
};
use serde::Deserialize;
use serde_json::{Map, Value};

/// A model of either registry and its parameters, as requests name it.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
pub struct ModelChoice {
    /// Registry name.
    pub model: String,
    /// Parameters by key (missing keys take their defaults).
    #[serde(default)]
    pub params: Map<String, Value>,
}

/// A built model of either registry.
#[derive(Clone, Debug)]
pub enum Built {
    /// A fiber scattering function.
    Fiber(Model),
    /// A surface BRDF.
    Surface(SurfaceModel),
}

/// One JSON value as a registry value.
pub(crate) fn raw(key: &str, value: &Value) -> ApiResult<Option<RawValue>> {
    Ok(Some(match value {
        Value::Null => return Ok(None),
        Value::String(s) => RawValue::Text(s.clone()),
        Value::Bool(b) => RawValue::Bool(*b),
        Value::Number(n) => RawValue::Number(
            n.as_f64().ok_or_else(|| ApiError::bad(format!("parameter `{key}`: {n} is not a number")))?,
        ),
        Value::Array(items) => RawValue::List(
            items
                .iter()
                .map(|v| raw(key, v)?.ok_or_else(|| ApiError::bad(format!("parameter `{key}`: null inside a list"))))
                .collect::<ApiResult<_>>()?,
        ),
        Value::Object(_) => {
            return Err(ApiError::bad(format!(
                "parameter `{key}`: expected a number, a string, a boolean or a list, got an object"
            )));
        }
    }))
}

impl ModelChoice {
    /// A choice from a name and textual parameters (tests, presets).
    #[must_use]
    pub fn new(model: &str, params: &[(&str, Value)]) -> Self {
        Self { model: model.into(), params: params.iter().map(|(k, v)| ((*k).to_string(), v.clone())).collect() }
    }

    /// Which registry holds the name (an unknown name is the registry's error, listing both).
    pub fn kind(&self) -> ApiResult<ModelKind> {
        Ok(lookup(&self.model).map_err(|e| ApiError::bad(e.to_string()))?.kind())
    }

    /// The `(key, value)` pairs; a text value for a parameter that names a file is refused
    /// (the explorer reads no files named in parameters).
    pub fn pairs(&self) -> ApiResult<Vec<(String, RawValue)>> {
        let entry = lookup(&self.model).map_err(|e| ApiError::bad(e.to_string()))?;
        let info = entry.info();
        if let Some(data) = info.data
            && let fiberlab_scatter::ExternalData::Table { key } = data
        {
            return Err(ApiError::bad(format!(
                "model `{}`: built from a measured table (`{key}=PATH`); the explorer builds models from \
                 parameters — load the table in Compare to compare or fit a model to it",
                info.name
            )));
        }
        let mut pairs = Vec::with_capacity(self.params.len());
        for (k, v) in &self.params {
            let Some(value) = raw(k, v)? else { continue };
            if let Some(spec) = info.params.iter().find(|p| p.key == k)
                && matches!(spec.kind, ParamKind::Text)
            {
                return Err(ApiError::bad(format!(
                    "model `{}`: parameter `{k}` names a file; the explorer reads no files named in parameters \
                     (use the model's presets)",
                    info.name
                )));
            }
            pairs.push((k.clone(), value));
        }
        Ok(pairs)
    }

    /// Builds the model from whichever registry holds its name; errors read as the command
    /// line's (`model `NAME`: …`).
    pub fn build(&self) -> ApiResult<Built> {
        self.build_with(&[])
    }

    /// [`ModelChoice::build`] with `overrides` replacing (or adding to) the parameters.
    pub fn build_with(&self, overrides: &[(&str, RawValue)]) -> ApiResult<Built> {
        let kind = self.kind()?;
        let mut pairs = self.pairs()?;
        for (k, v) in overrides {
            pairs.retain(|(key, _)| key != k);
            pairs.push(((*k).to_string(), v.clone()));
        }
        let context = |e: fiberlab_scatter::ModelError| ApiError::bad(format!("model `{}`: {e}", self.model));
        Ok(match kind {
            ModelKind::Fiber => Built::Fiber(build_raw(&self.model, &pairs).map_err(context)?),
            ModelKind::Surface => Built::Surface(build_surface_raw(&self.model, &pairs).map_err(context)?),
        })
    }

    /// Builds a fiber model (a surface model's name is an error saying so).
    pub fn build_fiber(&self) -> ApiResult<Model> {
        match self.build()? {
            Built::Fiber(m) => Ok(m),
            Built::Surface(_) => {
                Err(ApiError::bad(format!("`{}` is a surface model; a fiber model is needed here", self.model)))
            }
        }
    }
}

/// Checks that `w` is a finite unit vector (length within 1e−3 of 1, then normalized): the
/// command line's rule and message.
pub fn unit(w: [f64; 3], what: &str) -> ApiResult<DVec3> {
    let w = DVec3::from(w);
    let len = w.length();
    if !(w.is_finite() && (len - 1.0).abs() <= 1e-3) {
        return Err(ApiError::bad(format!(
            "{what}: expected a unit vector, got ({}, {}, {}) of length {len}",
            w.x, w.y, w.z
        )));
    }
    Ok(w / len)
}

/// Checks the offset across the fiber, `h ∈ [−1, 1]`.
pub fn offset(h: f64) -> ApiResult<f64> {
    if !(-1.0..=1.0).contains(&h) {
        return Err(ApiError::bad(format!("h: expected a value in [-1, 1], got {h}")));
    }
    Ok(h)
}

/// Checks an angle in degrees against `[lo, hi]`; returns radians.
pub fn degrees(what: &str, value: f64, lo: f64, hi: f64) -> ApiResult<f64> {
    if !(value.is_finite() && (lo..=hi).contains(&value)) {
        return Err(ApiError::bad(format!("{what}: expected degrees in [{lo}, {hi}], got {value}")));
    }
    Ok(value.to_radians())
}

/// A fiber direction at inclination θ (from the normal plane) and azimuth φ, degrees.
#[must_use]
pub fn fiber_direction(theta: f64, phi: f64) -> DVec3 {
    direction(theta, phi)
}

/// The offsets `h` a fiber model is evaluated at, with their weights: a far-field model at
/// `h = 0`; a near-field one at the given `h`, or averaged over the fiber's width with the
/// nodes of [`ScatteringFunction::eval_far`]'s default rule
/// ([`fiberlab_math::quadrature::width_nodes`], as many panels as the model's narrowest
/// feature needs: what a fit or a comparison with a far-field measurement uses).
#[must_use]
pub fn offsets(model: &impl ScatteringFunction, h: Option<f64>) -> Vec<(f64, f64)> {
    match (model.properties().field, h) {
        (Field::Far, _) => vec![(0.0, 1.0)],
        (Field::Near, Some(h)) => vec![(h, 1.0)],
        (Field::Near, None) => width_nodes(width_panels(model.width_feature())),
    }
}

/// A fiber model seen lobe by lobe: through [`ScatteringFunction::eval_lobes`] when it
/// separates its lobes (Chiang, Marschner), else through its `lobes` parameter (one model per
/// enabled lobe, as `fiberlab compare-model` builds them: `yan-fur`), else as one lobe `all`.
#[derive(Clone, Debug)]
pub struct Parts {
    /// Lobe names, in the model's order.
    pub names: Vec<String>,
    how: PartsHow,
}

#[derive(Clone, Debug)]
enum PartsHow {
    Separated(Box<Model>),
    PerModel(Vec<Model>),
}

impl Parts {
    /// The parts of the chosen fiber model.
    pub fn of(choice: &ModelChoice) -> ApiResult<Self> {
        let model = choice.build_fiber()?;
        let lobes: Vec<LobeInfo> = model.lobes();
        let mut scratch = vec![Rgb::ZERO; lobes.len()];
        let probe = direction(0.3, 0.0);
        if model.eval_lobes(probe, direction(-0.2, 2.0), 0.1, &mut scratch) {
            return Ok(Self {
                names: lobes.iter().map(|l| l.name.to_string()).collect(),
                how: PartsHow::Separated(Box::new(model)),
            });
        }
        let spec = fiberlab_scatter::find(&choice.model).map_err(|e| ApiError::bad(e.to_string()))?;
        if let Some(param) = spec.params.iter().find(|p| p.key == "lobes")
            && let ParamKind::Subset(_) = param.kind
        {
            let enabled: Vec<String> = match choice.params.get("lobes") {
                Some(Value::Array(items)) => items.iter().filter_map(|v| v.as_str().map(str::to_string)).collect(),
                Some(Value::String(s)) => s.split(',').map(|x| x.trim().to_string()).collect(),
                _ => param.default.split(',').map(str::to_string).collect(),
            };
            let models = enabled
                .iter()
                .map(|lobe| choice.build_with(&[("lobes", RawValue::Text(lobe.clone()))]))
                .map(|b| match b? {
                    Built::Fiber(m) => Ok(m),
                    Built::Surface(_) => Err(ApiError::internal("a lobe of a fiber model built a surface model")),
                })
                .collect::<ApiResult<Vec<_>>>()?;
            return Ok(Self { names: enabled, how: PartsHow::PerModel(models) });
        }
        Ok(Self { names: vec!["all".into()], how: PartsHow::PerModel(vec![model]) })
    }

    /// A model to ask for its field and offsets.
    #[must_use]
    pub fn model(&self) -> &Model {
        match &self.how {
            PartsHow::Separated(m) => m,
            PartsHow::PerModel(ms) => &ms[0],
        }
    }

    /// Writes each part's `f_s(ω_i, ω_o; h)` to `out[..names.len()]`.
    pub fn eval(&self, wi: DVec3, wo: DVec3, h: f64, out: &mut [Rgb]) {
        match &self.how {
            PartsHow::Separated(m) => {
                m.eval_lobes(wi, wo, h, out);
            }
            PartsHow::PerModel(ms) => {
                for (o, m) in out.iter_mut().zip(ms) {
                    *o = m.eval(wi, wo, h);
                }
            }
        }
    }
}

/// Colour channel of a plotted value.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Channel {
    /// Rec. 709 luminance.
    #[default]
    Luminance,
    /// Red.
    R,
    /// Green.
    G,
    /// Blue.
    B,
}

impl Channel {
    /// This channel of a colour.
    #[must_use]
    pub fn of(self, c: Rgb) -> f64 {
        match self {
            Channel::Luminance => c.luminance(),
            Channel::R => c[0],
            Channel::G => c[1],
            Channel::B => c[2],
        }
    }
}
