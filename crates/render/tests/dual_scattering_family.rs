//! Dual scattering against the path tracer on small members of the generated scene family
//! (`fiberlab_render::scene_family`; any member at the benchmark's size with the example
//! `dual_family`). For each scene: the hair-weighted mean of every colour channel within
//! [`CHANNEL_TOL`] of a path-traced reference's, the RMS relative error of the 16 × 16 blocks
//! the hair covers below [`BLOCK_TOL`], and the firefly ratio (99.99th percentile over median
//! of the per-pixel |dual − reference|, `fiberlab_io::block_error`) below [`FIREFLY_TOL`].
//!
//! The members cover every axis value: dense and sparse hair, skin and a dark head, front and
//! back light, white and blue sky, blond, brown and black.
//!
//! **What this does not show**: issue 37 asks for every channel's mean within 3 % of the path
//! tracer's. The dual-scattering approximation is not there: on these members it is between
//! 0.80 and 1.26 times the path tracer (measured at 32 spp against 128 spp), so [`CHANNEL_TOL`]
//! guards against regressions, not the target. The second test shows what the counted
//! backscatter depth (`back_depth=counted`) does on the sparse blond head over a dark head,
//! where the paper's half-space of hair behind every fiber (the default) makes dual scattering
//! 1.26 / 1.15 / 1.04 times the path tracer in R / G / B.

use fiberlab_io::LinearImage;
use fiberlab_io::block_error::{block_error, channel_ratios, firefly_ratio};
use fiberlab_render::dual_scattering::{DualScatteringSettings, Integrator, integrator_named};
use fiberlab_render::fiber_coverage::fiber_coverage;
use fiberlab_render::integrator::{RenderSettings, render};
use fiberlab_render::scene::Scene;
use fiberlab_render::scene_family::{Density, FamilyScene, FamilySize, HairColour, LightSide, Skin, Sky};
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// Largest |channel mean ratio − 1|: the reference's noise at 128 spp and the dual image's at
/// 32 spp are below 1 % here; the rest (up to 0.26 on these members) is the approximation's
/// bias (module docs: the target of 0.03 is not met).
const CHANNEL_TOL: f64 = 0.3;
/// Largest RMS relative error of the hair's 16 × 16 blocks (the bias included: 0.33 on the
/// sparse blond head over a dark head, whose one block is 24 % too bright in R).
const BLOCK_TOL: f64 = 0.4;
/// Largest firefly ratio (p99.99/median of |dual − reference|): the path tracer's own at 32 spp
/// is 15–40 on these scenes (front light) and up to a few hundred (back light: sun caustics
/// through TT, in the reference too).
const FIREFLY_TOL: f64 = 400.0;

fn image(scene: &Scene, integrator: Integrator, spp: u32, seed: u64) -> LinearImage {
    let settings = RenderSettings { spp, seed, integrator, ..RenderSettings::default() };
    render(scene, &settings, &|_| {}, &AtomicBool::new(false)).image
}

#[test]
fn dual_scattering_follows_the_path_tracer_on_the_scene_family() {
    let size = FamilySize { px: 40, ..FamilySize::TEST };
    let members = [
        FamilyScene {
            density: Density::Sparse,
            skin: Skin::Dark,
            light: LightSide::Front,
            sky: Sky::White,
            hair: HairColour::Blond,
        },
        FamilyScene {
            density: Density::Dense,
            skin: Skin::Visible,
            light: LightSide::Front,
            sky: Sky::Blue,
            hair: HairColour::Blond,
        },
        FamilyScene {
            density: Density::Sparse,
            skin: Skin::Visible,
            light: LightSide::Back,
            sky: Sky::Blue,
            hair: HairColour::Brown,
        },
        FamilyScene {
            density: Density::Dense,
            skin: Skin::Dark,
            light: LightSide::Back,
            sky: Sky::White,
            hair: HairColour::Black,
        },
    ];
    let mut report = String::new();
    let mut failures = Vec::new();
    for m in members {
        let file = fiberlab_render::scene_file::SceneFile::parse(&m.scene_text(&size, 32), Path::new("family.toml"))
            .unwrap_or_else(|e| panic!("{}: {e}", m.name()));
        let (scene, _) = file.build().unwrap();
        let mask = fiber_coverage(&scene, 3);
        let reference = image(&scene, Integrator::Path, 128, 1);
        let dual = integrator_named(&scene, "dual-scattering", DualScatteringSettings::default()).unwrap();
        let img = image(&scene, dual, 32, 0);
        let r = channel_ratios(&img, &reference, Some(&mask)).unwrap();
        let e = block_error(&img, &reference, Some(&mask)).unwrap();
        let (.., fireflies) = firefly_ratio(&img, &reference, Some(&mask)).unwrap();
        report += &format!(
            "{}: R/G/B {:.3} {:.3} {:.3}, block RMSE {:.3} ({} blocks), fireflies {fireflies:.0}\n",
            m.name(),
            r[0],
            r[1],
            r[2],
            e.block_rmse,
            e.blocks
        );
        if r.iter().any(|x| (x - 1.0).abs() > CHANNEL_TOL) || e.block_rmse > BLOCK_TOL || fireflies > FIREFLY_TOL {
            failures.push(m.name());
        }
    }
    println!("{report}");
    assert!(failures.is_empty(), "outside the bounds: {failures:?}\n{report}");
}

/// On sparse blond hair over a dark head the paper's half-space backscatter (the default) is
/// too bright; counting the fibers behind each one (`back_depth=counted`) brings it nearer the
/// path tracer, but overshoots: counted is 0.89 / 0.89 / 0.91 in R / G / B (40², 32 spp against
/// 128 spp; the test prints both). The bound is 0.15, and R must be nearer 1 than with the
/// half-space.
#[test]
fn counted_backscatter_depth_corrects_sparse_hair_over_a_dark_head() {
    let size = FamilySize { px: 40, ..FamilySize::TEST };
    let m = FamilyScene {
        density: Density::Sparse,
        skin: Skin::Dark,
        light: LightSide::Front,
        sky: Sky::White,
        hair: HairColour::Blond,
    };
    let file =
        fiberlab_render::scene_file::SceneFile::parse(&m.scene_text(&size, 32), Path::new("family.toml")).unwrap();
    let (scene, _) = file.build().unwrap();
    let mask = fiber_coverage(&scene, 3);
    let reference = image(&scene, Integrator::Path, 128, 1);
    let ratios = |option: &str| {
        let settings = DualScatteringSettings::from_options("exact", &[option]).unwrap();
        let dual = integrator_named(&scene, "dual-scattering", settings).unwrap();
        channel_ratios(&image(&scene, dual, 32, 0), &reference, Some(&mask)).unwrap()
    };
    let (half_space, counted) = (ratios("back_depth=infinite"), ratios("back_depth=counted"));
    println!("R/G/B half-space {half_space:.3?}, counted {counted:.3?}");
    assert!(half_space[0] > 1.15, "half-space backscatter R/G/B {half_space:?}");
    assert!(counted.iter().all(|r| (r - 1.0).abs() < 0.15), "counted backscatter depth R/G/B {counted:?}");
    assert!(
        (counted[0] - 1.0).abs() < (half_space[0] - 1.0).abs(),
        "counted R {counted:?} against half-space R {half_space:?}"
    );
}
