//! fiberlab's file formats and image metrics, and nothing else: no physics, no rendering.
//!
//! * [`hair`]: Cem Yuksel's binary `.hair` strand format (cyHair), read and write, with every
//!   malformed file reported as a typed [`hair::HairError`] naming the byte offset.
//! * [`image_file`]: linear OpenEXR and tone-mapped sRGB PNG output, each written to a temporary
//!   file in the destination directory and renamed into place, so a reader never sees half an image.
//! * [`image_metrics`]: RMSE, relative MSE, SSIM and FLIP between two images (`fiberlab compare`).
#![forbid(unsafe_code)]

pub mod hair;
pub mod image_file;
pub mod image_metrics;
pub mod pbrt_curves;
pub mod strands;
pub mod table;
pub mod usda_curves;

pub use hair::{HairError, HairFile, HairHeader};
pub use image_file::{ImageError, LinearImage, ToneMap};
pub use strands::{Basis, CurveKind, Format, StrandCounts, Strands, StrandsError};
