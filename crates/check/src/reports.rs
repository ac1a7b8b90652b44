//! Model-specific measurements printed by `fiberlab check` beside the generic tests:
//! Marschner's caustic positions, cubic-vs-exact root errors and albedo under both
//! normalizations; the hair models' light-side albedo at grazing light
//! (docs/theory/radiometry.md, "Backward-form models"); for `yan-fur`, the camera-side furnace
//! against its lobe masses and where the rest of the light goes (scattered in the
//! medulla, unscattered orders p ≥ 3, absorbed).

use crate::Row;
use crate::tolerance::{FURNACE_REL, ROUNDING_REL};
use fiberlab_math::frame::direction;
use fiberlab_scatter::marschner_2003::{albedo_table, caustic_table, cubic_azimuth_error_table};
use fiberlab_scatter::radiometry::{self, Quadrature};
use fiberlab_scatter::{Model, ScatteringFunction};

fn report(label: &str, test: String, value: f64) -> Row {
    Row { model: label.into(), test, value, expected: f64::NAN, tolerance: f64::NAN, pass: true, report: true }
}

/// Extra rows for `model` (empty for models without specific reports).
#[must_use]
pub fn model_reports(label: &str, model: &Model) -> Vec<Row> {
    let mut rows = Vec::new();
    match model {
        Model::Marschner(m) => {
            let p = m.params();
            let tds: Vec<f64> = [0.0f64, 10.0, 20.0, 30.0, 40.0, 45.0].iter().map(|d| d.to_radians()).collect();
            for c in caustic_table(p.eta, p.delta_eta, &tds) {
                let td = c.theta_d.to_degrees();
                rows.push(report(
                    label,
                    format!("TRT caustic φ_c exact θ_d={td:.0}° (deg)"),
                    c.exact.phi_c.to_degrees(),
                ));
                rows.push(report(
                    label,
                    format!("TRT caustic φ_c cubic θ_d={td:.0}° (deg)"),
                    c.cubic.phi_c.to_degrees(),
                ));
            }
            let hs: Vec<f64> = (0..=200).map(|k| -1.0 + k as f64 / 100.0).collect();
            for ep in [1.55, 1.7, 2.0, 3.0] {
                let table = cubic_azimuth_error_table(&[ep], &hs);
                for lobe in [1, 2] {
                    let worst = table.iter().filter(|r| r.p == lobe).map(|r| r.error.abs()).fold(0.0, f64::max);
                    let name = if lobe == 1 { "TT" } else { "TRT" };
                    rows.push(report(label, format!("max |Φ̂ − Φ| {name} η′={ep} (deg)"), worst.to_degrees()));
                }
            }
            let q = Quadrature { theta: 256, phi: 512, h: 1 };
            if let Ok(table) = albedo_table(p, &[0.0, 0.5, 1.0, 1.4], &q) {
                for r in table {
                    let t = r.theta_i;
                    rows.push(report(
                        label,
                        format!("albedo θ_i={t:.2} normalization=energy (lum.)"),
                        r.energy.luminance(),
                    ));
                    rows.push(report(
                        label,
                        format!("albedo θ_i={t:.2} normalization=paper (lum.)"),
                        r.paper.luminance(),
                    ));
                    // k_M = 1 vs ½: the paper-literal albedo is exactly twice the energy one.
                    let ratio = r.paper.luminance() / r.energy.luminance();
                    rows.push(Row {
                        model: label.into(),
                        test: format!("albedo paper/energy θ_i={t:.2}"),
                        value: ratio,
                        expected: 2.0,
                        tolerance: ROUNDING_REL,
                        pass: (ratio - 2.0).abs() <= ROUNDING_REL,
                        report: false,
                    });
                }
            }
        }
        Model::Chiang(_) | Model::Deon(_) => {
            let q = Quadrature::default();
            for t in [1.5f64, 1.55] {
                let rho = radiometry::albedo(model, direction(t, 0.0), &q);
                rows.push(report(label, format!("light-side albedo at grazing θ_i={t:.2} (lum.)"), rho.luminance()));
            }
        }
        Model::YanFur(fur) => {
            // Camera-side furnace = the enabled lobes' masses (A_p for R, TT, TRT, A_s·E for
            // TT^s, TRT^s: their densities are normalized); where the entering light goes:
            // scattered in the medulla (and how much of it TT^s + TRT^s return), orders p ≥ 3,
            // absorbed.
            let q = Quadrature::default();
            let enabled = fur.params().lobes;
            for (theta_o, h) in [(0.0f64, 0.0f64), (0.6, 0.6), (-1.1, -0.97)] {
                let wo = direction(theta_o, 0.4);
                let mut furnace = fiberlab_math::Rgb::ZERO;
                q.for_each_direction(|wi, dw| {
                    furnace += model.eval(wi, wo, h) * (fiberlab_math::frame::cos_theta(wi) * dw);
                });
                let b = fur.energy_budget(theta_o, h);
                let masses = [b.lobes[0], b.lobes[1], b.lobes[2], b.scattered_lobes[0], b.scattered_lobes[1]];
                let lobes = (0..5).filter(|&p| enabled[p]).map(|p| masses[p].luminance()).sum::<f64>();
                let err = (furnace.luminance() - lobes).abs() / lobes.max(1e-300);
                rows.push(Row {
                    model: label.into(),
                    test: format!("furnace θ_o={theta_o:.2} h={h} = Σ lobe masses (lum.)"),
                    value: furnace.luminance(),
                    expected: lobes,
                    tolerance: FURNACE_REL,
                    pass: err <= FURNACE_REL,
                    report: false,
                });
                for (what, x) in [
                    ("scattered in the medulla", b.scattered),
                    ("returned by TTs+TRTs", b.scattered_lobes[0] + b.scattered_lobes[1]),
                    ("unscattered orders p≥3", b.higher_orders),
                    ("absorbed", b.absorbed),
                ] {
                    rows.push(report(label, format!("{what} θ_o={theta_o:.2} h={h} (lum.)"), x.luminance()));
                }
            }
        }
        _ => {}
    }
    rows
}
