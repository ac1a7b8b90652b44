//! fiberlab's renderer for fiber assemblies: strands as round tubes ([`curves`]) in a BVH
//! ([`bvh`]; its node and leaf tests in explicit SIMD chosen at run time: [`simd`], the only
//! module allowed `unsafe`), a procedural hair generator ([`generator`]), spheres and triangle
//! meshes ([`shapes`]), camera, lights, a unidirectional path tracer with next-event estimation and
//! MIS ([`integrator`]), tiles and part merging, the TOML scene format ([`scene_file`]), and the
//! one model loader for user input ([`model_loader`], with [`toml_params`]). Surfaces carry
//! texture coordinates, shading normals and tangents ([`mesh`]; cabochon domes: [`cabochon`];
//! a cloth draped over a sphere: [`draped_cloth`])
//! and may take a registered surface model with image textures for its parameters
//! ([`surface_material`], [`texture`]; a procedural figured-maple map: [`figured_maple`]).
//!
//! Fiber scattering comes from [`fiberlab_scatter`] (any registered model); file formats from
//! [`fiberlab_io`]; the strand diameters a scene accepts are in [`strand_diameters`]. This
//! crate owns no scattering physics: at a fiber hit it builds the fiber frame (see [`curves`])
//! and calls the model; at a surface-model hit it builds the shading frame (see [`mesh`]) and
//! calls the surface model.
#![deny(unsafe_code)]

pub mod accumulation;
pub mod bench;
pub mod bvh;
pub mod cabochon;
pub mod camera;
pub mod curves;
pub mod draped_cloth;
pub mod dual_bounce;
pub mod dual_scattering;
pub mod fiber_count;
pub mod fiber_coverage;
pub mod figured_maple;
pub mod generator;
pub mod integrator;
pub mod light;
pub mod measured_table;
pub mod mesh;
pub mod model_loader;
pub mod region;
pub mod sampler;
pub mod scene;
pub mod scene_family;
pub mod scene_file;
pub mod shapes;
pub mod simd;
pub mod strand_diameters;
pub mod surface_material;
pub mod texture;
pub mod toml_params;
pub mod woven_goniophotometer;
pub mod woven_patch;

#[cfg(test)]
mod test_random;
