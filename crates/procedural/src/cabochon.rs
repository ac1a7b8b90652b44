//! A cabochon: the domed cut of chatoyant stones (tiger's eye, cat's-eye chrysoberyl), a cap of
//! a sphere on a flat base, as a triangle mesh with exact sphere normals and planar texture
//! coordinates.
//!
//! The cap has base radius `a` in the plane `y = 0` and height `h` (apex at `(0, h, 0)`), hence
//! sphere radius `R = (a² + h²)/(2h)` and centre `(0, h − R, 0)`. Texture coordinates are the
//! top view, `u = ½ + x/(2a)`, `v = ½ − z/(2a)`, so the tangent along `u` is the surface's direction of
//! increasing `x` at constant `z` and the frame's `y = z × x` points along `−z` at the apex (right-handed seen from
//! above): a fiber angle of 0 puts the fibers along `x`, in the surface, everywhere.

use fiberlab_geometry::TriangleMesh;
use fiberlab_math::DVec3;
use std::f64::consts::TAU;

/// Why a cabochon cannot be made.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("cabochon: {0}")]
pub struct CabochonError(String);

/// The dome (no base face: it sits on something), `rings` rings from the apex and `sectors`
/// around, its base centred at `base` (the module documentation puts it at the origin).
pub fn cabochon(
    base_radius: f64,
    height: f64,
    rings: usize,
    sectors: usize,
    base: DVec3,
) -> Result<TriangleMesh, CabochonError> {
    if !(base_radius.is_finite() && base_radius > 0.0) {
        return Err(CabochonError(format!("radius = {base_radius:?} must be finite and > 0")));
    }
    if !(height.is_finite() && height > 0.0 && height <= base_radius) {
        return Err(CabochonError(format!("height = {height:?} must be in (0, radius = {base_radius}]")));
    }
    if !(1..=4096).contains(&rings) || !(3..=4096).contains(&sectors) {
        return Err(CabochonError(format!("rings = {rings} (1–4096) and sectors = {sectors} (3–4096)")));
    }
    let r = (base_radius * base_radius + height * height) / (2.0 * height);
    let centre = DVec3::new(0.0, height - r, 0.0);
    if !base.is_finite() {
        return Err(CabochonError(format!("base centre {base} must be finite")));
    }
    // Polar angle from the apex to the rim.
    let rim = (base_radius / r).clamp(-1.0, 1.0).asin();
    let rim = if height > r { std::f64::consts::PI - rim } else { rim };
    let point = |ring: usize, sector: usize| {
        let theta = rim * ring as f64 / rings as f64;
        let phi = TAU * sector as f64 / sectors as f64;
        let n = DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
        let p = centre + n * r;
        (p, n, [0.5 + p.x / (2.0 * base_radius), 0.5 - p.z / (2.0 * base_radius)])
    };
    let (mut triangles, mut uvs, mut normals) = (Vec::new(), Vec::new(), Vec::new());
    let mut push = |c: [(DVec3, DVec3, [f64; 2]); 3]| {
        triangles.push(c.map(|x| x.0 + base));
        normals.push(c.map(|x| x.1));
        uvs.push(c.map(|x| x.2));
    };
    for ring in 0..rings {
        for s in 0..sectors {
            let (a, b) = (point(ring, s), point(ring, s + 1));
            let (c, d) = (point(ring + 1, s), point(ring + 1, s + 1));
            // Counter-clockwise seen from outside (normals outward).
            if ring > 0 {
                push([a, b, c]);
            }
            push([b, d, c]);
        }
    }
    Ok(TriangleMesh::with_attributes(triangles, uvs, normals))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_geometry::Ray;

    /// Rays straight down hit the dome at the sphere's height, with the sphere's normal, the
    /// top-view uv and the tangent ∂P/∂x at constant z, `(1, −x/(y − c_y), 0)`; outward winding.
    #[test]
    fn the_dome_is_the_sphere_cap() {
        let (a, h) = (1.0, 0.4);
        let mesh = cabochon(a, h, 48, 96, DVec3::ZERO).unwrap();
        let r = (a * a + h * h) / (2.0 * h);
        let c = DVec3::new(0.0, h - r, 0.0);
        for (x, z) in [(0.0, 0.0), (0.3, -0.2), (-0.6, 0.5), (0.1, 0.8)] {
            let (t, ng, s) = mesh.intersect_point(&Ray::new(DVec3::new(x, 5.0, z), -DVec3::Y)).unwrap();
            let y_sphere = c.y + (r * r - x * x - z * z).sqrt();
            assert!((5.0 - t - y_sphere).abs() < 2e-3, "({x}, {z}): {} vs {y_sphere}", 5.0 - t);
            assert!(ng.y > 0.0, "outward winding");
            let n = (DVec3::new(x, y_sphere, z) - c) / r;
            assert!((s.normal - n).length() < 1e-3, "{} vs {n}", s.normal);
            let [u, v] = s.uv.unwrap();
            assert!((u - (0.5 + x / 2.0)).abs() < 1e-9 && (v - (0.5 - z / 2.0)).abs() < 1e-9);
            let t_expected = DVec3::new(1.0, -x / (y_sphere - c.y), 0.0).normalize();
            // Per-facet ∂P/∂u: within the facets' angular size (2π/96 ≈ 0.065) of the smooth one.
            assert!((s.tangent - t_expected).length() < 2e-2, "{} vs {t_expected}", s.tangent);
        }
        assert!(mesh.intersect(&Ray::new(DVec3::new(1.2, 5.0, 0.0), -DVec3::Y)).is_none());
        assert!(cabochon(1.0, 1.5, 4, 8, DVec3::ZERO).is_err() && cabochon(1.0, 0.5, 0, 8, DVec3::ZERO).is_err());
    }
}
