//! Model parameters: ranges, specifications, parsing of `key=value` text and validation.
//!
//! Every model validates its parameters at construction with [`Range::check`], whether it
//! is built from Rust or from the command line, so NaN, ±∞ and out-of-range values never
//! reach the evaluation code.

use crate::ModelError;
pub use crate::error::ParameterError;
use crate::error::Shown;
use fiberlab_math::Rgb;
use std::fmt;

/// An interval of valid values, each end open or closed (`f64::INFINITY` for unbounded).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// Lower end.
    pub min: f64,
    /// Upper end.
    pub max: f64,
    /// Whether `min` itself is valid.
    pub min_inclusive: bool,
    /// Whether `max` itself is valid.
    pub max_inclusive: bool,
}

impl Range {
    /// `[min, max]`.
    #[must_use]
    pub const fn closed(min: f64, max: f64) -> Self {
        Self { min, max, min_inclusive: true, max_inclusive: true }
    }
    /// `(min, max]`.
    #[must_use]
    pub const fn open_closed(min: f64, max: f64) -> Self {
        Self { min, max, min_inclusive: false, max_inclusive: true }
    }
    /// `[min, max)`.
    #[must_use]
    pub const fn closed_open(min: f64, max: f64) -> Self {
        Self { min, max, min_inclusive: true, max_inclusive: false }
    }
    /// `(min, max)`.
    #[must_use]
    pub const fn open(min: f64, max: f64) -> Self {
        Self { min, max, min_inclusive: false, max_inclusive: false }
    }
    /// `[0, 1]`.
    pub const UNIT: Self = Self::closed(0.0, 1.0);

    /// True when `x` lies in the range (NaN never does).
    #[must_use]
    pub fn contains(&self, x: f64) -> bool {
        let lo = if self.min_inclusive { x >= self.min } else { x > self.min };
        let hi = if self.max_inclusive { x <= self.max } else { x < self.max };
        lo && hi
    }

    /// Returns `x` if it is finite and in range, else the error naming `key`.
    pub fn check(&self, key: &'static str, x: f64) -> Result<f64, ParameterError> {
        self.check_in(key, x, "")
    }

    /// [`Range::check`] for every channel of a colour.
    pub fn check_rgb(&self, key: &'static str, c: Rgb) -> Result<Rgb, ParameterError> {
        for i in 0..3 {
            self.check(key, c[i])?;
        }
        Ok(c)
    }

    /// Checks an angle given in **radians** against this range read in **degrees**, and
    /// reports a violation in degrees (the unit the user wrote). An end of the range that
    /// the degree → radian → degree round trip misses by rounding (≤ 1e−9°) counts as the end.
    pub fn check_degrees(&self, key: &'static str, radians: f64) -> Result<f64, ParameterError> {
        let d = radians.to_degrees();
        let d = if (d - self.min).abs() <= 1e-9 {
            self.min
        } else if (d - self.max).abs() <= 1e-9 {
            self.max
        } else {
            d
        };
        self.check_in(key, d, "degrees").map(|_| radians)
    }

    fn check_in(&self, key: &'static str, x: f64, unit: &'static str) -> Result<f64, ParameterError> {
        let range = if unit.is_empty() { self.to_string() } else { format!("{self} {unit}") };
        if !x.is_finite() {
            return Err(ParameterError::NotFinite { key, value: x, range });
        }
        if !self.contains(x) {
            return Err(ParameterError::OutOfRange { key, value: x, range });
        }
        Ok(x)
    }
}

/// Declares a model's error type for a model whose only way to fail is a parameter out of
/// its range: `Parameter(ParameterError)`, and its conversion into [`ModelError`]. Models with
/// more ways to fail write their enum by hand with the same `Parameter` variant.
macro_rules! parameter_error {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[non_exhaustive]
        #[derive(Clone, Debug, thiserror::Error, PartialEq)]
        pub enum $name {
            /// A parameter outside its range.
            #[error(transparent)]
            Parameter(#[from] $crate::params::ParameterError),
        }

        impl From<$name> for $crate::ModelError {
            fn from(e: $name) -> Self {
                match e {
                    $name::Parameter(p) => p.into(),
                }
            }
        }
    };
}
pub(crate) use parameter_error;

/// Parameters of a fiber described by one albedo per channel (the ideal diffuse fiber, the
/// Lambertian cylinder).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlbedoParams {
    /// Albedo ρ ∈ [0, 1] per channel.
    pub albedo: Rgb,
}

impl Default for AlbedoParams {
    /// Albedo 0.8.
    fn default() -> Self {
        Self { albedo: Rgb::splat(0.8) }
    }
}

impl AlbedoParams {
    /// ρ = 1: the white-furnace reference.
    #[must_use]
    pub fn white() -> Self {
        Self { albedo: Rgb::ONE }
    }

    /// Reads the registry parameter `albedo`.
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Self { albedo: p.color("albedo")? })
    }
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let end = |x: f64| {
            if x == f64::INFINITY {
                "∞".to_string()
            } else if x == f64::NEG_INFINITY {
                "−∞".to_string()
            } else {
                Shown(x).to_string()
            }
        };
        write!(
            f,
            "{}{}, {}{}",
            if self.min_inclusive { '[' } else { '(' },
            end(self.min),
            end(self.max),
            if self.max_inclusive { ']' } else { ')' }
        )
    }
}

/// What kind of value a parameter takes.
#[derive(Clone, Copy, Debug)]
pub enum ParamKind {
    /// A real number in the range.
    Number(Range),
    /// A whole number in the range.
    Integer(Range),
    /// A colour: one number or `r,g,b`, each channel in the range.
    Color(Range),
    /// One word out of a list.
    Choice(&'static [&'static str]),
    /// A comma-separated subset of a list (at least one element).
    Subset(&'static [&'static str]),
    /// Free text (e.g. a file path).
    Text,
}

/// The specification of one parameter, as `fiberlab models` lists it.
#[derive(Clone, Copy, Debug)]
pub struct ParamSpec {
    /// The key used on the command line and in scene files.
    pub key: &'static str,
    /// Kind and valid values.
    pub kind: ParamKind,
    /// Unit (e.g. "degrees", "1/radius", "" for dimensionless).
    pub unit: &'static str,
    /// Default as text; empty when the parameter is optional with no default.
    pub default: &'static str,
    /// One-line description.
    pub doc: &'static str,
}

/// A parameter value as it arrives at an edge of the program — a command-line `key=value`,
/// a scene file or a `--params-file` — before it is checked against its [`ParamSpec`].
/// Every edge converts its syntax into this one type (text stays text, TOML numbers,
/// booleans and arrays keep their structure) and [`ParamSpec::convert`] is the one place
/// that turns it into a validated [`ParamValue`], so arrays and booleans mean the same
/// everywhere: `lobes = ["r", "tt"]` ≡ `lobes=r,tt`, `glints = false` ≡ `glints=off`,
/// `sigma_a = [0.1, 0.2, 0.3]` ≡ `sigma_a=0.1,0.2,0.3`.
#[derive(Clone, Debug, PartialEq)]
pub enum RawValue {
    /// Text as written (`--param k=TEXT`, a TOML string).
    Text(String),
    /// A number (TOML integer or float; a fitted value).
    Number(f64),
    /// A boolean (TOML `true`/`false`); means `on`/`off` for on/off choices.
    Bool(bool),
    /// A list (TOML array): a colour's channels or a subset's elements.
    List(Vec<RawValue>),
}

impl From<&str> for RawValue {
    fn from(t: &str) -> Self {
        RawValue::Text(t.into())
    }
}
impl From<String> for RawValue {
    fn from(t: String) -> Self {
        RawValue::Text(t)
    }
}
impl From<f64> for RawValue {
    fn from(x: f64) -> Self {
        RawValue::Number(x)
    }
}
impl From<bool> for RawValue {
    fn from(b: bool) -> Self {
        RawValue::Bool(b)
    }
}
impl From<Rgb> for RawValue {
    fn from(c: Rgb) -> Self {
        RawValue::List(vec![RawValue::Number(c[0]), RawValue::Number(c[1]), RawValue::Number(c[2])])
    }
}

impl fmt::Display for RawValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RawValue::Text(t) => write!(f, "{t}"),
            RawValue::Number(x) => write!(f, "{}", Shown(*x)),
            RawValue::Bool(b) => write!(f, "{b}"),
            RawValue::List(items) => {
                let parts: Vec<String> = items.iter().map(ToString::to_string).collect();
                write!(f, "[{}]", parts.join(", "))
            }
        }
    }
}

/// A validated parameter value.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    /// A number.
    Number(f64),
    /// A colour.
    Color(Rgb),
    /// One of the choices.
    Choice(&'static str),
    /// A subset of the choices.
    Subset(Vec<&'static str>),
    /// Text.
    Text(String),
}

impl ParamSpec {
    /// Parses and validates `text` for this parameter (a command-line value).
    pub fn parse(&self, text: &str) -> Result<ParamValue, ModelError> {
        self.convert(&RawValue::Text(text.into()))
    }

    /// Converts and validates a value from any edge: the one conversion from text, numbers,
    /// booleans and lists to a typed value (see [`RawValue`]).
    pub fn convert(&self, raw: &RawValue) -> Result<ParamValue, ModelError> {
        let bad = |expected: String| ModelError::BadValue { key: self.key.into(), value: raw.to_string(), expected };
        let number = |r: &RawValue| -> Result<f64, ModelError> {
            match r {
                RawValue::Number(x) => Ok(*x),
                RawValue::Text(t) => t.trim().parse::<f64>().map_err(|_| bad("a number".into())),
                _ => Err(bad("a number".into())),
            }
        };
        // A list given as text is comma-separated; a TOML array is already a list.
        let items = |r: &RawValue| -> Vec<RawValue> {
            match r {
                RawValue::List(items) => items.clone(),
                RawValue::Text(t) => t.split(',').map(|s| RawValue::Text(s.trim().into())).collect(),
                other => vec![other.clone()],
            }
        };
        let word = |r: &RawValue| -> Option<String> {
            match r {
                RawValue::Text(t) => Some(t.trim().to_string()),
                RawValue::Bool(b) => Some(if *b { "on" } else { "off" }.into()),
                _ => None,
            }
        };
        // `true`/`false` written as text mean on/off too, for on/off choices.
        let choose = |choices: &'static [&'static str], w: &str| -> Option<&'static str> {
            let w = match w.to_ascii_lowercase().as_str() {
                "true" if choices.contains(&"on") => "on".to_string(),
                "false" if choices.contains(&"off") => "off".to_string(),
                other => other.to_string(),
            };
            choices.iter().find(|c| c.eq_ignore_ascii_case(&w)).copied()
        };
        // The range is shown with the parameter's unit, in which the value was given.
        match self.kind {
            ParamKind::Number(r) => Ok(ParamValue::Number(r.check_in(self.key, number(raw)?, self.unit)?)),
            ParamKind::Integer(r) => {
                let x = r.check_in(self.key, number(raw)?, self.unit)?;
                if x.fract() != 0.0 {
                    return Err(bad(format!("a whole number in {r}")));
                }
                Ok(ParamValue::Number(x))
            }
            ParamKind::Color(r) => {
                let channels = items(raw);
                let c = match channels.as_slice() {
                    [x] => Rgb::splat(number(x)?),
                    [r, g, b] => Rgb::new(number(r)?, number(g)?, number(b)?),
                    _ => return Err(bad("one number or three numbers r,g,b".into())),
                };
                for i in 0..3 {
                    r.check_in(self.key, c[i], self.unit)?;
                }
                Ok(ParamValue::Color(c))
            }
            ParamKind::Choice(choices) => word(raw)
                .and_then(|w| choose(choices, &w))
                .map(ParamValue::Choice)
                .ok_or_else(|| bad(format!("one of {}", choices.join(", ")))),
            ParamKind::Subset(choices) => {
                let expected = || bad(format!("a comma-separated subset of {}", choices.join(", ")));
                let mut out = Vec::new();
                for item in items(raw) {
                    let c = word(&item).and_then(|w| choose(choices, &w)).ok_or_else(expected)?;
                    if !out.contains(&c) {
                        out.push(c);
                    }
                }
                if out.is_empty() {
                    return Err(expected());
                }
                Ok(ParamValue::Subset(out))
            }
            ParamKind::Text => match raw {
                RawValue::Text(t) => Ok(ParamValue::Text(t.trim().into())),
                _ => Err(bad("text".into())),
            },
        }
    }

    /// Human-readable valid values, e.g. "[0, 1]" or "uniform|mirror".
    #[must_use]
    pub fn valid(&self) -> String {
        match self.kind {
            ParamKind::Number(r) => r.to_string(),
            ParamKind::Integer(r) => format!("integer in {r}"),
            ParamKind::Color(r) => format!("{r} per channel"),
            ParamKind::Choice(c) => c.join("|"),
            ParamKind::Subset(c) => format!("subset of {}", c.join(",")),
            ParamKind::Text => "text".into(),
        }
    }

    /// [`ParamSpec::valid`] for a Markdown table: the words of a choice or subset as code.
    #[must_use]
    pub fn valid_markdown(&self) -> String {
        let words = |c: &[&str]| c.iter().map(|w| format!("`{w}`")).collect::<Vec<_>>().join(", ");
        match self.kind {
            ParamKind::Choice(c) => format!("one of {}", words(c)),
            ParamKind::Subset(c) => format!("any of {}", words(c)),
            _ => self.valid(),
        }
    }
}

/// Validated parameters of one model: every key known, every value converted, defaults
/// filled in for keys that were not given. Models read their typed parameter struct from it
/// (each model's `XParams::from_param_set`), so text never travels past the edge.
#[derive(Clone, Debug)]
pub struct ParamSet {
    model: &'static str,
    specs: &'static [ParamSpec],
    values: Vec<(&'static str, ParamValue, bool)>,
}

impl ParamSet {
    /// Parses textual `key=value` pairs against `specs`; unknown keys and duplicates are errors.
    pub fn parse<K: AsRef<str>, V: AsRef<str>>(
        model: &'static str,
        specs: &'static [ParamSpec],
        pairs: &[(K, V)],
    ) -> Result<Self, ModelError> {
        let raw: Vec<(&str, RawValue)> = pairs.iter().map(|(k, v)| (k.as_ref(), RawValue::from(v.as_ref()))).collect();
        Self::from_raw(model, specs, &raw)
    }

    /// Converts pairs from any edge (see [`RawValue`]) against `specs`; unknown keys and
    /// duplicates are errors.
    pub fn from_raw<K: AsRef<str>>(
        model: &'static str,
        specs: &'static [ParamSpec],
        pairs: &[(K, RawValue)],
    ) -> Result<Self, ModelError> {
        let mut set = Self { model, specs, values: Vec::with_capacity(specs.len()) };
        for (k, v) in pairs {
            let spec = set.spec(k.as_ref())?;
            if set.values.iter().any(|(k, _, _)| *k == spec.key) {
                return Err(ModelError::Duplicate { key: spec.key.into() });
            }
            set.values.push((spec.key, spec.convert(v)?, true));
        }
        for spec in specs {
            if !spec.default.is_empty() && !set.values.iter().any(|(k, _, _)| *k == spec.key) {
                set.values.push((spec.key, spec.parse(spec.default)?, false));
            }
        }
        Ok(set)
    }

    fn spec(&self, key: &str) -> Result<&'static ParamSpec, ModelError> {
        let key = key.trim();
        self.specs.iter().find(|s| s.key == key).ok_or_else(|| ModelError::UnknownParameter {
            model: self.model.into(),
            key: key.into(),
            known: self.specs.iter().map(|s| s.key).collect::<Vec<_>>().join(", "),
        })
    }

    /// Sets `key` (given explicitly), validated like any edge value; e.g. a fitted number
    /// with `RawValue::Number`. Unknown keys are errors.
    pub fn set(&mut self, key: &str, value: impl Into<RawValue>) -> Result<(), ModelError> {
        let spec = self.spec(key)?;
        let v = spec.convert(&value.into())?;
        self.values.retain(|(k, _, _)| *k != spec.key);
        self.values.push((spec.key, v, true));
        Ok(())
    }

    /// The model's name.
    #[must_use]
    pub fn model(&self) -> &'static str {
        self.model
    }

    /// The specifications these values were converted against.
    #[must_use]
    pub fn specs(&self) -> &'static [ParamSpec] {
        self.specs
    }

    fn get(&self, key: &str) -> Option<&ParamValue> {
        self.values.iter().find(|(k, _, _)| *k == key).map(|(_, v, _)| v)
    }

    /// True when `key` was given explicitly (not a default).
    #[must_use]
    pub fn is_given(&self, key: &str) -> bool {
        self.values.iter().any(|(k, _, given)| *k == key && *given)
    }

    /// The error for a key that the model's own reader asks for with the wrong kind: a
    /// mismatch between a model's specification and its reader, reported, never a panic.
    fn missing(&self, key: &str, kind: &'static str) -> ModelError {
        ModelError::Specification { model: self.model, key: key.into(), kind }
    }

    /// A number parameter (given or default).
    pub fn number(&self, key: &str) -> Result<f64, ModelError> {
        self.number_opt(key).ok_or_else(|| self.missing(key, "number"))
    }

    /// A number parameter if it has a value.
    #[must_use]
    pub fn number_opt(&self, key: &str) -> Option<f64> {
        match self.get(key) {
            Some(ParamValue::Number(x)) => Some(*x),
            _ => None,
        }
    }

    /// An angle parameter given in degrees (given or default), returned in radians.
    pub fn degrees(&self, key: &str) -> Result<f64, ModelError> {
        self.number(key).map(f64::to_radians)
    }

    /// A colour parameter (given or default).
    pub fn color(&self, key: &str) -> Result<Rgb, ModelError> {
        self.color_opt(key).ok_or_else(|| self.missing(key, "colour"))
    }

    /// A colour parameter if it has a value.
    #[must_use]
    pub fn color_opt(&self, key: &str) -> Option<Rgb> {
        match self.get(key) {
            Some(ParamValue::Color(c)) => Some(*c),
            _ => None,
        }
    }

    /// A choice parameter (given or default).
    pub fn choice(&self, key: &str) -> Result<&'static str, ModelError> {
        match self.get(key) {
            Some(ParamValue::Choice(c)) => Ok(c),
            _ => Err(self.missing(key, "choice")),
        }
    }

    /// An on/off choice parameter as a boolean.
    pub fn switch(&self, key: &str) -> Result<bool, ModelError> {
        self.choice(key).map(|c| c == "on")
    }

    /// A subset parameter (given or default).
    pub fn subset(&self, key: &str) -> Result<&[&'static str], ModelError> {
        match self.get(key) {
            Some(ParamValue::Subset(c)) => Ok(c),
            _ => Err(self.missing(key, "subset")),
        }
    }

    /// A text parameter if it has a value.
    #[must_use]
    pub fn text(&self, key: &str) -> Option<&str> {
        match self.get(key) {
            Some(ParamValue::Text(t)) => Some(t),
            _ => None,
        }
    }
}

/// Splits `key=value` into its parts; errors name the text.
pub fn split_key_value(text: &str) -> Result<(String, String), ModelError> {
    let (k, v) = text.split_once('=').ok_or_else(|| ModelError::BadValue {
        key: text.into(),
        value: text.into(),
        expected: "key=value".into(),
    })?;
    Ok((k.trim().into(), v.trim().into()))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPECS: &[ParamSpec] = &[
        ParamSpec { key: "albedo", kind: ParamKind::Color(Range::UNIT), unit: "", default: "0.5", doc: "" },
        ParamSpec { key: "p", kind: ParamKind::Number(Range::open(0.0, 10.0)), unit: "", default: "", doc: "" },
        ParamSpec { key: "mode", kind: ParamKind::Choice(&["on", "off"]), unit: "", default: "on", doc: "" },
    ];

    #[test]
    fn parses_colours_choices_and_defaults() {
        let p = ParamSet::parse("m", SPECS, &[("albedo", "0.1,0.2,0.3"), ("mode", "OFF")]).unwrap();
        assert_eq!(p.color("albedo").unwrap(), Rgb::new(0.1, 0.2, 0.3));
        assert_eq!(p.choice("mode").unwrap(), "off");
        assert_eq!(p.number_opt("p"), None);
        assert!(p.is_given("albedo") && !p.is_given("p"));
        let d = ParamSet::parse::<&str, &str>("m", SPECS, &[]).unwrap();
        assert_eq!(d.color("albedo").unwrap(), Rgb::splat(0.5));
        assert!(matches!(d.number("albedo"), Err(ModelError::Specification { .. })));
    }

    #[test]
    fn text_numbers_booleans_and_lists_convert_alike() {
        const SUB: &[ParamSpec] = &[
            ParamSpec {
                key: "lobes",
                kind: ParamKind::Subset(&["r", "tt", "trt"]),
                unit: "",
                default: "r,tt,trt",
                doc: "",
            },
            ParamSpec { key: "glints", kind: ParamKind::Choice(&["on", "off"]), unit: "", default: "on", doc: "" },
            ParamSpec { key: "c", kind: ParamKind::Color(Range::UNIT), unit: "", default: "0.5", doc: "" },
        ];
        let text = ParamSet::parse("m", SUB, &[("lobes", "r, tt"), ("glints", "off"), ("c", "0.1,0.2,0.3")]).unwrap();
        let list = RawValue::List(vec!["r".into(), "tt".into()]);
        let raw = ParamSet::from_raw(
            "m",
            SUB,
            &[("lobes", list), ("glints", RawValue::Bool(false)), ("c", Rgb::new(0.1, 0.2, 0.3).into())],
        )
        .unwrap();
        for p in [&text, &raw] {
            assert_eq!(p.subset("lobes").unwrap(), &["r", "tt"]);
            assert!(!p.switch("glints").unwrap());
            assert_eq!(p.color("c").unwrap(), Rgb::new(0.1, 0.2, 0.3));
        }
        let t = ParamSet::parse("m", SUB, &[("glints", "true")]).unwrap();
        assert!(t.switch("glints").unwrap());
        assert!(ParamSet::from_raw("m", SUB, &[("lobes", RawValue::List(vec![]))]).is_err());
        assert!(ParamSet::from_raw("m", SUB, &[("c", RawValue::Bool(true))]).is_err());
        let mut s = ParamSet::parse::<&str, &str>("m", SUB, &[]).unwrap();
        s.set("c", 0.25).unwrap();
        assert!(s.is_given("c") && s.color("c").unwrap() == Rgb::splat(0.25));
        assert!(s.set("c", 2.0).is_err() && s.set("nope", 1.0).is_err());
    }

    #[test]
    fn angles_are_checked_and_reported_in_degrees() {
        let r = Range::closed(-20.0, 20.0);
        assert_eq!(r.check_degrees("alpha", 20f64.to_radians()).unwrap(), 20f64.to_radians());
        let e = r.check_degrees("alpha", 30f64.to_radians()).unwrap_err();
        assert!(e.to_string().contains("`alpha` = 30") && e.to_string().contains("[-20, 20] degrees"), "{e}");
        let e = Range::UNIT.check("x", 1e308).unwrap_err();
        assert!(e.to_string().contains("1e308"), "{e}");
        // Parsed parameters: the range carries the parameter's unit, the value as given.
        static TILT: [ParamSpec; 1] = [ParamSpec {
            key: "tilt",
            kind: ParamKind::Number(Range::open(-20.0, 20.0)),
            unit: "degrees",
            default: "0",
            doc: "",
        }];
        let e = ParamSet::parse("m", &TILT, &[("tilt", "25")]).unwrap_err().to_string();
        assert!(e.ends_with("`tilt` = 25 is out of range; valid range (-20, 20) degrees"), "{e}");
        let e = ParamSet::parse("m", &TILT, &[("tilt", "-1e308")]).unwrap_err().to_string();
        assert!(e.contains("`tilt` = -1e308 is out of range"), "{e}");
    }

    #[test]
    fn errors_name_the_key_and_range() {
        let e = ParamSet::parse("m", SPECS, &[("p", "NaN")]).unwrap_err();
        assert!(e.to_string().contains("`p`") && e.to_string().contains("(0, 10)"), "{e}");
        let e = ParamSet::parse("m", SPECS, &[("p", "10")]).unwrap_err();
        assert!(matches!(e, ModelError::Parameter(ParameterError::OutOfRange { key: "p", .. })), "{e}");
        let e = ParamSet::parse("m", SPECS, &[("q", "1")]).unwrap_err();
        assert!(e.to_string().contains("albedo, p, mode"), "{e}");
        let e = ParamSet::parse("m", SPECS, &[("albedo", "1,2")]).unwrap_err();
        assert!(e.to_string().contains("r,g,b"), "{e}");
        let e = ParamSet::parse("m", SPECS, &[("p", "1"), ("p", "2")]).unwrap_err();
        assert!(matches!(e, ModelError::Duplicate { .. }));
        assert!(ParamSet::parse("m", SPECS, &[("albedo", "inf")]).is_err());
    }
}
