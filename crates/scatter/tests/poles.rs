//! Every model is finite on the fiber axis (θ = ±90°) and well-behaved toward it: along
//! directions that approach either pole, `f_s` and the pdf are finite and non-negative, and
//! the value on the axis itself follows from the approach by the one rule every model uses
//! instead of jumping: `cosθ` is taken as `MIN_COS` there, and the azimuth, undefined on the
//! axis, as `φ = atan2(0, 0) = 0` (so the approach runs along φ = 0). The models' own growth toward the
//! axis is at most `1/cosθ` for the pdf and `1/cos²θ` for `f_s` (Marschner's `1/cos²θ_d` on
//! the specular cone; `1/cosθ_i` for the backward-form hair models and Kajiya–Kay), so the
//! step from `cosθ = 1e−7` to the axis (`1e−8`) may grow the pdf by 10× and `f_s` by 100×,
//! never more (a slack factor of 2 for the finite steps).

use fiberlab_check::rng::TestRng;
use fiberlab_math::frame::direction;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::{MIN_COS, MODELS, ScatteringFunction, build};

/// Slack on top of the growth law, for the finite step from cosθ = 1e−7 to the axis.
const SLACK: f64 = 2.0;

/// A direction at `cos θ = c` from the pole of sign `pole` (θ = pole·(π/2 − asin c)), azimuth φ.
fn near_pole(pole: f64, c: f64, phi: f64) -> DVec3 {
    if c == 0.0 { DVec3::new(pole, 0.0, 0.0) } else { direction(pole * (std::f64::consts::FRAC_PI_2 - c.asin()), phi) }
}

fn largest(f: Rgb) -> f64 {
    f[0].max(f[1]).max(f[2])
}

#[test]
fn every_model_approaches_the_poles_without_jumping() {
    let mut checked = 0;
    for spec in MODELS {
        let m = build::<&str, &str>(spec.name, &[]).unwrap();
        checked += approach_the_poles(&m, spec.name);
    }
    assert_eq!(checked, MODELS.len() * 2 * 3 * 3 * 3);
}

/// The parameters that set a lobe's width (the narrowest lobes are where a pole could jump).
const ROUGHNESS_KEYS: [&str; 8] = ["beta_m", "beta_n", "beta_r", "beta", "roughness", "p", "gamma_s", "gamma_v"];

/// The same approach with each roughness at both ends of its documented range (closed ends
/// themselves; an open end's nearest representable value inside it).
#[test]
fn every_roughness_at_the_ends_of_its_range_approaches_the_poles_without_jumping() {
    use fiberlab_scatter::params::ParamKind;
    let mut configurations = 0;
    for spec in MODELS {
        for p in spec.params.iter().filter(|p| ROUGHNESS_KEYS.contains(&p.key)) {
            let ParamKind::Number(r) = p.kind else { continue };
            let ends = [
                if r.min_inclusive { r.min } else { r.min.next_up() },
                if !r.max.is_finite() {
                    1e12
                } else if r.max_inclusive {
                    r.max
                } else {
                    r.max.next_down()
                },
            ];
            for x in ends {
                let value = format!("{x:e}");
                let label = format!("{} {}={value}", spec.name, p.key);
                let m = build(spec.name, &[(p.key, value.as_str())]).unwrap_or_else(|e| panic!("{label}: {e}"));
                approach_the_poles(&m, &label);
                configurations += 1;
            }
        }
    }
    assert!(configurations >= 2 * 8, "{configurations} roughness ends");
}

/// Asserts the module's rule for `m` (named `label` in messages) toward both poles, with ω_i,
/// ω_o or both moving; returns the number of approaches checked.
fn approach_the_poles(m: &fiberlab_scatter::Model, label: &str) -> usize {
    let steps = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 0.0];
    let others = [direction(0.3, 0.4), direction(-0.9, 2.0), direction(1.2, -2.8)];
    let mut checked = 0;
    for pole in [1.0, -1.0] {
        for (k, &other) in others.iter().enumerate() {
            for h in [-1.0, 0.3, 1.0] {
                // The moving direction is ω_i, then ω_o; also both at once (ω_i → one
                // pole, ω_o → the other: the specular cone at grazing).
                for which in 0..3 {
                    let at = |c: f64| {
                        // On the axis the azimuth is undefined; every model reads it as
                        // φ = atan2(0, 0) = 0, so the approach runs along φ = 0.
                        let w = near_pole(pole, c, 0.0);
                        let (wi, wo) = match which {
                            0 => (w, other),
                            1 => (other, w),
                            _ => (w, near_pole(-pole, c, 0.0)),
                        };
                        (m.eval(wi, wo, h), m.pdf(wi, wo, h))
                    };
                    let values: Vec<(Rgb, f64)> = steps.iter().map(|&c| at(c)).collect();
                    for ((f, pdf), c) in values.iter().zip(steps) {
                        assert!(
                            f.is_finite() && pdf.is_finite() && f.min_component() >= 0.0 && *pdf >= 0.0,
                            "{label}: cosθ = {c}, pole {pole}, case {which}: f {f:?}, pdf {pdf}"
                        );
                    }
                    let (f_near, pdf_near) = values[values.len() - 2];
                    let (f_axis, pdf_axis) = values[values.len() - 1];
                    let ratio = 1e-7 / MIN_COS;
                    assert!(
                        largest(f_axis) <= SLACK * ratio * ratio * largest(f_near) + 1e-12,
                        "{label}: f_s jumps at the axis (pole {pole}, other {k}, case {which}, h {h}): {f_near:?} → {f_axis:?}"
                    );
                    assert!(
                        pdf_axis <= SLACK * ratio * pdf_near + 1e-12,
                        "{label}: the pdf jumps at the axis (pole {pole}, case {which}, h {h}): {pdf_near} → {pdf_axis}"
                    );
                    checked += 1;
                }
            }
        }
    }
    checked
}

/// `sample` near and on the axis gives finite samples whose pdf is `pdf` (the same rule).
#[test]
fn sampling_from_the_axis_agrees_with_pdf() {
    let mut rng = TestRng::new(11);
    for spec in MODELS {
        let m = build::<&str, &str>(spec.name, &[]).unwrap();
        for wo in [DVec3::X, -DVec3::X, near_pole(1.0, 1e-7, 0.2)] {
            for _ in 0..64 {
                let u = rng.u4();
                if let Some(s) = m.sample(wo, 0.3, u) {
                    assert!(s.weight.is_finite() && s.pdf.is_finite() && s.wi.is_finite(), "{}: {s:?}", spec.name);
                    if !s.delta {
                        let p = m.pdf(s.wi, wo, 0.3);
                        assert!(
                            (s.pdf - p).abs() <= 1e-6 * p.max(1e-300),
                            "{}: sample pdf {} vs pdf {p}",
                            spec.name,
                            s.pdf
                        );
                    }
                }
            }
        }
    }
}
