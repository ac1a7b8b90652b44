//! No model produces NaN, ±∞ or negative values for any valid parameters, anywhere on the
//! sphere, including θ = ±π/2 exactly and h = ±1. Parameters are drawn from each model's own
//! specification (ends of the ranges included), so models added later are covered too.

use fiberlab_check::tolerance::UNIT_LENGTH_ABS;
use fiberlab_math::DVec3;
use fiberlab_math::frame::direction;
use fiberlab_scatter::params::{ParamKind, ParamSpec, Range};
use fiberlab_scatter::{MODELS, ScatteringFunction, build};
use proptest::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

/// A value in `range` chosen by `t ∈ [0, 1]`, hitting both ends (capped at 50 when unbounded).
fn pick(range: Range, t: f64) -> f64 {
    let lo = if range.min_inclusive { range.min } else { range.min + 1e-6_f64.max(range.min.abs() * 1e-9) };
    let hi = if range.max.is_finite() {
        if range.max_inclusive { range.max } else { range.max - 1e-6_f64.max(range.max.abs() * 1e-9) }
    } else {
        lo.max(0.0) + 50.0
    };
    if t < 0.15 {
        lo
    } else if t > 0.85 {
        hi
    } else {
        lo + (hi - lo) * (t - 0.15) / 0.7
    }
}

fn value(spec: &ParamSpec, t: f64) -> Option<String> {
    match spec.kind {
        ParamKind::Number(r) => Some(pick(r, t).to_string()),
        ParamKind::Integer(r) => Some(pick(r, t).round().clamp(r.min.ceil(), r.max.floor()).to_string()),
        ParamKind::Color(r) => Some(format!("{},{},{}", pick(r, t), pick(r, 1.0 - t), pick(r, (t * 7.0) % 1.0))),
        ParamKind::Choice(c) => Some(c[((t * c.len() as f64) as usize).min(c.len() - 1)].to_string()),
        ParamKind::Subset(c) => Some(c[..1 + ((t * c.len() as f64) as usize).min(c.len() - 1)].join(",")),
        ParamKind::Text => None,
    }
}

const EXTREME_THETAS: [f64; 5] = [FRAC_PI_2, -FRAC_PI_2, 0.0, FRAC_PI_2 - 1e-4, -1.2];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn finite_and_non_negative(
        model_index in 0..MODELS.len(),
        ts in prop::collection::vec(0.0f64..1.0, 12),
        angles in prop::collection::vec(-1.0f64..1.0, 4),
        h in prop::sample::select(vec![-1.0, -0.999_999, 0.0, 0.3, 1.0]),
        u in prop::collection::vec(0.0f64..1.0, 4),
        extreme in 0usize..5,
    ) {
        let spec = &MODELS[model_index];
        // Optional parameters without defaults may be mutually exclusive: give only those
        // with defaults, plus none of the optional ones.
        let pairs: Vec<(String, String)> = spec
            .params
            .iter()
            .enumerate()
            .filter(|(_, p)| !p.default.is_empty())
            .filter_map(|(k, p)| value(p, ts[k % ts.len()]).map(|v| (p.key.to_string(), v)))
            .collect();
        let model = match build(spec.name, &pairs) {
            Ok(m) => m,
            Err(e) => return Err(TestCaseError::fail(format!("{} {pairs:?}: {e}", spec.name))),
        };
        let dirs: [DVec3; 3] = [
            direction(angles[0] * FRAC_PI_2, angles[1] * PI),
            direction(EXTREME_THETAS[extreme], angles[2] * PI),
            direction(angles[3] * FRAC_PI_2, 0.0),
        ];
        for &wi in &dirs {
            for &wo in &dirs {
                let f = model.eval(wi, wo, h);
                let p = model.pdf(wi, wo, h);
                prop_assert!(f.is_finite() && f.min_component() >= 0.0, "{} {pairs:?}: eval {f:?} at {wi:?} {wo:?} h={h}", spec.name);
                prop_assert!(p.is_finite() && p >= 0.0, "{} {pairs:?}: pdf {p} at {wi:?} {wo:?} h={h}", spec.name);
            }
            if let Some(s) = model.sample(wi, h, [u[0], u[1], u[2], u[3]]) {
                prop_assert!(s.weight.is_finite() && s.weight.min_component() >= 0.0, "{} {pairs:?}: weight {:?}", spec.name, s.weight);
                prop_assert!(s.pdf.is_finite() && s.pdf >= 0.0);
                prop_assert!((s.wi.length() - 1.0).abs() < UNIT_LENGTH_ABS);
            }
        }
    }
}

#[test]
fn non_finite_parameters_are_rejected_for_every_model() {
    for spec in MODELS {
        for p in spec.params {
            if matches!(p.kind, ParamKind::Number(_) | ParamKind::Integer(_) | ParamKind::Color(_)) {
                for bad in ["NaN", "inf", "-inf"] {
                    let e = build(spec.name, &[(p.key, bad)]);
                    assert!(e.is_err(), "{} accepted {}={bad}", spec.name, p.key);
                    assert!(e.unwrap_err().to_string().contains(p.key));
                }
            }
        }
    }
}
