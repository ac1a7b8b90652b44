//! Model parameters: ranges, specifications, parsing of `key=value` text and validation.
//!
//! Every model validates its parameters at construction with [`Range::check`], whether it
//! is built from Rust or from the command line, so NaN, ±∞ and out-of-range values never
//! reach the evaluation code.

use crate::ModelError;
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
    pub fn check(&self, key: &str, x: f64) -> Result<f64, ModelError> {
        if !x.is_finite() {
            return Err(ModelError::NotFinite { key: key.into(), value: x, range: self.to_string() });
        }
        if !self.contains(x) {
            return Err(ModelError::OutOfRange { key: key.into(), value: x, range: self.to_string() });
        }
        Ok(x)
    }

    /// [`Range::check`] for every channel of a colour.
    pub fn check_rgb(&self, key: &str, c: Rgb) -> Result<Rgb, ModelError> {
        for i in 0..3 {
            self.check(key, c[i])?;
        }
        Ok(c)
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
                format!("{x}")
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

/// A parsed parameter value.
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
    /// Parses and validates `text` for this parameter.
    pub fn parse(&self, text: &str) -> Result<ParamValue, ModelError> {
        let text = text.trim();
        let number = |t: &str| -> Result<f64, ModelError> {
            t.trim().parse::<f64>().map_err(|_| ModelError::BadValue {
                key: self.key.into(),
                value: text.into(),
                expected: "a number".into(),
            })
        };
        match self.kind {
            ParamKind::Number(r) => Ok(ParamValue::Number(r.check(self.key, number(text)?)?)),
            ParamKind::Integer(r) => {
                let x = r.check(self.key, number(text)?)?;
                if x.fract() != 0.0 {
                    return Err(ModelError::BadValue {
                        key: self.key.into(),
                        value: text.into(),
                        expected: format!("a whole number in {r}"),
                    });
                }
                Ok(ParamValue::Number(x))
            }
            ParamKind::Color(r) => {
                let parts: Vec<&str> = text.split(',').collect();
                let c = match parts.as_slice() {
                    [x] => Rgb::splat(number(x)?),
                    [r, g, b] => Rgb::new(number(r)?, number(g)?, number(b)?),
                    _ => {
                        return Err(ModelError::BadValue {
                            key: self.key.into(),
                            value: text.into(),
                            expected: "one number or three numbers r,g,b".into(),
                        });
                    }
                };
                Ok(ParamValue::Color(r.check_rgb(self.key, c)?))
            }
            ParamKind::Choice(choices) => {
                choices.iter().find(|c| c.eq_ignore_ascii_case(text)).map(|c| ParamValue::Choice(c)).ok_or_else(|| {
                    ModelError::BadValue {
                        key: self.key.into(),
                        value: text.into(),
                        expected: format!("one of {}", choices.join(", ")),
                    }
                })
            }
            ParamKind::Subset(choices) => {
                let mut out = Vec::new();
                for word in text.split(',') {
                    let c = choices.iter().find(|c| c.eq_ignore_ascii_case(word.trim())).ok_or_else(|| {
                        ModelError::BadValue {
                            key: self.key.into(),
                            value: text.into(),
                            expected: format!("a comma-separated subset of {}", choices.join(", ")),
                        }
                    })?;
                    if !out.contains(c) {
                        out.push(*c);
                    }
                }
                Ok(ParamValue::Subset(out))
            }
            ParamKind::Text => Ok(ParamValue::Text(text.into())),
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
}

/// Validated parameters of one model: every key known, every value parsed, defaults
/// filled in for keys that were not given.
#[derive(Clone, Debug)]
pub struct ParamSet {
    model: &'static str,
    specs: &'static [ParamSpec],
    values: Vec<(&'static str, ParamValue, bool)>,
}

impl ParamSet {
    /// Parses `key=value` pairs against `specs`; unknown keys and duplicates are errors.
    pub fn parse<K: AsRef<str>, V: AsRef<str>>(
        model: &'static str,
        specs: &'static [ParamSpec],
        pairs: &[(K, V)],
    ) -> Result<Self, ModelError> {
        let mut values = Vec::with_capacity(specs.len());
        for (k, v) in pairs {
            let key = k.as_ref().trim();
            let spec = specs.iter().find(|s| s.key == key).ok_or_else(|| ModelError::UnknownParameter {
                model: model.into(),
                key: key.into(),
                known: specs.iter().map(|s| s.key).collect::<Vec<_>>().join(", "),
            })?;
            if values.iter().any(|(k, _, _)| *k == spec.key) {
                return Err(ModelError::Duplicate { key: key.into() });
            }
            values.push((spec.key, spec.parse(v.as_ref())?, true));
        }
        for spec in specs {
            if !spec.default.is_empty() && !values.iter().any(|(k, _, _)| *k == spec.key) {
                values.push((spec.key, spec.parse(spec.default)?, false));
            }
        }
        Ok(Self { model, specs, values })
    }

    /// The model's name.
    #[must_use]
    pub fn model(&self) -> &'static str {
        self.model
    }

    /// The specifications these values were parsed against.
    #[must_use]
    pub fn specs(&self) -> &'static [ParamSpec] {
        self.specs
    }

    fn get(&self, key: &str) -> Option<&ParamValue> {
        self.values.iter().find(|(k, _, _)| *k == key).map(|(_, v, _)| v)
    }

    /// True when the user gave `key` explicitly.
    #[must_use]
    pub fn is_given(&self, key: &str) -> bool {
        self.values.iter().any(|(k, _, given)| *k == key && *given)
    }

    /// A number parameter (given or default). Panics if `key` is not a number parameter
    /// of this model with a default: a programming error, not a user error.
    #[must_use]
    pub fn number(&self, key: &str) -> f64 {
        match self.get(key) {
            Some(ParamValue::Number(x)) => *x,
            other => panic!("{}: `{key}` is not a number parameter with a value: {other:?}", self.model),
        }
    }

    /// A number parameter if it has a value.
    #[must_use]
    pub fn number_opt(&self, key: &str) -> Option<f64> {
        match self.get(key) {
            Some(ParamValue::Number(x)) => Some(*x),
            _ => None,
        }
    }

    /// A colour parameter (given or default); see [`ParamSet::number`].
    #[must_use]
    pub fn color(&self, key: &str) -> Rgb {
        self.color_opt(key).unwrap_or_else(|| panic!("{}: `{key}` is not a colour parameter with a value", self.model))
    }

    /// A colour parameter if it has a value.
    #[must_use]
    pub fn color_opt(&self, key: &str) -> Option<Rgb> {
        match self.get(key) {
            Some(ParamValue::Color(c)) => Some(*c),
            _ => None,
        }
    }

    /// A choice parameter (given or default); see [`ParamSet::number`].
    #[must_use]
    pub fn choice(&self, key: &str) -> &'static str {
        match self.get(key) {
            Some(ParamValue::Choice(c)) => c,
            other => panic!("{}: `{key}` is not a choice parameter with a value: {other:?}", self.model),
        }
    }

    /// A subset parameter (given or default); see [`ParamSet::number`].
    #[must_use]
    pub fn subset(&self, key: &str) -> &[&'static str] {
        match self.get(key) {
            Some(ParamValue::Subset(c)) => c,
            other => panic!("{}: `{key}` is not a subset parameter with a value: {other:?}", self.model),
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
        assert_eq!(p.color("albedo"), Rgb::new(0.1, 0.2, 0.3));
        assert_eq!(p.choice("mode"), "off");
        assert_eq!(p.number_opt("p"), None);
        assert!(p.is_given("albedo") && !p.is_given("p"));
        let d = ParamSet::parse::<&str, &str>("m", SPECS, &[]).unwrap();
        assert_eq!(d.color("albedo"), Rgb::splat(0.5));
    }

    #[test]
    fn errors_name_the_key_and_range() {
        let e = ParamSet::parse("m", SPECS, &[("p", "NaN")]).unwrap_err();
        assert!(e.to_string().contains("`p`") && e.to_string().contains("(0, 10)"), "{e}");
        let e = ParamSet::parse("m", SPECS, &[("p", "10")]).unwrap_err();
        assert!(matches!(e, ModelError::OutOfRange { .. }), "{e}");
        let e = ParamSet::parse("m", SPECS, &[("q", "1")]).unwrap_err();
        assert!(e.to_string().contains("albedo, p, mode"), "{e}");
        let e = ParamSet::parse("m", SPECS, &[("albedo", "1,2")]).unwrap_err();
        assert!(e.to_string().contains("r,g,b"), "{e}");
        let e = ParamSet::parse("m", SPECS, &[("p", "1"), ("p", "2")]).unwrap_err();
        assert!(matches!(e, ModelError::Duplicate { .. }));
        assert!(ParamSet::parse("m", SPECS, &[("albedo", "inf")]).is_err());
    }
}
