//! Performance figures as library functions (used by the criterion bench and the CLI):
//! BVH build time and memory per segment, ray throughput for coherent camera rays and
//! incoherent rays, and path-traced samples per second.

use crate::camera::Camera;
use crate::integrator::{Region, RenderSettings, render};
use crate::scene::Scene;
use fiberlab_geometry::Ray;
use fiberlab_geometry::curves::CurveSet;
use fiberlab_io::HairFile;
use fiberlab_math::DVec3;
use fiberlab_procedural::generator::SplitMix64;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// BVH build figures.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildStats {
    /// Seconds to build the tubes and their BVH.
    pub seconds: f64,
    /// Tube segments.
    pub segments: usize,
    /// BVH pieces (segments after splitting long ones).
    pub pieces: usize,
    /// Bytes of segments + BVH.
    pub bytes: usize,
}

impl BuildStats {
    /// Bytes per segment.
    #[must_use]
    pub fn bytes_per_segment(&self) -> f64 {
        self.bytes as f64 / self.segments.max(1) as f64
    }
}

/// Builds the tubes of `hair` and reports time and memory.
#[must_use]
pub fn bvh_build(hair: &HairFile) -> (CurveSet, BuildStats) {
    let t = Instant::now();
    let set = hair.curve_set();
    let stats = BuildStats {
        seconds: t.elapsed().as_secs_f64(),
        segments: set.segment_count(),
        pieces: set.piece_count(),
        bytes: set.bytes(),
    };
    (set, stats)
}

/// Millions of closest-hit rays per second (one thread) for `rays` camera rays through a
/// `side × side` grid and the same number of incoherent rays (random origins in the tubes'
/// bounds, random directions). Returns `(camera, incoherent, fraction of rays that hit)`.
#[must_use]
pub fn ray_throughput(set: &CurveSet, camera: &Camera, rays: usize, seed: u64) -> (f64, f64, f64) {
    let side = (rays as f64).sqrt().ceil() as usize;
    let camera_rays: Vec<Ray> = (0..side * side)
        .map(|i| {
            let (x, y) = ((i % side) as f64 + 0.5, (i / side) as f64 + 0.5);
            camera.ray(x / side as f64 * f64::from(camera.width), y / side as f64 * f64::from(camera.height))
        })
        .collect();
    let b = set.bounds();
    let mut g = SplitMix64::new(seed);
    let random_rays: Vec<Ray> = (0..camera_rays.len())
        .map(|_| {
            let u = DVec3::new(g.next_f64(), g.next_f64(), g.next_f64());
            let o = b.min + (b.max - b.min) * u;
            Ray::new(o, g.next_signed_vec().normalize_or(DVec3::Y))
        })
        .collect();
    let time = |rays: &[Ray]| {
        let t = Instant::now();
        let hits = rays.iter().filter(|r| set.intersect(r).is_some()).count();
        (rays.len() as f64 / t.elapsed().as_secs_f64() / 1e6, hits)
    };
    let (cam, hits) = time(&camera_rays);
    let (inc, _) = time(&random_rays);
    (cam, inc, hits as f64 / camera_rays.len() as f64)
}

/// Millions of rays per second (one thread) of brute-force intersection (every segment
/// tested) for `rays` camera rays: the baseline the BVH's speed-up is quoted against.
#[must_use]
pub fn brute_force_throughput(set: &CurveSet, camera: &Camera, rays: usize) -> f64 {
    let side = (rays as f64).sqrt().ceil().max(1.0) as usize;
    let t = Instant::now();
    let mut hits = 0usize;
    for i in 0..side * side {
        let (x, y) = ((i % side) as f64 + 0.5, (i / side) as f64 + 0.5);
        let r = camera.ray(x / side as f64 * f64::from(camera.width), y / side as f64 * f64::from(camera.height));
        hits += usize::from(set.intersect_brute_force(&r).is_some());
    }
    std::hint::black_box(hits);
    (side * side) as f64 / t.elapsed().as_secs_f64() / 1e6
}

/// Camera samples per second of a full path-traced render of the central `side × side`
/// pixels with `spp` samples, on `threads` threads (0: all).
#[must_use]
pub fn samples_per_second(scene: &Scene, settings: &RenderSettings, side: u32, spp: u32, threads: usize) -> f64 {
    let (w, h) = (scene.camera().width, scene.camera().height);
    let (x0, y0) = ((w.saturating_sub(side)) / 2, (h.saturating_sub(side)) / 2);
    let region = Region { x0, y0, x1: (x0 + side).min(w), y1: (y0 + side).min(h) };
    let s = RenderSettings { spp, threads, region: Some(region), ..settings.clone() };
    let out = render(scene, &s, &|_| {}, &AtomicBool::new(false));
    out.stats.samples as f64 / out.stats.seconds
}
