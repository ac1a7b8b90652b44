//! fiberlab's file formats and image metrics, and nothing else: no physics, no rendering.
//!
//! * [`hair`]: Cem Yuksel's binary `.hair` strand format (cyHair), read and write, with every
//!   malformed file reported as a typed [`hair::HairError`] naming the byte offset.
//! * [`strands`]: [`Strands`], the format-neutral set of curves (control points, diameters,
//!   basis) every hair format reads into.
//! * [`strand_files`]: hair files of any format, by extension: read, written, counted.
//! * [`pbrt_curves`]: the `Shape "curve"`s of pbrt-v4 scene files (`.pbrt`, `.pbrt.gz`).
//! * [`usda_curves`]: USD `BasisCurves` in `.usda` text, read and write.
//! * [`image_file`]: linear OpenEXR and tone-mapped sRGB PNG output, each written through
//!   [`output_file`], so a reader never sees half an image.
//! * [`weave_pattern`]: Irawan & Marschner weave patterns (grid + yarns) as text, read and write,
//!   errors naming file, line and field.
//! * [`image_metrics`]: RMSE, relative MSE, SSIM and FLIP between two images (`fiberlab compare`).
//! * [`obj`]: Wavefront OBJ files as `fiberlab_geometry` triangle meshes, errors naming the line.
//! * [`input_file`]: how every reader opens a file — regular files only (never a FIFO or a
//!   device), read within the memory budget, errors naming the file and the line or byte.
//! * [`output_file`]: how every writer creates one — a temporary file renamed into place, never
//!   over a link, a device or a directory; standard streams written through.
//! * [`memory_budget`]: the memory check of the command line and Python, and the budget that
//!   bounds every input.
#![forbid(unsafe_code)]

pub mod block_error;
pub mod hair;
pub mod image_file;
pub mod image_metrics;
pub mod input_file;
mod lookahead;
pub mod memory_budget;
pub mod obj;
pub mod output_file;
pub mod pbrt_curves;
mod scene_text;
pub mod strand_files;
pub mod strands;
pub mod table;
pub mod usda_curves;
pub mod weave_pattern;

pub use hair::{HairError, HairFile, HairHeader};
pub use image_file::{ImageError, LinearImage, ToneMap};
pub use strand_files::{Format, StrandCounts};
pub use strands::{Basis, CurveKind, Strands, StrandsError};
