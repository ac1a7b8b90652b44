//! `fiberlab sample`: importance samples of ω_i given ω_o, as CSV
//! `wi_x,wi_y,wi_z,weight_r,weight_g,weight_b,pdf` (weight = f_s cosθ_i/pdf for fibers,
//! f_r·|cosθ_i|/pdf with θ from the normal for surfaces; pdf 0 for delta lobes, whose
//! weight is the lobe's throughput). Surface directions are in the local frame (z = normal). Rows are streamed as they are drawn
//! (constant memory for any `--count`); an output file larger than the free space of its file
//! system (at least [`MIN_ROW_BYTES`] per row) is refused before the first row. A signal
//! (Ctrl-C, SIGTERM, SIGHUP) stops the drawing: the rows written are kept as
//! `NAME.partial.csv` and the exit status is 130 (`crate::interrupt`). A model that draws no
//! sample at all for `--wo` (a surface seen from below) is an error, not an empty table.

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

/// The fewest bytes a row takes (`0,0,0,0,0,0,0` and a line break): the free-space check
/// refuses only outputs that cannot fit.
pub const MIN_ROW_BYTES: u64 = 14;

/// Draws the samples, writing each row as it is drawn.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let model = args.model.build_any()?;
    let wo = args.wo;
    if let Some(path) = &args.output {
        let bytes = (args.count as u64).saturating_mul(MIN_ROW_BYTES);
        fiberlab_io::output_file::check_free_space(path, bytes).map_err(anyhow::Error::msg)?;
    }
    let mut rng = Pcg64::seed_from_u64(args.seed);
    let stop = crate::interrupt::listen(&format!("drawing {} samples", args.count), "the rows written");
    stream_output(args.output.as_deref(), false, |out| {
        let mut w = csv::Writer::from_writer(out);
        w.write_record(["wi_x", "wi_y", "wi_z", "weight_r", "weight_g", "weight_b", "pdf"])?;
        let mut rows = 0usize;
        for k in 0..args.count {
            if k % 4096 == 0 && stop.load(std::sync::atomic::Ordering::Relaxed) {
                break;
            }
            let u = [rng.random(), rng.random(), rng.random(), rng.random()];
            let sample = match &model {
                AnyModel::Fiber(m) => m.sample(wo, args.h, u),
                AnyModel::Surface(m) => m.sample(wo, u),
            };
            if let Some(s) = sample {
                let v = [s.wi.x, s.wi.y, s.wi.z, s.weight[0], s.weight[1], s.weight[2], s.pdf];
                w.write_record(v.iter().map(|x| x.to_string()))?;
                rows += 1;
            }
        }
        w.flush()?;
        if rows == 0 && args.count > 0 && !crate::interrupt::stopped() {
            let below = matches!(model, AnyModel::Surface(_)) && wo.z <= 0.0;
            anyhow::bail!(
                "--wo {},{},{}: `{}` drew no sample in {} tries{}",
                wo.x,
                wo.y,
                wo.z,
                args.model.model,
                args.count,
                if below {
                    " (ω_o is below the surface: z ≤ 0 in the local frame, where a surface model scatters nothing)"
                } else {
                    ""
                }
            );
        }
        Ok(())
    })
}
