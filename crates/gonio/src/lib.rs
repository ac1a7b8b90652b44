//! The virtual goniophotometer: the full scattering distribution of a fiber measured by
//! tracing rays through explicit geometry (elliptical cross-section, tilted cuticle scales,
//! absorbing interior, scattering medulla), binned per path class into tables of `f_s`
//! with curve-radiometric normalization (docs/theory/radiometry.md).
//!
//! A collimated beam from `ω_i` illuminates the fiber uniformly over its projected width
//! and along one scale period; each bin's `f_s` is the fraction of intercepted power that
//! leaves through the bin divided by `∫_bin cosθ_r dω_r`, with a Monte Carlo standard error.
//! Measurements are deterministic for a seed, whatever the thread count. Pure: no I/O.
//!
//! Three instruments share that estimator: the single fiber ([`fiber`], this module's
//! [`measure`]), the slab of parallel fibers seen as a surface ([`fiber_slab`], wood), and the
//! periodic patch of explicit fibers path traced with a fiber model ([`cloth`], woven cloth;
//! its tubes are `fiberlab_geometry`'s curve BVH).
#![forbid(unsafe_code)]

pub mod bin_sums;
pub mod cloth;
pub mod fiber;
pub mod fiber_slab;
pub use bin_sums::BinSums;
pub mod interface;
pub mod model_comparison;
pub mod roulette;
pub mod surface;
pub mod trace;

pub use fiber::{FIBER_PARAMS, Fiber, FiberError, FiberKeyError, Lumen, Medulla, Orientation, SurfaceKind};
pub use trace::{Lobe, Outcome};

use fiberlab_math::frame::{direction, phi, theta, wrap_pi};
use fiberlab_math::{DVec3, Rgb};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::atomic::{AtomicBool, Ordering};
use surface::Surface;

/// Rays traced per independently seeded chunk.
const CHUNK: usize = 1 << 16;

/// What to measure, on a fiber ([`measure`]) or on a surface (the slab of
/// [`fiber_slab::measure_surface`], the woven patch of [`cloth::measure_cloth`]). For the woven
/// patch `theta_i`, `phi_i` are the direction paths are traced from (the viewer's, as the
/// renderer's camera paths), θ_i in [0, 89.9°).
#[derive(Clone, Copy, Debug)]
pub struct Setup {
    /// Light inclination θ_i (radians): on a fiber from the normal plane, |θ_i| < π/2; on a
    /// surface from the normal, [0, π/2).
    pub theta_i: f64,
    /// Light azimuth φ_i (radians): on a fiber relative to the frame's `y` axis (matters for
    /// ellipses); on a surface from `+x` toward `+y`.
    pub phi_i: f64,
    /// Number of rays.
    pub rays: usize,
    /// Bins in θ_r: on a fiber over [−π/2, π/2], on a surface over [0, π/2].
    pub bins_theta: usize,
    /// Bins in φ over [−π, π]: on a fiber φ = φ_r − φ_i, on a surface the absolute azimuth in
    /// the local frame.
    pub bins_phi: usize,
    /// Seed of the ray streams.
    pub seed: u64,
}

impl Setup {
    /// Bins per table, `bins_theta × bins_phi`, counted in u64; `None` on overflow.
    #[must_use]
    pub fn bin_count(&self) -> Option<u64> {
        (self.bins_theta as u64).checked_mul(self.bins_phi as u64)
    }

    /// Checks that the bins fit the measurement's 32-bit bin indices.
    pub fn check_bins(&self) -> Result<(), FiberError> {
        let bins = self.bins_theta as u128 * self.bins_phi as u128;
        if bins > u128::from(u32::MAX) {
            return Err(FiberError::TooManyBins { bins_theta: self.bins_theta, bins_phi: self.bins_phi, bins });
        }
        Ok(())
    }

    /// Peak bytes [`measure`] holds for this setup with `threads` worker threads: per bin the
    /// running sums (Σw and Σw², RGB f64, for the 6 tables: 6 × 2 × 24 = 288 bytes) and the
    /// result (`f` and `std` of the 6 tables: 288 more), and the ray records of one batch of
    /// chunks in flight (2 chunks of 65,536 rays per thread, 32 bytes each). `None` on overflow.
    #[must_use]
    pub fn estimated_bytes(&self, threads: usize) -> Option<u64> {
        let per_bin = 2 * RESULT_BYTES_PER_BIN;
        let records = (2 * threads.max(1) as u64).checked_mul((CHUNK * std::mem::size_of::<Record>()) as u64)?;
        self.bin_count()?.checked_mul(per_bin)?.checked_add(records)
    }
}

/// Bytes per bin of a measurement's six tables of `f` and `std` (RGB f64 each), the same as
/// of its running sums.
pub const RESULT_BYTES_PER_BIN: u64 = 6 * 2 * std::mem::size_of::<Rgb>() as u64;

/// One path class's table: per-bin `f_s` (sr⁻¹) and standard error, row-major `[θ][φ]`.
#[derive(Clone, Debug)]
pub struct LobeTable {
    /// Bin-averaged `f_s`.
    pub f: Vec<Rgb>,
    /// Monte Carlo standard error of `f`.
    pub std: Vec<Rgb>,
    /// Fraction of the intercepted power in this class (its albedo at θ_i).
    pub albedo: Rgb,
}

/// A measured scattering distribution.
#[derive(Clone, Debug)]
pub struct Measurement {
    /// The setup it was measured with.
    pub setup: Setup,
    /// Tables for `r, tt, trt, higher, medulla` (index = [`Lobe`] as usize) and `all` (index 5).
    pub lobes: Vec<LobeTable>,
    /// Rays that missed the fiber (sampled beam slightly wider than the mean fiber width).
    pub missed: usize,
    /// Paths dropped after too many events.
    pub dropped: usize,
    /// Paths ended by a rough interface sending them back into its microsurface (the energy
    /// the single-scattering microfacet interface loses; 0 for a smooth fiber).
    pub masked: usize,
    /// Rays actually traced (fewer than requested if interrupted).
    pub traced: usize,
}

/// Rows of `fiberlab measure`'s table ([`fiberlab_io::table::write`]).
impl fiberlab_io::table::Tabulated for Measurement {
    fn incidence(&self) -> (f64, f64) {
        (self.setup.theta_i, self.setup.phi_i)
    }

    fn bins(&self) -> (usize, usize) {
        (self.setup.bins_theta, self.setup.bins_phi)
    }

    fn bin_centre(&self, i: usize, j: usize) -> (f64, f64) {
        Measurement::bin_centre(self, i, j)
    }

    fn lobe_tables(&self) -> Vec<(&'static str, &[Rgb], &[Rgb])> {
        Self::LOBE_NAMES.iter().zip(&self.lobes).map(|(name, l)| (*name, &l.f[..], &l.std[..])).collect()
    }
}

impl Measurement {
    /// Lobe names in table order.
    pub const LOBE_NAMES: [&'static str; 6] = ["r", "tt", "trt", "higher", "medulla", "all"];

    /// Centre (θ_r, φ) in radians of bin `(i, j)`.
    #[must_use]
    pub fn bin_centre(&self, i: usize, j: usize) -> (f64, f64) {
        let s = &self.setup;
        (-FRAC_PI_2 + (i as f64 + 0.5) * PI / s.bins_theta as f64, -PI + (j as f64 + 0.5) * TAU / s.bins_phi as f64)
    }

    /// Table of lobe `name` (`r`, `tt`, `trt`, `higher`, `medulla`, `all`).
    #[must_use]
    pub fn lobe(&self, name: &str) -> Option<&LobeTable> {
        Self::LOBE_NAMES.iter().position(|n| *n == name).map(|k| &self.lobes[k])
    }
}

/// `∫_bin cosθ dω` for the θ-row `i` (all φ-bins of a row are equal).
fn cos_weighted_solid_angle(i: usize, bins_theta: usize, bins_phi: usize) -> f64 {
    let a = -FRAC_PI_2 + i as f64 * PI / bins_theta as f64;
    let b = a + PI / bins_theta as f64;
    let prim = |t: f64| 0.5 * t + 0.25 * (2.0 * t).sin();
    (prim(b) - prim(a)) * TAU / bins_phi as f64
}

/// Half-width of the nominal cross-section seen across direction `e` (unit, normal plane).
fn half_width(fiber: &Fiber, psi: f64, e: DVec3) -> f64 {
    let (s, c) = psi.sin_cos();
    let ev = e.y * c + e.z * s;
    let ew = -e.y * s + e.z * c;
    (ev * ev + fiber.aspect * fiber.aspect * ew * ew).sqrt()
}

/// One ray's contribution: bin, lobe and weight (weight already includes the beam factor).
struct Record {
    bin: u32,
    lobe: u8,
    w: Rgb,
}

/// Measures the scattering distribution of `fiber` for `setup`. `progress(rays_done)` is
/// called after each chunk; setting `stop` ends the measurement early (what was traced is
/// kept and normalized by the rays actually traced).
pub fn measure(
    fiber: &Fiber,
    setup: &Setup,
    stop: &AtomicBool,
    progress: impl Fn(usize) + Sync,
) -> Result<Measurement, FiberError> {
    fiber.validate()?;
    if setup.theta_i.is_nan() || setup.theta_i.abs() >= 89.9f64.to_radians() {
        let value = setup.theta_i.to_degrees();
        return Err(FiberError::OutOfRange { key: "theta_i", value, range: "(−89.9, 89.9) degrees" });
    }
    setup.check_bins()?;
    let (nt, np) = (setup.bins_theta.max(1), setup.bins_phi.max(1));
    let wi = direction(setup.theta_i, setup.phi_i);
    let d = -wi;
    let e = DVec3::X.cross(d).normalize(); // across the beam, in the normal plane
    let half_scale = if fiber.has_scales() { 0.5 * fiber.scale_length * fiber.scale_angle.tan().abs() } else { 0.0 };
    let s_max = 1.0 + half_scale;
    // Mean nominal half-width over orientations (one value for a fixed orientation).
    let mean_half = match fiber.orientation {
        Orientation::Fixed(psi) => half_width(fiber, psi, e),
        Orientation::Average => (0..4096).map(|k| half_width(fiber, TAU * k as f64 / 4096.0, e)).sum::<f64>() / 4096.0,
    };
    // Rays start 4 radii from the axis, beyond the surface (radius < 1.25 with scales): along
    // the beam that is 4/cosθ_i back, not 4 (at θ_i > 76° a start 4 back along the beam was
    // still inside the fiber).
    let back_off = 4.0 / (d.y * d.y + d.z * d.z).sqrt();
    let chunks = setup.rays.div_ceil(CHUNK);
    let mut sums = BinSums::new(5, nt * np);
    let (mut missed, mut dropped, mut masked, mut traced) = (0usize, 0usize, 0usize, 0usize);
    let batch = 2 * rayon::current_num_threads().max(1);
    let mut next = 0;
    while next < chunks && !stop.load(Ordering::Relaxed) {
        let end = (next + batch).min(chunks);
        let results: Vec<(Vec<Record>, [usize; 3], usize)> = (next..end)
            .into_par_iter()
            .map(|c| {
                let n = CHUNK.min(setup.rays - c * CHUNK);
                let mut rng = Pcg64::seed_from_u64(setup.seed ^ (c as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
                let mut records = Vec::with_capacity(n);
                let (mut miss, mut drop, mut lost) = (0, 0, 0);
                for _ in 0..n {
                    let psi = match fiber.orientation {
                        Orientation::Fixed(p) => p,
                        Orientation::Average => TAU * rng.random::<f64>(),
                    };
                    let surface = Surface::new(psi, fiber.aspect, fiber.scale_angle, fiber.scale_length);
                    let half = half_width(fiber, psi, e);
                    let offset = (2.0 * rng.random::<f64>() - 1.0) * half * s_max;
                    let x0 = rng.random::<f64>() * fiber.scale_length;
                    let origin = DVec3::X * x0 + e * offset - d * back_off;
                    match trace::trace(fiber, &surface, origin, d, &mut rng) {
                        Outcome::Missed => miss += 1,
                        Outcome::Dropped => drop += 1,
                        Outcome::Masked => lost += 1,
                        Outcome::Exit(x) => {
                            let (tr, rel) = (theta(x.direction), wrap_pi(phi(x.direction) - setup.phi_i));
                            let i = (((tr + FRAC_PI_2) / PI * nt as f64) as usize).min(nt - 1);
                            let j = (((rel + PI) / TAU * np as f64) as usize).min(np - 1);
                            // Each ray carries the beam power of its width: s_max·half/mean_half.
                            let beam = s_max * half / mean_half;
                            records.push(Record { bin: (i * np + j) as u32, lobe: x.lobe as u8, w: x.weight * beam });
                        }
                    }
                }
                progress(n);
                (records, [miss, drop, lost], n)
            })
            .collect();
        // Merge in chunk order: the sums do not depend on the thread count.
        for (records, [miss, drop, lost], n) in results {
            for r in records {
                sums.add(r.lobe as usize, r.bin as usize, r.w);
            }
            missed += miss;
            dropped += drop;
            masked += lost;
            traced += n;
        }
        next = end;
    }
    let lobes = sums.tables(traced, nt, np, |i| cos_weighted_solid_angle(i, nt, np));
    Ok(Measurement { setup: *setup, lobes, missed, dropped, masked, traced })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_estimate_and_bin_limit_in_u64() {
        let setup = Setup { theta_i: 0.3, phi_i: 0.0, rays: 10, bins_theta: 180, bins_phi: 360, seed: 1 };
        assert_eq!(setup.bin_count(), Some(64_800));
        assert_eq!(std::mem::size_of::<Record>(), 32);
        // 576 bytes per bin; 2 threads: 4 chunks of 65,536 records of 32 bytes.
        assert_eq!(setup.estimated_bytes(2), Some(64_800 * 576 + 4 * 65_536 * 32));
        let absurd = Setup { bins_theta: 100_000, bins_phi: 100_000, ..setup };
        assert_eq!(absurd.estimated_bytes(1), Some(10_000_000_000 * 576 + 2 * 65_536 * 32));
        let e = absurd.check_bins().unwrap_err().to_string();
        assert!(e.contains("100000 × 100000 = 10000000000 bins"), "{e}");
        let e = measure(&Fiber::default(), &absurd, &AtomicBool::new(false), |_| {}).unwrap_err();
        assert!(matches!(e, FiberError::TooManyBins { .. }), "{e}");
        assert!(Setup { bins_theta: 65_536, bins_phi: 65_535, ..setup }.check_bins().is_ok());
        assert!(Setup { bins_theta: 65_536, bins_phi: 65_536, ..setup }.check_bins().is_err());
        assert_eq!(Setup { bins_theta: usize::MAX, bins_phi: usize::MAX, ..setup }.estimated_bytes(1), None);
    }
    use fiberlab_math::fresnel;

    fn run(fiber: &Fiber, theta_i: f64, rays: usize, bins: (usize, usize)) -> Measurement {
        let setup = Setup { theta_i, phi_i: 0.0, rays, bins_theta: bins.0, bins_phi: bins.1, seed: 7 };
        measure(fiber, &setup, &AtomicBool::new(false), |_| {}).unwrap()
    }

    #[test]
    fn lossless_smooth_fiber_conserves_energy() {
        let m = run(&Fiber::default(), 0.4, 200_000, (36, 72));
        let all = m.lobe("all").unwrap().albedo;
        let kept = 1.0 - m.dropped as f64 / m.traced as f64;
        assert!((all[0] - kept).abs() < 1e-12, "albedo {all:?}, dropped {}", m.dropped);
        assert!(m.dropped < 20);
        let sum: f64 = (0..5).map(|k| m.lobes[k].albedo[1]).sum();
        assert!((sum - all[1]).abs() < 1e-12);
        assert_eq!(m.missed, 0);
    }

    /// Light at grazing incidence: the rays of a lossless smooth fiber leave it, and the
    /// share that one external reflection sends back is the closed form
    /// `½∫_{−1}^{1} F(cosθ_i·√(1 − h²)) dh` (the incidence angle at offset h of a cylinder).
    /// Rays used to start 4 radii back along the beam, which at θ_i > 76° is still inside the
    /// fiber: at 85° 94 % of them bounced to the event limit and were dropped.
    #[test]
    fn grazing_light_on_a_smooth_fiber_keeps_its_energy_and_the_closed_form_reflection() {
        let eta = Fiber::default().eta;
        for theta_deg in [-85.0f64, 78.0, 89.5] {
            let theta = theta_deg.to_radians();
            let rays = 200_000;
            let m = run(&Fiber::default(), theta, rays, (36, 72));
            assert_eq!(m.missed, 0, "θ_i = {theta_deg}°");
            // Near 90° the inner reflectance nears 1 too: a few paths reach the event limit.
            assert!(m.dropped < rays / 2000, "θ_i = {theta_deg}°: dropped {}", m.dropped);
            let all = m.lobe("all").unwrap().albedo[0];
            assert!((all - 1.0 + m.dropped as f64 / m.traced as f64).abs() < 1e-12, "θ_i = {theta_deg}°: {all}");
            let n = 20_000;
            let closed: f64 = (0..n)
                .map(|k| {
                    let h = -1.0 + (k as f64 + 0.5) * 2.0 / n as f64;
                    fresnel::dielectric(theta.cos() * (1.0 - h * h).sqrt(), eta)
                })
                .sum::<f64>()
                / n as f64;
            let r = m.lobe("r").unwrap().albedo[0];
            let se = (closed * (1.0 - closed) / rays as f64).sqrt();
            assert!((r - closed).abs() < 5.0 * se, "θ_i = {theta_deg}°: R {r}, closed form {closed} ± {se}");
        }
    }

    /// A lossless rough fiber (circular and elliptical, with scales) keeps every ray's power
    /// except what its interfaces mask: each exit carries the product of its masking weights,
    /// each masked path loses all. Between the two, nothing is created.
    #[test]
    fn lossless_rough_fiber_accounts_for_every_ray() {
        for fiber in [
            Fiber { roughness: 0.3, ..Fiber::default() },
            Fiber { roughness: 0.6, aspect: 0.7, scale_angle: 3f64.to_radians(), ..Fiber::default() },
        ] {
            let m = run(&fiber, 0.4, 100_000, (18, 36));
            let all = m.lobe("all").unwrap().albedo[0];
            let masked = m.masked as f64 / m.traced as f64;
            assert!(m.masked > 0 && m.dropped < 5, "{m:?}");
            // Exits carry weights ≤ 1: the albedo is at most the unmasked fraction (the masking
            // weights of the survivors cost more the rougher the fiber and the longer the path).
            eprintln!("α {}: albedo {all:.4}, masked {masked:.4}", fiber.roughness);
            assert!(all <= 1.0 - masked + 1e-12 && all > 0.6 * (1.0 - masked), "{all} {masked}");
        }
    }

    #[test]
    fn smooth_reflection_matches_fresnel_weighted_mirror_cone() {
        // R lands exactly on θ_r = −θ_i; per φ-column the power is
        // ∫_col F(η, cosθ_i cos(φ/2)) cos(φ/2)/4 dφ (docs/theory/radiometry.md, "Ideal specular
        // fiber").
        let theta_i = 0.3;
        let (nt, np) = (180, 36);
        let m = run(&Fiber::default(), theta_i, 2_000_000, (nt, np));
        let r = m.lobe("r").unwrap();
        let row = (((-theta_i + FRAC_PI_2) / PI) * nt as f64) as usize;
        let omega = cos_weighted_solid_angle(row, nt, np);
        for j in 0..np {
            let (a, b) = (-PI + j as f64 * TAU / np as f64, -PI + (j + 1) as f64 * TAU / np as f64);
            let k = 2000;
            let expected: f64 = (0..k)
                .map(|s| {
                    let p = a + (s as f64 + 0.5) * (b - a) / k as f64;
                    fresnel::dielectric(theta_i.cos() * (0.5 * p).cos(), 1.55) * (0.5 * p).cos() / 4.0 * (b - a)
                        / k as f64
                })
                .sum();
            let got = r.f[row * np + j][0] * omega;
            let se = r.std[row * np + j][0] * omega;
            assert!((got - expected).abs() < 5.0 * se + 1e-6, "column {j}: {got} vs {expected} ± {se}");
        }
        // Nothing of R outside that row.
        let elsewhere: f64 =
            (0..nt).filter(|&i| i != row).map(|i| (0..np).map(|j| r.f[i * np + j][0]).sum::<f64>()).sum();
        assert_eq!(elsewhere, 0.0);
    }

    /// Peak of the θ-marginal of a lobe, restricted to |φ| in [lo, hi] (degrees), as θ_r + θ_i
    /// (radians), with parabolic interpolation between bins.
    fn peak_shift(m: &Measurement, lobe: &str, lo: f64, hi: f64) -> f64 {
        let t = m.lobe(lobe).unwrap();
        let (nt, np) = (m.setup.bins_theta, m.setup.bins_phi);
        let marginal: Vec<f64> = (0..nt)
            .map(|i| {
                (0..np)
                    .filter(|&j| (lo..=hi).contains(&m.bin_centre(i, j).1.to_degrees().abs()))
                    .map(|j| t.f[i * np + j][0] * cos_weighted_solid_angle(i, nt, np))
                    .sum()
            })
            .collect();
        let k = (1..nt - 1).max_by(|&a, &b| marginal[a].total_cmp(&marginal[b])).unwrap();
        let (a, b, c) = (marginal[k - 1], marginal[k], marginal[k + 1]);
        let offset = if a - 2.0 * b + c != 0.0 { 0.5 * (a - c) / (a - 2.0 * b + c) } else { 0.0 };
        m.bin_centre(k, 0).0 + offset * PI / nt as f64 + m.setup.theta_i
    }

    #[test]
    fn tilted_scales_shift_r_toward_the_root_and_tt_trt_toward_the_tip() {
        let alpha = 3f64.to_radians();
        let fiber = Fiber { scale_angle: alpha, scale_length: 0.3, ..Fiber::default() };
        let m = run(&fiber, 0.3, 2_000_000, (720, 72));
        let smooth = run(&Fiber::default(), 0.3, 2_000_000, (720, 72));
        let shift =
            |lobe: &str, lo: f64, hi: f64| (peak_shift(&m, lobe, lo, hi) - peak_shift(&smooth, lobe, lo, hi)) / alpha;
        let (r_back, r_all) = (shift("r", 0.0, 30.0), shift("r", 0.0, 180.0));
        let (tt, trt) = (shift("tt", 150.0, 180.0), shift("trt", 0.0, 60.0));
        eprintln!("peak shifts / α: R(|φ|<30°) {r_back:.2} R(all) {r_all:.2} TT(forward) {tt:.2} TRT {trt:.2}");
        assert!((r_back + 2.0).abs() < 0.3, "R shift {r_back}");
        assert!(r_all < -1.0, "R shift {r_all}");
        assert!(tt > 0.3 && tt < 2.0, "TT shift {tt}");
        assert!(trt > 2.0 && trt < 5.0, "TRT shift {trt}");
    }

    /// `½∫ A(p, h) dh` for p = 1 (TT) and 2 (TRT) with exact 3D Fresnel and absorption
    /// `exp(−σ_a·path)`, where `path(γ_t, θ_t)` is the internal path of one chord.
    fn lobe_albedo(theta: f64, sigma: f64, p: i32, path: impl Fn(f64, f64) -> f64) -> f64 {
        let (eta, (st, ct)) = (1.55, theta.sin_cos());
        let n = 20_000;
        (0..n)
            .map(|k| {
                let h = -1.0 + (k as f64 + 0.5) * 2.0 / n as f64;
                let f = fresnel::dielectric(ct * (1.0 - h * h).sqrt(), eta);
                let gamma_t = fiberlab_math::bravais::sin_gamma_t(h, eta, st, ct).asin();
                let cos_theta_t = fiberlab_math::bravais::cos_theta_t(eta, st);
                let t = (-sigma * path(gamma_t, cos_theta_t)).exp();
                (1.0 - f).powi(2) * f.powi(p - 1) * t.powi(p) / n as f64
            })
            .sum()
    }

    #[test]
    fn absorption_follows_the_chord_length_not_the_printed_path() {
        let (theta, sigma) = (0.4, 0.6);
        let fiber = Fiber { sigma_a: Rgb::splat(sigma), ..Fiber::default() };
        let m = run(&fiber, theta, 2_000_000, (18, 36));
        for (lobe, p) in [("tt", 1), ("trt", 2)] {
            let measured = m.lobe(lobe).unwrap().albedo[0];
            // Standard error of a fraction estimated from N Bernoulli-like weights ≤ 1.
            let se = (measured * (1.0 - measured) / m.traced as f64).sqrt();
            let chord = lobe_albedo(theta, sigma, p, |g, ct| 2.0 * g.cos() / ct);
            let printed = lobe_albedo(theta, sigma, p, |g, ct| 2.0 * (1.0 + (2.0 * g).cos()) / ct);
            eprintln!("{lobe}: measured {measured:.5} ± {se:.5}, chord {chord:.5}, printed {printed:.5}");
            assert!((measured - chord).abs() < 5.0 * se, "{lobe}: {measured} vs chord {chord}");
            assert!((measured - printed).abs() > 20.0 * se, "{lobe}: cannot tell the formulas apart");
        }
    }

    #[test]
    fn lambertian_surface_reproduces_the_analytic_lambertian_cylinder() {
        // f_s = (ρ/4π)·[(π − |φ|)cosφ + sin|φ|], independent of θ (docs/theory/radiometry.md,
        // "Lambertian cylinder").
        let rho = 0.7;
        let fiber = Fiber { surface: SurfaceKind::Lambertian(Rgb::splat(rho)), ..Fiber::default() };
        let (nt, np) = (12, 24);
        let m = run(&fiber, 0.5, 4_000_000, (nt, np));
        let all = m.lobe("all").unwrap();
        assert!((all.albedo[0] - rho).abs() < 1e-12);
        let mut worst: f64 = 0.0;
        for i in 0..nt {
            for j in 0..np {
                let (a, b) = (-PI + j as f64 * TAU / np as f64, -PI + (j + 1) as f64 * TAU / np as f64);
                let k = 400;
                let expected: f64 = (0..k)
                    .map(|s| {
                        let p: f64 = a + (s as f64 + 0.5) * (b - a) / k as f64;
                        let g = (PI - p.abs()) * p.cos() + p.abs().sin();
                        rho / (4.0 * PI) * g / k as f64
                    })
                    .sum();
                let (got, se) = (all.f[i * np + j][0], all.std[i * np + j][0]);
                // Error expected from the analytic value itself (each hit carries weight ρ).
                let omega = cos_weighted_solid_angle(i, nt, np);
                let se_expected = (expected * omega * rho / m.traced as f64).sqrt() / omega;
                let z = (got - expected) / se.max(se_expected);
                worst = worst.max(z.abs());
                assert!(z.abs() < 5.0, "bin ({i}, {j}): {got} vs {expected} ± {se}");
            }
        }
        eprintln!("worst |z| = {worst:.2}");
    }

    #[test]
    fn deterministic_for_a_seed_whatever_the_threads() {
        let fiber = Fiber { scale_angle: 3f64.to_radians(), sigma_a: Rgb::new(0.2, 0.4, 0.8), ..Fiber::default() };
        let a = run(&fiber, 0.2, 150_000, (18, 36));
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let b = pool.install(|| run(&fiber, 0.2, 150_000, (18, 36)));
        assert_eq!(a.lobes[5].f, b.lobes[5].f);
    }
}

#[cfg(test)]
mod medulla_tests {
    use super::*;

    /// A medulla that neither scatters nor absorbs differently from the cortex is invisible: with
    /// σ_s = 0 the walk draws no extra random numbers, so the same seed traces the same paths,
    /// and only the split of each chord into pieces (rounding) may differ. Before the medium was
    /// kept as state, points placed on the boundary were classified by their rounded radius and
    /// ≈ 30 % of the rays through the medulla were dropped or bypassed it.
    #[test]
    fn a_clear_medulla_matching_the_cortex_changes_nothing() {
        let sigma_a = Rgb::new(0.3, 0.6, 1.2);
        let plain = Fiber { sigma_a, ..Fiber::default() };
        for (radius, theta_i) in [(0.5, 0.0), (0.8, 0.5), (0.3, -0.9)] {
            let clear = Fiber { medulla: Some(Medulla { radius, sigma_s: 0.0, sigma_a, g: 0.0 }), ..plain };
            let setup = Setup { theta_i, phi_i: 0.0, rays: 100_000, bins_theta: 18, bins_phi: 36, seed: 5 };
            let a = measure(&plain, &setup, &AtomicBool::new(false), |_| {}).unwrap();
            let b = measure(&clear, &setup, &AtomicBool::new(false), |_| {}).unwrap();
            assert_eq!((b.dropped, b.missed), (a.dropped, a.missed), "κ {radius}, θ_i {theta_i}");
            for lobe in ["r", "tt", "trt", "all"] {
                let (x, y) = (a.lobe(lobe).unwrap().albedo, b.lobe(lobe).unwrap().albedo);
                for c in 0..3 {
                    assert!((x[c] - y[c]).abs() <= 1e-9 * x[c].max(1e-12), "{lobe} κ {radius}: {x:?} vs {y:?}");
                }
            }
            assert_eq!(b.lobe("medulla").unwrap().albedo, Rgb::ZERO);
        }
    }

    #[test]
    fn lossless_scattering_medulla_conserves_energy_and_forms_its_own_lobe() {
        let fiber = Fiber {
            medulla: Some(Medulla { radius: 0.5, sigma_s: 4.0, sigma_a: Rgb::ZERO, g: 0.3 }),
            ..Fiber::default()
        };
        let setup = Setup { theta_i: 0.3, phi_i: 0.0, rays: 200_000, bins_theta: 18, bins_phi: 36, seed: 2 };
        let m = measure(&fiber, &setup, &AtomicBool::new(false), |_| {}).unwrap();
        let kept = 1.0 - m.dropped as f64 / m.traced as f64;
        assert!((m.lobes[5].albedo[0] - kept).abs() < 1e-12);
        let medulla = m.lobe("medulla").unwrap().albedo[0];
        assert!(medulla > 0.2, "medulla lobe {medulla}");
        // Medulla absorption removes energy only from paths that scatter in it.
        let absorbing = Fiber {
            medulla: Some(Medulla { radius: 0.5, sigma_s: 4.0, sigma_a: Rgb::splat(2.0), g: 0.3 }),
            ..Fiber::default()
        };
        let a = measure(&absorbing, &setup, &AtomicBool::new(false), |_| {}).unwrap();
        assert!(
            a.lobes[5].albedo[0] < 0.95
                && (a.lobe("r").unwrap().albedo[0] - m.lobe("r").unwrap().albedo[0]).abs() < 1e-12
        );
    }
}

#[cfg(test)]
mod lumen_tests {
    use super::*;

    fn run(fiber: &Fiber, theta_i: f64, rays: usize) -> Measurement {
        let setup = Setup { theta_i, phi_i: 0.0, rays, bins_theta: 18, bins_phi: 36, seed: 9 };
        measure(fiber, &setup, &AtomicBool::new(false), |_| {}).unwrap()
    }

    /// A lumen of the wall's own index is the medulla's boundary: crossed straight, drawing no
    /// random number, so the same seed traces the same paths as the solid fiber (clear, since
    /// the lumen does not absorb).
    #[test]
    fn an_index_matched_lumen_changes_nothing() {
        let plain = Fiber::default();
        let matched = Fiber { lumen: Some(Lumen { radius: 0.6, eta: plain.eta }), ..plain };
        let (a, b) = (run(&plain, 0.4, 100_000), run(&matched, 0.4, 100_000));
        assert_eq!((b.dropped, b.missed), (a.dropped, a.missed));
        for lobe in ["r", "tt", "trt", "higher", "all"] {
            let (x, y) = (a.lobe(lobe).unwrap().albedo, b.lobe(lobe).unwrap().albedo);
            for c in 0..3 {
                assert!((x[c] - y[c]).abs() <= 1e-9 * x[c].max(1e-12), "{lobe}: {x:?} vs {y:?}");
            }
        }
    }

    /// A clear wall around an air lumen loses nothing (all light leaves, but for dropped paths);
    /// the outer reflection does not see the lumen (the same R within its binomial error: the
    /// streams differ after the first ray that meets the lumen); the lumen turns light out of
    /// the forward TT lobe.
    #[test]
    fn a_lossless_hollow_fiber_conserves_energy() {
        let plain = Fiber::default();
        let hollow = Fiber { lumen: Some(Lumen { radius: 0.7, eta: 1.0 }), ..plain };
        let (a, b) = (run(&plain, 0.3, 200_000), run(&hollow, 0.3, 200_000));
        let kept = 1.0 - b.dropped as f64 / b.traced as f64;
        assert!((b.lobes[5].albedo[0] - kept).abs() < 1e-12 && kept > 0.999, "{kept}");
        let (ra, rb) = (a.lobe("r").unwrap().albedo[0], b.lobe("r").unwrap().albedo[0]);
        let sigma = (ra * (1.0 - ra) / a.traced as f64).sqrt();
        assert!((ra - rb).abs() < 5.0 * std::f64::consts::SQRT_2 * sigma, "R {ra} vs {rb} (σ {sigma})");
        let forward = |m: &Measurement| {
            let t = m.lobe("tt").unwrap();
            // φ columns within 30° of forward scattering (|φ| ≥ 150°), all θ rows.
            (0..18 * 36).filter(|k| (k % 36) < 3 || (k % 36) >= 33).map(|k| t.f[k][0]).sum::<f64>()
        };
        // (More forward, as it happens: crossing the air lumen turns a ray back toward its
        // original direction; the amount is the model's business, `tests/hollow_fiber.rs`.)
        assert!((forward(&b) - forward(&a)).abs() > 0.05 * forward(&a), "{} vs {}", forward(&b), forward(&a));
    }
}
