//! TOML values → [`RawValue`]: the one conversion of parameter tables written in TOML
//! (scene files' `params = { … }`, `--params-file`, `fiberlab measure --fiber`). Strings stay
//! text, integers and floats become numbers, booleans stay booleans and arrays stay lists, so
//! [`fiberlab_scatter::params::ParamSpec::convert`] applies the same rules to them as to a
//! command-line `key=value`: `lobes = ["r", "tt"]` ≡ `lobes=r,tt`, `glints = false` ≡
//! `glints=off`.

use fiberlab_scatter::params::RawValue;
use thiserror::Error;

/// A TOML value that no parameter can take (a table or a date).
#[derive(Clone, Debug, Error, PartialEq, Eq)]
#[error("parameter `{key}` = {value} is not a number, string, boolean or array")]
pub struct UnsupportedValue {
    /// The key.
    pub key: String,
    /// The value, as TOML.
    pub value: String,
}

/// Converts one TOML value; `None` for tables and dates (also inside arrays).
#[must_use]
pub fn raw_value(value: &toml::Value) -> Option<RawValue> {
    Some(match value {
        toml::Value::String(s) => RawValue::Text(s.clone()),
        // Integers as f64: exact up to 2⁵³, far beyond any parameter's range.
        toml::Value::Integer(i) => RawValue::Number(*i as f64),
        toml::Value::Float(x) => RawValue::Number(*x),
        toml::Value::Boolean(b) => RawValue::Bool(*b),
        toml::Value::Array(items) => RawValue::List(items.iter().map(raw_value).collect::<Option<_>>()?),
        toml::Value::Datetime(_) | toml::Value::Table(_) => return None,
    })
}

/// Converts every entry of a TOML table to `(key, value)` pairs, in the table's order.
pub fn raw_pairs(table: &toml::Table) -> Result<Vec<(String, RawValue)>, UnsupportedValue> {
    table
        .iter()
        .map(|(k, v)| {
            raw_value(v)
                .map(|raw| (k.clone(), raw))
                .ok_or_else(|| UnsupportedValue { key: k.clone(), value: v.to_string() })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strings_numbers_booleans_and_arrays_keep_their_structure() {
        let t: toml::Table =
            "a = \"x\"\nb = 3\nc = 0.25\nd = false\ne = [\"r\", \"tt\"]\nf = [1, 2.5]\n".parse().unwrap();
        let pairs = raw_pairs(&t).unwrap();
        let get = |k: &str| pairs.iter().find(|(key, _)| key == k).map(|(_, v)| v.clone()).unwrap();
        assert_eq!(get("a"), RawValue::Text("x".into()));
        assert_eq!(get("b"), RawValue::Number(3.0));
        assert_eq!(get("c"), RawValue::Number(0.25));
        assert_eq!(get("d"), RawValue::Bool(false));
        assert_eq!(get("e"), RawValue::List(vec!["r".into(), "tt".into()]));
        assert_eq!(get("f"), RawValue::List(vec![RawValue::Number(1.0), RawValue::Number(2.5)]));
    }

    #[test]
    fn tables_and_dates_are_refused_with_their_key() {
        let t: toml::Table = "a = { b = 1 }".parse().unwrap();
        assert_eq!(raw_pairs(&t).unwrap_err().key, "a");
        let t: toml::Table = "d = [1979-05-27]".parse().unwrap();
        assert!(raw_pairs(&t).unwrap_err().to_string().contains("`d`"));
    }
}
