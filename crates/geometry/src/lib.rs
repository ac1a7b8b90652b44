//! fiberlab's geometry: what rays meet, and how fast they find it. It owns
//!
//! * [`ray`]: rays with their interval of accepted distances;
//! * [`curves`]: strands as round tubes (polylines of cylinders clipped by miter planes, cubic
//!   B-spline and Bézier curves subdivided to them) and the fiber frame at a hit;
//! * [`bvh`]: the wide bounding volume hierarchy (8-wide nodes quantized to 8 bits, oriented
//!   nodes for hair) with closest-hit and any-hit walks;
//! * [`simd`]: the node and leaf tests in explicit SIMD chosen at run time — the workspace's one
//!   module allowed `unsafe` (ARCHITECTURE.md, "Unsafe code: one audited SIMD module");
//! * [`shapes`]: spheres and triangle meshes; [`mesh`]: their shading geometry (texture
//!   coordinates, shading normals, tangents); [`ribbons`]: flat strips along curves (ribbon
//!   and camera-facing flat curves) as triangle meshes.
//!
//! It stops at geometry: no scattering, no files (OBJ and hair files are read by `fiberlab-io`),
//! no rendering. It depends only on `fiberlab-math`, so the renderer, the goniophotometers and
//! the GPU backend share one tree.
#![deny(unsafe_code)]

pub mod bvh;
pub mod curves;
pub mod mesh;
pub mod ray;
pub mod ribbons;
pub mod shapes;
pub mod simd;

#[cfg(test)]
mod test_random;

pub use bvh::Aabb;
pub use curves::{CubicBasis, CurveHit, CurveSet, Tubes};
pub use ray::Ray;
pub use shapes::TriangleMesh;
