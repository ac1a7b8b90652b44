//! `fiberlab bench`: eval and sample throughput of each model (ns/call), with the ideal
//! diffuse fiber's eval measured in the same run as the baseline.

use crate::model_args::ModelArgs;
use fiberlab_math::frame::direction;
use fiberlab_scatter::{MODELS, Model, ScatteringFunction};
use std::hint::black_box;
use std::time::Instant;

/// Flags of `fiberlab bench`.
#[derive(clap::Args)]
pub struct Args {
    /// Benchmark only this model (default: every registered model with default parameters).
    #[arg(long)]
    model: Option<String>,
    /// Parameter for --model as KEY=VALUE (repeatable).
    #[arg(long = "param", value_name = "KEY=VALUE", requires = "model")]
    params: Vec<String>,
    /// Calls per measurement.
    #[arg(long, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(1..))]
    calls: u64,
    /// Also measure the renderer on the default scene: BVH build, rays/s (camera and
    /// incoherent, against brute force), samples/s.
    #[arg(long)]
    render: bool,
    /// Strands of the generated head for the BVH figures (with --render).
    #[arg(long, default_value_t = 20_000)]
    strands: usize,
}

/// Renderer figures on the default scene, quoted against brute force measured in the same run.
fn render_figures(strands: usize) -> anyhow::Result<()> {
    use fiberlab_procedural::generator::HairParams;
    use fiberlab_render::bench::{brute_force_throughput, bvh_build, ray_throughput, samples_per_second};
    use fiberlab_render::scene_file::SceneFile;
    let file = SceneFile::default_scene();
    let (scene, settings) = file.build()?;
    let hair = HairParams { strands, ..HairParams::default() }.generate()?;
    let (set, stats) = bvh_build(&hair);
    println!(
        "BVH: {} strands, {} segments ({} pieces): build {:.2} s, {:.1} bytes/segment, {:.1} MiB",
        strands,
        stats.segments,
        stats.pieces,
        stats.seconds,
        stats.bytes_per_segment(),
        stats.bytes as f64 / (1 << 20) as f64
    );
    let (cam, inc, hit) = ray_throughput(&set, scene.camera(), 200_000, 1);
    let brute = brute_force_throughput(&set, scene.camera(), 400);
    println!(
        "rays, 1 thread: camera {cam:.3} Mrays/s ({:.0}% hit), incoherent {inc:.3} Mrays/s; brute force {brute:.5} Mrays/s (BVH camera = {:.0}× brute force)",
        hit * 100.0,
        cam / brute
    );
    let one = samples_per_second(&scene, &settings, 64, 2, 1);
    let all = samples_per_second(&scene, &settings, 128, 2, 0);
    println!(
        "path-traced samples/s (default scene, centre crop): 1 thread {one:.0}, {} threads {all:.0} ({:.2}× one thread)",
        rayon::current_num_threads(),
        all / one
    );
    Ok(())
}

/// Direction pairs and offsets cycled through by the measurements.
fn inputs() -> Vec<(fiberlab_math::DVec3, fiberlab_math::DVec3, f64, [f64; 4])> {
    (0..1024)
        .map(|k| {
            let t = k as f64;
            let u = [(t * 0.618_034) % 1.0, (t * 0.414_214) % 1.0, (t * 0.732_051) % 1.0, (t * 0.236_068) % 1.0];
            (
                direction((t * 0.37).sin() * 1.4, t * 0.91),
                direction((t * 0.53).cos() * 1.4, t * 1.7),
                (t * 0.29).sin(),
                u,
            )
        })
        .collect()
}

/// Median over 5 repetitions of the time per call, in ns.
fn time_per_call(calls: usize, mut f: impl FnMut(usize)) -> f64 {
    let mut runs: Vec<f64> = (0..5)
        .map(|_| {
            let start = Instant::now();
            for k in 0..calls {
                f(k);
            }
            start.elapsed().as_secs_f64() * 1e9 / calls as f64
        })
        .collect();
    runs.sort_by(f64::total_cmp);
    runs[2]
}

fn measure(model: &Model, calls: usize) -> (f64, f64) {
    let data = inputs();
    let eval = time_per_call(calls, |k| {
        let (wi, wo, h, _) = data[k & 1023];
        black_box(model.eval(black_box(wi), black_box(wo), h));
    });
    let sample = time_per_call(calls, |k| {
        let (_, wo, h, u) = data[k & 1023];
        black_box(model.sample(black_box(wo), h, u));
    });
    (eval, sample)
}

/// Runs the measurements and prints the table.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let baseline_model = fiberlab_scatter::build::<&str, &str>("diffuse", &[])?;
    let (baseline, _) = measure(&baseline_model, args.calls as usize);
    let models: Vec<(String, Model)> = match &args.model {
        Some(name) => {
            let m = ModelArgs { model: name.clone(), params: args.params.clone(), params_file: None };
            vec![(m.label(), m.build()?)]
        }
        None => MODELS
            .iter()
            .map(|s| Ok((s.name.to_string(), fiberlab_scatter::build::<&str, &str>(s.name, &[])?)))
            .collect::<anyhow::Result<_>>()?,
    };
    if args.render {
        render_figures(args.strands)?;
    }
    println!("baseline: diffuse eval = {baseline:.2} ns/call ({} calls × 5, median)", args.calls);
    println!("{:<40} {:>12} {:>10} {:>14} {:>10}", "model", "eval ns", "× base", "sample ns", "× base");
    for (label, model) in &models {
        let (e, s) = measure(model, args.calls as usize);
        println!("{label:<40} {e:>12.2} {:>10.1} {s:>14.2} {:>10.1}", e / baseline, s / baseline);
    }
    Ok(())
}
