//! How much of each pixel the fibers cover: the fraction of an `n × n` stratified grid of
//! camera rays per pixel whose nearest hit is a fiber. The benchmarks
//! (`bench/dual_scattering/head.py`) use it as a mask, measuring errors only in the blocks of
//! pixels the hair covers. Deterministic (cell centres, no random numbers).

use crate::scene::{Hit, Scene};
use fiberlab_io::LinearImage;
use rayon::prelude::*;

/// The coverage of every pixel of `scene`'s camera, in all three channels of the image, from
/// `n × n` rays per pixel (`n ≥ 1`; 0 is taken as 1).
#[must_use]
pub fn fiber_coverage(scene: &Scene, n: u32) -> LinearImage {
    let n = n.max(1);
    let camera = scene.camera();
    let (w, h) = (camera.width as usize, camera.height as usize);
    let inv = 1.0 / f64::from(n);
    let pixels: Vec<[f32; 3]> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            let mut hits = 0u32;
            for sy in 0..n {
                for sx in 0..n {
                    let ray = camera.ray(x + (f64::from(sx) + 0.5) * inv, y + (f64::from(sy) + 0.5) * inv);
                    if matches!(scene.intersect(&ray), Some(Hit::Fiber { .. })) {
                        hits += 1;
                    }
                }
            }
            let c = (f64::from(hits) * inv * inv) as f32;
            [c; 3]
        })
        .collect();
    LinearImage::from_pixels(w, h, pixels).expect("w × h pixels")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::scene::SceneBuilder;
    use fiberlab_geometry::curves::CurveSet;
    use fiberlab_math::DVec3;

    #[test]
    fn a_fiber_across_the_view_covers_its_projected_width() {
        // Camera at distance D looking down −z at a straight fiber along x through the target,
        // longer than the view. The covered pixel count is the fiber's projected width in pixels
        // times the image width, the pixel footprint at distance D being 2·D·tan(fov/2)/height
        // (a 10° field: the distance varies by < 0.4 % across the view). 32 × 32 rays per pixel:
        // the stratified rows resolve the 3.7-pixel-wide fiber to < 1 %.
        let (d, fov, size, r) = (10.0, 10.0_f64, 32u32, 0.1);
        let camera = Camera::look_at(DVec3::new(0.0, 0.0, d), DVec3::ZERO, DVec3::Y, fov, size, size).unwrap();
        let mut b = SceneBuilder::new(camera);
        let m = b.fiber_material(fiberlab_scatter::build("kajiya-kay", &[] as &[(&str, &str)]).unwrap());
        let (p, radii) = ([DVec3::new(-5.0, 0.0, 0.0), DVec3::new(5.0, 0.0, 0.0)], [r, r]);
        b.fibers(CurveSet::from_polylines([(&p[..], &radii[..])]), m);
        let scene = b.build();
        let image = fiber_coverage(&scene, 32);
        let pixel = 2.0 * d * (0.5 * fov.to_radians()).tan() / f64::from(size);
        let expected = f64::from(size) * 2.0 * r / pixel;
        let covered: f64 = image.pixels().iter().map(|p| f64::from(p[0])).sum();
        assert!((covered / expected - 1.0).abs() < 0.015, "covered {covered} px, expected {expected}");
        // Rows far from the fiber are empty, and values are fractions.
        assert!((0..size as usize).all(|x| image.get(x, 0)[0] == 0.0 && image.get(x, size as usize - 1)[0] == 0.0));
        assert!(image.pixels().iter().all(|p| (0.0..=1.0).contains(&p[0])));
    }
}
