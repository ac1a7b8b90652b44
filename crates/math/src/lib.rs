//! Pure mathematics shared by every fiberlab model: the fiber frame and its angles,
//! the RGB spectrum type, special functions (stable `i0e`, logistic, Gaussian),
//! dielectric Fresnel and Bravais' modified indices, quadrature rules (Gauss–Legendre and the
//! one width average of near-field quantities). No I/O, no allocation on hot paths.
//!
//! # Conventions (docs/theory/conventions.md), used by every crate
//! Directions are unit vectors in the **fiber frame**: `x` = tangent `u` (root → tip),
//! `y` = `v` (for elliptical fibers the major axis), `z` = `w = u × v`. The normal plane is
//! span(y, z). For a direction `ω = sinθ·u + cosθ·(cosφ·v + sinφ·w)`:
//! * `θ ∈ [−π/2, π/2]` is the inclination from the normal plane (`sinθ = ω.x`);
//! * `φ = atan2(ω.z, ω.y)` is the azimuth about the fiber.
//!
//! Both directions point away from the fiber: `ω_i` toward the light, `ω_r` (= `ω_o`) toward
//! the viewer. The relative azimuth is `φ = φ_r − φ_i` wrapped to (−π, π]; `φ = 0` is
//! backscatter and `φ = ±π` is forward scattering. `h ∈ [−1, 1]` is the offset across the
//! fiber in radii, increasing toward `+y`. Angles are radians everywhere inside the code;
//! degrees appear only at the command line and file edges.
#![forbid(unsafe_code)]

pub mod bravais;
pub mod frame;
pub mod fresnel;
pub mod noise;
pub mod phase;
pub mod quadrature;
pub mod special;
pub mod spectrum;
pub mod split_mix;

pub use frame::{FiberFrame, relative_phi, wrap_pi};
pub use glam::DVec3;
pub use spectrum::{Rgb, Spectrum};
