//! The validation harness: every claim a scattering model makes, tested the same way for
//! every model (statrs' `check_continuous_distribution`, Mitsuba's `chi2.py`).
//!
//! [`check_model`] runs, for one configured model: finiteness and non-negativity sweeps
//! (including θ = ±π/2 and h = ±1), the light-side albedo by quadrature against closed forms
//! of docs/theory/radiometry.md ([`expected`]), the energy bound when claimed, the
//! camera-side furnace by quadrature against Monte Carlo of `sample()`, reciprocity (tested
//! when claimed, measured and reported otherwise), `∫ pdf dω = 1`, `sample()` agreeing with
//! `eval()`/`pdf()`, and a χ² goodness-of-fit test of `sample()` against `pdf()`. What each
//! test asserts and how it relates to upstream tests: docs/theory/validation.md. It stops at
//! reporting: printing and exit codes belong to the CLI.
#![forbid(unsafe_code)]

pub mod chi2;
pub mod expected;
pub mod reports;
pub mod rng;
pub mod surface;
pub mod tolerance;

use chi2::{Chi2Config, Pole, chi2_cone, chi2_test};
use fiberlab_math::frame::{cos_theta, direction, theta};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::radiometry::{self, Quadrature};
use fiberlab_scatter::{Field, Lobes, Model, ModelError, ScatteringFunction, build};
use rayon::prelude::*;
use rng::TestRng;
use serde::Serialize;
use tolerance::*;

/// One line of the check table.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Model configuration label, e.g. `specular azimuth=mirror fresnel=on`.
    pub model: String,
    /// What was tested.
    pub test: String,
    /// Measured value.
    pub value: f64,
    /// Expected value (NaN for report-only rows).
    pub expected: f64,
    /// Allowed deviation (meaning depends on the test; NaN for report-only rows).
    pub tolerance: f64,
    /// Whether the test passed (report-only rows always pass).
    pub pass: bool,
    /// True for measurements reported without a pass/fail claim.
    pub report: bool,
}

/// A model configuration to check: registry name and `key=value` parameters.
#[derive(Clone, Debug)]
pub struct CheckCase {
    /// Registry name.
    pub model: String,
    /// Parameters.
    pub params: Vec<(String, String)>,
}

impl CheckCase {
    /// A case from a name and `key=value` pairs.
    #[must_use]
    pub fn new(model: &str, params: &[(&str, &str)]) -> Self {
        Self { model: model.into(), params: params.iter().map(|(k, v)| ((*k).into(), (*v).into())).collect() }
    }

    /// `name key=value …`.
    #[must_use]
    pub fn label(&self) -> String {
        let mut s = self.model.clone();
        for (k, v) in &self.params {
            s.push_str(&format!(" {k}={v}"));
        }
        s
    }

    /// Builds the model.
    pub fn build(&self) -> Result<Model, ModelError> {
        build(&self.model, &self.params)
    }
}

/// The configurations `fiberlab check` validates: every registered model (fiber and
/// surface) with its defaults, plus the variants whose claims differ (white furnace,
/// Fresnel, exponents, presets, finishes).
#[must_use]
pub fn default_cases() -> Vec<CheckCase> {
    let mut cases: Vec<CheckCase> = fiberlab_scatter::MODELS.iter().map(|m| CheckCase::new(m.name, &[])).collect();
    cases.extend(fiberlab_scatter::SURFACE_MODELS.iter().map(|m| CheckCase::new(m.name, &[])));
    cases.extend([
        CheckCase::new("lambertian", &[("k_d", "1")]),
        CheckCase::new("wood", &[("preset", "tigers-eye")]),
        CheckCase::new("wood", &[("preset", "cats-eye")]),
        CheckCase::new("wood", &[("roughness", "0.2")]),
        CheckCase::new("wood", &[("fiber_angle", "40"), ("fiber_dip", "30"), ("beta", "5")]),
        CheckCase::new("wood", &[("k_d", "0"), ("k_f", "0.159"), ("roughness", "0.1"), ("fiber_dip", "-20")]),
        CheckCase::new("wood", &[("eta", "1"), ("k_f", "0"), ("k_d", "1")]),
        CheckCase::new("leaf", &[("roughness", "0.15"), ("anth", "15"), ("n", "2.5")]),
        CheckCase::new("leaf", &[("roughness", "1"), ("cab", "0"), ("car", "0"), ("cw", "0"), ("cm", "0")]),
    ]);
    // Every fabric of Sadeghi et al. 2013's table (the default, linen-plain, is above).
    cases.extend(
        fiberlab_scatter::sadeghi_2013::SADEGHI_PRESETS[1..]
            .iter()
            .map(|&name| CheckCase::new("sadeghi-2013", &[("preset", name)])),
    );
    cases.push(CheckCase::new(
        "sadeghi-thread",
        &[("eta", "1.345"), ("k_d", "0.1"), ("gamma_s", "4"), ("gamma_v", "8")],
    ));
    cases.extend([
        CheckCase::new("diffuse", &[("albedo", "1")]),
        CheckCase::new("diffuse", &[("albedo", "0.2,0.5,0.9")]),
        CheckCase::new("lambertian-cylinder", &[("albedo", "1")]),
        CheckCase::new("specular", &[("azimuth", "mirror"), ("fresnel", "on")]),
        CheckCase::new("specular", &[("azimuth", "uniform"), ("fresnel", "off")]),
        CheckCase::new("specular", &[("azimuth", "uniform"), ("fresnel", "on"), ("eta", "1.33")]),
        CheckCase::new("kajiya-kay", &[("k_d", "0"), ("k_s", "1"), ("p", "10")]),
        CheckCase::new("kajiya-kay", &[("k_d", "0.02"), ("k_s", "0.3"), ("p", "100")]),
        CheckCase::new("goldman", &[("rho_reflect", "0.9,0.6,0.3"), ("rho_transmit", "0.2")]),
        CheckCase::new("marschner", &[("sigma_a", "0"), ("glints", "off")]),
        CheckCase::new("marschner", &[("roots", "cubic"), ("normalization", "paper")]),
        CheckCase::new("marschner", &[("eccentricity", "0.85"), ("sigma_a", "0")]),
        CheckCase::new("chiang", &[("sigma_a", "0")]),
        CheckCase::new("chiang", &[("sigma_a", "0"), ("alpha", "0"), ("beta_m", "0.5"), ("beta_n", "0.7")]),
        CheckCase::new("chiang", &[("color", "0.6,0.4,0.2"), ("beta_m", "0.4"), ("beta_n", "0.4")]),
        CheckCase::new("hollow-fiber", &[("kappa", "0.9"), ("beta_m", "0.1"), ("beta_n", "0.1")]),
        CheckCase::new("hollow-fiber", &[("sigma_a", "0.4,0.8,1.5"), ("alpha", "3"), ("kappa", "0.3")]),
        CheckCase::new("hollow-fiber", &[("lumen_eta", "2.5"), ("kappa", "0.7"), ("lobes", "tt,residual")]),
        CheckCase::new("deon", &[("sigma_a", "0")]),
        CheckCase::new("deon", &[("eumelanin", "0.3"), ("theta_n", "difference")]),
        CheckCase::new("yan-fur", &[("beta_m", "4"), ("beta_n", "5"), ("kappa", "0.8"), ("sigma_m_s", "3")]),
        CheckCase::new("yan-fur", &[("beta_m", "30"), ("beta_n", "40"), ("layers", "0.5"), ("color", "0.7,0.5,0.3")]),
        CheckCase::new("yan-fur", &[("sigma_c_a", "0"), ("sigma_m_s", "0"), ("kappa", "0"), ("alpha", "0")]),
        CheckCase::new("yan-fur", &[("sigma_c_a", "0"), ("kappa", "0.8"), ("sigma_m_s", "2")]),
        CheckCase::new("huang-2022", &[("aspect", "1"), ("sigma_a", "0"), ("alpha", "0")]),
        CheckCase::new(
            "huang-2022",
            &[("roughness", "0.1"), ("aspect", "0.7"), ("orientation", "30"), ("eumelanin", "0.3")],
        ),
        CheckCase::new(
            "huang-2022",
            &[
                ("roughness", "1"),
                ("orientation", "average"),
                ("color", "0.6,0.4,0.2"),
                ("reflection", "2"),
                ("transmission", "0.5"),
                ("alpha", "-20"),
            ],
        ),
    ]);
    cases
}

/// How thoroughly to check (the test suite and `fiberlab check` use the default).
#[derive(Clone, Copy, Debug)]
pub struct Effort {
    /// Samples per χ² case.
    pub chi2_samples: usize,
    /// Samples per sample-consistency and Monte Carlo furnace case.
    pub samples: usize,
    /// Random direction pairs for finiteness and reciprocity.
    pub pairs: usize,
}

impl Default for Effort {
    fn default() -> Self {
        Self { chi2_samples: 500_000, samples: 100_000, pairs: 20_000 }
    }
}

/// Viewer directions used by the per-direction tests (θ_o from normal to grazing on either
/// side: 1.555 rad is 0.9° from the fiber axis).
const WO_THETAS: [f64; 6] = [0.0, 0.6, -1.1, 1.45, 1.555, -1.555];
/// Viewers (indices into [`WO_THETAS`]) whose χ² runs on the grid about the fiber normal
/// ([`chi2::Pole::Normal`]), the orientation of a renderer's shading frame, where the fiber
/// axis is a point inside a cell: a sampling density that is infinite per steradian on the
/// axis (a lobe truncated there) shows as a deficit of that grid's `∫pdf` and a rejection.
const NORMAL_POLE_VIEWERS: [usize; 2] = [4, 5];
/// Models (every configuration) or configurations (a case's full label, as `fiberlab check`
/// prints it) whose rows on the grid about the fiber normal are reported, not enforced (their χ²
/// at the grazing viewers is enforced on the fiber-axis grid instead). `yan-fur`: its
/// medulla-scattered lobes draw φ from tables and then θ_i given φ, so near the axis their
/// density, finite since the pole taper, still depends on φ (discontinuous at the axis), which
/// that grid does not resolve: with β_m = 4°, β_n = 5° its ∫pdf there is 1.004 at θ_o = 1.555
/// (h = 0.8), and the default's χ² at θ_o = −1.555 gives p = 7e−4. `hollow-fiber` with κ = 0.9,
/// β_m = β_n = 0.1 (its other cases, β = 0.3, are enforced: ∫pdf 1.0001–1.0005): its ∫pdf on that grid is 1.035 at θ_o = 1.555 (h = 0.8) and 0.991 at
/// θ_o = −1.555 (h = −0.2), χ² p = 2e−6. Not its sampler's θ_i: d'Eon's `M_p` is a density per
/// steradian, finite on the axis (`hollow_fiber.rs` in scatter's tests,
/// `grazing_viewers_have_a_pdf_finite_at_the_axis_and_bounded_weights`), and drawing θ_i through
/// the pole taper left the grid off (0.989, 0.998) and raised the largest weight from 1 to 139.
/// The cause is the lobes themselves: 0.9° from the axis with β_m = 0.1 most of the mass lies
/// within 5° of it, where the grid's nodes do not resolve the azimuthal lobe `N_q` (β_n = 0.1),
/// which `eval` has too. `chiang` with β_m = β_n = 0.1 (not among its cases) gives 1.029 and
/// 0.995 there; β_n = 0.3 gives 1.006–1.007 for either model, β_m = 0.3 1.003.
const NORMAL_POLE_REPORTED: [&str; 2] = ["yan-fur", "hollow-fiber kappa=0.9 beta_m=0.1 beta_n=0.1"];
/// Models whose camera-side furnace at the grazing viewers ([`NORMAL_POLE_VIEWERS`]) is
/// reported, not enforced, against the default quadrature. `measured`: a table is a staircase
/// in θ_i whose steps (bin edges moved along the cone) crowd toward the axis at a grazing
/// viewer, and the default 256 × 512 midpoint rule integrates it 0.6 % high there (a table of
/// Kajiya–Kay, 90 × 72 bins, θ_o = ±1.555: 0.24898 against 0.247534 from a rule 36× finer,
/// which the Monte Carlo estimate, 0.24760, agrees with). The model's own test
/// `measured::tests::grazing_furnace_and_pdf_by_a_fine_rule` enforces both at these viewers.
const GRAZING_QUADRATURE_REPORTED: [&str; 1] = ["measured"];
/// Light inclinations of the albedo table.
pub const ALBEDO_THETAS: [f64; 4] = [0.0, 0.5, 1.0, 1.4];

/// The (viewer index, h) pairs of the per-direction tests: far-field models at h = 0;
/// near-field models pair each viewer with a different offset, from the axis to the edge.
fn direction_cases(f: &impl ScatteringFunction) -> Vec<(usize, f64)> {
    if f.properties().field == Field::Near {
        vec![(0, 0.0), (1, 0.6), (2, -0.97), (3, 0.3), (1, -0.4), (4, 0.8), (5, -0.2)]
    } else {
        (0..WO_THETAS.len()).map(|k| (k, 0.0)).collect()
    }
}

/// Relative difference, robust to zeros.
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(1e-300)
}

fn max_rel(a: Rgb, b: Rgb) -> f64 {
    (0..3).map(|c| if a[c] == b[c] { 0.0 } else { rel(a[c], b[c]) }).fold(0.0, f64::max)
}

/// Runs every applicable test on `f`, labelling rows with `label`.
pub fn check_model(label: &str, f: &Model, effort: &Effort) -> Vec<Row> {
    let props = f.properties();
    let mut t = Table { label, rows: Vec::new() };
    // The registry name, the label's first word ("measured (tabulated KK)" → "measured").
    let model_name = label.split_whitespace().next().unwrap_or("");
    let mut rng = TestRng::new(0x5eed);
    let wos: Vec<DVec3> = WO_THETAS.iter().enumerate().map(|(k, &t)| direction(t, 0.4 + 1.3 * k as f64)).collect();

    // 1. finiteness and non-negativity, random and extreme arguments
    let (nonfinite, negative) = finiteness(f, effort.pairs, &mut rng);
    t.test("finite eval/pdf/sample (bad count)".into(), nonfinite as f64, 0.0, 0.0, nonfinite == 0);
    t.test("non-negative eval/pdf (bad count)".into(), negative as f64, 0.0, 0.0, negative == 0);

    // 2. light-side albedo against closed forms; energy bound when claimed (a model with
    // neither gets its albedo reported, on a coarser grid)
    let q = Quadrature::default();
    let claimed = props.energy_conserving || ALBEDO_THETAS.iter().any(|&t| expected::albedo(f, t).is_some());
    let q_albedo = if claimed { q } else { REPORT_QUADRATURE };
    let mut max_albedo: f64 = 0.0;
    for &ti in &ALBEDO_THETAS {
        let wi = direction(ti, 0.3);
        let rho = radiometry::albedo(f, wi, &q_albedo);
        max_albedo = max_albedo.max(rho.max_component());
        match expected::albedo(f, ti) {
            Some(e) => {
                let err = max_rel(rho, e);
                t.test(
                    format!("light-side albedo θ_i={ti:.2} (luminance)"),
                    rho.luminance(),
                    e.luminance(),
                    ALBEDO_REL,
                    err <= ALBEDO_REL,
                )
            }
            None => t.report(format!("light-side albedo θ_i={ti:.2} (luminance)"), rho.luminance()),
        }
    }
    if props.energy_conserving {
        t.test(
            "energy bound max ρ ≤ 1".into(),
            max_albedo,
            1.0,
            ENERGY_BOUND_SLACK,
            max_albedo <= 1.0 + ENERGY_BOUND_SLACK,
        );
    }

    // 3. camera-side furnace: quadrature of eval vs Monte Carlo of sample weights
    for (k, h) in direction_cases(f) {
        let wo = wos[k];
        let quad = furnace_at(f, wo, h, &q);
        let (mc, se) = mc_furnace(f, wo, h, effort.samples, &mut rng);
        if let Some(e) = expected::camera_furnace(f) {
            let err = max_rel(quad, e);
            t.test(
                format!("white furnace θ_o={:.3} h={h} (quadrature)", WO_THETAS[k]),
                quad.luminance(),
                e.luminance(),
                FURNACE_REL,
                err <= FURNACE_REL,
            );
        }
        let tol = MC_SIGMAS * se.luminance() + MC_QUADRATURE_REL * quad.luminance().abs() + ROUNDING_REL;
        let pass = (mc.luminance() - quad.luminance()).abs() <= tol;
        let test = format!("furnace θ_o={:.3} h={h}: MC vs quadrature", WO_THETAS[k]);
        if NORMAL_POLE_VIEWERS.contains(&k) && GRAZING_QUADRATURE_REPORTED.contains(&model_name) {
            t.report(
                format!("{test} (reported: GRAZING_QUADRATURE_REPORTED; quadrature {:.6})", quad.luminance()),
                mc.luminance(),
            );
        } else {
            t.test(test, mc.luminance(), quad.luminance(), tol, pass);
        }
    }

    // 4. reciprocity (a model that does not claim it gets a report at the cost of the default
    // width rule: fewer pairs when its width average takes more nodes, as huang-2022's 1024)
    let panels = fiberlab_math::quadrature::width_panels(f.width_feature());
    let recip_pairs = if props.reciprocal || props.field == Field::Far {
        effort.pairs / 4
    } else {
        (effort.pairs / 4 * fiberlab_math::quadrature::WIDTH_PANELS / panels).max(200)
    };
    let (recip, recip_samples) = reciprocity(f, recip_pairs, &mut rng);
    if props.reciprocal {
        t.test("reciprocity max relative defect".into(), recip, 0.0, RECIPROCITY_REL, recip <= RECIPROCITY_REL);
    } else {
        t.report("non-reciprocity max relative (report)".into(), recip);
        if let Model::KajiyaKay(kk) = f {
            let defect = kajiya_kay_ratio_defect(kk, &recip_samples);
            t.test(
                "non-reciprocity = cosθ_r/cosθ_i (max rel. error)".into(),
                defect,
                0.0,
                ROUNDING_REL,
                defect <= ROUNDING_REL,
            );
        }
    }

    // 5–7. pdf normalization, sample consistency, χ²
    let cases = direction_cases(f);
    let alpha = CHI2_SIGNIFICANCE / cases.len() as f64;
    let normal_reported = NORMAL_POLE_REPORTED.iter().any(|&r| r == model_name || r == label);
    let results: Vec<_> = cases
        .par_iter()
        .map(|&(k, h)| {
            let wo = wos[k];
            let integral = pdf_integral(f, wo, h);
            let grazing = NORMAL_POLE_VIEWERS.contains(&k) && props.lobes != Lobes::Delta;
            let normal_integral = grazing.then(|| normal_pole_pdf_integral(f, wo, h));
            let chi2_config =
                |pole| Chi2Config { samples: effort.chi2_samples, seed: 99 + k as u64, pole, ..Default::default() };
            let normal_chi2 = (grazing && normal_reported).then(|| chi2_test(f, wo, h, &chi2_config(Pole::Normal)));
            let consistency = sample_consistency(f, wo, h, effort.samples / 5, 17 + k as u64);
            let outcome = if props.lobes == Lobes::Delta {
                chi2_cone(f, wo, 180, effort.chi2_samples, 99 + k as u64)
            } else {
                let pole = if grazing && !normal_reported { Pole::Normal } else { Pole::FiberAxis };
                chi2_test(f, wo, h, &chi2_config(pole))
            };
            (k, h, integral, normal_integral, normal_chi2, consistency, outcome)
        })
        .collect();
    for (k, h, integral, normal_integral, normal_chi2, consistency, outcome) in results {
        let th = WO_THETAS[k];
        t.test(
            format!("∫pdf dω θ_o={th:.3} h={h}"),
            integral,
            1.0,
            PDF_INTEGRAL_ABS,
            (integral - 1.0).abs() <= PDF_INTEGRAL_ABS,
        );
        if let Some(integral) = normal_integral {
            let test = format!("∫pdf dω θ_o={th:.3} h={h}, grid about the fiber normal");
            if normal_reported {
                t.report(format!("{test} (reported: NORMAL_POLE_REPORTED)"), integral);
            } else {
                t.test(
                    test,
                    integral,
                    1.0,
                    NORMAL_POLE_PDF_INTEGRAL_ABS,
                    (integral - 1.0).abs() <= NORMAL_POLE_PDF_INTEGRAL_ABS,
                );
            }
        }
        if let Some(o) = normal_chi2 {
            t.report(
                format!("χ² p-value θ_o={th:.3} h={h}, grid about the fiber normal (reported: NORMAL_POLE_REPORTED)"),
                o.p_value,
            );
        }
        t.test(
            format!("sample vs eval/pdf θ_o={th:.3} h={h} (max rel.)"),
            consistency,
            0.0,
            SAMPLE_CONSISTENCY_REL,
            consistency <= SAMPLE_CONSISTENCY_REL,
        );
        let on_normal_grid = NORMAL_POLE_VIEWERS.contains(&k) && props.lobes != Lobes::Delta && !normal_reported;
        let grid = if on_normal_grid { ", grid about the fiber normal" } else { "" };
        t.test(
            format!(
                "χ² p-value θ_o={th:.3} h={h}{grid} (dof {}, impossible {}, unresolved cells {})",
                outcome.dof, outcome.impossible, outcome.untrusted
            ),
            outcome.p_value,
            alpha,
            alpha,
            outcome.passes(alpha),
        );
    }
    t.rows.extend(reports::model_reports(label, f));
    t.rows
}

/// Rows of one model under construction.
struct Table<'a> {
    label: &'a str,
    rows: Vec<Row>,
}

impl Table<'_> {
    fn test(&mut self, test: String, value: f64, expected: f64, tolerance: f64, pass: bool) {
        self.rows.push(Row { model: self.label.into(), test, value, expected, tolerance, pass, report: false });
    }

    fn report(&mut self, test: String, value: f64) {
        let nan = f64::NAN;
        self.rows.push(Row {
            model: self.label.into(),
            test,
            value,
            expected: nan,
            tolerance: nan,
            pass: true,
            report: true,
        });
    }
}

/// Checks every case (in parallel); a case whose model fails to build yields a failing row.
#[must_use]
pub fn check_cases(cases: &[CheckCase], effort: &Effort) -> Vec<Row> {
    check_cases_with_progress(cases, effort, || {})
}

/// [`check_cases`], calling `done` after each case finishes (for progress bars).
pub fn check_cases_with_progress(cases: &[CheckCase], effort: &Effort, done: impl Fn() + Sync) -> Vec<Row> {
    check_cases_until(cases, effort, done, &std::sync::atomic::AtomicBool::new(false))
}

/// [`check_cases_with_progress`] that starts no case once `stop` is set (a signal handler's
/// flag): the rows of the cases finished (and of those in flight, which run to their end).
pub fn check_cases_until(
    cases: &[CheckCase],
    effort: &Effort,
    done: impl Fn() + Sync,
    stop: &std::sync::atomic::AtomicBool,
) -> Vec<Row> {
    cases
        .par_iter()
        .flat_map(|case| {
            if stop.load(std::sync::atomic::Ordering::Relaxed) {
                return Vec::new();
            }
            let rows = check_case(case, effort);
            done();
            rows
        })
        .collect()
}

/// Checks one case (a fiber or a surface model, by the registry that holds its name); a
/// model that fails to build yields a failing row.
#[must_use]
pub fn check_case(case: &CheckCase, effort: &Effort) -> Vec<Row> {
    let rows = match fiberlab_scatter::lookup(&case.model).map(|e| e.kind()) {
        Ok(fiberlab_scatter::ModelKind::Surface) => fiberlab_scatter::build_surface(&case.model, &case.params)
            .map(|m| surface::check_surface_model(&case.label(), &m, effort)),
        _ => case.build().map(|m| check_model(&case.label(), &m, effort)),
    };
    match rows {
        Ok(rows) => rows,
        Err(e) => vec![Row {
            model: case.label(),
            test: format!("build: {e}"),
            value: f64::NAN,
            expected: f64::NAN,
            tolerance: f64::NAN,
            pass: false,
            report: false,
        }],
    }
}

/// Counts non-finite and negative results over random and extreme arguments.
pub fn finiteness(f: &impl ScatteringFunction, pairs: usize, rng: &mut TestRng) -> (usize, usize) {
    let extremes = [
        DVec3::X,
        -DVec3::X,
        DVec3::Y,
        -DVec3::Z,
        direction(std::f64::consts::FRAC_PI_2 - 1e-12, 0.3),
        direction(-std::f64::consts::FRAC_PI_2 + 1e-12, -2.0),
        direction(0.0, std::f64::consts::PI),
    ];
    let hs = [-1.0, -0.999999, 0.0, 0.5, 1.0];
    let (mut nonfinite, mut negative) = (0, 0);
    let mut test = |wi: DVec3, wo: DVec3, h: f64, u: [f64; 4]| {
        let v = f.eval(wi, wo, h);
        let p = f.pdf(wi, wo, h);
        if !v.is_finite() || !p.is_finite() {
            nonfinite += 1;
        }
        if v.min_component() < 0.0 || p < 0.0 {
            negative += 1;
        }
        if let Some(s) = f.sample(wo, h, u) {
            if !s.weight.is_finite()
                || !s.pdf.is_finite()
                || !s.wi.is_finite()
                || (s.wi.length() - 1.0).abs() > UNIT_LENGTH_ABS
            {
                nonfinite += 1;
            }
            if s.weight.min_component() < 0.0 || s.pdf < 0.0 {
                negative += 1;
            }
        }
    };
    for &a in &extremes {
        for &b in &extremes {
            for &h in &hs {
                for u in [[0.0; 4], [0.999_999_999; 4], [0.5, 0.0, 0.999_999, 0.25]] {
                    test(a, b, h, u);
                }
            }
        }
    }
    for _ in 0..pairs {
        let (wi, wo) = (rng.sphere_direction(), rng.sphere_direction());
        let h = rng.offset();
        test(wi, wo, h, rng.u4());
    }
    (nonfinite, negative)
}

/// Camera-side furnace at a fixed h: `∫ f_s(ω_i, ω_o; h) cosθ_i dω_i` by quadrature.
fn furnace_at(f: &Model, wo: DVec3, h: f64, q: &Quadrature) -> Rgb {
    if f.properties().lobes == Lobes::Delta {
        return radiometry::furnace(f, wo, q);
    }
    let mut sum = Rgb::ZERO;
    q.for_each_direction(|wi, dw| sum += f.eval(wi, wo, h) * (cos_theta(wi) * dw));
    sum
}

/// Mean sample weight (camera-side furnace) with its standard error.
fn mc_furnace(f: &Model, wo: DVec3, h: f64, n: usize, rng: &mut TestRng) -> (Rgb, Rgb) {
    let (mut s, mut s2) = (Rgb::ZERO, Rgb::ZERO);
    for _ in 0..n {
        if let Some(x) = f.sample(wo, h, rng.u4()) {
            s += x.weight;
            s2 += x.weight * x.weight;
        }
    }
    let m = s / n as f64;
    (m, ((s2 / n as f64 - m * m).map(|v| v.max(0.0)) / n as f64).map(f64::sqrt))
}

/// Max relative reciprocity defect of the (h-averaged) f_s over random pairs; also returns
/// the pairs with their two values for model-specific analysis. `fiberlab check` calls it
/// with `Effort::pairs / 4` pairs from `TestRng::new(0x5eed)` after the finiteness sweep; the
/// explorer's read-out with a fresh generator.
pub fn reciprocity(f: &Model, pairs: usize, rng: &mut TestRng) -> (f64, Vec<(DVec3, DVec3, Rgb, Rgb)>) {
    let eval_avg = |a: DVec3, b: DVec3| f.eval_far(a, b);
    let mut worst: f64 = 0.0;
    let mut samples = Vec::with_capacity(pairs);
    for _ in 0..pairs {
        let (wi, wr) = (rng.sphere_direction(), rng.sphere_direction());
        let (a, b) = (eval_avg(wi, wr), eval_avg(wr, wi));
        if a.max_component() > 1e-12 || b.max_component() > 1e-12 {
            worst = worst.max(max_rel(a, b));
        }
        samples.push((wi, wr, a, b));
    }
    (worst, samples)
}

/// Kajiya–Kay: `(f(i,r) − k_d)/(f(r,i) − k_d)` must equal `cosθ_r/cosθ_i`
/// (docs/theory/radiometry.md, "Reciprocity ratio").
fn kajiya_kay_ratio_defect(
    kk: &fiberlab_scatter::kajiya_kay_1989::KajiyaKay,
    pairs: &[(DVec3, DVec3, Rgb, Rgb)],
) -> f64 {
    let mut worst: f64 = 0.0;
    for &(wi, wr, a, b) in pairs {
        let (sa, sb) = (a - kk.k_d(), b - kk.k_d());
        if sa.max_component() > 1e-6 && sb.max_component() > 1e-6 && cos_theta(wi) > 1e-3 && cos_theta(wr) > 1e-3 {
            let predicted = expected::kajiya_kay_reciprocity_ratio(cos_theta(wi), cos_theta(wr));
            worst = worst.max(rel(sa.luminance() / sb.luminance(), predicted));
        }
    }
    worst
}

/// `∫ pdf(ω_i | ω_o, h) dω_i` on a fine midpoint grid (delta models: `∫ n(φ) dφ`).
pub fn pdf_integral(f: &impl ScatteringFunction, wo: DVec3, h: f64) -> f64 {
    if f.properties().lobes == Lobes::Delta {
        let n = 20_000;
        let t = theta(wo);
        return (0..n)
            .map(|j| {
                f.cone(t, -std::f64::consts::PI + (j as f64 + 0.5) * std::f64::consts::TAU / n as f64).pdf
                    * std::f64::consts::TAU
                    / n as f64
            })
            .sum();
    }
    let q = Quadrature { theta: 512, phi: 768, h: 1 };
    let mut sum = 0.0;
    q.for_each_direction(|wi, dw| sum += f.pdf(wi, wo, h) * dw);
    sum
}

/// `∫ pdf(ω_i | ω_o, h) dω_i` by the plain midpoint rule on a grid about the fiber normal
/// ([`Pole::Normal`]: 96 × 192 cells of 4 × 4 nodes, uniform in `ω·w` and the azimuth about
/// `w`), where the fiber axis is a point inside the grid: a pdf that is finite per steradian
/// integrates to 1 here as on the fiber-axis grid; one that grows like `1/cosθ_i` toward the
/// axis does not.
pub fn normal_pole_pdf_integral(f: &impl ScatteringFunction, wo: DVec3, h: f64) -> f64 {
    let cfg = Chi2Config { bins_theta: 96, bins_phi: 192, sub: 4, pole: Pole::Normal, ..Default::default() };
    chi2::expected_masses(f, wo, h, &cfg).iter().sum()
}

/// Max relative disagreement of `sample()` with `pdf()` and `eval()·cosθ_i/pdf`.
pub fn sample_consistency(f: &impl ScatteringFunction, wo: DVec3, h: f64, n: usize, seed: u64) -> f64 {
    let mut rng = TestRng::new(seed);
    let delta = f.properties().lobes == Lobes::Delta;
    let mut worst: f64 = 0.0;
    for _ in 0..n {
        let Some(s) = f.sample(wo, h, rng.u4()) else { continue };
        if delta {
            let c = f.cone(theta(wo), fiberlab_math::relative_phi(s.wi, wo));
            worst = worst.max(max_rel(s.weight, c.value / c.pdf));
        } else {
            let pdf = f.pdf(s.wi, wo, h);
            worst = worst.max(rel(s.pdf, pdf));
            if pdf > 0.0 {
                worst = worst.max(max_rel(s.weight, f.eval(s.wi, wo, h) * (cos_theta(s.wi) / pdf)));
            }
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each entry of the lists of reported rows names a registered model or the label of a
    /// default case, so that renaming a case's parameters cannot silently enforce its rows.
    #[test]
    fn every_reported_entry_names_a_model_or_a_default_case() {
        let cases = default_cases();
        for entry in NORMAL_POLE_REPORTED.iter().chain(&GRAZING_QUADRATURE_REPORTED) {
            let model = fiberlab_scatter::lookup(entry).is_ok();
            assert!(model || cases.iter().any(|c| c.label() == *entry), "{entry} is no model or case");
        }
        assert!(fiberlab_scatter::lookup("no-such-model").is_err());
    }
}
