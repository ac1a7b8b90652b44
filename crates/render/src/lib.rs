//! fiberlab's CPU renderer for fiber assemblies: camera, lights, film, a unidirectional path
//! tracer with next-event estimation and MIS ([`integrator`]) and dual scattering
//! ([`dual_scattering`]), progressive and resumable accumulation ([`accumulation`]), tiles and
//! part merging, the TOML scene format ([`scene_file`]), and the one model loader for user input
//! ([`model_loader`], with [`toml_params`]). Surfaces may take a registered surface model with
//! image textures for its parameters ([`surface_material`], [`texture`]).
//!
//! What it renders comes from below: strands, the BVH, spheres and meshes from
//! [`fiberlab_geometry`]; generated grooms, woven patches, draped cloth, figured maple and
//! cabochons from [`fiberlab_procedural`]; fiber and surface scattering from
//! [`fiberlab_scatter`] (any registered model); file formats from [`fiberlab_io`]; the strand
//! diameters a scene accepts are in [`strand_diameters`]. This crate owns no scattering physics
//! and no intersection code: at a fiber hit it builds the fiber frame and calls the model; at a
//! surface-model hit it builds the shading frame and calls the surface model.
#![forbid(unsafe_code)]

pub mod accumulation;
pub mod bench;
pub mod camera;
pub mod dual_bounce;
pub mod dual_scattering;
pub mod fiber_count;
pub mod fiber_coverage;
pub mod integrator;
pub mod light;
pub mod measured_table;
pub mod model_loader;
pub mod region;
pub mod render_request;
pub mod ribbon_curves;
pub mod sampler;
pub mod scene;
pub mod scene_family;
pub mod scene_file;
pub mod strand_diameters;
pub mod surface_material;
pub mod texture;
pub mod toml_params;
