//! Surface models fitted to the bins of a surface table: each bin's value against the model's
//! average over the bin, in the table's `cosθ dω` measure.

use crate::observation::{Channel, channels, std_floor};
use crate::outcome::{FitError, FitOptions, FitResult, FreeParam};
use crate::problem::{Problem, check_data, coordinates_of};
use crate::solve::solve;
use fiberlab_io::table::LobeSlices;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::params::ParamSet;
use fiberlab_scatter::{SurfaceModel, SurfaceScattering, find_surface};

/// One bin of a surface table: the table's fixed direction (its `theta_i, phi_i`) and
/// quadrature nodes over the bin's directions (surface frame, `z` the normal), with weights
/// summing to 1, so that `Σ w·f_r` over the nodes is the model's average over the bin in the
/// measure the table uses. The fixed direction is the light's (`f_r(ω_fixed, ω_k)`, a table
/// traced from the light) unless `fixed_is_viewer` (`f_r(ω_k, ω_fixed)`, a table traced from
/// the viewer, as the renderer's camera paths are): it matters for a non-reciprocal model.
#[derive(Clone, Debug)]
pub struct SurfaceBin {
    /// The table's fixed direction.
    pub fixed: DVec3,
    /// Whether `fixed` is toward the viewer (else toward the light).
    pub fixed_is_viewer: bool,
    /// `(direction, weight)` nodes.
    pub nodes: Vec<(DVec3, f64)>,
}

impl SurfaceBin {
    /// The model's average of `f_r` over the bin.
    #[must_use]
    pub fn average(&self, model: &SurfaceModel) -> Rgb {
        self.nodes.iter().fold(Rgb::ZERO, |acc, &(d, w)| {
            let f = if self.fixed_is_viewer { model.eval(d, self.fixed) } else { model.eval(self.fixed, d) };
            acc + f * w
        })
    }
}

/// One measured number of a surface bin.
#[derive(Clone, Copy, Debug)]
pub struct BinObservation {
    /// Index of its bin in [`SurfaceData::bins`].
    pub bin: usize,
    /// Measured bin-averaged `f_r` (sr⁻¹) in `channel`.
    pub value: f64,
    /// Its standard error (> 0).
    pub sigma: f64,
    /// What of `f_r` was measured.
    pub channel: Channel,
}

/// A surface table as fit data: its bins and the numbers measured on them.
#[derive(Clone, Debug, Default)]
pub struct SurfaceData {
    /// The bins.
    pub bins: Vec<SurfaceBin>,
    /// The measured numbers (any order; the channels of one bin share its evaluation).
    pub observations: Vec<BinObservation>,
}

/// The bins of one incidence of a surface table, `[θ_o][φ_o]` row-major: θ_o in [0, π/2]
/// in `nt` bins from the normal, φ_o (absolute azimuth from `x` toward `y`) in [−π, π) in
/// `np` bins; each bin integrated by the midpoint rule on `sub × sub` nodes weighted by the
/// `cosθ_o dω_o = sinθ_o cosθ_o dθ_o dφ_o` measure of a BRDF table (a bin's value is the power
/// it receives per cos-weighted solid angle).
#[must_use]
pub fn surface_bins(
    theta_i: f64,
    phi_i: f64,
    nt: usize,
    np: usize,
    sub: usize,
    fixed_is_viewer: bool,
) -> Vec<SurfaceBin> {
    let dir = |th: f64, ph: f64| DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
    let wi = dir(theta_i, phi_i);
    let (dt, dp) = (std::f64::consts::FRAC_PI_2 / nt as f64, std::f64::consts::TAU / np as f64);
    let sub = sub.max(1);
    (0..nt * np)
        .map(|b| {
            let (i, j) = (b / np, b % np);
            let mut nodes = Vec::with_capacity(sub * sub);
            for a in 0..sub {
                let th = (i as f64 + (a as f64 + 0.5) / sub as f64) * dt;
                for c in 0..sub {
                    let ph = -std::f64::consts::PI + (j as f64 + (c as f64 + 0.5) / sub as f64) * dp;
                    nodes.push((dir(th, ph), th.sin() * th.cos()));
                }
            }
            let total: f64 = nodes.iter().map(|n| n.1).sum();
            nodes.iter_mut().for_each(|n| n.1 /= total);
            SurfaceBin { fixed: wi, fixed_is_viewer, nodes }
        })
        .collect()
}

/// Refuses, before they are made, the [`surface_bins`] of `incidences` incidences of an
/// `nt` × `np` table with `sub`² nodes per bin when their nodes (a direction and a weight, 32
/// bytes each) are more than the memory budget ([`fiberlab_io::memory_budget`]): a large
/// `--subsamples` would otherwise abort the process in the allocation.
pub fn check_surface_bins(nt: usize, np: usize, incidences: usize, sub: usize) -> Result<(), FitError> {
    let nodes = (nt as u64)
        .saturating_mul(np as u64)
        .saturating_mul(incidences as u64)
        .saturating_mul(sub as u64)
        .saturating_mul(sub as u64);
    fiberlab_io::memory_budget::check_needs(&[fiberlab_io::memory_budget::Need::items(
        format!("{nodes} bin nodes ({sub}² per bin)"),
        nodes,
        32,
    )])
    .map_err(|e| FitError::Setup(e.to_string()))
}

/// A surface model's bin averages of `f_r` on `bins`.
#[must_use]
pub fn bin_averages(model: &SurfaceModel, bins: &[SurfaceBin]) -> Vec<Rgb> {
    bins.iter().map(|b| b.average(model)).collect()
}

/// Fits the `free` parameters of the surface model whose other parameters are `base`
/// (validated; a surface model's name) to the bins of a surface table: the objective is
/// `χ² = Σ ((⟨f_r⟩_bin − value)/σ)²` with the model averaged over each bin ([`surface_bins`]),
/// as the table's values are. A colour parameter is fitted per channel when any observation
/// is of a channel.
pub fn fit_surface(
    base: &ParamSet,
    free: &[FreeParam],
    data: &SurfaceData,
    options: &FitOptions,
) -> Result<FitResult, FitError> {
    let spec = find_surface(base.model())?;
    let obs = &data.observations;
    if let Some(o) = obs.iter().find(|o| o.bin >= data.bins.len()) {
        return Err(FitError::Setup(format!("observation of bin {} beyond the {} bins", o.bin, data.bins.len())));
    }
    let per_channel = obs.iter().any(|o| o.channel != Channel::Luminance);
    let (coordinates, start) = coordinates_of(&spec.info, base, free, per_channel)?;
    check_data(obs.len(), coordinates.len(), obs.iter().map(|o| (o.value, o.sigma)))?;
    let build = |p: &ParamSet| (spec.build)(p);
    let residuals = |m: &SurfaceModel| {
        let f = bin_averages(m, &data.bins);
        obs.iter().map(|o| (o.channel.of(f[o.bin]) - o.value) / o.sigma).collect()
    };
    let problem = Problem { build: &build, base, coordinates: &coordinates, residuals: &residuals, constraint: None };
    solve(&problem, start, obs.len(), options)
}

/// A surface table's lobe as fit data: the bins of every incidence (see
/// [`surface_bins`]) with their values per channel (or luminance) and
/// standard errors (floored at the median positive one); and the `(θ, φ)` bin grid.
pub fn from_surface_table(
    t: &LobeSlices,
    per_channel: bool,
    sub: usize,
    viewer_first: bool,
) -> Result<SurfaceData, FitError> {
    let (nt, np) = (t.bins_theta, t.bins_phi);
    let peak = t.f.iter().flatten().map(|v| v.luminance()).fold(0.0, f64::max);
    if peak <= 0.0 {
        return Err(FitError::Setup("the lobe is zero in every bin; nothing to fit".into()));
    }
    check_surface_bins(nt, np, t.theta_in.len(), sub)?;
    let floor = std_floor(t);
    let mut data = SurfaceData::default();
    for s in 0..t.theta_in.len() {
        let first = data.bins.len();
        data.bins.extend(surface_bins(t.theta_in[s], t.phi_in[s], nt, np, sub, viewer_first));
        for b in 0..nt * np {
            for channel in channels(per_channel) {
                data.observations.push(BinObservation {
                    bin: first + b,
                    value: channel.of(t.f[s][b]),
                    sigma: channel.of(t.std[s][b]).max(floor),
                    channel,
                });
            }
        }
    }
    Ok(data)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_scatter::{build_surface, find};

    fn sadeghi(pairs: &[(&str, &str)]) -> ParamSet {
        let spec = find_surface("sadeghi-2013").unwrap();
        ParamSet::parse(spec.name, spec.params, pairs).unwrap()
    }

    /// A surface table synthesised from `sadeghi-2013` with known thread parameters — bin
    /// averages on a finer quadrature (6 × 6 nodes) than the fit's (3 × 3), plus 2 % noise
    /// per channel — is fitted from other starting values: the parameters come back within
    /// a few standard errors, the colour per channel.
    #[test]
    fn sadeghi_parameters_are_recovered_from_a_noisy_synthetic_table() {
        let truth_pairs = [("gamma_s_1", "9"), ("k_d_1", "0.4"), ("albedo_1", "0.2,0.45,0.7")];
        let truth = build_surface("sadeghi-2013", &truth_pairs).unwrap();
        let mut uniform = fiberlab_check::rng::TestRng::new(2013).into_uniforms();
        let (nt, np) = (12, 24);
        let mut data = SurfaceData::default();
        for (ti, pi) in [(0.5, 0.3), (1.0, 2.0)] {
            let fine = surface_bins(ti, pi, nt, np, 6, false);
            let f = bin_averages(&truth, &fine);
            let first = data.bins.len();
            data.bins.extend(surface_bins(ti, pi, nt, np, 3, false));
            for (b, v) in f.iter().enumerate() {
                for c in 0..3 {
                    let sigma = 0.02 * v[c] + 1e-4;
                    let z = ((0..4).map(|_| uniform()).sum::<f64>() - 2.0) * 3f64.sqrt();
                    data.observations.push(BinObservation {
                        bin: first + b,
                        value: v[c] + sigma * z,
                        sigma,
                        channel: Channel::Rgb(c),
                    });
                }
            }
        }
        let free = [
            FreeParam { key: "gamma_s_1".into(), start: vec![15.0] },
            FreeParam { key: "k_d_1".into(), start: vec![0.2] },
            FreeParam { key: "albedo_1".into(), start: vec![0.5] },
        ];
        let r =
            fit_surface(&sadeghi(&[]), &free, &data, &FitOptions { max_iters: 600, ..FitOptions::default() }).unwrap();
        let expect = [9.0, 0.4, 0.2, 0.45, 0.7];
        for (k, ((key, v), u)) in r.params.iter().zip(&r.uncertainties).enumerate() {
            let u = u.sigma().unwrap_or_else(|| panic!("{key}: {u:?}"));
            assert!((v - expect[k]).abs() < 5.0 * u + 0.01 * expect[k], "{key} = {v} ± {u}, truth {}", expect[k]);
        }
        assert!(r.chi2 / (r.dof as f64) < 2.0, "reduced χ² {}", r.chi2 / r.dof as f64);
    }

    /// The midpoint bins integrate the BRDF measure exactly for a constant: a Lambertian
    /// surface's bin averages equal k_d/π in every bin, whatever the node count.
    #[test]
    fn bin_averages_of_a_constant_brdf_are_that_constant() {
        let m = build_surface("lambertian", &[("k_d", "0.6")]).unwrap();
        for sub in [1, 4] {
            for f in bin_averages(&m, &surface_bins(0.7, -1.0, 5, 8, sub, sub == 4)) {
                assert!((f.luminance() - 0.6 / std::f64::consts::PI).abs() < 1e-12, "{f:?}");
            }
        }
    }

    /// The fixed direction of a bin is the light's unless `fixed_is_viewer`: for the
    /// non-reciprocal `sadeghi-2013` the two readings differ, and each is the model's
    /// `f_r(ω_light, ω_viewer)` with the directions in their places.
    #[test]
    fn the_fixed_direction_is_the_light_or_the_viewer() {
        let m = build_surface("sadeghi-2013", &[("preset", "silk-shot")]).unwrap();
        let (fixed, d) = (DVec3::new(0.5, 0.1, 0.86).normalize(), DVec3::new(-0.3, 0.6, 0.74).normalize());
        let bin = |fixed_is_viewer| SurfaceBin { fixed, fixed_is_viewer, nodes: vec![(d, 1.0)] };
        let (light, viewer) = (bin(false).average(&m), bin(true).average(&m));
        assert_eq!(light, m.eval(fixed, d));
        assert_eq!(viewer, m.eval(d, fixed));
        assert!((light.luminance() - viewer.luminance()).abs() > 1e-3 * light.luminance(), "{light:?} {viewer:?}");
    }

    /// A fiber model's name is refused by the surface fit, naming the surface models.
    #[test]
    fn a_fiber_model_is_refused_by_the_surface_fit() {
        let spec = find("chiang").unwrap();
        let base = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let e = fit_surface(
            &base,
            &[FreeParam { key: "beta_m".into(), start: vec![0.3] }],
            &SurfaceData::default(),
            &FitOptions { max_iters: 1, ..FitOptions::default() },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("fiber model") && e.contains("sadeghi-2013"), "{e}");
    }
}
