//! The one width average (`ScatteringFunction::eval_far`): for every near-field model, with its
//! defaults and with narrow azimuthal lobes, the default rule agrees with a 2048-node rule of the
//! same kind (1024 panels) and with a 20000-cell midpoint rule in `h` (an independent
//! discretisation); a far-field model's width average is its value.

use fiberlab_math::frame::direction;
use fiberlab_math::quadrature::width_nodes;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::{Field, MODELS, Model, ScatteringFunction, build};

fn directions() -> Vec<(DVec3, DVec3)> {
    let mut out = Vec::new();
    for (ti, pi) in [(0.1, 0.0), (-0.7, 1.0), (1.2, -2.0)] {
        for (to, po) in [(0.3, 0.4), (-0.2, 2.9), (0.9, -1.3), (-1.3, 3.1)] {
            out.push((direction(ti, pi), direction(to, po)));
        }
    }
    out
}

fn reference(model: &Model, wi: DVec3, wo: DVec3) -> Rgb {
    width_nodes(1024).iter().fold(Rgb::ZERO, |s, &(h, w)| s + model.eval(wi, wo, h) * w)
}

fn midpoint_in_h(model: &Model, wi: DVec3, wo: DVec3) -> Rgb {
    let n = 20_000;
    (0..n).fold(Rgb::ZERO, |s, k| s + model.eval(wi, wo, -1.0 + (k as f64 + 0.5) * 2.0 / n as f64)) / n as f64
}

#[test]
fn eval_far_is_the_width_average_of_every_near_field_model() {
    let mut models: Vec<(String, Model)> = MODELS
        .iter()
        .filter_map(|spec| {
            let m = build(spec.name, &[] as &[(&str, &str)]).ok()?;
            Some((spec.name.to_string(), m))
        })
        .collect();
    for beta_n in ["0.2", "0.5"] {
        models.push((format!("chiang beta_n={beta_n}"), build("chiang", &[("beta_n", beta_n)]).unwrap()));
    }
    let mut checked = 0;
    for (name, model) in &models {
        for (wi, wo) in directions() {
            let far = model.eval_far(wi, wo);
            let scale = reference(model, wi, wo).max_component().max(1e-6);
            if model.properties().field == Field::Far {
                assert_eq!(far, model.eval(wi, wo, 0.0), "{name}: a far-field model's average is its value");
                continue;
            }
            for (what, want) in
                [("2048-node rule", reference(model, wi, wo)), ("midpoints in h", midpoint_in_h(model, wi, wo))]
            {
                for c in 0..3 {
                    assert!(
                        (far[c] - want[c]).abs() <= 2e-3 * scale,
                        "{name}: eval_far {far:?} vs {what} {want:?} at {wi} {wo}"
                    );
                }
            }
            checked += 1;
        }
    }
    assert!(checked >= 3 * 12, "near-field models were checked ({checked} cases)");
}
