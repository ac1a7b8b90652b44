//! The fit itself: Nelder–Mead (the `argmin` crate) from the starting values, polished by
//! Levenberg–Marquardt steps, with the uncertainties at the optimum ([`crate::uncertainty`]).

use crate::observation::{Channel, Observation};
use crate::outcome::{AtBound, FitError, FitOptions, FitResult, FreeParam, Step, Stop};
use crate::problem::{Coordinate, IterationObserver, Problem, check_data, coordinates_of, fiber_residuals, jacobian};
use crate::uncertainty::{invert, on_bound, uncertainties};
use argmin::core::observers::ObserverMode;
use argmin::core::{Error, Executor, KV, Solver, State, TerminationReason, TerminationStatus};
use argmin::solver::neldermead::NelderMead;
use fiberlab_scatter::params::ParamSet;
use fiberlab_scatter::{Model, find};

/// Fits the `free` parameters (with one starting value each) of the model whose other
/// parameters are `base`, in at most `max_iters` iterations: [`fit_with`] without progress.
pub fn fit(
    base: &ParamSet,
    free: &[(String, f64)],
    data: &[Observation],
    max_iters: u64,
) -> Result<FitResult, FitError> {
    let free: Vec<FreeParam> = free.iter().map(|(k, v)| FreeParam { key: k.clone(), start: vec![*v] }).collect();
    fit_with(base, &free, data, &FitOptions { max_iters, ..FitOptions::default() })
}

/// A condition every trial model of a constrained fit must meet (e.g. an energy bound):
/// `true` when the model is admissible.
pub type Constraint<'a> = &'a (dyn Fn(&Model) -> bool + Sync);

/// [`fit`] with the trial models restricted to those `constraint` admits: inadmissible
/// parameters cost as much as parameters outside the model's valid range (Nelder–Mead with
/// an extreme barrier) and the polishing steps never take them, so the result is admissible
/// whenever the starting point is (a starting point the constraint rejects is
/// [`FitError::Setup`]). The uncertainties are those of the unconstrained problem at the
/// optimum (meaningless for a parameter the constraint holds on its boundary).
pub fn fit_constrained(
    base: &ParamSet,
    free: &[(String, f64)],
    data: &[Observation],
    max_iters: u64,
    constraint: Option<Constraint>,
) -> Result<FitResult, FitError> {
    let free: Vec<FreeParam> = free.iter().map(|(k, v)| FreeParam { key: k.clone(), start: vec![*v] }).collect();
    fit_under(base, &free, data, &FitOptions { max_iters, ..FitOptions::default() }, constraint)
}

/// Fits the `free` parameters of the model whose other parameters are `base` (validated;
/// its model is `base.model()`). Free parameters are real numbers or colours; a colour is
/// fitted per channel when any observation is of a channel, else as one grey value.
pub fn fit_with(
    base: &ParamSet,
    free: &[FreeParam],
    data: &[Observation],
    options: &FitOptions,
) -> Result<FitResult, FitError> {
    fit_under(base, free, data, options, None)
}

/// [`fit_with`] under an optional constraint ([`fit_constrained`]).
fn fit_under(
    base: &ParamSet,
    free: &[FreeParam],
    data: &[Observation],
    options: &FitOptions,
    constraint: Option<Constraint>,
) -> Result<FitResult, FitError> {
    let spec = find(base.model())?;
    if spec.data.is_some() {
        return Err(FitError::Setup(format!("model `{}` is a table; it has no parameters to fit", spec.name)));
    }
    let per_channel = data.iter().any(|o| o.channel != Channel::Luminance);
    let (coordinates, start) = coordinates_of(&spec.info, base, free, per_channel)?;
    check_data(data.len(), coordinates.len(), data.iter().map(|o| (o.value, o.sigma)))?;
    let build = |p: &ParamSet| (spec.build)(p);
    let residuals = |m: &Model| fiber_residuals(data, m);
    let constraint = constraint.map(|c| c as &(dyn Fn(&Model) -> bool + Sync));
    let problem = Problem { build: &build, base, coordinates: &coordinates, residuals: &residuals, constraint };
    solve(&problem, start, data.len(), options)
}

/// Nelder–Mead from `start`, polished, with the uncertainties at the optimum.
pub(crate) fn solve<M>(
    problem: &Problem<M>,
    start: Vec<f64>,
    observations: usize,
    options: &FitOptions,
) -> Result<FitResult, FitError> {
    let coordinates = problem.coordinates;
    let start_model = problem.model_at(&start)?;
    if !problem.admits(&start_model) {
        return Err(FitError::Setup("the starting point does not satisfy the fit's constraint".into()));
    }
    let mut simplex = vec![start.clone()];
    for k in 0..start.len() {
        let mut p = start.clone();
        p[k] += if p[k].abs() > 1e-3 { 0.15 * p[k] } else { 0.05 };
        simplex.push(p);
    }
    let solver = NelderMead::new(simplex).with_sd_tolerance(1e-9).map_err(|e| FitError::Optimizer(e.to_string()))?;
    let stoppable = Stoppable { inner: solver, stop: options.stop.clone() };
    let mut executor = Executor::new(problem.clone(), stoppable).configure(|s| s.max_iters(options.max_iters));
    let names: Vec<String> = coordinates.iter().map(Coordinate::name).collect();
    if options.progress.is_some() || options.trace.is_some() {
        let observer = IterationObserver {
            progress: options.progress.clone(),
            trace: options.trace.clone(),
            names: names.clone(),
        };
        executor = executor.add_observer(observer, ObserverMode::Always);
    }
    let res = executor.run().map_err(|e| FitError::Optimizer(e.to_string()))?;
    let iterations = res.state().get_iter();
    let stopped = || options.stop.as_ref().is_some_and(|stop| stop());
    let best = res.state().get_best_param().cloned().unwrap_or_else(|| start.clone());
    // Stopped by a signal: the best point so far, not polished.
    let best = if stopped() {
        best
    } else {
        polish(problem, best, |step, p, cost| {
            if let Some(progress) = &options.progress {
                progress(options.max_iters + step);
            }
            if let (Some(trace), Some((p, chi2))) = (&options.trace, p.zip(cost)) {
                let params = names.iter().cloned().zip(p.iter().copied()).collect();
                trace(&Step { iteration: options.max_iters + step, params, chi2 });
            }
        })
    };
    let m = problem.model_at(&best)?;
    let residuals = problem.residuals(&m);
    let chi2: f64 = residuals.iter().map(|r| r * r).sum();
    let dof = observations - coordinates.len();
    let at_bound: Vec<Option<AtBound>> = coordinates.iter().zip(&best).map(|(c, &v)| on_bound(v, c.range)).collect();
    if !chi2.is_finite() {
        return Err(FitError::Setup(format!(
            "χ² = {chi2} at the best point: the values and standard errors overflow double precision \
             (value / σ beyond 1e154); check the data's units"
        )));
    }
    let uncertainties = uncertainties(problem, &best, &residuals, &at_bound, chi2 / dof as f64);
    let mut values: Vec<(String, Vec<f64>)> = Vec::new();
    for (c, &v) in coordinates.iter().zip(&best) {
        match values.last_mut() {
            Some((k, vs)) if c.channel.is_some_and(|ch| ch > 0) && k == c.key => vs.push(v),
            _ => values.push((c.key.to_string(), vec![v])),
        }
    }
    Ok(FitResult {
        params: coordinates.iter().map(Coordinate::name).zip(best).collect(),
        uncertainties,
        at_bound,
        values,
        chi2,
        dof,
        residuals,
        iterations,
        interrupted: stopped(),
    })
}

/// A solver that also ends when [`FitOptions::stop`] is set (after the iteration in flight).
struct Stoppable<S> {
    inner: S,
    stop: Option<Stop>,
}

impl<O, I: State, S: Solver<O, I>> Solver<O, I> for Stoppable<S> {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn init(&mut self, problem: &mut argmin::core::Problem<O>, state: I) -> Result<(I, Option<KV>), Error> {
        self.inner.init(problem, state)
    }

    fn next_iter(&mut self, problem: &mut argmin::core::Problem<O>, state: I) -> Result<(I, Option<KV>), Error> {
        self.inner.next_iter(problem, state)
    }

    fn terminate(&mut self, state: &I) -> TerminationStatus {
        if self.stop.as_ref().is_some_and(|stop| stop()) {
            return TerminationStatus::Terminated(TerminationReason::Interrupt);
        }
        self.inner.terminate(state)
    }
}

/// Largest number of Levenberg–Marquardt steps after the simplex (reported to the progress
/// callback as iterations after the optimizer's).
pub const POLISH_ITERATIONS: u64 = 20;

/// Levenberg–Marquardt steps from the simplex's best point (Nelder–Mead crawls in many
/// dimensions, e.g. three channels of two colours): each solves
/// `(JᵀJ + λ·diag JᵀJ) δ = −Jᵀr` and is kept only when it lowers χ² inside the valid ranges.
///
/// `progress(k, point, χ²)` is called before the k-th step with no point, and after a step that
/// lowered χ² with the new point and its χ².
fn polish<M>(problem: &Problem<M>, mut p: Vec<f64>, progress: impl Fn(u64, Option<&[f64]>, Option<f64>)) -> Vec<f64> {
    let chi2 = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>();
    let Ok(m) = problem.model_at(&p) else { return p };
    let mut r = problem.residuals(&m);
    let mut cost = chi2(&r);
    let mut lambda = 1e-3;
    for step in 0..POLISH_ITERATIONS {
        progress(step, None, None);
        let Some(jac) = jacobian(problem, &p, &r).into_iter().collect::<Option<Vec<_>>>() else { break };
        let n = p.len();
        let jtj: Vec<Vec<f64>> =
            (0..n).map(|a| (0..n).map(|b| jac[a].iter().zip(&jac[b]).map(|(x, y)| x * y).sum()).collect()).collect();
        let jtr: Vec<f64> = (0..n).map(|a| jac[a].iter().zip(&r).map(|(x, y)| x * y).sum()).collect();
        let (mut improved, mut accepted) = (false, false);
        while lambda < 1e12 {
            let damped: Vec<Vec<f64>> = (0..n)
                .map(|a| {
                    (0..n).map(|b| jtj[a][b] + if a == b { lambda * jtj[a][a].max(1e-300) } else { 0.0 }).collect()
                })
                .collect();
            let Some(inv) = invert(damped) else { break };
            let trial: Vec<f64> = (0..n).map(|a| p[a] - (0..n).map(|b| inv[a][b] * jtr[b]).sum::<f64>()).collect();
            if let Ok(m) = problem.model_at(&trial)
                && problem.admits(&m)
            {
                let rt = problem.residuals(&m);
                let ct = chi2(&rt);
                if ct < cost {
                    let relative = (cost - ct) / cost.max(1e-300);
                    (p, r, cost) = (trial, rt, ct);
                    lambda = (lambda * 0.3).max(1e-12);
                    improved = relative > 1e-9;
                    accepted = true;
                    break;
                }
            }
            lambda *= 10.0;
        }
        // A step taken is reported, also the last one (too small to go on): the trace's last
        // point is the result.
        if accepted {
            progress(step + 1, Some(&p), Some(cost));
        }
        if !improved {
            break;
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BOUND_TOLERANCE, MAX_CONDITION, Uncertainty, Undefined};
    use fiberlab_math::frame::direction;
    use fiberlab_math::{DVec3, Rgb};
    use fiberlab_scatter::{ScatteringFunction, build};
    use std::sync::Arc;

    /// The width average of `f_s` by 4000 midpoints in `h`: an independent rule for the data
    /// (the fit itself uses the Gauss–Legendre rule of `eval_far`).
    fn width_averaged(model: &Model, wi: DVec3, wo: DVec3) -> Rgb {
        let n = 4000;
        (0..n).fold(Rgb::ZERO, |a, k| a + model.eval(wi, wo, -1.0 + (k as f64 + 0.5) * 2.0 / n as f64)) / n as f64
    }

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
                let f = width_averaged(&truth, wi, wo).luminance();
                let sigma = 0.02 * f + 1e-4;
                // Sum of 4 uniforms: a bounded, nearly Gaussian deviate of unit variance.
                let z = ((0..4).map(|_| uniform()).sum::<f64>() - 2.0) * 3f64.sqrt();
                data.push(Observation { wi, wo, value: f + sigma * z, sigma, channel: Channel::Luminance });
            }
        }
        let free = vec![("beta_m".to_string(), 0.25), ("beta_n".to_string(), 0.3), ("alpha".to_string(), 0.5)];
        let r = fit(&chiang(&[("sigma_a", "0.5")]), &free, &data, 400).unwrap();
        let expect = [0.35, 0.45, 3.0];
        for (k, ((key, v), u)) in r.params.iter().zip(&r.uncertainties).enumerate() {
            let u = u.sigma().unwrap_or_else(|| panic!("{key}: {u:?}"));
            assert!((v - expect[k]).abs() < 5.0 * u + 1e-3, "{key} = {v} ± {u}, truth {}", expect[k]);
        }
        assert!(r.at_bound.iter().all(Option::is_none), "{:?}", r.at_bound);
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
                data.push(Observation {
                    wi,
                    wo,
                    value: truth.eval(wi, wo, 0.0).luminance(),
                    sigma: 0.01,
                    channel: Channel::Luminance,
                });
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
        let o = Observation {
            wi: direction(0.0, 0.0),
            wo: direction(0.1, 1.0),
            value: 1.0,
            sigma: 0.0,
            channel: Channel::Luminance,
        };
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
        let e = fit(&base, &[("beta_m".into(), 0.3), ("beta_m".into(), 0.4)], &ok, 10).unwrap_err().to_string();
        assert!(e.contains("more than once"), "{e}");
        let e = fit(&chiang(&[("beta_m", "0.3")]), &[("beta_m".into(), 0.3)], &ok, 10).unwrap_err().to_string();
        assert!(e.contains("both fixed and free"), "{e}");
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

    /// Directions of a small test grid (ω_i, ω_o).
    fn grid() -> Vec<(DVec3, DVec3)> {
        let mut pairs = Vec::new();
        for i in 0..8 {
            for j in 0..12 {
                pairs.push((direction(-1.1 + 0.3 * i as f64, 0.0), direction(-1.2 + 0.2 * j as f64, 0.5 * j as f64)));
            }
        }
        pairs
    }

    /// The luminance of `truth` on [`grid`], with a 1 % standard error.
    fn luminance_data(truth: &Model) -> Vec<Observation> {
        grid()
            .into_iter()
            .map(|(wi, wo)| {
                let value = truth.eval(wi, wo, 0.0).luminance();
                Observation { wi, wo, value, sigma: 0.01 * value + 1e-6, channel: Channel::Luminance }
            })
            .collect()
    }

    /// The ideal diffuse fiber is `f_s = ρ/π²` (closed form). Data of ρ = 1.3, beyond its valid
    /// range [0, 1]: the fit ends on the upper bound, says so, and gives no σ for it.
    #[test]
    fn a_parameter_on_its_bound_is_flagged_and_has_no_sigma() {
        let value = 1.3 / std::f64::consts::PI.powi(2);
        let data: Vec<Observation> = grid()
            .into_iter()
            .map(|(wi, wo)| Observation { wi, wo, value, sigma: 0.01 * value, channel: Channel::Luminance })
            .collect();
        let spec = find("diffuse").unwrap();
        let base = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let r = fit(&base, &[("albedo".into(), 0.5)], &data, 400).unwrap();
        let b = r.at_bound[0].expect("on its bound");
        assert!(!b.lower && b.bound == 1.0, "{b:?}");
        assert!((r.params[0].1 - 1.0).abs() <= BOUND_TOLERANCE, "{:?}", r.params);
        assert_eq!(r.uncertainties[0], Uncertainty::Undefined(Undefined::AtBound));
        assert!(b.to_string().contains("upper bound 1.0"), "{b}");
        // Inside the range (ρ = 0.6), nothing is flagged and σ is defined.
        let inside: Vec<Observation> =
            data.iter().map(|o| Observation { value: o.value * 0.6 / 1.3, sigma: o.sigma * 0.6 / 1.3, ..*o }).collect();
        let r = fit(&base, &[("albedo".into(), 0.5)], &inside, 400).unwrap();
        assert!(r.at_bound[0].is_none() && r.uncertainties[0].sigma().is_some(), "{r:?}");
        assert!((r.params[0].1 - 0.6).abs() < 1e-4, "{:?}", r.params);
    }

    /// With `k_s = 0` Kajiya–Kay does not depend on its exponent `p`: p's uncertainty is
    /// undefined with that reason (never NaN), while `k_d`'s is still given.
    #[test]
    fn an_uncertainty_the_data_cannot_give_says_why() {
        let spec = find("kajiya-kay").unwrap();
        let base = ParamSet::parse(spec.name, spec.params, &[("k_s", "0")]).unwrap();
        let truth = build("kajiya-kay", &[("k_d", "0.3"), ("k_s", "0")]).unwrap();
        let data = luminance_data(&truth);
        let r = fit(&base, &[("k_d".into(), 0.2), ("p".into(), 10.0)], &data, 400).unwrap();
        assert!(r.uncertainties[0].sigma().is_some_and(f64::is_finite), "{:?}", r.uncertainties);
        assert_eq!(r.uncertainties[1], Uncertainty::Undefined(Undefined::NoEffect));
        assert!(Undefined::NoEffect.to_string().contains("do not depend"));
    }

    /// Goldman's f_s is Kajiya–Kay's times `ρ_reflect·a + ρ_transmit·b` (Goldman 1997), so
    /// scaling (k_d, k_s) by c and (ρ_reflect, ρ_transmit) by 1/c fits equally well: the
    /// Jacobian is rank-deficient and every uncertainty is undefined for that reason, while
    /// the identifiable ratio k_d/k_s is recovered.
    #[test]
    fn parameters_that_trade_off_are_reported_as_ill_conditioned() {
        let truth =
            build("goldman", &[("k_d", "0.04"), ("k_s", "0.2"), ("rho_reflect", "0.5"), ("rho_transmit", "0.3")])
                .unwrap();
        let data = luminance_data(&truth);
        let spec = find("goldman").unwrap();
        let base = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let free: Vec<(String, f64)> = [("k_d", 0.02), ("k_s", 0.1), ("rho_reflect", 0.6), ("rho_transmit", 0.4)]
            .map(|(k, v)| (k.into(), v))
            .into();
        let r = fit(&base, &free, &data, 400).unwrap();
        for u in &r.uncertainties {
            assert!(matches!(u, Uncertainty::Undefined(Undefined::IllConditioned(c)) if *c > MAX_CONDITION), "{u:?}");
        }
        assert!((r.params[0].1 / r.params[1].1 - 0.2).abs() < 1e-3, "{:?}", r.params);
        assert!(Undefined::IllConditioned(1e16).to_string().contains("ill-conditioned"));
    }

    /// A colour fitted per channel from per-channel data of the model itself at a known
    /// absorption: the three channels come back, and luminance-only data of the same model
    /// cannot be fitted with three starting channels.
    #[test]
    fn a_colour_is_recovered_per_channel() {
        let fixed = [("beta_m", "0.3"), ("beta_n", "0.4"), ("alpha", "2")];
        let truth = build("chiang", &[fixed.as_slice(), &[("sigma_a", "0.2,0.6,1.4")]].concat()).unwrap();
        let mut data = Vec::new();
        for (wi, wo) in grid() {
            let f = width_averaged(&truth, wi, wo);
            for c in 0..3 {
                data.push(Observation { wi, wo, value: f[c], sigma: 0.01 * f[c] + 1e-6, channel: Channel::Rgb(c) });
            }
        }
        let free = [FreeParam { key: "sigma_a".into(), start: vec![0.5] }];
        let calls = Arc::new(std::sync::atomic::AtomicU64::new(0));
        let counter = calls.clone();
        let progress: Arc<dyn Fn(u64) + Send + Sync> = Arc::new(move |_| {
            counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        });
        let options = FitOptions { max_iters: 400, progress: Some(progress), ..FitOptions::default() };
        let r = fit_with(&chiang(&fixed), &free, &data, &options).unwrap();
        let names: Vec<&str> = r.params.iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(names, ["sigma_a[r]", "sigma_a[g]", "sigma_a[b]"]);
        for (c, want) in [0.2, 0.6, 1.4].into_iter().enumerate() {
            assert!((r.params[c].1 - want).abs() < 1e-3 * want, "{:?}", r.params);
        }
        assert_eq!(r.values, vec![("sigma_a".to_string(), r.params.iter().map(|p| p.1).collect())]);
        let calls = calls.load(std::sync::atomic::Ordering::Relaxed);
        assert!(calls > r.iterations && calls <= r.iterations + POLISH_ITERATIONS, "{calls} reports");
        // The trace reports the best point so far: χ² never rises, and its last point is
        // the result.
        let steps = Arc::new(std::sync::Mutex::new(Vec::<Step>::new()));
        let sink = steps.clone();
        let traced = FitOptions {
            max_iters: 400,
            trace: Some(Arc::new(move |s: &Step| sink.lock().unwrap().push(s.clone()))),
            ..FitOptions::default()
        };
        let t = fit_with(&chiang(&fixed), &free, &data, &traced).unwrap();
        let steps = steps.lock().unwrap();
        assert!(steps.len() as u64 >= t.iterations, "{} steps for {} iterations", steps.len(), t.iterations);
        assert!(steps.windows(2).all(|w| w[1].chi2 <= w[0].chi2 && w[1].iteration >= w[0].iteration));
        let last = steps.last().unwrap();
        assert_eq!(last.params, t.params);
        assert!((last.chi2 - t.chi2).abs() <= 1e-9 * t.chi2.max(1.0), "{} vs {}", last.chi2, t.chi2);
        let luminance: Vec<Observation> =
            data.iter().map(|o| Observation { channel: Channel::Luminance, ..*o }).collect();
        let three = [FreeParam { key: "sigma_a".into(), start: vec![0.5, 0.5, 0.5] }];
        let e = fit_with(&chiang(&fixed), &three, &luminance, &options).unwrap_err().to_string();
        assert!(e.contains("cannot tell the channels"), "{e}");
    }

    /// Data a fit cannot mean anything for is refused, not "fitted": all zeros, values so
    /// large that no parameter changes χ² (the start values came back as the fit), and σ so
    /// small that χ² overflows.
    #[test]
    fn data_without_information_is_refused() {
        let spec = find("kajiya-kay").unwrap();
        let base = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let data = luminance_data(&build("kajiya-kay", &[("k_d", "0.3")]).unwrap());
        let zeros: Vec<Observation> = data.iter().map(|o| Observation { value: 0.0, ..*o }).collect();
        let e = fit(&base, &[("k_d".into(), 0.2)], &zeros, 50).unwrap_err().to_string();
        assert!(e.contains("every observed value is 0"), "{e}");
        let huge: Vec<Observation> = data.iter().map(|o| Observation { value: 1e300, sigma: 5e298, ..*o }).collect();
        let e = fit(&base, &[("k_d".into(), 0.2)], &huge, 50).unwrap_err().to_string();
        assert!(e.contains("no free parameter changes χ²"), "{e}");
        let tiny_sigma: Vec<Observation> = data.iter().map(|o| Observation { sigma: 1e-300, ..*o }).collect();
        let e = fit(&base, &[("k_d".into(), 0.2)], &tiny_sigma, 50).unwrap_err().to_string();
        assert!(e.contains("overflow double precision"), "{e}");
    }

    /// A fit whose stop flag is set ends after the iteration in flight with its best point.
    #[test]
    fn a_stopped_fit_returns_its_best_point_so_far() {
        let spec = find("kajiya-kay").unwrap();
        let base = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let data = luminance_data(&build("kajiya-kay", &[("k_d", "0.3")]).unwrap());
        let free = [FreeParam { key: "k_d".into(), start: vec![0.2] }];
        let options = FitOptions { max_iters: 400, stop: Some(std::sync::Arc::new(|| true)), ..FitOptions::default() };
        let r = fit_with(&base, &free, &data, &options).unwrap();
        assert!(r.interrupted && r.iterations <= 1, "{r:?}");
        let r = fit_with(&base, &free, &data, &FitOptions { max_iters: 400, ..FitOptions::default() }).unwrap();
        assert!(!r.interrupted && (r.params[0].1 - 0.3).abs() < 1e-3, "{r:?}");
    }
}
