//! Dual scattering against the path tracer on small members of the generated scene family
//! (`fiberlab_render::scene_family`; any member at the benchmark's size with the example
//! `dual_family`). For each scene: the hair-weighted mean of every colour channel within
//! [`CHANNEL_TOL`] of a path-traced reference's, the RMS relative error of the 16 × 16 blocks
//! the hair covers below [`BLOCK_TOL`], and the firefly ratio (99.99th percentile over median
//! of the per-pixel |dual − reference|, `fiberlab_io::block_error`) below [`FIREFLY_TOL`].
//!
//! The members cover every axis value: dense and sparse hair, skin and a dark head, front and
//! back light, white and blue sky, blond, brown and black, no floor and a grey floor (light
//! off it reaches the hair from below, through the hair: the surface bounce).
//!
//! **What this does not show**: issue 37 asks for every channel's mean within 3 % of the path
//! tracer's. The dual-scattering approximation is not there: on these members it is between
//! 0.90 and 1.12 times the path tracer (measured at 32 spp against 128 spp; it was 0.80–1.26
//! with the paper's forward attenuation, backscatter series and half-space), so
//! [`CHANNEL_TOL`] guards against regressions, not the target. These are the family's small
//! size ([`FamilySize::TEST`], thick strands): at its benchmark size the same members come out
//! brighter by up to 0.12 (`bench/dual_scattering/result.md`, "The family at its two sizes"). The second test shows that the
//! defaults beat the paper's form on blond hair over a dark head, dense and sparse.

use fiberlab_io::LinearImage;
use fiberlab_io::block_error::{block_error, channel_ratios, firefly_ratio};
use fiberlab_render::dual_scattering::{DualScatteringSettings, Integrator, integrator_named};
use fiberlab_render::fiber_coverage::fiber_coverage;
use fiberlab_render::integrator::{RenderSettings, render};
use fiberlab_render::scene::Scene;
use fiberlab_render::scene_family::{Density, FamilyScene, FamilySize, Floor, HairColour, LightSide, Skin, Sky};
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// Largest |channel mean ratio − 1|: the reference's noise at 128 spp and the dual image's at
/// 32 spp are below 1 % here; the rest (up to 0.097 on these members) is the approximation's
/// bias (module docs: the target of 0.03 is not met).
const CHANNEL_TOL: f64 = 0.15;
/// Largest RMS relative error of the hair's 16 × 16 blocks (the bias included: 0.12 on the
/// dense blond head over skin; 0.33 with the paper's form on the sparse blond head).
const BLOCK_TOL: f64 = 0.25;
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
            floor: Floor::None,
        },
        FamilyScene {
            density: Density::Dense,
            skin: Skin::Visible,
            light: LightSide::Front,
            sky: Sky::Blue,
            hair: HairColour::Blond,
            floor: Floor::None,
        },
        FamilyScene {
            density: Density::Sparse,
            skin: Skin::Visible,
            light: LightSide::Back,
            sky: Sky::Blue,
            hair: HairColour::Brown,
            floor: Floor::None,
        },
        FamilyScene {
            density: Density::Dense,
            skin: Skin::Dark,
            light: LightSide::Back,
            sky: Sky::White,
            hair: HairColour::Black,
            floor: Floor::None,
        },
        FamilyScene {
            density: Density::Dense,
            skin: Skin::Visible,
            light: LightSide::Front,
            sky: Sky::White,
            hair: HairColour::Blond,
            floor: Floor::Grey,
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

/// The defaults (the beam's forward attenuation on the counted line, the backscatter series
/// that ends at the fiber, the counted depth of the hair behind it) against the paper's
/// (`a_f=averaged`, `back_series=paper`, `back_depth=infinite`) on blond hair over a dark
/// head, dense and sparse, front sun: the paper's is 0.82 / 0.83 / 0.85 (dense) and
/// 1.16 / 1.08 / 0.99 (sparse) times the path tracer in R / G / B, the defaults 0.93 / 1.00 /
/// 1.05 and 0.95 / 0.97 / 1.00 (40², 32 spp against 128; the test prints them). Each member's
/// worst channel must be nearer 1 with the defaults, and within 0.1.
#[test]
fn defaults_beat_the_papers_form_on_blond_hair_dense_and_sparse() {
    let size = FamilySize { px: 40, ..FamilySize::TEST };
    let paper = ["a_f=averaged", "back_series=paper", "back_depth=infinite"];
    let mut report = String::new();
    let mut worst = Vec::new();
    for density in [Density::Dense, Density::Sparse] {
        let m = FamilyScene {
            density,
            skin: Skin::Dark,
            light: LightSide::Front,
            sky: Sky::White,
            hair: HairColour::Blond,
            floor: Floor::None,
        };
        let file =
            fiberlab_render::scene_file::SceneFile::parse(&m.scene_text(&size, 32), Path::new("family.toml")).unwrap();
        let (scene, _) = file.build().unwrap();
        let mask = fiber_coverage(&scene, 3);
        let reference = image(&scene, Integrator::Path, 128, 1);
        let ratios = |options: &[&str]| {
            let settings = DualScatteringSettings::from_options("exact", options).unwrap();
            let dual = integrator_named(&scene, "dual-scattering", settings).unwrap();
            channel_ratios(&image(&scene, dual, 32, 0), &reference, Some(&mask)).unwrap()
        };
        let (defaults, papers) = (ratios(&[]), ratios(&paper));
        let error = |r: [f64; 3]| r.iter().map(|x| (x - 1.0).abs()).fold(0.0, f64::max);
        report += &format!("{}: defaults {defaults:.3?}, paper's {papers:.3?}\n", m.name());
        worst.push((m.name(), error(defaults), error(papers)));
    }
    println!("{report}");
    for (name, defaults, papers) in worst {
        assert!(defaults < papers && defaults < 0.1, "{name}: worst channel {defaults} against {papers}\n{report}");
    }
}
