//! Fitting scattering-model parameters to measured values by weighted least squares:
//! Nelder–Mead (the `argmin` crate) on `χ² = Σ ((f_s(ω_i, ω_o) − value)/σ)²`, then
//! uncertainties from the Gauss–Newton covariance `(JᵀJ)⁻¹·χ²/dof` at the optimum.
//! Values are luminances of `f_s` in sr⁻¹; near-field models are averaged over h. Pure.
#![forbid(unsafe_code)]

use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::neldermead::NelderMead;
use fiberlab_math::DVec3;
use fiberlab_scatter::params::{ParamKind, ParamSet, RawValue};
use fiberlab_scatter::{Field, Model, ModelError, ModelSpec, ScatteringFunction, find};
use thiserror::Error;

/// One measured value.
#[derive(Clone, Copy, Debug)]
pub struct Observation {
    /// Direction toward the light (fiber frame).
    pub wi: DVec3,
    /// Direction toward the viewer (fiber frame).
    pub wo: DVec3,
    /// Measured `f_s` luminance (sr⁻¹).
    pub value: f64,
    /// Its standard error (> 0).
    pub sigma: f64,
}

/// Why a fit could not be made.
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum FitError {
    /// The starting parameters do not build a model.
    #[error("starting point: {0}")]
    Model(#[from] ModelError),
    /// Nothing to fit.
    #[error("{0}")]
    Setup(String),
    /// The optimizer failed.
    #[error("optimizer: {0}")]
    Optimizer(String),
}

/// A fitted model.
#[derive(Clone, Debug)]
pub struct FitResult {
    /// Free parameters and their fitted values.
    pub params: Vec<(String, f64)>,
    /// One-σ uncertainties of the free parameters (NaN when the covariance is singular).
    pub uncertainties: Vec<f64>,
    /// χ² at the optimum.
    pub chi2: f64,
    /// Degrees of freedom (observations − free parameters).
    pub dof: usize,
    /// Normalized residuals `(f − value)/σ` per observation.
    pub residuals: Vec<f64>,
    /// Optimizer iterations.
    pub iterations: u64,
}

/// The least-squares problem: the model's validated fixed parameters and the free keys,
/// whose trial values are set as numbers (never formatted to text and parsed back).
struct Problem<'a> {
    spec: &'static ModelSpec,
    base: &'a ParamSet,
    free: &'a [String],
    data: &'a [Observation],
    constraint: Option<Constraint<'a>>,
}

impl Problem<'_> {
    fn model_at(&self, p: &[f64]) -> Result<Model, ModelError> {
        let mut params = self.base.clone();
        for (k, v) in self.free.iter().zip(p) {
            params.set(k, RawValue::Number(*v))?;
        }
        (self.spec.build)(&params)
    }

    fn residuals(&self, m: &Model) -> Vec<f64> {
        let near = m.properties().field == Field::Near;
        self.data
            .iter()
            .map(|o| {
                let f = if near {
                    (0..8).map(|k| m.eval(o.wi, o.wo, -1.0 + (k as f64 + 0.5) / 4.0).luminance()).sum::<f64>() / 8.0
                } else {
                    m.eval(o.wi, o.wo, 0.0).luminance()
                };
                (f - o.value) / o.sigma
            })
            .collect()
    }
}

impl CostFunction for Problem<'_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, p: &Self::Param) -> Result<f64, Error> {
        // Parameters outside a model's valid range, or models the constraint rejects, cost
        // "infinitely" much (an extreme barrier: the simplex never steps outside).
        Ok(match self.model_at(p) {
            Ok(m) if self.constraint.is_none_or(|admissible| admissible(&m)) => {
                self.residuals(&m).iter().map(|r| r * r).sum()
            }
            _ => 1e300,
        })
    }
}

/// Fits the `free` parameters (with starting values) of the model whose other parameters
/// are `base` (validated; its model is `base.model()`). Free parameters are real numbers or
/// colours; a colour is fitted as one grey value (all channels equal), since the values
/// fitted are luminances.
pub fn fit(
    base: &ParamSet,
    free: &[(String, f64)],
    data: &[Observation],
    max_iters: u64,
) -> Result<FitResult, FitError> {
    fit_constrained(base, free, data, max_iters, None)
}

/// A condition every trial model of a constrained fit must meet (e.g. an energy bound):
/// `true` when the model is admissible.
pub type Constraint<'a> = &'a (dyn Fn(&Model) -> bool + Sync);

/// [`fit`] with the trial models restricted to those `constraint` admits: inadmissible
/// parameters cost as much as parameters outside the model's valid range (Nelder–Mead with
/// an extreme barrier), so the result is admissible whenever the starting point is (a
/// starting point the constraint rejects is [`FitError::Setup`]). The uncertainties are
/// those of the unconstrained problem at the optimum (meaningless for a parameter the
/// constraint holds on its boundary).
pub fn fit_constrained(
    base: &ParamSet,
    free: &[(String, f64)],
    data: &[Observation],
    max_iters: u64,
    constraint: Option<Constraint>,
) -> Result<FitResult, FitError> {
    let spec = find(base.model())?;
    if spec.data.is_some() {
        return Err(FitError::Setup(format!("model `{}` is a table; it has no parameters to fit", spec.name)));
    }
    for (key, _) in free {
        match spec.params.iter().find(|s| s.key == key) {
            // A colour parameter is fitted as one grey value (all channels equal).
            Some(s) if matches!(s.kind, ParamKind::Number(_) | ParamKind::Color(_)) => {}
            Some(_) => {
                return Err(FitError::Setup(format!("`{key}` is not a real-valued parameter of `{}`", spec.name)));
            }
            None => {
                let known: Vec<&str> = spec.params.iter().map(|s| s.key).collect();
                return Err(FitError::Setup(format!(
                    "model `{}` has no parameter `{key}`; its parameters are: {}",
                    spec.name,
                    known.join(", ")
                )));
            }
        }
    }
    if free.is_empty() {
        return Err(FitError::Setup("no free parameters (give --init key=value)".into()));
    }
    if data.len() <= free.len() {
        return Err(FitError::Setup(format!("{} observations for {} free parameters", data.len(), free.len())));
    }
    if data.iter().any(|o| o.sigma.is_nan() || o.sigma <= 0.0 || !o.value.is_finite()) {
        return Err(FitError::Setup("every observation needs a finite value and σ > 0".into()));
    }
    let keys: Vec<String> = free.iter().map(|(k, _)| k.clone()).collect();
    let start: Vec<f64> = free.iter().map(|(_, v)| *v).collect();
    let problem = Problem { spec, base, free: &keys, data, constraint };
    let start_model = problem.model_at(&start)?;
    if constraint.is_some_and(|admissible| !admissible(&start_model)) {
        return Err(FitError::Setup("the starting point does not satisfy the fit's constraint".into()));
    }
    let mut simplex = vec![start.clone()];
    for k in 0..start.len() {
        let mut p = start.clone();
        p[k] += if p[k].abs() > 1e-3 { 0.15 * p[k] } else { 0.05 };
        simplex.push(p);
    }
    let solver = NelderMead::new(simplex).with_sd_tolerance(1e-9).map_err(|e| FitError::Optimizer(e.to_string()))?;
    let res = Executor::new(Problem { spec, base, free: &keys, data, constraint }, solver)
        .configure(|s| s.max_iters(max_iters))
        .run()
        .map_err(|e| FitError::Optimizer(e.to_string()))?;
    let best = res.state().get_best_param().cloned().unwrap_or(start);
    let iterations = res.state().get_iter();
    let m = problem.model_at(&best)?;
    let residuals = problem.residuals(&m);
    let chi2: f64 = residuals.iter().map(|r| r * r).sum();
    let dof = data.len() - free.len();
    let uncertainties = covariance(&problem, &best, &residuals)
        .map(|c| (0..best.len()).map(|k| (c[k][k] * chi2 / dof as f64).max(0.0).sqrt()).collect())
        .unwrap_or_else(|| vec![f64::NAN; best.len()]);
    Ok(FitResult { params: keys.into_iter().zip(best).collect(), uncertainties, chi2, dof, residuals, iterations })
}

/// `(JᵀJ)⁻¹` from a central-difference Jacobian of the residuals; `None` if singular.
fn covariance(problem: &Problem, p: &[f64], r0: &[f64]) -> Option<Vec<Vec<f64>>> {
    let n = p.len();
    let mut jac = vec![vec![0.0; r0.len()]; n];
    for k in 0..n {
        let step = 1e-4 * p[k].abs().max(1.0);
        let (mut lo, mut hi) = (p.to_vec(), p.to_vec());
        lo[k] -= step;
        hi[k] += step;
        // Central difference, or one-sided at the edge of a parameter's valid range.
        let (ra, rb, width) = match (problem.model_at(&lo), problem.model_at(&hi)) {
            (Ok(a), Ok(b)) => (problem.residuals(&a), problem.residuals(&b), 2.0 * step),
            (Err(_), Ok(b)) => (r0.to_vec(), problem.residuals(&b), step),
            (Ok(a), Err(_)) => (problem.residuals(&a), r0.to_vec(), step),
            _ => return None,
        };
        for i in 0..r0.len() {
            jac[k][i] = (rb[i] - ra[i]) / width;
        }
    }
    let jtj: Vec<Vec<f64>> =
        (0..n).map(|a| (0..n).map(|b| jac[a].iter().zip(&jac[b]).map(|(x, y)| x * y).sum()).collect()).collect();
    invert(jtj)
}

/// Gauss–Jordan inverse of a small symmetric matrix with partial pivoting.
fn invert(mut a: Vec<Vec<f64>>) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let mut inv: Vec<Vec<f64>> = (0..n).map(|i| (0..n).map(|j| f64::from(u8::from(i == j))).collect()).collect();
    for c in 0..n {
        let p = (c..n).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))?;
        if a[p][c].abs() < 1e-300 {
            return None;
        }
        a.swap(c, p);
        inv.swap(c, p);
        let d = a[c][c];
        for j in 0..n {
            a[c][j] /= d;
            inv[c][j] /= d;
        }
        for i in 0..n {
            if i != c {
                let f = a[i][c];
                for j in 0..n {
                    a[i][j] -= f * a[c][j];
                    inv[i][j] -= f * inv[c][j];
                }
            }
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_math::frame::direction;
    use fiberlab_scatter::build;

    fn chiang(pairs: &[(&str, &str)]) -> ParamSet {
        let spec = find("chiang").unwrap();
        ParamSet::parse(spec.name, spec.params, pairs).unwrap()
    }

    /// Synthetic data from known Chiang parameters plus 2 % Gaussian-like noise: the fit
    /// recovers them within a few standard errors.
    #[test]
    fn round_trip_recovers_known_parameters() {
        let truth =
            build("chiang", &[("beta_m", "0.35"), ("beta_n", "0.45"), ("alpha", "3"), ("sigma_a", "0.5")]).unwrap();
        let mut uniform = fiberlab_check::rng::TestRng::new(12345).into_uniforms();
        let mut data = Vec::new();
        for i in 0..12 {
            for j in 0..16 {
                let wi = direction(-1.0 + 0.17 * i as f64, 0.0);
                let wo = direction(-1.3 + 0.16 * j as f64 + 0.05 * i as f64, 0.4 * j as f64);
                let f: f64 =
                    (0..8).map(|k| truth.eval(wi, wo, -1.0 + (k as f64 + 0.5) / 4.0).luminance()).sum::<f64>() / 8.0;
                let sigma = 0.02 * f + 1e-4;
                // Sum of 4 uniforms: a bounded, nearly Gaussian deviate of unit variance.
                let z = ((0..4).map(|_| uniform()).sum::<f64>() - 2.0) * 3f64.sqrt();
                data.push(Observation { wi, wo, value: f + sigma * z, sigma });
            }
        }
        let free = vec![("beta_m".to_string(), 0.25), ("beta_n".to_string(), 0.3), ("alpha".to_string(), 0.5)];
        let r = fit(&chiang(&[("sigma_a", "0.5")]), &free, &data, 400).unwrap();
        let expect = [0.35, 0.45, 3.0];
        for (k, ((key, v), u)) in r.params.iter().zip(&r.uncertainties).enumerate() {
            assert!((v - expect[k]).abs() < 5.0 * u + 1e-3, "{key} = {v} ± {u}, truth {}", expect[k]);
        }
        assert!(r.chi2 / (r.dof as f64) < 2.0, "reduced χ² {}", r.chi2 / r.dof as f64);
    }

    /// Exact Kajiya–Kay data (p = 30): the unconstrained fit recovers p, a fit constrained
    /// to p ≥ 40 ends admissible, on the boundary, and a rejected start is an error.
    #[test]
    fn a_constraint_keeps_every_trial_model_admissible() {
        let spec = find("kajiya-kay").unwrap();
        let truth = build("kajiya-kay", &[("k_d", "0.05"), ("k_s", "0.1"), ("p", "30")]).unwrap();
        let mut data = Vec::new();
        for i in 0..9 {
            for j in 0..9 {
                let (wi, wo) = (direction(-0.8 + 0.2 * i as f64, 0.0), direction(-0.8 + 0.2 * j as f64, 1.0));
                data.push(Observation { wi, wo, value: truth.eval(wi, wo, 0.0).luminance(), sigma: 0.01 });
            }
        }
        let base = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let free = [("k_d".to_string(), 0.04), ("k_s".to_string(), 0.12), ("p".to_string(), 45.0)];
        let p_of = |m: &Model| match m {
            Model::KajiyaKay(k) => k.p(),
            _ => unreachable!(),
        };
        let at_least_40 = |m: &Model| p_of(m) >= 40.0;
        let free_fit = fit(&base, &free, &data, 2000).unwrap();
        assert!((free_fit.params[2].1 - 30.0).abs() < 0.5, "{:?}", free_fit.params);
        let held = fit_constrained(&base, &free, &data, 2000, Some(&at_least_40)).unwrap();
        let p = held.params[2].1;
        assert!((40.0..40.5).contains(&p), "constrained p = {p}");
        assert!(held.chi2 > free_fit.chi2, "{} vs {}", held.chi2, free_fit.chi2);
        let start = [("k_d".to_string(), 0.04), ("k_s".to_string(), 0.12), ("p".to_string(), 35.0)];
        assert!(matches!(fit_constrained(&base, &start, &data, 10, Some(&at_least_40)), Err(FitError::Setup(_))));
    }

    #[test]
    fn bad_setups_are_errors() {
        let o = Observation { wi: direction(0.0, 0.0), wo: direction(0.1, 1.0), value: 1.0, sigma: 0.0 };
        let base = chiang(&[]);
        assert!(fit(&base, &[("beta_m".into(), 0.3)], &[o, o, o], 10).is_err());
        assert!(fit(&base, &[], &[o], 10).is_err());
        // A key the model does not have, and a key that is not a real number, are named.
        let ok = [o, o, o, o].map(|mut x| {
            x.sigma = 1.0;
            x
        });
        let e = fit(&base, &[("beta".into(), 0.3)], &ok, 10).unwrap_err().to_string();
        assert!(e.contains("`beta`") && e.contains("beta_m"), "{e}");
        let spec = find("marschner").unwrap();
        let marschner = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let e = fit(&marschner, &[("glints".into(), 0.3)], &ok, 10).unwrap_err().to_string();
        assert!(e.contains("`glints`") && e.contains("real-valued"), "{e}");
        assert!(
            fit(
                &base,
                &[("beta_m".into(), 7.0)],
                &[o, o, o].map(|mut x| {
                    x.sigma = 1.0;
                    x
                }),
                10
            )
            .is_err()
        );
    }
}
