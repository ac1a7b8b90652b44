//! Dual scattering against the path tracer on the generated scene family
//! (`fiberlab_render::scene_family`): for each scene, a path-traced reference (cached as
//! `DIR/NAME_ref.exr`), the dual-scattering image and the path tracer at the same spp, and per
//! image the hair-weighted mean of each channel over the reference's, the RMS relative error
//! of the 16 × 16 blocks the hair covers, the firefly ratio (99.99th percentile over median of
//! the per-pixel |image − reference| on hair pixels, `fiberlab_io::block_error`) and the
//! render seconds. Without `--only` it runs over the whole family (96 scenes; `--only floor` the 48
//! with a floor).
//!
//! `cargo run --release -p fiberlab-render --example dual_family -- [--size test|bench]
//! [--ref-spp 512] [--spp 16] [--only NAME,…] [--dual KEY=VALUE]… [--dir DIR] [--threads N]
//! [--no-path]`
use fiberlab_io::LinearImage;
use fiberlab_io::block_error::{block_error, channel_ratios, firefly_ratio};
use fiberlab_render::dual_scattering::{DualScatteringSettings, Integrator, integrator_named};
use fiberlab_render::fiber_coverage::fiber_coverage;
use fiberlab_render::integrator::{RenderSettings, render};
use fiberlab_render::scene::Scene;
use fiberlab_render::scene_family::{FamilyScene, FamilySize};
use fiberlab_render::scene_file::SceneFile;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

fn render_image(scene: &Scene, integrator: Integrator, spp: u32, seed: u64, threads: usize) -> (LinearImage, f64) {
    let settings = RenderSettings { spp, seed, threads, integrator, ..RenderSettings::default() };
    let out = render(scene, &settings, &|_| {}, &AtomicBool::new(false));
    (out.image, out.stats.seconds)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let (mut size, mut ref_spp, mut spp, mut threads) = (FamilySize::TEST, 512u32, 16u32, 0usize);
    let (mut only, mut dual, mut dir, mut with_path) = (Vec::<String>::new(), Vec::<String>::new(), None, true);
    while let Some(a) = args.next() {
        let mut value = || args.next().unwrap_or_else(|| panic!("{a} needs a value"));
        match a.as_str() {
            "--size" => size = value().parse().unwrap_or_else(|e| panic!("--size: {e}")),
            "--ref-spp" => ref_spp = value().parse().expect("--ref-spp N"),
            "--spp" => spp = value().parse().expect("--spp N"),
            "--threads" => threads = value().parse().expect("--threads N"),
            "--only" => only = value().split(',').map(String::from).collect(),
            "--dual" => dual.push(value()),
            "--dir" => dir = Some(PathBuf::from(value())),
            "--no-path" => with_path = false,
            other => panic!("unknown argument {other}"),
        }
    }
    let dir = dir.unwrap_or_else(|| std::env::temp_dir().join("dual_family"));
    std::fs::create_dir_all(&dir).expect("create the work directory");
    let settings = DualScatteringSettings::from_options("exact", &dual).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "| scene | image | spp | R | G | B | block RMSE | fireflies (p99.99/median) | render s |\n|---|---|---|---|---|---|---|---|---|"
    );
    for member in FamilyScene::all() {
        let name = member.name();
        if !only.is_empty() && !only.iter().any(|o| name.contains(o.as_str())) {
            continue;
        }
        let text = member.scene_text(&size, spp);
        let file = SceneFile::parse(&text, Path::new("family.toml")).unwrap_or_else(|e| panic!("{name}: {e}"));
        let (scene, _) = file.build().unwrap_or_else(|e| panic!("{name}: {e}"));
        let mask = fiber_coverage(&scene, 4);
        let ref_path = dir.join(format!("{name}_{}_ref{ref_spp}.exr", size.px));
        let reference = match LinearImage::read_exr(&ref_path) {
            Ok(r) => r,
            Err(_) => {
                let (r, t) = render_image(&scene, Integrator::Path, ref_spp, 1, threads);
                r.write_exr(&ref_path).unwrap_or_else(|e| panic!("{}: {e}", ref_path.display()));
                println!("| {name} | reference (path, seed 1) | {ref_spp} | | | | | | {t:.1} |");
                r
            }
        };
        let dual_integrator = integrator_named(&scene, "dual-scattering", settings).unwrap_or_else(|e| panic!("{e}"));
        let mut images = vec![("dual scattering", dual_integrator)];
        if with_path {
            images.push(("path", Integrator::Path));
        }
        for (label, integrator) in images {
            let (img, t) = render_image(&scene, integrator, spp, 0, threads);
            let tag = if label == "path" { "path" } else { "dual" };
            let _ = img.write_exr(&dir.join(format!("{name}_{}_{tag}{spp}.exr", size.px)));
            let r = channel_ratios(&img, &reference, Some(&mask)).expect("same size");
            let e = block_error(&img, &reference, Some(&mask)).expect("same size");
            let (_, _, fireflies) = firefly_ratio(&img, &reference, Some(&mask)).expect("same size");
            println!(
                "| {name} | {label} | {spp} | {:.3} | {:.3} | {:.3} | {:.3} | {fireflies:.1} | {t:.1} |",
                r[0], r[1], r[2], e.block_rmse
            );
        }
    }
}
