//! `fiberlab sample`: importance samples of ω_i given ω_o, as CSV
//! `wi_x,wi_y,wi_z,weight_r,weight_g,weight_b,pdf` (weight = f_s cosθ_i/pdf for fibers,
//! f_r·|cosθ_i|/pdf with θ from the normal for surfaces; pdf 0 for delta lobes, whose
//! weight is the lobe's throughput). Surface directions are in the local frame (z = normal). Rows are streamed as they are drawn
//! (constant memory for any `--count`).

use crate::arg_values;
use crate::files::{output_file_or_stdout, stream_output};
use crate::model_args::AnyModel;
use crate::model_args::ModelArgs;
use fiberlab_math::DVec3;
use fiberlab_scatter::{ScatteringFunction, SurfaceScattering};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::path::PathBuf;

/// Flags of `fiberlab sample`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    model: ModelArgs,
    /// Viewer direction ω_o as x,y,z (unit vector; fiber frame, or for surface models the
    /// local frame with z = the normal).
    #[arg(long, allow_hyphen_values = true, value_parser = arg_values::unit_vector)]
    wo: DVec3,
    /// Offset across the fiber, in [-1, 1] (near-field fiber models; surfaces ignore it).
    #[arg(long, default_value = "0", allow_hyphen_values = true, value_parser = arg_values::offset)]
    h: f64,
    /// Number of samples.
    #[arg(long)]
    count: usize,
    /// Seed of the random stream.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output CSV (default: standard output); its directory is checked writable first.
    #[arg(long, value_parser = output_file_or_stdout)]
    output: Option<PathBuf>,
}

/// Draws the samples, writing each row as it is drawn.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let model = args.model.build_any()?;
    let wo = args.wo;
    let mut rng = Pcg64::seed_from_u64(args.seed);
    stream_output(args.output.as_deref(), false, |out| {
        let mut w = csv::Writer::from_writer(out);
        w.write_record(["wi_x", "wi_y", "wi_z", "weight_r", "weight_g", "weight_b", "pdf"])?;
        for _ in 0..args.count {
            let u = [rng.random(), rng.random(), rng.random(), rng.random()];
            let sample = match &model {
                AnyModel::Fiber(m) => m.sample(wo, args.h, u),
                AnyModel::Surface(m) => m.sample(wo, u),
            };
            if let Some(s) = sample {
                let v = [s.wi.x, s.wi.y, s.wi.z, s.weight[0], s.weight[1], s.weight[2], s.pdf];
                w.write_record(v.iter().map(|x| x.to_string()))?;
            }
        }
        w.flush()?;
        Ok(())
    })
}
