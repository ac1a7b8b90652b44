//! Uncertainties of the fitted values from the Gauss–Newton covariance `(JᵀJ)⁻¹·χ²/dof` with a
//! central-difference Jacobian, and the bounds a value ended on.

use crate::outcome::{AtBound, BOUND_TOLERANCE, MAX_CONDITION, Uncertainty, Undefined};
use crate::problem::{Problem, jacobian};
use fiberlab_scatter::params::Range;

/// The end of `range` that `v` is within [`BOUND_TOLERANCE`] of, if any.
pub(crate) fn on_bound(v: f64, range: Range) -> Option<AtBound> {
    let width = range.max - range.min;
    let tolerance = |bound: f64| BOUND_TOLERANCE * if width.is_finite() { width } else { bound.abs().max(1.0) };
    if range.min.is_finite() && v - range.min <= tolerance(range.min) {
        Some(AtBound { bound: range.min, lower: true, range })
    } else if range.max.is_finite() && range.max - v <= tolerance(range.max) {
        Some(AtBound { bound: range.max, lower: false, range })
    } else {
        None
    }
}

/// The uncertainties from `(JᵀJ)⁻¹ · χ²/dof` (`scale`), with a central-difference Jacobian
/// of the residuals. Coordinates on which the data do not depend, or on a bound, are held
/// fixed (their uncertainty undefined, the others' conditional on them); the rest share one
/// verdict when their scaled `JᵀJ` is ill-conditioned.
pub(crate) fn uncertainties<M>(
    problem: &Problem<M>,
    p: &[f64],
    r0: &[f64],
    at_bound: &[Option<AtBound>],
    scale: f64,
) -> Vec<Uncertainty> {
    let n = p.len();
    let mut out: Vec<Option<Uncertainty>> = vec![None; n];
    let jac: Vec<Vec<f64>> = jacobian(problem, p, r0)
        .into_iter()
        .enumerate()
        .map(|(k, column)| {
            match &column {
                None => out[k] = Some(Uncertainty::Undefined(Undefined::NoDerivative)),
                // No effect is the deeper reason: such a parameter drifts, and may drift onto a bound.
                Some(c) if c.iter().all(|x| *x == 0.0) => out[k] = Some(Uncertainty::Undefined(Undefined::NoEffect)),
                Some(_) if at_bound[k].is_some() => out[k] = Some(Uncertainty::Undefined(Undefined::AtBound)),
                Some(_) => {}
            }
            column.unwrap_or_default()
        })
        .collect();
    let kept: Vec<usize> = (0..n).filter(|&k| out[k].is_none()).collect();
    let jtj: Vec<Vec<f64>> = kept
        .iter()
        .map(|&a| kept.iter().map(|&b| jac[a].iter().zip(&jac[b]).map(|(x, y)| x * y).sum()).collect())
        .collect();
    // Scaled to unit diagonal, so the condition number measures dependence, not units.
    let d: Vec<f64> = (0..kept.len()).map(|i| jtj[i][i].sqrt()).collect();
    let scaled: Vec<Vec<f64>> =
        (0..kept.len()).map(|i| (0..kept.len()).map(|j| jtj[i][j] / (d[i] * d[j])).collect()).collect();
    let verdict = match invert(scaled.clone()) {
        Some(inv) => {
            let norm =
                |m: &[Vec<f64>]| m.iter().map(|row| row.iter().map(|x| x.abs()).sum::<f64>()).fold(0.0, f64::max);
            let condition = norm(&scaled) * norm(&inv);
            if condition.is_finite() && condition <= MAX_CONDITION { Ok(inv) } else { Err(condition) }
        }
        None => Err(f64::INFINITY),
    };
    for (i, &k) in kept.iter().enumerate() {
        out[k] = Some(match &verdict {
            Ok(inv) => Uncertainty::Sigma((inv[i][i] / (d[i] * d[i]) * scale).max(0.0).sqrt()),
            Err(condition) => Uncertainty::Undefined(Undefined::IllConditioned(*condition)),
        });
    }
    out.into_iter().map(|u| u.unwrap_or(Uncertainty::Undefined(Undefined::NoDerivative))).collect()
}

/// Inverse of a small square matrix (rows of `a`) by `nalgebra`'s LU decomposition with
/// partial pivoting; `None` when it is singular.
pub(crate) fn invert(a: Vec<Vec<f64>>) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let inverse = nalgebra::DMatrix::from_fn(n, n, |i, j| a[i][j]).try_inverse()?;
    Some((0..n).map(|i| (0..n).map(|j| inverse[(i, j)]).collect()).collect())
}
