//! χ² of the cloth models' samplers against their pdfs, and the sampled estimate of
//! `∫ f_r cosθ_i dω_i` against quadrature. The surface models are wrapped as
//! [`ScatteringFunction`]s so that the fiber harness's χ² (which bins the whole sphere) applies.

use fiberlab_check::chi2::{Chi2Config, chi2_test};
use fiberlab_check::rng::TestRng;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::sadeghi_2013::{SADEGHI_PRESETS, Sadeghi2013, SadeghiThread, ThreadParams};
use fiberlab_scatter::{Field, Lobes, Properties, Sample, ScatteringFunction, SurfaceScattering};
use std::f64::consts::{FRAC_PI_2, TAU};

/// A surface model seen through the fiber interface (directions unchanged, `h` ignored).
struct AsFiber<'a, S: SurfaceScattering>(&'a S);

impl<S: SurfaceScattering> ScatteringFunction for AsFiber<'_, S> {
    fn properties(&self) -> Properties {
        Properties { reciprocal: false, energy_conserving: false, field: Field::Far, lobes: Lobes::Smooth }
    }
    fn eval(&self, wi: DVec3, wo: DVec3, _h: f64) -> Rgb {
        self.0.eval(wi, wo)
    }
    fn pdf(&self, wi: DVec3, wo: DVec3, _h: f64) -> f64 {
        self.0.pdf(wi, wo)
    }
    fn sample(&self, wo: DVec3, _h: f64, u: [f64; 4]) -> Option<Sample> {
        self.0.sample(wo, u)
    }
}

fn hemisphere(theta: f64, phi: f64) -> DVec3 {
    let (s, c) = theta.sin_cos();
    DVec3::new(s * phi.cos(), s * phi.sin(), c)
}

fn cfg(seed: u64) -> Chi2Config {
    Chi2Config { bins_theta: 32, bins_phi: 64, sub: 4, samples: 200_000, seed, ..Default::default() }
}

#[test]
fn sadeghi_surface_sampler_passes_chi2_for_every_preset() {
    for (k, name) in SADEGHI_PRESETS.iter().enumerate() {
        let m = Sadeghi2013::preset(name).unwrap();
        for (l, wo) in [hemisphere(0.3, 0.5), hemisphere(1.2, 2.0)].into_iter().enumerate() {
            let out = chi2_test(&AsFiber(&m), wo, 0.0, &cfg(17 + 2 * k as u64 + l as u64));
            assert!(out.passes(1e-3), "{name} wo {wo}: {out:?}");
            assert!((out.pdf_integral - 1.0).abs() < 2e-3, "{name}: ∫pdf = {}", out.pdf_integral);
        }
    }
}

#[test]
fn sadeghi_thread_sampler_passes_chi2() {
    let f = SadeghiThread::new(ThreadParams::default()).unwrap();
    for (k, wo) in
        [fiberlab_math::frame::direction(0.2, 0.4), fiberlab_math::frame::direction(-1.2, 2.0)].into_iter().enumerate()
    {
        let out = chi2_test(&f, wo, 0.0, &cfg(40 + k as u64));
        assert!(out.passes(1e-3), "{out:?}");
    }
}

/// `E[weight] = ∫ f_r cosθ_i dω_i`, the quadrature side by a midpoint rule over the light
/// hemisphere.
#[test]
fn sadeghi_sample_weights_estimate_the_quadrature_integral() {
    let m = Sadeghi2013::preset("linen-plain").unwrap();
    let wo = hemisphere(0.7, 1.0);
    let (nt, np) = (120, 240);
    let (dt, dp) = (FRAC_PI_2 / nt as f64, TAU / np as f64);
    let mut quad = 0.0;
    for a in 0..nt {
        let t = (a as f64 + 0.5) * dt;
        for b in 0..np {
            quad += m.eval(hemisphere(t, (b as f64 + 0.5) * dp), wo)[1] * t.cos() * t.sin() * dt * dp;
        }
    }
    let mut rng = TestRng::new(99);
    let n = 400_000;
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..n {
        let w = m.sample(wo, rng.u4()).map_or(0.0, |s| s.weight[1]);
        sum += w;
        sum2 += w * w;
    }
    let mean = sum / n as f64;
    let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
    assert!((mean - quad).abs() < 5.0 * sigma + 1e-3 * quad, "MC {mean} ± {sigma} vs quadrature {quad}");
}

#[test]
fn irawan_sampler_passes_chi2_for_every_preset() {
    use fiberlab_scatter::irawan_2012::{IRAWAN_PRESETS, Irawan2012};
    for (k, name) in IRAWAN_PRESETS.iter().enumerate() {
        let mut m = Irawan2012::preset(name).unwrap();
        m.set_position(0.3, 0.7);
        let wo = hemisphere(0.2 + 0.2 * k as f64, 0.5 * k as f64);
        let out = chi2_test(&AsFiber(&m), wo, 0.0, &cfg(60 + k as u64));
        assert!(out.passes(1e-3), "{name}: {out:?}");
        assert!((out.pdf_integral - 1.0).abs() < 2e-3, "{name}: ∫pdf = {}", out.pdf_integral);
    }
}

/// `E[weight] = ∫ f_r cosθ_i dω_i` for the Irawan sampler at a point with a highlight.
#[test]
fn irawan_sample_weights_estimate_the_quadrature_integral() {
    let mut m = fiberlab_scatter::irawan_2012::Irawan2012::preset("silk-charmeuse").unwrap();
    m.set_position(0.3, 0.42);
    let wo = hemisphere(0.5, 0.3);
    let (nt, np) = (200, 400);
    let (dt, dp) = (FRAC_PI_2 / nt as f64, TAU / np as f64);
    let mut quad = 0.0;
    for a in 0..nt {
        let t = (a as f64 + 0.5) * dt;
        for b in 0..np {
            quad += m.eval(hemisphere(t, (b as f64 + 0.5) * dp), wo)[0] * t.cos() * t.sin() * dt * dp;
        }
    }
    let mut rng = TestRng::new(5);
    let n = 400_000;
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..n {
        let w = m.sample(wo, rng.u4()).map_or(0.0, |s| s.weight[0]);
        sum += w;
        sum2 += w * w;
    }
    let mean = sum / n as f64;
    let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
    assert!((mean - quad).abs() < 5.0 * sigma + 2e-3 * quad, "MC {mean} ± {sigma} vs quadrature {quad}");
}
