//! Ribbon and flat curves from hair files as triangle meshes for a surface model: what a
//! `[[hair]]` entry with a surface material (such as `leaf`) renders.
//!
//! * [`CurveKind::Ribbon`] curves (pbrt `ribbon`, USD `BasisCurves` with `normals`): oriented
//!   ribbons, the width along `n × tangent`, the normals interpolated along each span
//!   spherically between its end normals ([`Strands::to_polylines`]);
//! * [`CurveKind::Flat`] curves (pbrt `flat`, its default): ribbons turned toward the camera's
//!   eye at every station (the module docs of [`fiberlab_geometry::ribbons`] say how this
//!   differs from pbrt, which turns them toward each ray);
//! * [`CurveKind::Cylinder`] curves are round: they take a fiber model, not a surface.
//!
//! Cubic curves become polylines of `segments_per_curve` segments per span first, as tubes do;
//! each polyline segment becomes two triangles ([`fiberlab_geometry::ribbons`]: corners,
//! shading normals, `u` across and `v` along the strand).

use fiberlab_geometry::TriangleMesh;
use fiberlab_geometry::ribbons::{Facing, Ribbons};
use fiberlab_io::memory_budget::{Need, check_needs};
use fiberlab_io::{CurveKind, Strands, StrandsError};
use fiberlab_math::DVec3;

/// Bytes per ribbon triangle while the mesh is built and held (its corners, texture
/// coordinates, normals, tangent and BVH share: as `fiberlab_procedural::grass`).
pub const BYTES_PER_TRIANGLE: u64 = 600;

/// The triangles the ribbons of `strands` make at `segments_per_curve` segments per cubic
/// span (at most; a station of width 0 drops one).
#[must_use]
pub fn triangle_count(strands: &Strands, segments_per_curve: usize) -> u64 {
    let segments = if strands.basis == fiberlab_io::Basis::Linear {
        strands.span_count()
    } else {
        strands.span_count().saturating_mul(segments_per_curve.max(1) as u64)
    };
    segments.saturating_mul(2)
}

/// The mesh of the ribbon or flat curves `strands` (module docs); flat curves face `eye`.
/// Refused: round curves, and a mesh beyond the memory budget (checked before it is built).
pub fn ribbon_mesh(strands: &Strands, segments_per_curve: usize, eye: DVec3) -> Result<TriangleMesh, StrandsError> {
    if strands.kind == CurveKind::Cylinder {
        return Err(StrandsError::Inconsistent(
            "these curves are round (pbrt \"cylinder\", USD curves without normals); a surface model needs ribbon or \
             flat curves, a round strand takes a fiber model"
                .into(),
        ));
    }
    if strands.kind == CurveKind::Ribbon && strands.normals.is_empty() {
        return Err(StrandsError::Inconsistent("ribbon curves without normals".into()));
    }
    let triangles = triangle_count(strands, segments_per_curve);
    check_needs(&[Need::items(format!("{triangles} ribbon triangles"), triangles, BYTES_PER_TRIANGLE)])
        .map_err(|e| StrandsError::Inconsistent(e.to_string()))?;
    let lines = strands.to_polylines(segments_per_curve)?;
    let mut out = Ribbons::default();
    let (mut centre, mut widths, mut normals) = (Vec::new(), Vec::new(), Vec::new());
    for r in lines.strand_ranges() {
        centre.clear();
        widths.clear();
        normals.clear();
        centre.extend(lines.points[r.clone()].iter().map(|p| DVec3::from(p.map(f64::from))));
        widths.extend(lines.widths[r.clone()].iter().map(|&w| f64::from(w)));
        let facing = if lines.normals.is_empty() {
            Facing::Toward(eye)
        } else {
            normals.extend(lines.normals[r].iter().map(|n| DVec3::from(n.map(f64::from))));
            Facing::Normals(&normals)
        };
        out.push(&centre, &widths, facing);
    }
    Ok(out.into_mesh())
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_geometry::Ray;
    use fiberlab_io::Basis;

    /// One straight Bézier ribbon along x whose normal turns from +y to +z over its span: the
    /// polyline stations carry the spherically interpolated normals, so the ribbon's width
    /// runs along z at the root and along −y at the tip, and a ray straight down hits the
    /// root half but misses where the ribbon stands on its edge.
    #[test]
    fn a_twisting_ribbon_follows_its_interpolated_normals() {
        let strands = Strands {
            points: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0]],
            widths: vec![0.2; 4],
            counts: vec![4],
            basis: Basis::Bezier,
            kind: CurveKind::Ribbon,
            normals: vec![[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        };
        let mesh = ribbon_mesh(&strands, 8, DVec3::ZERO).unwrap();
        assert_eq!(mesh.len(), 16);
        let down = |x: f64, z: f64| Ray::new(DVec3::new(x, 1.0, z), DVec3::NEG_Y);
        // At the root the ribbon lies flat in y = 0, 0.2 wide in z.
        let (t, n) = mesh.intersect(&down(0.05, 0.09)).expect("root face");
        assert!((t - 1.0).abs() < 5e-3 && n.y.abs() > 0.95, "t {t}, n {n}");
        // At the tip it stands on its edge in z = 0: a ray beside the edge misses.
        assert!(mesh.intersect(&down(2.95, 0.05)).is_none());
        // Halfway (45°), its half-width projects to 0.1·cos 45° on z.
        assert!(mesh.intersect(&down(1.52, 0.06)).is_some());
        assert!(mesh.intersect(&down(1.52, 0.08)).is_none());
    }

    #[test]
    fn round_curves_are_refused_and_flat_curves_face_the_eye() {
        let mut s = Strands {
            points: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
            widths: vec![0.1; 2],
            counts: vec![2],
            basis: Basis::Linear,
            kind: CurveKind::Cylinder,
            normals: Vec::new(),
        };
        assert!(ribbon_mesh(&s, 8, DVec3::Y).unwrap_err().to_string().contains("fiber model"));
        s.kind = CurveKind::Flat;
        // Seen from +z the strip faces +z: a ray along −z hits it across its whole width.
        let mesh = ribbon_mesh(&s, 8, DVec3::new(0.5, 0.0, 5.0)).unwrap();
        assert!(mesh.intersect(&Ray::new(DVec3::new(0.5, 0.045, 1.0), DVec3::NEG_Z)).is_some());
        assert!(mesh.intersect(&Ray::new(DVec3::new(0.5, 0.055, 1.0), DVec3::NEG_Z)).is_none());
    }
}
