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

/// The value at an end of `range`: the end itself where it is valid, else the nearest
/// representable value inside it (the true end of an open range: `(0, 1]` ends at the
/// smallest positive double); an infinite end is taken as 1e12.
fn end_of(range: Range, upper: bool) -> f64 {
    let (end, inclusive) = if upper { (range.max, range.max_inclusive) } else { (range.min, range.min_inclusive) };
    if !end.is_finite() {
        return if upper { 1e12 } else { -1e12 };
    }
    match (inclusive, upper) {
        (true, _) => end,
        (false, true) => end.next_down(),
        (false, false) => end.next_up(),
    }
}

/// Every numeric parameter of every fiber model at each end of its documented range (the
/// others at their defaults): the model builds, and `f_s`, the pdf and the samples are finite
/// and non-negative everywhere — poles, grazing, h = ±1 — with each sample's pdf the pdf of
/// its direction. Roughnesses swept to their ends found `chiang` and `deon` NaN at
/// `beta_m = 1e-200` and ∞ at `beta_n = 1e-320`.
#[test]
fn every_parameter_at_the_ends_of_its_range_is_finite() {
    sweep_parameter_ends(|model, key| !slow_to_build(model, key));
}

/// The parameters of `yan-fur` that build new medulla tables (seconds each): swept by
/// [`every_slow_parameter_at_the_ends_of_its_range_is_finite`], run by name.
fn slow_to_build(model: &str, key: &str) -> bool {
    model == "yan-fur" && matches!(key, "kappa" | "sigma_m_s" | "sigma_m_a" | "g" | "eta" | "color")
}

/// The parameter ends [`every_parameter_at_the_ends_of_its_range_is_finite`] leaves out
/// because each takes seconds to build (about 40 s of CPU in all): `cargo test --release -p
/// fiberlab-scatter --test finite_everywhere -- --ignored`.
#[test]
#[ignore = "about 40 s of CPU: run by name"]
fn every_slow_parameter_at_the_ends_of_its_range_is_finite() {
    sweep_parameter_ends(slow_to_build);
}

/// Checks every numeric parameter `(model, key)` that `include` selects at both ends of its
/// range ([`end_of`]; the others at their defaults), in parallel: the model builds, and
/// [`first_problem`] finds nothing.
fn sweep_parameter_ends(include: impl Fn(&str, &str) -> bool) {
    use rayon::prelude::*;
    let thetas = [FRAC_PI_2, -FRAC_PI_2, 0.0, FRAC_PI_2 - 1e-7, -1.3];
    let dirs: Vec<DVec3> = thetas.iter().zip([0.0, 2.0, PI, 0.3, 1.0]).map(|(&t, p)| direction(t, p)).collect();
    let uniforms = [[0.0, 0.0, 0.0, 0.0], [0.5, 0.5, 0.5, 0.5], [0.999_999, 0.3, 0.7, 0.999_999]];
    let mut cases: Vec<(&str, &str, String)> = Vec::new();
    for spec in MODELS {
        for p in spec.params.iter().filter(|p| include(spec.name, p.key)) {
            let range = match p.kind {
                ParamKind::Number(r) | ParamKind::Integer(r) | ParamKind::Color(r) => r,
                _ => continue,
            };
            for upper in [false, true] {
                let mut x = end_of(range, upper);
                if matches!(p.kind, ParamKind::Integer(_)) {
                    x = if upper { x.floor() } else { x.ceil() };
                }
                let value =
                    if matches!(p.kind, ParamKind::Color(_)) { format!("{x:e},{x:e},{x:e}") } else { format!("{x:e}") };
                cases.push((spec.name, p.key, value));
            }
        }
    }
    assert!(cases.len() >= 10, "{} parameter ends", cases.len());
    // One message per parameter end that fails, so that every failing end is listed at once.
    let failures: Vec<String> = cases
        .par_iter()
        .filter_map(|(name, key, value)| {
            let at = format!("{name} {key}={value}");
            match build(name, &[(*key, value.as_str())]) {
                Err(e) => Some(format!("{at}: refused inside its documented range: {e}")),
                Ok(model) => first_problem(&model, &dirs, &uniforms).map(|p| format!("{at}: {p}")),
            }
        })
        .collect();
    assert!(failures.is_empty(), "{} parameter ends fail:\n{}", failures.len(), failures.join("\n"));
}

/// The first non-finite or negative value, bad sample, or sample whose pdf is not the pdf of
/// its direction, of `model` over the direction pairs and h = ±1, 0.3.
fn first_problem(model: &fiberlab_scatter::Model, dirs: &[DVec3], uniforms: &[[f64; 4]]) -> Option<String> {
    for &h in &[-1.0, 0.3, 1.0] {
        for &wi in dirs {
            for &wo in dirs {
                let (f, pdf) = (model.eval(wi, wo, h), model.pdf(wi, wo, h));
                if !(f.is_finite() && f.min_component() >= 0.0 && pdf.is_finite() && pdf >= 0.0) {
                    return Some(format!("f_s {f:?}, pdf {pdf} at {wi} {wo} h={h}"));
                }
            }
            for &u in uniforms {
                let Some(s) = model.sample(wi, h, u) else { continue };
                let finite =
                    s.weight.is_finite() && s.weight.min_component() >= 0.0 && s.pdf.is_finite() && s.pdf >= 0.0;
                if !finite || (s.wi.length() - 1.0).abs() >= UNIT_LENGTH_ABS {
                    return Some(format!("sample {s:?} for ωo {wi} h={h}"));
                }
                if !s.delta {
                    let q = model.pdf(s.wi, wi, h);
                    if (s.pdf - q).abs() > 1e-6 * q.max(1e-300) {
                        return Some(format!("sample pdf {} vs pdf {q} (ωo {wi}, h={h}, u {u:?})", s.pdf));
                    }
                }
            }
        }
    }
    None
}

/// Found by `finite_and_non_negative` (its seed is kept in `finite_everywhere.proptest-regressions`):
/// a `yan-fur` medulla absorbing so strongly (σ_m^a ≈ 8·10⁵ per unit radius) that the light
/// leaving it backward was a subnormal total, whose normalised θ_o profile came out 0/0. Every
/// lobe's value, the pdf and the samples must stay finite, the scattered lobes zero.
#[test]
fn yan_fur_with_a_medulla_that_absorbs_almost_everything_is_finite() {
    let pairs = [
        ("eta", "1.000001"),
        ("kappa", "0.9306615367862716"),
        ("sigma_m_s", "39.63684165682063"),
        ("sigma_m_a", "816549.3107473425"),
        ("g", "0.294156324848866"),
        ("layers", "0.000001"),
        ("alpha", "-20"),
        ("beta_m", "0.5"),
        ("beta_n", "0.5"),
        ("lobes", "r,tt,trt,tts,trts"),
        ("field", "near"),
    ];
    let model = build("yan-fur", &pairs).expect("inside every documented range");
    let dirs = [
        DVec3::new(0.192_959_805_150_644_84, 0.981_206_662_021_933_6, 0.0),
        direction(0.3, 2.0),
        direction(-1.2, -0.7),
    ];
    for &wi in &dirs {
        for &wo in &dirs {
            for h in [-1.0, 0.0, 0.3, 1.0] {
                let f = model.eval(wi, wo, h);
                let p = model.pdf(wi, wo, h);
                assert!(f.is_finite() && f.min_component() >= 0.0, "eval {f:?} at {wi:?} {wo:?} h={h}");
                assert!(p.is_finite() && p >= 0.0, "pdf {p} at {wi:?} {wo:?} h={h}");
            }
        }
        for u in [[0.1, 0.5, 0.9, 0.3], [0.99, 0.01, 0.5, 0.7]] {
            if let Some(s) = model.sample(wi, 0.0, u) {
                assert!(s.weight.is_finite() && s.pdf.is_finite(), "sample {:?} pdf {}", s.weight, s.pdf);
            }
        }
    }
}
