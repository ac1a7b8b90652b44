//! The chatoyant band of a tiger's-eye slab lies on the analytic ψ_h = 0 locus and moves with
//! the light.
//!
//! For fibers in the surface plane along the tangent `x` (dip 0), refraction through the polish
//! scales tangential components by 1/η, so `ψ = asin(ω′·x) = asin(ω_x/η)` and
//! `ψ_h = ψ_i + ψ_r = 0 ⇔ ω_i·x + ω_r·x = 0` (Marschner et al. 2005's fiber highlight; the
//! interface changes only its strength). On a flat slab seen by a pinhole camera at `E` under a
//! distant light `ω_i`, the band is the set of points `p` with `(E − p)·x/|E − p| = −ω_i·x`: a
//! curve across the fibers. Each image row's brightest pixel is compared with that locus,
//! computed from the camera rays alone.

use fiberlab_geometry::shapes::TriangleMesh;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_render::camera::Camera;
use fiberlab_render::integrator::{RenderSettings, render};
use fiberlab_render::light::Light;
use fiberlab_render::scene::{SceneBuilder, SurfaceMaterial};
use fiberlab_render::surface_material::ModelMaterial;
use fiberlab_scatter::{build_surface, find_surface};
use std::sync::atomic::AtomicBool;

const SIDE: u32 = 64;

/// Column of the brightest pixel of every row, and the analytic locus column per row
/// (the zero crossing of `ω_r·x + ω_i·x` between pixel centres, linearly interpolated).
fn band(light: DVec3) -> (Vec<f64>, Vec<f64>) {
    let eye = DVec3::new(0.0, 2.0, 0.0);
    let camera = Camera::look_at(eye, DVec3::ZERO, DVec3::Z, 60.0, SIDE, SIDE).unwrap();
    let spec = find_surface("wood").unwrap();
    let model = build_surface("wood", &[("preset", "tigers-eye")]).unwrap();
    let mut b = SceneBuilder::new(camera.clone());
    let m = b.surface_material(SurfaceMaterial::Model(Box::new(
        ModelMaterial::new(spec.name, spec.params, model, &[]).unwrap(),
    )));
    // The floor's tangent is +x: the fibers run along x.
    b.mesh(TriangleMesh::floor(0.0, 50.0), m);
    let wi = light.normalize();
    b.light(Light::Distant { direction: wi, irradiance: Rgb::ONE });
    let settings = RenderSettings { spp: 4, max_depth: 1, seed: 1, ..RenderSettings::default() };
    let out = render(&b.build(), &settings, &|_| {}, &AtomicBool::new(false));
    let (mut peaks, mut locus) = (Vec::new(), Vec::new());
    for y in 0..SIDE as usize {
        let row: Vec<f64> = (0..SIDE as usize).map(|x| f64::from(out.image.get(x, y)[0])).collect();
        let peak = (0..row.len()).max_by(|&a, &b| row[a].total_cmp(&row[b])).unwrap();
        let g: Vec<f64> = (0..SIDE)
            .map(|x| {
                let ray = camera.ray(f64::from(x) + 0.5, y as f64 + 0.5);
                let p = ray.o + ray.d * (-ray.o.y / ray.d.y);
                (eye - p).normalize().x + wi.x
            })
            .collect();
        let Some(k) = (0..g.len() - 1).find(|&k| g[k].signum() != g[k + 1].signum()) else { continue };
        locus.push(k as f64 + g[k] / (g[k] - g[k + 1]));
        peaks.push(peak as f64);
    }
    (peaks, locus)
}

#[test]
fn the_band_follows_the_psi_h_zero_locus_at_two_light_positions() {
    let mut centres = Vec::new();
    for light in [DVec3::new(-0.3, 1.0, 0.1), DVec3::new(0.25, 1.0, -0.2)] {
        let (peaks, locus) = band(light);
        assert!(peaks.len() as u32 > SIDE / 2, "the locus crosses most rows: {}", peaks.len());
        for (row, (p, l)) in peaks.iter().zip(&locus).enumerate() {
            assert!((p - l).abs() <= 1.0, "light {light}: row {row}: brightest column {p}, locus {l:.2}");
        }
        centres.push(locus.iter().sum::<f64>() / locus.len() as f64);
    }
    // The band moved across the image with the light (so the comparison is not vacuous).
    assert!((centres[0] - centres[1]).abs() > 10.0, "band centres {centres:?}");
}
