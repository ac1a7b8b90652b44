//! fiberlab's procedural assets: the things scenes and measurements are made of, generated from
//! a few parameters and a seed (deterministic, independent of thread count).
//!
//! * [`generator`]: hair (straight, wavy, curly, clumped) grown over a head sphere, and fur;
//! * [`woven_patch`]: a woven patch built from its fibers (yarns of twisted plies of fibers,
//!   plain and twill weaves), for the renderer and the cloth goniophotometer;
//! * [`draped_cloth`]: a cloth mesh draped over a sphere, with texture coordinates;
//! * [`figured_maple`]: a procedural figured-maple map of wood fiber direction and figure;
//! * [`cabochon`]: a polished cabochon dome for chatoyant minerals;
//! * [`grass`]: a patch of grass blades as curved, twisted, tapered ribbons in tufts (also as
//!   ribbon curves, for a curve file);
//! * [`cotton_boll`]: an open cotton boll, locks of wandering lint fibres.
//!
//! It stops at making geometry and parameter maps: it reads and writes no files (the formats
//! are `fiberlab-io`'s) and renders nothing.
#![forbid(unsafe_code)]

pub mod cabochon;
pub mod cotton_boll;
pub mod draped_cloth;
pub mod figured_maple;
pub mod generator;
pub mod grass;
pub mod woven_patch;
