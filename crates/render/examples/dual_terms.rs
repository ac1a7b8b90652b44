//! Dual scattering term by term against a path-traced decomposition, on one member of the
//! generated scene family (`fiberlab_render::scene_family`).
//!
//! The path side is an independent, plain path tracer (next-event estimation only, no MIS, no
//! code shared with `integrator::radiance` beyond the scene's intersection and light
//! sampling) whose every contribution is filed by the path that carried it, counting the
//! first fiber the camera ray meets as vertex 1:
//! * `direct`: the light sample at vertex 1 (single scattering, no fiber in the way);
//! * `forward`: paths through fibers only whose every fiber vertex after the first scatters
//!   forward (the light leaves on the far side of the fiber: `ω_i·ω_o < 0` in the fiber's
//!   normal plane) — what dual scattering's global term `T_f·f_s^G` stands for;
//! * `back`: paths through fibers only with at least one backward event after vertex 1 — the
//!   local backscatter `f_back`;
//! * `surface`: paths that meet the skin (or any surface) after vertex 1 — the `through`
//!   surface bounce;
//! * `other`: everything whose first vertex is not a fiber (skin, sky seen directly).
//!
//! The path's classes follow the fiber's own halves (an event is backward when the light
//! leaves on the side it came from), which is not how dual scattering splits the light: a
//! chain of forward events can turn round and bring light back up out of the hair. So the
//! fiber-only paths (`forward` + `back`) are also split by where vertex 2 lies, on the family's
//! head (a sphere at the origin): `from above` (vertex 2 farther from the centre than vertex 1:
//! the light reached vertex 1 from the side of the hair's surface, what the global term stands
//! for) and `from below` (vertex 2 deeper: light returning from the hair behind the fiber, what
//! the local backscatter stands for).
//!
//! The dual side renders the same scene with terms switched off: `d_f = d_b = 0`, no bounce
//! (the direct term `w·f_s`), `d_b = 0` (adds the global term), no bounce (adds the
//! backscatter), and the default (adds the surface bounce); each term is the difference of
//! two renders. Each row prints the hair-weighted channel means of the path's and the dual's
//! term over the path tracer's whole image mean, so the rows' differences add up to the whole
//! image's bias.
//!
//! `cargo run --release -p fiberlab-render --example dual_terms -- --only dense-dark-front-white-blond
//! [--size test|bench] [--spp 64] [--path-spp 256] [--dual KEY=VALUE]…`
use fiberlab_io::LinearImage;
use fiberlab_io::block_error::channel_ratios;
use fiberlab_math::Rgb;
use fiberlab_math::split_mix::SplitMix64;
use fiberlab_render::dual_scattering::{DualScatteringSettings, Integrator, integrator_named};
use fiberlab_render::fiber_coverage::fiber_coverage;
use fiberlab_render::integrator::{RenderSettings, render};
use fiberlab_render::scene::{Hit, Scene};
use fiberlab_render::scene_family::{FamilyScene, FamilySize};
use fiberlab_render::scene_file::SceneFile;
use rayon::prelude::*;
use std::path::Path;

#[path = "independent_path/mod.rs"]
mod independent_path;
use std::sync::atomic::AtomicBool;

/// The path tracer's categories (module docs).
const TERMS: [&str; 5] = ["direct", "forward", "back", "surface", "other"];
/// The fiber-only paths (`forward` + `back`) split by vertex 2's depth (module docs).
const FROM: [&str; 2] = ["fibers, from above", "fibers, from below"];
const MAX_DEPTH: usize = 64;

/// One path's contributions, filed by category.
fn trace(scene: &Scene, px: f64, py: f64, rng: &mut SplitMix64) -> [Rgb; 7] {
    let mut out = [Rgb::ZERO; 7];
    let mut ray = scene.camera().ray(px, py);
    let mut beta = Rgb::ONE;
    // Category of the path so far: None before the first vertex.
    let mut first_is_fiber = None;
    let (mut backward, mut surface) = (false, false);
    // Distance of vertex 1 from the head's centre, and whether vertex 2 is deeper.
    let (mut radius_1, mut below) = (0.0, false);
    for depth in 0..MAX_DEPTH {
        let Some(hit) = scene.intersect(&ray) else {
            if depth == 0 {
                for light in scene.lights() {
                    out[4] += light.escaped(ray.d);
                }
            }
            break;
        };
        let fiber = matches!(hit, Hit::Fiber { .. });
        if depth == 0 {
            first_is_fiber = Some(fiber);
        } else if !fiber {
            surface = true;
        }
        let category = match first_is_fiber {
            Some(false) => 4,
            _ if depth == 0 => 0,
            _ if surface => 3,
            _ if backward => 2,
            _ => 1,
        };
        let p = match &hit {
            Hit::Fiber { hit, .. } => hit.p,
            Hit::Surface { p, .. } => *p,
        };
        match depth {
            0 => radius_1 = p.length(),
            1 => below = p.length() < radius_1,
            _ => {}
        }
        let eps = 1e-9 * (1.0 + p.abs().max_element());
        if let Some((wi, light)) = independent_path::light_sample(scene, &hit, ray.d, p, rng) {
            // A backward event at this (later) fiber vertex counts for the light sample too.
            let mut c = category;
            if let Hit::Fiber { hit, .. } = &hit
                && depth > 0
                && c == 1
                && independent_path::backward_event(hit, ray.d, wi)
            {
                c = 2;
            }
            let light = beta * light;
            out[c] += light;
            if c == 1 || c == 2 {
                out[5 + usize::from(below)] += light;
            }
        }
        // Continue the path.
        let u = [rng.next_f64(), rng.next_f64(), rng.next_f64(), rng.next_f64()];
        let Some((wi, weight)) = independent_path::scatter(scene, &hit, ray.d, depth, u, &mut backward) else { break };
        if !independent_path::carry_on(&mut beta, weight, depth, rng) {
            break;
        }
        ray = fiberlab_geometry::Ray { o: p, d: wi, t_min: eps, t_max: f64::INFINITY };
    }
    out
}

fn term_images(scene: &Scene, spp: u32) -> Vec<LinearImage> {
    let camera = scene.camera();
    let (w, h) = (camera.width as usize, camera.height as usize);
    let rows: Vec<Vec<[Rgb; 7]>> = (0..h)
        .into_par_iter()
        .map(|y| {
            (0..w)
                .map(|x| {
                    let mut rng = SplitMix64::new(0x5eed ^ ((y * w + x) as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
                    let mut sum = [Rgb::ZERO; 7];
                    for _ in 0..spp {
                        let (jx, jy) = (rng.next_f64(), rng.next_f64());
                        let c = trace(scene, x as f64 + jx, y as f64 + jy, &mut rng);
                        for (s, c) in sum.iter_mut().zip(c) {
                            *s += c;
                        }
                    }
                    sum.map(|s| s / f64::from(spp))
                })
                .collect()
        })
        .collect();
    (0..7)
        .map(|k| {
            let px: Vec<[f32; 3]> =
                rows.iter().flatten().map(|c| [c[k][0] as f32, c[k][1] as f32, c[k][2] as f32]).collect();
            LinearImage::from_pixels(w, h, px).expect("size")
        })
        .collect()
}

fn add(a: &LinearImage, b: &LinearImage, sign: f32) -> LinearImage {
    let px: Vec<[f32; 3]> = a
        .pixels()
        .iter()
        .zip(b.pixels())
        .map(|(p, q)| [p[0] + sign * q[0], p[1] + sign * q[1], p[2] + sign * q[2]])
        .collect();
    LinearImage::from_pixels(a.width(), a.height(), px).expect("size")
}

fn main() {
    let mut args = std::env::args().skip(1);
    let (mut size, mut spp, mut path_spp, mut only, mut dual) =
        (FamilySize::TEST, 64u32, 256u32, String::from("dense-dark-front-white-blond"), Vec::<String>::new());
    while let Some(a) = args.next() {
        let mut value = || args.next().unwrap_or_else(|| panic!("{a} needs a value"));
        match a.as_str() {
            "--size" => size = value().parse().unwrap_or_else(|e| panic!("--size: {e}")),
            "--spp" => spp = value().parse().expect("--spp N"),
            "--path-spp" => path_spp = value().parse().expect("--path-spp N"),
            "--only" => only = value(),
            "--dual" => dual.push(value()),
            other => panic!("unknown argument {other}"),
        }
    }
    let member =
        FamilyScene::all().into_iter().find(|m| m.name() == only).unwrap_or_else(|| panic!("no member {only}"));
    let file = SceneFile::parse(&member.scene_text(&size, spp), Path::new("family.toml")).expect("family scene");
    let (scene, _) = file.build().expect("family scene");
    let mask = fiber_coverage(&scene, 4);
    let path = term_images(&scene, path_spp);
    let total = path[1..5].iter().fold(path[0].clone(), |a, b| add(&a, b, 1.0));
    // The independent tracer against the renderer's path tracer, as a check of both.
    let render_with = |integrator: Integrator| {
        let settings = RenderSettings { spp, seed: 0, integrator, ..RenderSettings::default() };
        render(&scene, &settings, &|_| {}, &AtomicBool::new(false)).image
    };
    let renderer_path = render_with(Integrator::Path);
    let ratio = |img: &LinearImage| channel_ratios(img, &total, Some(&mask)).expect("same size");
    let dual_with = |options: &[&str]| {
        let mut all: Vec<String> = dual.clone();
        all.extend(options.iter().map(|s| s.to_string()));
        let settings = DualScatteringSettings::from_options("exact", &all).unwrap_or_else(|e| panic!("{e}"));
        render_with(integrator_named(&scene, "dual-scattering", settings).expect("dual"))
    };
    let d_direct = dual_with(&["d_f=0", "d_b=0", "surface_bounce=off"]);
    let d_forward = dual_with(&["d_b=0", "surface_bounce=off"]);
    let d_lights = dual_with(&["surface_bounce=off"]);
    let d_all = dual_with(&[]);
    let dual_terms = [
        add(&d_direct, &path[4], -1.0),
        add(&d_forward, &d_direct, -1.0),
        add(&d_lights, &d_forward, -1.0),
        add(&d_all, &d_lights, -1.0),
        path[4].clone(),
    ];
    println!("{} ({}², path {path_spp} spp, dual {spp} spp)", member.name(), size.px);
    let r = ratio(&renderer_path);
    println!("renderer's path tracer over this tracer: {:.3} {:.3} {:.3}", r[0], r[1], r[2]);
    println!("| term | path R | G | B | dual R | G | B |\n|---|---|---|---|---|---|---|");
    for (k, name) in TERMS.iter().enumerate() {
        let (a, b) = (ratio(&path[k]), ratio(&dual_terms[k]));
        println!("| {name} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |", a[0], a[1], a[2], b[0], b[1], b[2]);
    }
    // The global term against the light from above, the backscatter against the light from below.
    for (k, name) in FROM.iter().enumerate() {
        let (a, b) = (ratio(&path[5 + k]), ratio(&dual_terms[1 + k]));
        let term = ["global", "backscatter"][k];
        println!(
            "| {name} (dual: {term}) | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
            a[0], a[1], a[2], b[0], b[1], b[2]
        );
    }
    let d = ratio(&d_all);
    println!("| all | 1 | 1 | 1 | {:.3} | {:.3} | {:.3} |", d[0], d[1], d[2]);
}
