//! The cloth goniophotometer: an explicit periodic patch of fibers (a woven patch of
//! `fiberlab_procedural::woven_patch`, or any periodic set of strands) path traced with a fiber
//! scattering function at every fiber hit, tabulated as a BRDF on the surface-table format of
//! the wood slab ([`crate::fiber_slab`], `fiberlab_io::table::SURFACE_HEADER`), so
//! `compare-model` and `fit` read it.
//!
//! The fibers are the renderer's tubes in the curve BVH of `fiberlab_geometry`, with the same
//! fiber frame at a hit ([`fiberlab_geometry::CurveHit::frame`]).
//!
//! # Estimator
//! One lateral period `[0, P_x) × [0, P_y)` of the patch is the unit cell; the curves of the
//! 3 × 3 periods around it are in the BVH, and a path is traced inside the cell only: a ray
//! that reaches a lateral side re-enters from the opposite one (the patch is infinite and
//! periodic, no edge effects). A path starts above the patch at a uniform point of the cell,
//! heading along `−ω`, `ω = (θ, φ)` the setup's direction; at every fiber hit the model
//! samples the next direction exactly as the renderer's camera paths do (`sample(ω_o, h)`
//! with `ω_o` the reversed ray, weight `f_s cosθ/pdf`); after [`ROULETTE_AFTER`] events and
//! whenever the weight falls below ¼, Russian roulette ends paths without bias. A path
//! leaving through the top in direction `ω'` adds its weight to the bin of `ω'`. Under
//! the patch there is either nothing (the path leaves as transmitted) or a Lambertian
//! substrate of given albedo.
//!
//! Tracing from `ω` is the renderer's estimator, so the bin of `ω'` estimates
//! `∫_bin f_r(ω', ω) cosθ' dω'` of the patch *as the renderer sees it*: light from `ω'`,
//! viewer at `ω`. The table stores it under `θ_i = θ`, `θ_o = θ'`; for reciprocal fibers the
//! two readings agree (tested), for non-reciprocal fiber models (Chiang, `sadeghi-thread`)
//! the table is the viewer-side one, the one an image of the explicit patch shows.
//! `f_r = P_bin / ∫_bin cosθ dω` as in the slab.
//!
//! Path classes (named as the slab's): `fiber` (one fiber event, no substrate), `multiple` (two or more fiber
//! events, no substrate), `substrate` (touched the substrate), `all`.

use crate::Setup;
use fiberlab_geometry::{CurveSet, Ray};
use fiberlab_math::split_mix::SplitMix64;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::{Model, ScatteringFunction};
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::atomic::{AtomicBool, Ordering};
use thiserror::Error;

/// Rays per independently seeded chunk.
const CHUNK: usize = 1 << 13;
/// Events after which paths survive with probability 0.99 per event.
pub const ROULETTE_AFTER: usize = 64;
/// Events after which a path is dropped (counted).
pub const MAX_EVENTS: usize = 100_000;

/// An invalid measurement.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum ClothGonioError {
    /// A value outside its range.
    #[error("cloth goniophotometer `{key}` = {value} is invalid; valid range {range}")]
    OutOfRange {
        /// Key.
        key: &'static str,
        /// Value (degrees for angles).
        value: f64,
        /// Range.
        range: &'static str,
    },
}

/// A periodic fiber sample.
pub struct PeriodicPatch {
    /// Curves of the cell and its 8 neighbours.
    pub curves: CurveSet,
    /// Lateral periods `P_x`, `P_y`.
    pub period: (f64, f64),
    /// Height range of the fibers (`z_min`, `z_max`), tubes included.
    pub z_range: (f64, f64),
    /// Lambertian substrate albedo at `z_min` (`None`: no substrate, light passes).
    pub substrate: Option<Rgb>,
}

/// The measured BRDF and what passed through.
#[derive(Clone, Debug)]
pub struct ClothMeasurement {
    /// The setup.
    pub setup: Setup,
    /// Per class ([`ClothMeasurement::LOBE_NAMES`]): bin values `f_r`, standard errors, albedo.
    pub lobes: Vec<crate::LobeTable>,
    /// Fraction of the power leaving through the bottom (no substrate).
    pub transmitted: Rgb,
    /// Standard error of `transmitted` (luminance-free, per channel).
    pub transmitted_std: Rgb,
    /// Paths dropped after [`MAX_EVENTS`].
    pub dropped: usize,
    /// Paths traced.
    pub traced: usize,
    /// Mean fiber events per path.
    pub mean_events: f64,
}

/// Rows of `fiberlab measure`'s table ([`fiberlab_io::table::write`]).
impl fiberlab_io::table::Tabulated for ClothMeasurement {
    fn incidence(&self) -> (f64, f64) {
        (self.setup.theta_i, self.setup.phi_i)
    }

    fn bins(&self) -> (usize, usize) {
        (self.setup.bins_theta, self.setup.bins_phi)
    }

    fn bin_centre(&self, i: usize, j: usize) -> (f64, f64) {
        ClothMeasurement::bin_centre(self, i, j)
    }

    fn lobe_tables(&self) -> Vec<(&'static str, &[Rgb], &[Rgb])> {
        Self::LOBE_NAMES.iter().zip(&self.lobes).map(|(name, l)| (*name, &l.f[..], &l.std[..])).collect()
    }
}

impl ClothMeasurement {
    /// Classes in table order.
    pub const LOBE_NAMES: [&'static str; 4] = ["fiber", "multiple", "substrate", "all"];

    /// Centre `(θ, φ)` of bin `(i, j)`.
    #[must_use]
    pub fn bin_centre(&self, i: usize, j: usize) -> (f64, f64) {
        let s = &self.setup;
        ((i as f64 + 0.5) * FRAC_PI_2 / s.bins_theta as f64, -PI + (j as f64 + 0.5) * TAU / s.bins_phi as f64)
    }
}

/// How a path ended.
enum Ending {
    /// Left through the top: direction, weight, class.
    Up(DVec3, Rgb, u8),
    /// Left through the bottom.
    Down(Rgb),
    /// Absorbed (roulette, black substrate, no sample).
    Absorbed,
    /// Too many events.
    Dropped,
}

/// Distance along `d` from `o` to the boundary of `[lo, hi]` in one coordinate.
fn exit_distance(o: f64, d: f64, lo: f64, hi: f64) -> f64 {
    if d > 0.0 {
        (hi - o) / d
    } else if d < 0.0 {
        (lo - o) / d
    } else {
        f64::INFINITY
    }
}

impl PeriodicPatch {
    fn trace(&self, model: &Model, wi: DVec3, rng: &mut SplitMix64, events: &mut u64) -> Ending {
        let (px, py) = self.period;
        let (z0, z1) = self.z_range;
        let top = z1 + 1e-6 * (z1 - z0).max(1e-9);
        let mut p = DVec3::new(rng.next_f64() * px, rng.next_f64() * py, top);
        let mut d = -wi;
        let mut weight = Rgb::ONE;
        let (mut fibers, mut substrate) = (0u32, false);
        let class = |fibers: u32, substrate: bool| -> u8 {
            if substrate {
                2
            } else if fibers == 1 {
                0
            } else {
                1
            }
        };
        let mut t_min = 0.0;
        for event in 0..MAX_EVENTS {
            if !crate::roulette::survives(&mut weight, event, ROULETTE_AFTER, || rng.next_f64()) {
                return Ending::Absorbed;
            }
            let tx = exit_distance(p.x, d.x, 0.0, px);
            let ty = exit_distance(p.y, d.y, 0.0, py);
            let tz = exit_distance(p.z, d.z, z0, top);
            let t_box = tx.min(ty).min(tz).max(0.0);
            let ray = Ray { o: p, d, t_min, t_max: t_box };
            if let Some(hit) = self.curves.intersect(&ray) {
                *events += 1;
                fibers += 1;
                let frame = hit.frame(d);
                let wo = frame.to_local(-d);
                let u = [rng.next_f64(), rng.next_f64(), rng.next_f64(), rng.next_f64()];
                let Some(s) = model.sample(wo, hit.h, u) else { return Ending::Absorbed };
                if s.weight.is_black() {
                    return Ending::Absorbed;
                }
                weight *= s.weight;
                d = frame.to_world(s.wi).normalize();
                p = hit.p;
                t_min = 1e-9 * (1.0 + p.abs().max_element());
                continue;
            }
            p += d * t_box;
            t_min = 0.0;
            if tz <= tx && tz <= ty {
                if d.z > 0.0 {
                    return Ending::Up(d, weight, class(fibers, substrate));
                }
                p.z = z0;
                match self.substrate {
                    None => return Ending::Down(weight),
                    Some(albedo) => {
                        substrate = true;
                        if albedo.is_black() {
                            return Ending::Absorbed;
                        }
                        weight *= albedo;
                        let (u0, u1) = (rng.next_f64(), rng.next_f64());
                        let r = u0.sqrt();
                        let (sn, cs) = (TAU * u1).sin_cos();
                        d = DVec3::new(r * cs, r * sn, (1.0 - u0).max(0.0).sqrt());
                    }
                }
            } else if tx <= ty {
                p.x = if d.x > 0.0 { 0.0 } else { px };
            } else {
                p.y = if d.y > 0.0 { 0.0 } else { py };
            }
        }
        Ending::Dropped
    }
}

/// Measures the BRDF of `patch` with `model` at every fiber; `progress(paths)` per chunk,
/// `stop` ends early (what was traced is kept, normalized by the paths traced).
pub fn measure_cloth(
    patch: &PeriodicPatch,
    model: &Model,
    setup: &Setup,
    stop: &AtomicBool,
    progress: impl Fn(usize) + Sync,
) -> Result<ClothMeasurement, ClothGonioError> {
    if !(0.0..89.9f64.to_radians()).contains(&setup.theta_i) {
        let value = setup.theta_i.to_degrees();
        return Err(ClothGonioError::OutOfRange { key: "theta_i", value, range: "[0, 89.9) degrees from the normal" });
    }
    if !setup.phi_i.is_finite() {
        return Err(ClothGonioError::OutOfRange { key: "phi_i", value: setup.phi_i, range: "finite degrees" });
    }
    let (nt, np) = (setup.bins_theta, setup.bins_phi);
    if nt == 0 || np == 0 || nt.saturating_mul(np) > 1 << 24 {
        return Err(ClothGonioError::OutOfRange {
            key: "bins", value: nt as f64 * np as f64, range: "1 … 2^24 bins"
        });
    }
    let (st, ct) = setup.theta_i.sin_cos();
    let wi = DVec3::new(st * setup.phi_i.cos(), st * setup.phi_i.sin(), ct);
    let chunks = setup.rays.div_ceil(CHUNK);
    let mut sums = crate::BinSums::new(3, nt * np);
    let mut down = [Rgb::ZERO; 2];
    let (mut dropped, mut traced, mut events) = (0usize, 0usize, 0u64);
    let batch = 2 * rayon::current_num_threads().max(1);
    let mut next = 0;
    type Chunk = (Vec<(u32, u8, Rgb)>, [Rgb; 2], usize, usize, u64);
    while next < chunks && !stop.load(Ordering::Relaxed) {
        let end = (next + batch).min(chunks);
        let results: Vec<Chunk> = (next..end)
            .into_par_iter()
            .map(|c| {
                let n = CHUNK.min(setup.rays - c * CHUNK);
                let mut rng = SplitMix64::stream(setup.seed, c as u64);
                let mut records = Vec::with_capacity(n);
                let mut down = [Rgb::ZERO; 2];
                let (mut drop, mut ev) = (0, 0u64);
                for _ in 0..n {
                    match patch.trace(model, wi, &mut rng, &mut ev) {
                        Ending::Up(dir, w, class) => {
                            let t = dir.z.clamp(-1.0, 1.0).acos();
                            let f = dir.y.atan2(dir.x);
                            let i = ((t / FRAC_PI_2 * nt as f64) as usize).min(nt - 1);
                            let j = (((f + PI) / TAU * np as f64) as usize).min(np - 1);
                            records.push(((i * np + j) as u32, class, w));
                        }
                        Ending::Down(w) => {
                            down[0] += w;
                            down[1] += w * w;
                        }
                        Ending::Absorbed => {}
                        Ending::Dropped => drop += 1,
                    }
                }
                progress(n);
                (records, down, drop, n, ev)
            })
            .collect();
        for (records, d, drop, n, ev) in results {
            for (bin, class, w) in records {
                sums.add(class as usize, bin as usize, w);
            }
            down[0] += d[0];
            down[1] += d[1];
            dropped += drop;
            traced += n;
            events += ev;
        }
        next = end;
    }
    let n = traced.max(1) as f64;
    let lobes = sums.tables(traced, nt, np, |i| crate::fiber_slab::bin_cos_solid_angle(i, nt, np));
    let t = down[0] / n;
    let t_std = ((down[1] / n - t * t).map(|x| x.max(0.0)) / n).map(f64::sqrt);
    Ok(ClothMeasurement {
        setup: *setup,
        lobes,
        transmitted: t,
        transmitted_std: t_std,
        dropped,
        traced,
        mean_events: events as f64 / n,
    })
}

impl PeriodicPatch {
    /// A periodic patch from strands `(points, radii)` that tile `[0, 3P_x) × [0, 3P_y)` with 3 × 3
    /// repeats of the pattern (as `WovenPatch::fibers(3, 3)` makes them): shifted so that the
    /// middle repeat is the cell `[0, P_x) × [0, P_y)`, the height range taken from the points
    /// and the widest tube, and `substrate` at its bottom (or none).
    #[must_use]
    pub fn from_repeats(strands: &[(&[DVec3], Vec<f64>)], period: (f64, f64), substrate: Option<Rgb>) -> Self {
        let shift = DVec3::new(period.0, period.1, 0.0);
        let shifted: Vec<(Vec<DVec3>, &[f64])> = strands
            .iter()
            .map(|(points, radii)| (points.iter().map(|&q| q - shift).collect(), radii.as_slice()))
            .collect();
        let curves = CurveSet::from_polylines(shifted.iter().map(|(p, r)| (p.as_slice(), *r)));
        let (lo, hi) =
            shifted.iter().flat_map(|(p, _)| p).fold((f64::MAX, f64::MIN), |(a, b), q| (a.min(q.z), b.max(q.z)));
        let r = 2.0 * strands.iter().flat_map(|(_, r)| r).fold(0.0f64, |a, &b| a.max(b));
        Self { curves, period, z_range: (lo - r, hi + r), substrate }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A woven patch of the procedural crate as a periodic patch.
    fn woven(weave: &fiberlab_procedural::woven_patch::WovenPatch) -> PeriodicPatch {
        let fibers = weave.fibers(3, 3).unwrap();
        PeriodicPatch::from_repeats(&fibers.polylines(), (weave.period(), weave.period()), None)
    }

    fn model(name: &str, params: &[(&str, &str)]) -> Model {
        fiberlab_scatter::build(name, params).unwrap()
    }

    /// A flat layer of straight parallel fibers along `x`, two rows deep, period `(1, 2r·gap)`.
    fn layer(rows: usize, radius: f64, gap: f64) -> PeriodicPatch {
        let py = 2.0 * radius * gap;
        let mut lines: Vec<(Vec<DVec3>, Vec<f64>)> = Vec::new();
        for row in 0..rows {
            let z = -(row as f64) * 2.2 * radius;
            let off = if row % 2 == 1 { 0.5 * py } else { 0.0 };
            for k in -1..=1 {
                let y = off + 0.25 * py + k as f64 * py;
                lines.push((vec![DVec3::new(-1.0, y, z), DVec3::new(2.0, y, z)], vec![radius; 2]));
            }
        }
        let curves = CurveSet::from_polylines(lines.iter().map(|(p, r)| (p.as_slice(), r.as_slice())));
        let zmin = -(rows as f64) * 2.2 * radius - radius;
        PeriodicPatch { curves, period: (1.0, py), z_range: (zmin, radius * 1.01), substrate: None }
    }

    fn setup(theta: f64, phi: f64, rays: usize) -> Setup {
        Setup { theta_i: theta.to_radians(), phi_i: phi.to_radians(), rays, bins_theta: 9, bins_phi: 16, seed: 7 }
    }

    fn run(p: &PeriodicPatch, m: &Model, s: &Setup) -> ClothMeasurement {
        measure_cloth(p, m, s, &AtomicBool::new(false), |_| {}).unwrap()
    }

    /// White furnace: lossless Chiang fibers (σ_a = 0) in a woven patch without substrate
    /// conserve energy on the camera side, so reflected + transmitted = 1 within noise.
    #[test]
    fn lossless_woven_patch_reflects_plus_transmits_one() {
        let weave = fiberlab_procedural::woven_patch::WovenPatch {
            fibers_per_ply: 10,
            samples_per_spacing: 12,
            ..Default::default()
        };
        let patch = woven(&weave);
        let m = model("chiang", &[("sigma_a", "0"), ("beta_m", "0.3"), ("beta_n", "0.3")]);
        for theta in [0.0, 60.0] {
            let r = run(&patch, &m, &setup(theta, 30.0, 20_000));
            let total = r.lobes[3].albedo + r.transmitted;
            assert!(r.mean_events > 2.0, "too few bounces to test anything: {}", r.mean_events);
            assert!((total[1] - 1.0).abs() < 0.02, "θ = {theta}: R + T = {total:?} (T = {:?})", r.transmitted);
            // Absorbing fibers lose energy: the balance is a real test.
            let dark = model("chiang", &[("sigma_a", "0.5"), ("beta_m", "0.3"), ("beta_n", "0.3")]);
            let d = run(&patch, &dark, &setup(theta, 30.0, 5_000));
            assert!((d.lobes[3].albedo + d.transmitted)[1] < 0.9);
        }
    }

    /// White furnace with a white substrate: ideal diffuse fibers of albedo 1 over a white
    /// Lambertian floor reflect everything.
    #[test]
    fn diffuse_fibers_over_white_substrate_reflect_everything() {
        let mut patch = layer(2, 0.05, 1.5);
        patch.substrate = Some(Rgb::ONE);
        let m = model("diffuse", &[("albedo", "1")]);
        let r = run(&patch, &m, &setup(40.0, 0.0, 20_000));
        let a = r.lobes[3].albedo[0];
        assert!((a - 1.0).abs() < 0.01 && r.transmitted == Rgb::ZERO, "albedo {a}");
    }

    /// Reciprocity: with reciprocal fibers (ideal diffuse) the tabulated BRDF of the woven
    /// patch is symmetric: f(ω_a → bin of ω_b) ≈ f(ω_b → bin of ω_a) within the noise.
    #[test]
    fn tabulated_brdf_is_reciprocal_for_reciprocal_fibers() {
        let weave = fiberlab_procedural::woven_patch::WovenPatch {
            weave: fiberlab_procedural::woven_patch::Weave::Twill21,
            fibers_per_ply: 10,
            samples_per_spacing: 12,
            ..Default::default()
        };
        let patch = woven(&weave);
        let m = model("diffuse", &[("albedo", "0.9")]);
        // Directions at bin centres: θ bins of 10°, φ bins of 22.5°.
        let (a, b) = ((25.0, -78.75), (65.0, 56.25));
        let ra = run(&patch, &m, &setup(a.0, a.1, 60_000));
        let rb = run(&patch, &m, &setup(b.0, b.1, 60_000));
        let bin = |t: f64, p: f64| ((t / 10.0) as usize) * 16 + ((p + 180.0) / 22.5) as usize;
        let (fab, sab) = (ra.lobes[3].f[bin(b.0, b.1)][0], ra.lobes[3].std[bin(b.0, b.1)][0]);
        let (fba, sba) = (rb.lobes[3].f[bin(a.0, a.1)][0], rb.lobes[3].std[bin(a.0, a.1)][0]);
        let z = (fab - fba).abs() / (sab * sab + sba * sba).sqrt();
        // Bins have finite size: allow 4σ plus 5 % for the bin averaging.
        assert!(
            fab > 0.0 && (fab - fba).abs() < 4.0 * (sab * sab + sba * sba).sqrt() + 0.05 * fab,
            "{fab} vs {fba}, z = {z}"
        );
    }

    /// Single scattering off a flat layer of straight parallel fibers along `x` leaves on the
    /// specular cone: the exit direction keeps `ω·x = −ω_i·x` (the cone of the fiber slab and
    /// of Marschner's R lobe without shift), so nearly all of the `fiber` class's power sits
    /// within a few roughness widths of the cone.
    #[test]
    fn single_scatter_of_a_parallel_layer_lies_on_the_specular_cone() {
        let patch = layer(1, 0.05, 1.2);
        let m = model("chiang", &[("sigma_a", "0"), ("beta_m", "0.05"), ("beta_n", "0.3"), ("alpha", "0")]);
        let s = Setup { bins_theta: 90, bins_phi: 180, ..setup(50.0, 0.0, 40_000) };
        let r = run(&patch, &m, &s);
        let single = &r.lobes[0];
        let (mut on, mut total) = (0.0, 0.0);
        for i in 0..90 {
            let omega = crate::fiber_slab::bin_cos_solid_angle(i, 90, 180);
            for j in 0..180 {
                let (t, p) = r.bin_centre(i, j);
                let along = t.sin() * p.cos();
                let power = single.f[i * 180 + j][1] * omega;
                total += power;
                // Cone: ω·x = −sin 50° (x along the fibers, light at φ = 0).
                if (along + 50f64.to_radians().sin()).abs() < 0.12 {
                    on += power;
                }
            }
        }
        assert!(total > 0.05, "{total}");
        assert!(on / total > 0.9, "only {} of the single-scatter power on the cone", on / total);
    }
}
