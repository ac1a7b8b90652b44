//! Dual scattering's global (forward) term split by depth, against the path tracer's forward
//! light, on one member of the generated scene family (`fiberlab_render::scene_family`).
//!
//! Path side: the independent path tracer of `dual_terms` (next-event estimation only), keeping
//! only its `forward` paths (the camera ray meets a fiber first, every later vertex is a fiber
//! that scatters forward); each contribution is filed by the number `k` of fiber vertices after
//! the first and by the number `n` of fibers on the straight line from the first vertex toward
//! the light sample that ends the path. Dual side: at the first vertex, one light sample shaded
//! with the global term alone (`T_f·f_s^G`, `d_b = 0`), filed by the `n` of its shadow ray.
//! Every value is a share of the path tracer's light from paths whose first vertex is a fiber.
//!
//! It also prints the tables' forward attenuations at a few inclinations (ā_f, averaged over
//! the light's azimuth with fixed halves, against a_f^beam, the far side of the light's own
//! azimuth), and the path's fiber-only light (`forward`, `back`) split by whether vertex 2 lies
//! farther from the head's centre than vertex 1 or deeper (issue 37: most of the path's
//! `forward` light comes back up from deeper hair).
//!
//! `cargo run --release -p fiberlab-render --example dual_forward -- --only dense-dark-front-white-blond
//! [--size test|bench] [--path-spp 512] [--spp 32] [--dual KEY=VALUE]…`
use fiberlab_math::split_mix::SplitMix64;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_render::dual_scattering::{DualScattering, DualScatteringSettings, RENDER_TABLE_RESOLUTION};
use fiberlab_render::scene::{Hit, Scene};
use fiberlab_render::scene_family::{FamilyScene, FamilySize};
use fiberlab_render::scene_file::SceneFile;
use fiberlab_scatter::ScatteringFunction;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::path::Path;

#[path = "independent_path/mod.rs"]
mod independent_path;

const MAX_DEPTH: usize = 64;
/// Buckets of `n` (fibers on the straight line) and of `k` (forward events after vertex 1).
const N_EDGES: [usize; 9] = [0, 1, 2, 3, 4, 6, 8, 16, 32];
const K_EDGES: [usize; 7] = [1, 2, 3, 4, 6, 8, 16];

fn bucket(edges: &[usize], v: usize) -> usize {
    edges.iter().rposition(|&e| v >= e).unwrap_or(0)
}

#[derive(Clone)]
struct Tally {
    total: Rgb,
    path_n: Vec<Rgb>,
    path_k: Vec<Rgb>,
    dual_n: Vec<Rgb>,
    /// Path light by [forward, back] × [vertex 2 above x, below x] (radius about the head).
    depth_split: [Rgb; 4],
}

impl Tally {
    fn new() -> Self {
        Self {
            total: Rgb::ZERO,
            path_n: vec![Rgb::ZERO; N_EDGES.len()],
            path_k: vec![Rgb::ZERO; K_EDGES.len()],
            dual_n: vec![Rgb::ZERO; N_EDGES.len()],
            depth_split: [Rgb::ZERO; 4],
        }
    }
    fn merge(mut self, o: Self) -> Self {
        self.total += o.total;
        for (a, b) in self.path_n.iter_mut().zip(o.path_n) {
            *a += b;
        }
        for (a, b) in self.path_k.iter_mut().zip(o.path_k) {
            *a += b;
        }
        for (a, b) in self.dual_n.iter_mut().zip(o.dual_n) {
            *a += b;
        }
        for (a, b) in self.depth_split.iter_mut().zip(o.depth_split) {
            *a += b;
        }
        self
    }
}

fn skip_of(
    scene: &Scene,
    hit: &fiberlab_geometry::curves::CurveHit,
    material: fiberlab_render::scene::FiberMaterialId,
) -> Option<(usize, u32)> {
    scene.fibers().iter().position(|f| f.material() == material).map(|a| (a, hit.strand))
}

/// One path of the independent tracer; forward contributions go into `tally`; returns the
/// whole contribution of a path whose first vertex is a fiber.
fn trace(scene: &Scene, dual: &DualScattering, px: f64, py: f64, rng: &mut SplitMix64, tally: &mut Tally) {
    let mut ray = scene.camera().ray(px, py);
    let mut beta = Rgb::ONE;
    let mut first: Option<(DVec3, fiberlab_geometry::curves::CurveHit, fiberlab_render::scene::FiberMaterialId)> = None;
    let (mut backward, mut surface) = (false, false);
    let mut k = 0usize;
    let mut below = false;
    for depth in 0..MAX_DEPTH {
        let Some(hit) = scene.intersect(&ray) else { break };
        match (&hit, depth) {
            (Hit::Fiber { hit, material }, 0) => first = Some((ray.d, *hit, *material)),
            (Hit::Surface { .. }, 0) => return,
            (Hit::Surface { .. }, _) => surface = true,
            (Hit::Fiber { hit: v, .. }, _) => {
                if k == 0 {
                    below = v.p.length() < first.expect("vertex 1").1.p.length();
                }
                k += 1;
            }
        }
        let p = match &hit {
            Hit::Fiber { hit, .. } => hit.p,
            Hit::Surface { p, .. } => *p,
        };
        let eps = 1e-9 * (1.0 + p.abs().max_element());
        if let Some((wi, light)) = independent_path::light_sample(scene, &hit, ray.d, p, rng) {
            let c = beta * light;
            tally.total += c;
            let back_here = match &hit {
                Hit::Fiber { hit, .. } => depth > 0 && independent_path::backward_event(hit, ray.d, wi),
                Hit::Surface { .. } => false,
            };
            if depth > 0 && !surface {
                let fwd = !backward && !back_here;
                tally.depth_split[usize::from(!fwd) * 2 + usize::from(below)] += c;
            }
            if depth > 0 && !surface && !backward && !back_here {
                // Forward light: the straight line from vertex 1 toward this light.
                let (_, h1, m1) = first.expect("vertex 1 is a fiber");
                let e1 = 1e-9 * (1.0 + h1.p.abs().max_element());
                let line = fiberlab_geometry::Ray { o: h1.p, d: wi, t_min: e1, t_max: f64::INFINITY };
                let (n, _, _) = dual.count(scene, &line, skip_of(scene, &h1, m1), 4.0 * h1.radius);
                tally.path_n[bucket(&N_EDGES, n as usize)] += c;
                tally.path_k[bucket(&K_EDGES, k)] += c;
            }
        }
        let u = [rng.next_f64(), rng.next_f64(), rng.next_f64(), rng.next_f64()];
        let Some((wi, weight)) = independent_path::scatter(scene, &hit, ray.d, depth, u, &mut backward) else { break };
        if !independent_path::carry_on(&mut beta, weight, depth, rng) {
            break;
        }
        ray = fiberlab_geometry::Ray { o: p, d: wi, t_min: eps, t_max: f64::INFINITY };
    }
}

/// The dual global term at vertex 1 for one light sample, filed by n.
fn dual_global(scene: &Scene, dual: &DualScattering, px: f64, py: f64, rng: &mut SplitMix64, tally: &mut Tally) {
    let ray = scene.camera().ray(px, py);
    let Some(Hit::Fiber { hit, material }) = scene.intersect(&ray) else { return };
    let p = hit.p;
    let eps = 1e-9 * (1.0 + p.abs().max_element());
    let Some((emitter, select)) = scene.light_picker().pick(rng.next_f64()) else { return };
    let Some(ls) = scene.sample_emitter(emitter, p, [rng.next_f64(), rng.next_f64()]) else { return };
    let t_max = if ls.distance.is_finite() { ls.distance * (1.0 - 1e-9) - eps } else { f64::INFINITY };
    let shadow = fiberlab_geometry::Ray { o: p, d: ls.wi, t_min: eps, t_max };
    if scene.intersect_surfaces(&shadow).is_some() {
        return;
    }
    let skip = skip_of(scene, &hit, material);
    let (n, product, spread2) = dual.count(scene, &shadow, skip, 4.0 * hit.radius);
    let frame = hit.frame(ray.d);
    let (wi, wo) = (frame.to_local(ls.wi), frame.to_local(-ray.d));
    let cos_i = (1.0 - wi.x * wi.x).max(0.0).sqrt();
    let weight = ls.radiance * (cos_i / (select * ls.pdf));
    if n >= 1.0 {
        let f = dual.scattering(scene, material, wi, wo, hit.h, n, product, spread2);
        tally.dual_n[bucket(&N_EDGES, n as usize)] += f * weight;
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let (mut size, mut spp, mut dual_spp, mut only, mut options) =
        (FamilySize::TEST, 512u32, 32u32, String::from("dense-dark-front-white-blond"), Vec::<String>::new());
    while let Some(a) = args.next() {
        let mut value = || args.next().unwrap_or_else(|| panic!("{a} needs a value"));
        match a.as_str() {
            "--size" => size = value().parse().unwrap_or_else(|e| panic!("--size: {e}")),
            "--path-spp" => spp = value().parse().expect("--path-spp N"),
            "--spp" => dual_spp = value().parse().expect("--spp N"),
            "--only" => only = value(),
            "--dual" => options.push(value()),
            other => panic!("unknown argument {other}"),
        }
    }
    let member =
        FamilyScene::all().into_iter().find(|m| m.name() == only).unwrap_or_else(|| panic!("no member {only}"));
    let file = SceneFile::parse(&member.scene_text(&size, spp), Path::new("family.toml")).expect("family scene");
    let (scene, _) = file.build().expect("family scene");
    options.push("d_b=0".into());
    options.push("cutoff=0".into());
    let settings = DualScatteringSettings::from_options("exact", &options).unwrap_or_else(|e| panic!("{e}"));
    let dual = DualScattering::new(&scene, settings, &RENDER_TABLE_RESOLUTION).expect("dual");
    {
        // The tables against the forward fraction of light from one azimuth (relative halves).
        let model = scene.fiber_model(scene.fibers()[0].material());
        let t = fiberlab_scatter::dual_scattering_tables::DualTables::new(model, &RENDER_TABLE_RESOLUTION).unwrap();
        for theta in [0.0f64, 0.3, 0.6, 0.9] {
            let af = t.lookup(theta, |r| r.forward);
            let ab = t.lookup(theta, |r| r.backward);
            let wi = fiberlab_math::frame::direction(theta, 0.0);
            let (nt, np, nh) = (96, 96, 16);
            let (mut fw, mut bw) = (Rgb::ZERO, Rgb::ZERO);
            for i in 0..nt {
                let to = -PI / 2.0 + (i as f64 + 0.5) * PI / nt as f64;
                for j in 0..np {
                    let po = (j as f64 + 0.5) * 2.0 * PI / np as f64;
                    let wo = fiberlab_math::frame::direction(to, po);
                    let mut f = Rgb::ZERO;
                    for k in 0..nh {
                        let h = -1.0 + (k as f64 + 0.5) * 2.0 / nh as f64;
                        f += model.eval(wi, wo, h) / nh as f64;
                    }
                    let v = f * (to.cos() * to.cos() * (PI / nt as f64) * (2.0 * PI / np as f64));
                    if po.cos() < 0.0 { fw += v } else { bw += v }
                }
            }
            let beam = t.lookup(theta, |r| r.forward_beam);
            println!(
                "θ {theta}: ā_f {:.3} {:.3} {:.3}, ā_b {:.3} {:.3} {:.3}; a_f^beam {:.3} {:.3} {:.3}; \
                 one azimuth by quadrature: far side {:.3} {:.3} {:.3}, near side {:.3} {:.3} {:.3}",
                af[0],
                af[1],
                af[2],
                ab[0],
                ab[1],
                ab[2],
                beam[0],
                beam[1],
                beam[2],
                fw[0],
                fw[1],
                fw[2],
                bw[0],
                bw[1],
                bw[2]
            );
        }
    }
    let camera = scene.camera();
    let (w, h) = (camera.width as usize, camera.height as usize);
    let tally = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let mut t = Tally::new();
            let mut rng = SplitMix64::new(0x5eed ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            let mut rng_dual = SplitMix64::new(0xd0a1 ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            for _ in 0..spp {
                let (x, y) = ((i % w) as f64 + rng.next_f64(), (i / w) as f64 + rng.next_f64());
                trace(&scene, &dual, x, y, &mut rng, &mut t);
            }
            // The path tracer's sum is over `spp` paths per pixel, the dual's over `dual_spp`.
            let mut d = Tally::new();
            for _ in 0..dual_spp {
                let (x, y) = ((i % w) as f64 + rng_dual.next_f64(), (i / w) as f64 + rng_dual.next_f64());
                dual_global(&scene, &dual, x, y, &mut rng_dual, &mut d);
            }
            let scale = f64::from(spp) / f64::from(dual_spp);
            t.dual_n = d.dual_n.into_iter().map(|v| v * scale).collect();
            t
        })
        .reduce(Tally::new, Tally::merge);
    let norm = tally.total;
    let show = |v: Rgb| format!("{:.4} {:.4} {:.4}", v[0] / norm[0], v[1] / norm[1], v[2] / norm[2]);
    println!("{} ({}², {spp} spp): shares of the path tracer's fiber-first light", member.name(), size.px);
    println!("| n | path forward R G B | dual global R G B |");
    let (mut sp, mut sd) = (Rgb::ZERO, Rgb::ZERO);
    for (b, e) in N_EDGES.iter().enumerate() {
        println!("| ≥{e} | {} | {} |", show(tally.path_n[b]), show(tally.dual_n[b]));
        sp += tally.path_n[b];
        sd += tally.dual_n[b];
    }
    println!("| all | {} | {} |", show(sp), show(sd));
    let d = &tally.depth_split;
    println!("path forward, vertex 2 above: {} below: {}", show(d[0]), show(d[1]));
    println!("path back,    vertex 2 above: {} below: {}", show(d[2]), show(d[3]));
    println!("| k | path forward R G B |");
    for (b, e) in K_EDGES.iter().enumerate() {
        println!("| ≥{e} | {} |", show(tally.path_k[b]));
    }
}
