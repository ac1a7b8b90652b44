//! The GPU's scattering code and sampler against the CPU's: the f_s and pdf of Chiang's,
//! Kajiya–Kay's, Marschner's, d'Eon's, Yan's fur and hollow fibers, the reference fibers
//! (diffuse, Lambertian cylinder, specular, Goldman) and of the leaf, Lambertian, wood,
//! Sadeghi and Irawan–Marschner cloth surface models on random directions and offsets (f32
//! tolerance), their samples' density and
//! weight at the directions they return, the χ² of the GPU's samples against the CPU's pdf, and
//! the sampler's values.

mod common;

use fiberlab_check::chi2::{Chi2Config, chi2_test};
use fiberlab_check::rng::TestRng;
use fiberlab_check::surface::{AsFiberGrid, to_fiber};
use fiberlab_gpu::model_probe::{self, ChiangCase, ChiangResult};
use fiberlab_math::frame::{cos_theta, direction, phi, sin_theta};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_render::sampler::PixelSampler;
use fiberlab_scatter::Field;
use fiberlab_scatter::chiang_2016::{Chiang, ChiangParams};
use fiberlab_scatter::deon_2011::{AzimuthalInclination, Deon, DeonParams};
use fiberlab_scatter::goldman_1997::{Goldman, GoldmanParams};
use fiberlab_scatter::hair::absorption::Absorption;
use fiberlab_scatter::hair::fiber::HairFiberParams;
use fiberlab_scatter::hollow_fiber::{HollowFiber, HollowFiberParams};
use fiberlab_scatter::huang_2022::{Huang, HuangParams, Orientation};
use fiberlab_scatter::ideal_diffuse::{IdealDiffuse, IdealDiffuseParams};
use fiberlab_scatter::ideal_specular::{Azimuth, IdealSpecular, IdealSpecularParams};
use fiberlab_scatter::irawan_2012::Irawan2012;
use fiberlab_scatter::kajiya_kay_1989::{KajiyaKay, KajiyaKayParams};
use fiberlab_scatter::lambert_1760::{Lambertian, LambertianParams};
use fiberlab_scatter::lambertian_cylinder::{LambertianCylinder, LambertianCylinderParams};
use fiberlab_scatter::leaf::{Leaf, LeafParams};
use fiberlab_scatter::marschner_2003::{Marschner, MarschnerParams};
use fiberlab_scatter::marschner_2005::{Wood, WoodParams};
use fiberlab_scatter::sadeghi_2013::{SADEGHI_PRESETS, Sadeghi2013};
use fiberlab_scatter::yan_2017::{CortexAbsorption, YanFur, YanFurParams};
use fiberlab_scatter::{Model, Properties, Sample, ScatteringFunction, SurfaceScattering};
use glam::Vec3;
use std::f64::consts::{FRAC_PI_2, TAU};
use std::sync::atomic::{AtomicUsize, Ordering};

fn fibers() -> Vec<(&'static str, Chiang)> {
    let lossless = ChiangParams { absorption: Absorption::NONE, ..ChiangParams::default() };
    let rough = ChiangParams { beta_m: 0.9, beta_n: 0.8, alpha: (-5f64).to_radians(), ..ChiangParams::blond() };
    let smooth = ChiangParams { beta_m: 0.12, beta_n: 0.15, alpha: 3f64.to_radians(), ..ChiangParams::black() };
    [("brown", ChiangParams::brown()), ("lossless", lossless), ("rough blond", rough), ("smooth black", smooth)]
        .into_iter()
        .map(|(n, p)| (n, Chiang::new(p).unwrap()))
        .collect()
}

fn dvec(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

/// A random case: directions uniform in θ ∈ (−1.5, 1.5) and φ, the grazing angles and h = ±1
/// among them.
fn case(rng: &mut TestRng, k: usize) -> ChiangCase {
    let u = rng.u4();
    let theta = |x: f64| -1.5 + 3.0 * x;
    let mut wo = direction(theta(u[0]), TAU * u[1]);
    let wi = direction(theta(u[2]), TAU * u[3]);
    if k.is_multiple_of(17) {
        wo = direction(FRAC_PI_2 - 1e-3, 0.3);
    }
    let h = match k % 13 {
        0 => 1.0,
        1 => -1.0,
        _ => rng.u4()[0] * 2.0 - 1.0,
    };
    let uu = rng.u4();
    ChiangCase {
        wo: wo.as_vec3().normalize(),
        h: h as f32,
        wi: wi.as_vec3().normalize(),
        u: uu.map(|x| (x as f32).min(1.0 - f32::EPSILON / 2.0)),
    }
}

/// f_s and pdf agree with the CPU's at the same (f32) inputs to 5·10⁻⁴ of the largest channel
/// (measured worst 4.5·10⁻⁵; with the driver's own sin, cos and atan, which Vulkan lets be off
/// by 2⁻¹¹ and 4096 ulp, it was 4·10⁻³); sampled directions are unit vectors whose pdf and
/// weight the CPU confirms.
#[test]
fn chiang_eval_pdf_and_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(5);
    for (name, fiber) in fibers() {
        let cases: Vec<ChiangCase> = (0..4000).map(|k| case(&mut rng, k)).collect();
        let got = model_probe::chiang(gpu, &fiber, &cases).unwrap();
        matches_the_cpu(name, &fiber, &cases, &got);
    }
}

/// Checks the GPU's results on `cases` against `cpu`: f_s to 5·10⁻⁴ of the largest channel, the
/// pdf to 5·10⁻⁴ relative (at ω_i, or within 2·10⁻⁶ rad of it in θ: a table's cell edge), sampled directions unit vectors whose pdf (to 3·10⁻³) and weight the
/// CPU confirms, and more than 2,000 samples checked.
fn matches_the_cpu<M: ScatteringFunction>(name: &str, cpu: &M, cases: &[ChiangCase], got: &[ChiangResult]) {
    matches_the_cpu_where(name, cpu, cases, got, 5e-4, |_| true);
}

/// [`matches_the_cpu`] with f_s and the pdf to `tol` (instead of 5·10⁻⁴) on the cases where
/// `compare` holds; on the others only that the GPU's values are finite and non-negative.
fn matches_the_cpu_where<M: ScatteringFunction>(
    name: &str,
    cpu: &M,
    cases: &[ChiangCase],
    got: &[ChiangResult],
    tol: f64,
    compare: impl Fn(&ChiangCase) -> bool,
) {
    let (mut sampled, mut worst) = (0, 0.0f64);
    for (c, g) in cases.iter().zip(got) {
        let finite = g.f.iter().chain([&g.pdf]).all(|x| x.is_finite() && *x >= 0.0);
        assert!(finite, "{name}: f {:?} pdf {} at {c:?}", g.f, g.pdf);
        if !compare(c) {
            continue;
        }
        let (wo, wi, h) = (dvec(c.wo), dvec(c.wi), f64::from(c.h));
        let (f, pdf) = (cpu.eval(wi, wo, h), cpu.pdf(wi, wo, h));
        let scale = f.max_component().max(1e-3);
        for k in 0..3 {
            let err = (f64::from(g.f[k]) - f[k]).abs() / scale;
            worst = worst.max(err);
            assert!(err < tol, "{name}: f[{k}] {} vs {} at {c:?}", g.f[k], f[k]);
        }
        // A tabulated lobe's density (Kajiya–Kay's, Goldman's) steps at its cells' edges: where
        // ω_i lies within f32 rounding (2·10⁻⁶ rad) of an edge either cell's value is right.
        let pdf_close = |p: f64| (f64::from(g.pdf) - p).abs() <= tol * p.max(1e-3);
        let (theta_i, phi_i) = (sin_theta(wi).atan2(cos_theta(wi)), phi(wi));
        let near_edge = || [-2e-6, 2e-6].iter().any(|d| pdf_close(cpu.pdf(direction(theta_i + d, phi_i), wo, h)));
        assert!(pdf_close(pdf) || near_edge(), "{name}: pdf {} vs {pdf} at {c:?}", g.pdf);
        if g.sample_pdf > 0.0 {
            let swi = dvec(g.sample_wi);
            assert!((swi.length() - 1.0).abs() < 1e-5, "{name}: |ω_i| = {}", swi.length());
            let (f, pdf) = (cpu.eval(swi, wo, h), cpu.pdf(swi, wo, h));
            if pdf > 1e-2 {
                assert!(
                    (f64::from(g.sample_pdf) / pdf - 1.0).abs() < 3e-3,
                    "{name}: sample pdf {} vs {pdf}",
                    g.sample_pdf
                );
                let weight = f * (cos_theta(swi) / pdf);
                for k in 0..3 {
                    let err = (f64::from(g.sample_weight[k]) - weight[k]).abs();
                    assert!(
                        err < 3e-3 * weight.max_component().max(1e-2),
                        "{name}: weight {:?} vs {weight:?}",
                        g.sample_weight
                    );
                }
                sampled += 1;
            }
        }
    }
    eprintln!("{name}: {} evaluations, {sampled} samples checked, worst relative f error {worst:.2e}", cases.len());
    assert!(sampled > 2000, "{name}: only {sampled} samples checked");
}

/// `cfg.samples` cases at one camera direction and offset, with the χ² seed's uniforms.
fn sample_cases(wo: DVec3, h: f64, cfg: &Chi2Config) -> Vec<ChiangCase> {
    let mut rng = TestRng::new(cfg.seed);
    (0..cfg.samples)
        .map(|_| ChiangCase {
            wo: wo.as_vec3(),
            h: h as f32,
            wi: Vec3::X,
            u: rng.u4().map(|x| (x as f32).min(1.0 - f32::EPSILON / 2.0)),
        })
        .collect()
}

/// χ² of the GPU's samples `got` (of [`sample_cases`]) against `cpu`'s pdf at the f32 camera
/// direction and offset the GPU used.
fn gpu_samples_follow_the_cpu_pdf<M: ScatteringFunction>(
    name: &str,
    cpu: &M,
    wo: DVec3,
    h: f64,
    got: &[ChiangResult],
    cfg: &Chi2Config,
) {
    let samples = got.iter().map(|g| (g.sample_pdf > 0.0).then(|| dvec(g.sample_wi))).collect();
    let f = GpuSamples { cpu, samples, next: AtomicUsize::new(0) };
    let out = chi2_test(&f, dvec(wo.as_vec3()), f64::from(h as f32), cfg);
    eprintln!("{name}: χ² {:.1} dof {} p {:.3}", out.statistic, out.dof, out.p_value);
    assert!(out.passes(1e-3), "{name}: {out:?}");
}

fn kajiya_kay_fibers() -> Vec<(&'static str, KajiyaKay)> {
    let sharp = KajiyaKayParams { k_d: Rgb::new(0.02, 0.01, 0.005), k_s: Rgb::new(0.3, 0.2, 0.1), p: 2000.0 };
    let specular_only = KajiyaKayParams { k_d: Rgb::ZERO, k_s: Rgb::splat(0.2), p: 8.0 };
    let medium = KajiyaKayParams { k_d: Rgb::new(0.1, 0.05, 0.02), k_s: Rgb::splat(0.2), p: 30.0 };
    [
        ("default", KajiyaKayParams::default()),
        ("sharp", sharp),
        ("specular only", specular_only),
        ("medium lobe", medium),
    ]
    .into_iter()
    .map(|(n, p)| (n, KajiyaKay::new(p).unwrap()))
    .collect()
}

/// Kajiya–Kay: f_s to 5·10⁻⁴ of the largest channel (its 1/cosθ_i grows without bound at
/// grazing light, so the scale is f's own), the pdf to 5·10⁻⁴ relative, and each sample's pdf
/// and weight as the CPU computes them at the direction returned.
#[test]
fn kajiya_kay_eval_pdf_and_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(6);
    for (name, fiber) in kajiya_kay_fibers() {
        let cases: Vec<ChiangCase> = (0..4000).map(|k| case(&mut rng, k)).collect();
        let got = model_probe::kajiya_kay(gpu, &fiber, &cases).unwrap();
        matches_the_cpu(&format!("kajiya-kay {name}"), &fiber, &cases, &got);
    }
}

/// χ² of the GPU's Kajiya–Kay samples against the CPU's pdf, at a near-normal and a
/// steep camera direction.
#[test]
fn kajiya_kay_gpu_samples_follow_the_cpu_pdf() {
    let Some(gpu) = common::gpu() else { return };
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 200_000, seed: 10, ..Default::default() };
    for (name, fiber) in kajiya_kay_fibers() {
        for theta_o in [0.35, -1.1] {
            let wo = direction(theta_o, FRAC_PI_2);
            let got = model_probe::kajiya_kay(gpu, &fiber, &sample_cases(wo, 0.0, &cfg)).unwrap();
            gpu_samples_follow_the_cpu_pdf(&format!("kajiya-kay {name} θ_o {theta_o}"), &fiber, wo, 0.0, &got, &cfg);
        }
    }
}

/// The smooth reference fibers: diffuse, the Lambertian cylinder, and Goldman's fiber with
/// forward and backward weights apart, equal, and one of them zero.
fn reference_fibers() -> Vec<(&'static str, Model)> {
    let goldman = |rho_reflect: Rgb, rho_transmit: Rgb, p: f64| {
        let kajiya_kay = KajiyaKayParams { k_d: Rgb::new(0.1, 0.05, 0.02), k_s: Rgb::splat(0.2), p };
        Model::Goldman(Goldman::new(GoldmanParams { kajiya_kay, rho_reflect, rho_transmit }).unwrap())
    };
    vec![
        ("diffuse", Model::Diffuse(IdealDiffuse::new(IdealDiffuseParams { albedo: Rgb::new(0.8, 0.5, 0.2) }).unwrap())),
        (
            "lambertian-cylinder",
            Model::LambertianCylinder(
                LambertianCylinder::new(LambertianCylinderParams { albedo: Rgb::new(0.9, 0.6, 0.3) }).unwrap(),
            ),
        ),
        ("goldman forward", goldman(Rgb::new(0.9, 0.8, 0.7), Rgb::new(0.2, 0.3, 0.1), 30.0)),
        ("goldman equal", goldman(Rgb::splat(0.5), Rgb::splat(0.5), 8.0)),
        ("goldman backward only", goldman(Rgb::splat(1.0), Rgb::ZERO, 300.0)),
    ]
}

/// The smooth reference fibers' f_s, pdf and samples against the CPU's (as
/// `matches_the_cpu` checks every fiber model).
#[test]
fn reference_fibers_eval_pdf_and_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(21);
    for (name, fiber) in reference_fibers() {
        let cases: Vec<ChiangCase> = (0..4000).map(|k| case(&mut rng, k)).collect();
        let got = model_probe::reference_fiber(gpu, &fiber, &cases).expect("a reference fiber").unwrap();
        matches_the_cpu(name, &fiber, &cases, &got);
    }
}

/// χ² of the GPU's samples of the smooth reference fibers against the CPU's pdf, at a
/// near-normal and a steep camera direction.
#[test]
fn reference_fiber_gpu_samples_follow_the_cpu_pdf() {
    let Some(gpu) = common::gpu() else { return };
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 200_000, seed: 22, ..Default::default() };
    for (name, fiber) in reference_fibers() {
        for theta_o in [0.35, -1.1] {
            let wo = direction(theta_o, FRAC_PI_2);
            let got = model_probe::reference_fiber(gpu, &fiber, &sample_cases(wo, 0.0, &cfg)).unwrap().unwrap();
            gpu_samples_follow_the_cpu_pdf(&format!("{name} θ_o {theta_o}"), &fiber, wo, 0.0, &got, &cfg);
        }
    }
}

/// The specular fiber's delta lobe: zero f_s and pdf, and from the same uniforms the CPU's
/// direction on the cone θ_i = −θ_o and its weight (Fresnel or 1), for both azimuths.
#[test]
fn specular_fiber_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(23);
    for azimuth in [Azimuth::Uniform, Azimuth::Mirror] {
        for fresnel_eta in [None, Some(1.55)] {
            let cpu = IdealSpecular::new(IdealSpecularParams { azimuth, fresnel_eta }).unwrap();
            let model = Model::Specular(cpu.clone());
            let cases: Vec<ChiangCase> = (0..2000).map(|k| case(&mut rng, k)).collect();
            let got = model_probe::reference_fiber(gpu, &model, &cases).unwrap().unwrap();
            let mut worst = 0.0f64;
            for (c, g) in cases.iter().zip(&got) {
                assert!(g.f == [0.0; 3] && g.pdf == 0.0, "{azimuth:?}: a delta lobe evaluates to 0");
                let u = c.u.map(f64::from);
                let s = cpu.sample(dvec(c.wo), f64::from(c.h), u).expect("the specular fiber always samples");
                assert!(s.delta);
                assert_eq!(g.sample_pdf, 1.0, "the GPU's delta marker");
                let dw = (dvec(g.sample_wi) - s.wi).length();
                worst = worst.max(dw);
                assert!(dw < 2e-4, "{azimuth:?} {fresnel_eta:?}: ω_i {:?} vs {:?} at {c:?}", g.sample_wi, s.wi);
                for k in 0..3 {
                    assert!(
                        (f64::from(g.sample_weight[k]) - s.weight[k]).abs() < 1e-4,
                        "{azimuth:?} {fresnel_eta:?}: weight {:?} vs {:?}",
                        g.sample_weight,
                        s.weight
                    );
                }
            }
            eprintln!("specular {azimuth:?} η {fresnel_eta:?}: worst |Δω_i| {worst:.1e}");
        }
    }
}

fn marschner_fibers() -> Vec<(&'static str, Marschner)> {
    let eccentric =
        MarschnerParams { eccentricity: 0.85, sigma_a: Rgb::new(0.1, 0.2, 0.4), ..MarschnerParams::default() };
    let no_glints = MarschnerParams {
        glints: false,
        beta_r: 5f64.to_radians(),
        alpha_r: 4f64.to_radians(),
        ..MarschnerParams::default()
    };
    // The ends of the ranges: the narrowest, most tilted lobes (TT 0.5° wide, TRT 30° off)
    // with the most eccentric section, and the widest lobes with η′ > 2 (merged, fading glints).
    let narrow = MarschnerParams {
        alpha_r: (-20f64).to_radians(),
        beta_r: 1f64.to_radians(),
        eccentricity: 0.75,
        k_g: 10.0,
        w_c: 1f64.to_radians(),
        ..MarschnerParams::default()
    };
    let wide = MarschnerParams {
        alpha_r: 20f64.to_radians(),
        beta_r: 20f64.to_radians(),
        eta: 2.5,
        sigma_a: Rgb::ZERO,
        w_c: 45f64.to_radians(),
        delta_eta: 2.0,
        delta_h_m: 2.0,
        ..MarschnerParams::default()
    };
    [
        ("default", MarschnerParams::default()),
        ("dark", MarschnerParams::dark()),
        ("paper literal", MarschnerParams::paper_literal()),
        ("eccentric", eccentric),
        ("no glints", no_glints),
        ("narrow", narrow),
        ("wide", wide),
    ]
    .into_iter()
    .map(|(n, p)| (n, Marschner::new(p).unwrap()))
    .collect()
}

/// Marschner (exact and cubic roots, printed path and normalization, eccentric TRT, glints off,
/// the ends of the lobe width, tilt, η and glint ranges):
/// f_s to 5·10⁻⁴ of the largest channel, the pdf to 5·10⁻⁴ relative, and each sample's pdf and
/// weight as the CPU computes them at the direction returned, over random directions (grazing
/// viewers and h = ±1 among them; h is ignored by this far-field model).
#[test]
fn marschner_eval_pdf_and_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(7);
    for (name, fiber) in marschner_fibers() {
        // 2,500 pairs per variant (not 4,000 as above): lavapipe solves Marschner's roots slowly.
        let cases: Vec<ChiangCase> = (0..2500).map(|k| case(&mut rng, k)).collect();
        let got = model_probe::marschner(gpu, &fiber, &cases).unwrap();
        matches_the_cpu(&format!("marschner {name}"), &fiber, &cases, &got);
    }
}

/// χ² of the GPU's Marschner samples against the CPU's pdf: Table 1's fiber, the paper as
/// printed, the eccentric and the widest-lobe variants, each at one camera direction
/// (near-normal, grazing or steep; 60,000 samples each: lavapipe solves the roots of every
/// sample on two cores). Not the narrow variant: its 0.5°-wide TT lobe is finer than this grid
/// integrates (∫pdf = 1.12 on it); its samples are checked against the CPU's pdf at every
/// direction drawn, above.
#[test]
fn marschner_gpu_samples_follow_the_cpu_pdf() {
    let Some(gpu) = common::gpu() else { return };
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 60_000, seed: 12, ..Default::default() };
    let directions = [("default", 0.35), ("paper literal", 1.555), ("eccentric", -1.1), ("wide", -1.1)];
    let fibers = marschner_fibers();
    for (name, theta_o) in directions {
        let fiber = &fibers.iter().find(|(n, _)| *n == name).unwrap().1;
        let wo = direction(theta_o, FRAC_PI_2);
        let got = model_probe::marschner(gpu, fiber, &sample_cases(wo, 0.0, &cfg)).unwrap();
        gpu_samples_follow_the_cpu_pdf(&format!("marschner {name} θ_o {theta_o}"), fiber, wo, 0.0, &got, &cfg);
    }
}

fn deon_fibers() -> Vec<(&'static str, Deon)> {
    let lossless = HairFiberParams { absorption: Absorption::NONE, ..HairFiberParams::default() };
    let smooth = HairFiberParams { beta_m: 0.12, beta_n: 0.15, alpha: 3f64.to_radians(), ..HairFiberParams::black() };
    let rough = HairFiberParams { beta_m: 0.8, beta_n: 0.7, ..HairFiberParams::blond() };
    [
        ("brown", DeonParams::brown()),
        ("lossless", DeonParams { fiber: lossless, ..DeonParams::default() }),
        ("smooth black, θ_d", DeonParams { fiber: smooth, theta_n: AzimuthalInclination::Difference, p_max: 3 }),
        ("rough blond, p_max 5", DeonParams { fiber: rough, p_max: 5, ..DeonParams::default() }),
    ]
    .into_iter()
    .map(|(n, p)| (n, Deon::new(p).unwrap()))
    .collect()
}

/// d'Eon (its azimuthal table copied to the GPU; camera and θ_d inclinations, p_max 3 and 5): f_s
/// to 5·10⁻⁴ of the largest channel, the pdf to 5·10⁻⁴ relative, and each sample's pdf and weight
/// as the CPU computes them at the direction returned.
#[test]
fn deon_eval_pdf_and_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(8);
    for (name, fiber) in deon_fibers() {
        let cases: Vec<ChiangCase> = (0..4000).map(|k| case(&mut rng, k)).collect();
        let got = model_probe::deon(gpu, &fiber, &cases).unwrap();
        matches_the_cpu(&format!("deon {name}"), &fiber, &cases, &got);
    }
}

/// χ² of the GPU's d'Eon samples against the CPU's pdf, each variant at a near-normal or a
/// steep camera direction.
#[test]
fn deon_gpu_samples_follow_the_cpu_pdf() {
    let Some(gpu) = common::gpu() else { return };
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 200_000, seed: 12, ..Default::default() };
    for ((name, fiber), theta_o) in deon_fibers().into_iter().zip([0.35, -1.1, 0.35, -1.1]) {
        let wo = direction(theta_o, FRAC_PI_2);
        let got = model_probe::deon(gpu, &fiber, &sample_cases(wo, 0.0, &cfg)).unwrap();
        gpu_samples_follow_the_cpu_pdf(&format!("deon {name} θ_o {theta_o}"), &fiber, wo, 0.0, &got, &cfg);
    }
}

fn yan_furs() -> Vec<(&'static str, YanFur)> {
    let deg = |x: f64| x.to_radians();
    // A thick, absorbing, forward-scattering medulla under a 3-interface cuticle, the narrowest
    // lobes and the most negative tilt.
    let dense = YanFurParams {
        kappa: 0.8,
        sigma_m_s: 8.0,
        sigma_m_a: 0.5,
        g: 0.6,
        layers: 3.0,
        alpha: deg(-20.0),
        beta_m: deg(0.5),
        beta_n: deg(0.5),
        ..YanFurParams::default()
    };
    // From a colour, a back-scattering lossless medulla, the widest lobes, η at 2.5.
    let wide = YanFurParams {
        absorption: CortexAbsorption::Color(Rgb::new(0.8, 0.5, 0.3)),
        eta: 2.5,
        kappa: 0.3,
        sigma_m_s: 20.0,
        g: -0.5,
        alpha: deg(20.0),
        beta_m: deg(60.0),
        beta_n: deg(60.0),
        ..YanFurParams::default()
    };
    let scattered_only = YanFurParams { lobes: [false, false, false, true, true], ..YanFurParams::default() };
    let no_medulla = YanFurParams { kappa: 0.0, lobes: [true, true, true, false, false], ..YanFurParams::default() };
    let far = YanFurParams { field: Field::Far, beta_n: deg(30.0), ..YanFurParams::default() };
    [
        ("default", YanFurParams::default()),
        ("dense medulla, narrow", dense),
        ("coloured, wide", wide),
        ("scattered lobes only", scattered_only),
        ("no medulla", no_medulla),
        ("far field", far),
    ]
    .into_iter()
    .map(|(n, p)| (n, YanFur::new(p).unwrap()))
    .collect()
}

/// Yan fur (its medulla tables and far-field nodes copied to the GPU; every parameter at an end
/// of its range in some variant, the scattered lobes alone, no medulla, the far field): f_s to
/// 5·10⁻⁴ of the largest channel, the pdf to 5·10⁻⁴ relative, and each sample's pdf and weight as
/// the CPU computes them at the direction returned, over random directions and h (grazing
/// viewers and h = ±1 among them).
#[test]
fn yan_fur_eval_pdf_and_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(13);
    for (name, fiber) in yan_furs() {
        // 3,200 pairs: with the scattered lobes alone, only chords through the medulla sample.
        let cases: Vec<ChiangCase> = (0..3200).map(|k| case(&mut rng, k)).collect();
        let got = model_probe::yan_fur(gpu, &fiber, &cases).unwrap();
        matches_the_cpu(&format!("yan-fur {name}"), &fiber, &cases, &got);
    }
}

/// χ² of the GPU's Yan fur samples against the CPU's pdf: the default fiber, the coloured one
/// with the widest lobes and a back-scattering medulla, the scattered lobes alone (drawn by the
/// tables' samplers), at near-normal, steep and grazing camera directions (100,000 samples
/// each). The far field draws h uniformly and then this near-field sampler; its pdf and weight
/// at each sample are checked against the CPU's above (its χ² took 32 s on lavapipe: each pdf
/// integrates 144 near-field values).
#[test]
fn yan_fur_gpu_samples_follow_the_cpu_pdf() {
    let Some(gpu) = common::gpu() else { return };
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 100_000, seed: 14, ..Default::default() };
    let fibers = yan_furs();
    for (name, theta_o, h) in
        [("default", 0.35, 0.3), ("coloured, wide", -1.1, -0.2), ("scattered lobes only", 1.5, 0.1)]
    {
        let fiber = &fibers.iter().find(|(n, _)| *n == name).unwrap().1;
        let wo = direction(theta_o, FRAC_PI_2);
        let got = model_probe::yan_fur(gpu, fiber, &sample_cases(wo, h, &cfg)).unwrap();
        gpu_samples_follow_the_cpu_pdf(&format!("yan-fur {name} θ_o {theta_o} h {h}"), fiber, wo, h, &got, &cfg);
    }
}

fn huangs() -> Vec<(&'static str, Huang)> {
    let deg = |x: f64| x.to_radians();
    // The roughest, flattest fiber, random orientations, the steepest tilt, η at its top.
    let flat = HuangParams {
        roughness: 1.0,
        aspect: 0.1,
        orientation: Orientation::Average,
        alpha: deg(20.0),
        eta: 4.0,
        absorption: Absorption::BLOND,
        ..HuangParams::default()
    };
    // The smoothest: a circle, the most negative tilt, black, multipliers at their ends.
    let smooth = HuangParams {
        roughness: 0.01,
        aspect: 1.0,
        alpha: deg(-20.0),
        absorption: Absorption::BLACK,
        reflection: 10.0,
        transmission: 0.0,
        secondary_reflection: 10.0,
        ..HuangParams::default()
    };
    // Lossless, a tilted ellipse, the lowest η.
    let lossless = HuangParams {
        roughness: 0.15,
        aspect: 0.5,
        orientation: Orientation::Fixed(deg(30.0)),
        eta: 1.01,
        absorption: Absorption::NONE,
        ..HuangParams::default()
    };
    // The hair of `scenes/hair_huang.toml`.
    let scene = HuangParams {
        roughness: 0.15,
        aspect: 0.7,
        orientation: Orientation::Average,
        absorption: Absorption::Melanin { eumelanin: 0.4, pheomelanin: 0.15 },
        ..HuangParams::default()
    };
    [
        ("default", HuangParams::default()),
        ("rough flat average", flat),
        ("smooth black", smooth),
        ("lossless tilted ellipse", lossless),
        ("scene", scene),
    ]
    .into_iter()
    .map(|(n, p)| (n, Huang::new(p).unwrap()))
    .collect()
}

/// Huang 2022 (its interface tables and lattice shifts copied; every parameter at an end of
/// its range in some variant: roughness 0.01 and 1, aspect 0.1 and 1, tilt ±20°, η 1.01 and 4,
/// multipliers 0 and 10, fixed and averaged orientations): f_s to 5·10⁻⁴ of the largest channel,
/// the pdf to 5·10⁻⁴ relative, and each sample's pdf and weight as the CPU computes them at the
/// direction returned, over random directions and h (grazing viewers and h = ±1 among them).
#[test]
fn huang_eval_pdf_and_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(15);
    for (name, fiber) in huangs() {
        let cases: Vec<ChiangCase> = (0..3200).map(|k| case(&mut rng, k)).collect();
        let got = model_probe::huang(gpu, &fiber, &cases).unwrap();
        matches_the_cpu_where(&format!("huang-2022 {name}"), &fiber, &cases, &got, 1e-3, |c| c.h.abs() < 1.0);
    }
}

/// χ² of the GPU's Huang samples against the CPU's pdf: the default fiber, the rough flat one
/// with random orientations, the smooth one (narrow R and TRT lobes), at near-normal, steep and
/// grazing camera directions (100,000 samples each).
#[test]
fn huang_gpu_samples_follow_the_cpu_pdf() {
    let Some(gpu) = common::gpu() else { return };
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 100_000, seed: 16, ..Default::default() };
    let fibers = huangs();
    for (name, theta_o, h) in
        [("default", 0.35, 0.3), ("rough flat average", -1.1, -0.6), ("lossless tilted ellipse", 1.4, 0.1)]
    {
        let fiber = &fibers.iter().find(|(n, _)| *n == name).unwrap().1;
        let wo = direction(theta_o, FRAC_PI_2);
        let got = model_probe::huang(gpu, fiber, &sample_cases(wo, h, &cfg)).unwrap();
        gpu_samples_follow_the_cpu_pdf(&format!("huang-2022 {name} θ_o {theta_o} h {h}"), fiber, wo, h, &got, &cfg);
    }
}

fn leaves() -> Vec<(&'static str, Leaf)> {
    let mut senescent = LeafParams { roughness: 1.0, eta: 1.2, ..LeafParams::default() };
    senescent.contents.n = 3.0;
    senescent.contents.cab = 5.0;
    senescent.contents.cbrown = 2.0;
    senescent.contents.anth = 40.0;
    // A glossy cuticle (α 0.03: f32 keeps GGX's D near its peak to 10⁻⁴ down to about there).
    let glossy = LeafParams { roughness: 0.03, eta: 2.0, ..LeafParams::default() };
    [("default", LeafParams::default()), ("senescent, rough", senescent), ("glossy", glossy)]
        .into_iter()
        .map(|(n, p)| (n, Leaf::new(p).unwrap()))
        .collect()
}

/// A random pair of surface directions on the whole sphere (z the normal), grazing ones among
/// them, with uniforms for the sample.
fn surface_case(rng: &mut TestRng, k: usize) -> ChiangCase {
    let dir = |u: f64, v: f64| {
        let z = 2.0 * u - 1.0;
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * (TAU * v).cos(), r * (TAU * v).sin(), z)
    };
    let u = rng.u4();
    let mut wo = dir(u[0], u[1]);
    if k.is_multiple_of(17) {
        wo = DVec3::new(1.0, 0.0, 1e-3).normalize();
    }
    let uu = rng.u4();
    ChiangCase {
        wo: wo.as_vec3().normalize(),
        h: 0.0,
        wi: dir(u[2], u[3]).as_vec3().normalize(),
        u: uu.map(|x| (x as f32).min(1.0 - f32::EPSILON / 2.0)),
    }
}

/// Checks the GPU's results on `cases` (surface frame) against the surface model `cpu`: f_s to
/// 5·10⁻⁴ of the largest channel, the pdf to 5·10⁻⁴ relative, sampled directions unit vectors
/// whose pdf (to 3·10⁻³) and weight the CPU confirms, more than 1,500 samples checked.
fn surface_matches_the_cpu<S: SurfaceScattering>(name: &str, cpu: &S, cases: &[ChiangCase], got: &[ChiangResult]) {
    let (mut sampled, mut worst) = (0, 0.0f64);
    for (c, g) in cases.iter().zip(got) {
        let (wo, wi) = (dvec(c.wo), dvec(c.wi));
        let (f, pdf) = (cpu.eval(wi, wo), cpu.pdf(wi, wo));
        let scale = f.max_component().max(1e-3);
        for k in 0..3 {
            let err = (f64::from(g.f[k]) - f[k]).abs() / scale;
            worst = worst.max(err);
            assert!(err < 5e-4, "{name}: f[{k}] {} vs {} at {c:?}", g.f[k], f[k]);
        }
        assert!((f64::from(g.pdf) - pdf).abs() <= 5e-4 * pdf.max(1e-3), "{name}: pdf {} vs {pdf}", g.pdf);
        if g.sample_pdf > 0.0 {
            let swi = dvec(g.sample_wi);
            assert!((swi.length() - 1.0).abs() < 1e-5, "{name}: |ω_i| = {}", swi.length());
            let (f, pdf) = (cpu.eval(swi, wo), cpu.pdf(swi, wo));
            if pdf > 1e-2 {
                assert!((f64::from(g.sample_pdf) / pdf - 1.0).abs() < 3e-3, "{name}: {} vs {pdf}", g.sample_pdf);
                let weight = f * (swi.z.abs() / pdf);
                for k in 0..3 {
                    let err = (f64::from(g.sample_weight[k]) - weight[k]).abs();
                    assert!(
                        err < 3e-3 * weight.max_component().max(1e-2),
                        "{name}: weight {:?} vs {weight:?}",
                        g.sample_weight
                    );
                }
                sampled += 1;
            }
        }
    }
    eprintln!("{name}: {} evaluations, {sampled} samples checked, worst relative f error {worst:.2e}", cases.len());
    assert!(sampled > 1500, "{name}: only {sampled} samples checked");
}

/// The leaf surface model (its cuticle albedo table copied to the GPU; the default leaf, a
/// senescent one with the roughest cuticle, the lowest index and the spongiest structure, and a
/// glossy one with the highest index), as `surface_matches_the_cpu` checks, over random
/// direction pairs on both sides (reflection and transmission); and the `lambertian` model.
#[test]
fn surface_models_eval_pdf_and_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(16);
    for (name, leaf) in leaves() {
        let cases: Vec<ChiangCase> = (0..4000).map(|k| surface_case(&mut rng, k)).collect();
        let got = model_probe::leaf(gpu, &leaf, &cases).unwrap();
        surface_matches_the_cpu(&format!("leaf {name}"), &leaf, &cases, &got);
    }
    let lambertian = Lambertian::new(LambertianParams { k_d: Rgb::new(0.9, 0.5, 0.1) }).unwrap();
    let cases: Vec<ChiangCase> = (0..4000).map(|k| surface_case(&mut rng, k)).collect();
    let got = model_probe::lambertian(gpu, &lambertian, &cases).unwrap();
    surface_matches_the_cpu("lambertian", &lambertian, &cases, &got);
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 100_000, seed: 18, ..Default::default() };
    let wo = DVec3::new(0.5, -0.3, 0.6).normalize();
    let got: Vec<ChiangResult> = model_probe::lambertian(gpu, &lambertian, &sample_cases(wo, 0.0, &cfg))
        .unwrap()
        .into_iter()
        .map(|g| ChiangResult { sample_wi: to_fiber(dvec(g.sample_wi)).as_vec3(), ..g })
        .collect();
    gpu_samples_follow_the_cpu_pdf(
        "lambertian",
        &AsFiberGrid(&lambertian),
        to_fiber(dvec(wo.as_vec3())),
        0.0,
        &got,
        &cfg,
    );
}

/// χ² of the GPU's leaf samples against the CPU's pdf (binned on the check harness's grid
/// about the normal), each leaf at a near-normal or a grazing viewer, from above or below.
#[test]
fn leaf_gpu_samples_follow_the_cpu_pdf() {
    let Some(gpu) = common::gpu() else { return };
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 100_000, seed: 17, ..Default::default() };
    let directions = [DVec3::new(0.3, 0.1, 0.95), DVec3::new(0.9, -0.2, -0.2), DVec3::new(-0.5, 0.6, 0.4)];
    for ((name, leaf), wo) in leaves().iter().zip(directions) {
        let wo = wo.normalize();
        let cases = sample_cases(wo, 0.0, &cfg);
        let got: Vec<ChiangResult> = model_probe::leaf(gpu, leaf, &cases)
            .unwrap()
            .into_iter()
            .map(|g| ChiangResult { sample_wi: to_fiber(dvec(g.sample_wi)).as_vec3(), ..g })
            .collect();
        let grid = AsFiberGrid(leaf);
        let wo_grid = to_fiber(dvec(wo.as_vec3()));
        gpu_samples_follow_the_cpu_pdf(&format!("leaf {name}"), &grid, wo_grid, 0.0, &got, &cfg);
    }
}

fn hollow_fibers() -> Vec<(&'static str, HollowFiber)> {
    let deg = |x: f64| x.to_radians();
    // A thin absorbing wall round a wide lumen, the narrowest lobes, the most negative tilt.
    let thin = HollowFiberParams {
        kappa: 0.9,
        absorption: Absorption::SigmaA(Rgb::new(0.4, 0.8, 1.6)),
        beta_m: 0.05,
        beta_n: 0.05,
        alpha: deg(-20.0),
        ..HollowFiberParams::default()
    };
    // A water-filled lumen in a dense wall (η 2.5), the widest lobes.
    let water = HollowFiberParams {
        eta: 2.5,
        kappa: 0.6,
        lumen_eta: 1.33,
        beta_m: 1.0,
        beta_n: 1.0,
        alpha: deg(20.0),
        ..HollowFiberParams::default()
    };
    // A lumen denser than the wall, TT and the residual only.
    let dense = HollowFiberParams {
        kappa: 0.7,
        lumen_eta: 2.0,
        lobes: [false, true, false, true],
        ..HollowFiberParams::default()
    };
    [
        ("default", HollowFiberParams::default()),
        ("thin absorbing wall", thin),
        ("water-filled", water),
        ("dense lumen, TT and residual", dense),
    ]
    .into_iter()
    .map(|(n, p)| (n, HollowFiber::new(p).unwrap()))
    .collect()
}

/// Hollow fibers (air, water and denser-than-wall lumens, every wall-pass kind; the ends of the
/// roughness and tilt ranges; lobes switched off), as `matches_the_cpu` checks them, over random
/// directions and h (grazing viewers and h = ±1 among them).
#[test]
fn hollow_fiber_eval_pdf_and_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(29);
    for (name, fiber) in hollow_fibers() {
        let cases: Vec<ChiangCase> = (0..4000).map(|k| case(&mut rng, k)).collect();
        let got = model_probe::hollow_fiber(gpu, &fiber, &cases).unwrap();
        matches_the_cpu(&format!("hollow-fiber {name}"), &fiber, &cases, &got);
    }
}

/// χ² of the GPU's hollow-fiber samples against the CPU's pdf, at a camera direction and offset
/// through the lumen and one that misses it.
#[test]
fn hollow_fiber_gpu_samples_follow_the_cpu_pdf() {
    let Some(gpu) = common::gpu() else { return };
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 100_000, seed: 31, ..Default::default() };
    let fibers = hollow_fibers();
    for (name, theta_o, h) in [("default", 0.35, 0.3), ("water-filled", -1.1, -0.2), ("thin absorbing wall", 0.2, 0.95)]
    {
        let fiber = &fibers.iter().find(|(n, _)| *n == name).unwrap().1;
        let wo = direction(theta_o, FRAC_PI_2);
        let got = model_probe::hollow_fiber(gpu, fiber, &sample_cases(wo, h, &cfg)).unwrap();
        gpu_samples_follow_the_cpu_pdf(&format!("hollow-fiber {name} θ_o {theta_o} h {h}"), fiber, wo, h, &got, &cfg);
    }
}

/// Woven fabrics: filament (silk charmeuse: ψ = 0, smoothing ss = 0.5; polyester lining) and
/// staple yarns (cotton denim and wool gabardine: ψ = ∓30°), warps and wefts.
fn fabrics() -> Vec<(&'static str, Irawan2012)> {
    ["silk-charmeuse", "polyester-lining", "cotton-denim", "wool-gabardine"]
        .into_iter()
        .map(|n| (n, Irawan2012::preset(n).unwrap()))
        .collect()
}

/// `irawan-2012` on the GPU against the CPU at random tile positions (u, v ∈ [−3, 5): tiles
/// other than the first and negative coordinates) and direction pairs on both sides, grazing
/// ones among them: f_s to 5·10⁻⁴ of the largest channel and the pdf to 5·10⁻⁴ relative, except
/// where the f64 and f32 evaluations fall on the two sides of a highlight's edge (the integrand
/// is cut off at |y − y*| = δ_y/2, |x − x*| = δ_x/2, |u*| = u_max and |D| = 1): there the CPU at
/// inputs moved by 10⁻⁵ must reach the GPU's value, and such cases are under 1 %; sampled
/// directions are unit vectors whose pdf the CPU confirms (3·10⁻³), their weights too but for
/// under 1 % (edges again).
#[test]
fn irawan_eval_pdf_and_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(23);
    for (name, fabric) in fabrics() {
        let cases: Vec<ChiangCase> = (0..6000).map(|k| surface_case(&mut rng, k)).collect();
        let positions: Vec<[f32; 2]> =
            cases.iter().map(|_| rng.u4()).map(|u| [(8.0 * u[0] - 3.0) as f32, (8.0 * u[1] - 3.0) as f32]).collect();
        let got = model_probe::irawan(gpu, &fabric, &cases, &positions).unwrap();
        let (mut sampled, mut edges, mut weight_edges, mut highlights, mut worst) = (0, 0, 0, 0, 0.0f64);
        for ((c, p), g) in cases.iter().zip(&positions).zip(&got) {
            let at = |du: f64, dv: f64| {
                let mut m = fabric.clone();
                m.set_position(f64::from(p[0]) + du, f64::from(p[1]) + dv);
                m
            };
            let cpu = at(0.0, 0.0);
            let (wo, wi) = (dvec(c.wo), dvec(c.wi));
            let (f, pdf) = (cpu.eval(wi, wo), cpu.pdf(wi, wo));
            let scale = f.max_component().max(1e-3);
            let err = (0..3).map(|k| (f64::from(g.f[k]) - f[k]).abs() / scale).fold(0.0, f64::max);
            if cpu.integrand(wi, wo) > 0.0 {
                highlights += 1;
            }
            if err < 5e-4 {
                worst = worst.max(err);
            } else {
                // On an edge: some nearby input of the CPU gives the GPU's value.
                let near = (0..64).any(|k| {
                    let d = 1e-5 * ((k as f64) * 0.7).sin();
                    let e = 1e-5 * ((k as f64) * 1.3).cos();
                    let m = at(d, e);
                    let wi2 = (wi + DVec3::new(e, d, -e)).normalize();
                    let f2 = m.eval(wi2, wo);
                    (0..3).all(|j| (f64::from(g.f[j]) - f2[j]).abs() < 5e-4 * f2.max_component().max(1e-3))
                });
                assert!(near, "{name}: f {:?} vs {f:?} at {c:?}, position {p:?}", g.f);
                edges += 1;
            }
            assert!((f64::from(g.pdf) - pdf).abs() <= 5e-4 * pdf.max(1e-3), "{name}: pdf {} vs {pdf}", g.pdf);
            if g.sample_pdf > 0.0 {
                let swi = dvec(g.sample_wi);
                assert!((swi.length() - 1.0).abs() < 1e-5, "{name}: |ω_i| = {}", swi.length());
                let spdf = cpu.pdf(swi, wo);
                assert!((f64::from(g.sample_pdf) / spdf - 1.0).abs() < 3e-3, "{name}: {} vs {spdf}", g.sample_pdf);
                let weight = cpu.eval(swi, wo) * (swi.z.max(0.0) / spdf);
                let err = (0..3).map(|k| (f64::from(g.sample_weight[k]) - weight[k]).abs()).fold(0.0, f64::max);
                if err > 3e-3 * weight.max_component().max(1e-2) {
                    weight_edges += 1;
                }
                sampled += 1;
            }
        }
        eprintln!(
            "{name}: {} evaluations ({highlights} in a highlight), {edges} on an edge, {sampled} samples ({weight_edges} weights off), worst relative f error {worst:.2e}",
            cases.len()
        );
        assert!(edges * 100 < cases.len() && weight_edges * 100 < sampled, "{name}: too many on an edge");
        assert!(highlights > 100 && sampled > 2000, "{name}: {highlights} highlights, {sampled} samples");
    }
}

/// χ² of the GPU's `irawan-2012` samples against the CPU's pdf (binned on the check harness's
/// grid about the normal), at a near-normal and a grazing viewer.
#[test]
fn irawan_gpu_samples_follow_the_cpu_pdf() {
    let Some(gpu) = common::gpu() else { return };
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 100_000, seed: 19, ..Default::default() };
    let fabric = Irawan2012::preset("cotton-denim").unwrap();
    for wo in [DVec3::new(0.3, 0.1, 0.95), DVec3::new(-0.9, 0.3, 0.15)] {
        let wo = wo.normalize();
        let cases = sample_cases(wo, 0.0, &cfg);
        let positions = vec![[0.3, 0.6]; cases.len()];
        let got: Vec<ChiangResult> = model_probe::irawan(gpu, &fabric, &cases, &positions)
            .unwrap()
            .into_iter()
            .map(|g| ChiangResult { sample_wi: to_fiber(dvec(g.sample_wi)).as_vec3(), ..g })
            .collect();
        let grid = AsFiberGrid(&fabric);
        gpu_samples_follow_the_cpu_pdf("irawan cotton-denim", &grid, to_fiber(dvec(wo.as_vec3())), 0.0, &got, &cfg);
    }
}

fn woods() -> Vec<(&'static str, Wood)> {
    let deg = f64::to_radians;
    let rough = WoodParams {
        roughness: 0.3,
        fiber_angle: deg(35.0),
        fiber_dip: deg(25.0),
        beta: deg(4.0),
        ..WoodParams::default()
    };
    let steep = WoodParams {
        eta: 1.75,
        roughness: 0.08,
        k_d: Rgb::new(0.5, 0.3, 0.1),
        k_f: Rgb::new(0.1, 0.05, 0.02),
        beta: deg(20.0),
        fiber_angle: deg(-120.0),
        fiber_dip: deg(80.0),
    };
    let vertical = WoodParams {
        k_d: Rgb::splat(0.2),
        roughness: 0.5,
        beta: deg(45.0),
        fiber_dip: deg(-90.0),
        ..WoodParams::default()
    };
    [
        ("default (smooth finish)", WoodParams::default()),
        ("rough, dipped", rough),
        ("tiger's eye", WoodParams::tigers_eye()),
        ("steep dip", steep),
        ("vertical fibers, β 45°", vertical),
    ]
    .into_iter()
    .map(|(n, p)| (n, Wood::new(p).unwrap()))
    .collect()
}

/// The wood surface model (Marschner et al. 2005: smooth and rough finishes, fibers in the
/// plane, dipped, vertical; β from 3° to 45°), as `surface_matches_the_cpu` checks, over random
/// direction pairs on the whole sphere; the smooth finish's mirror samples (pdf −1 on the GPU)
/// are the CPU's delta samples of the same uniforms, direction and weight.
#[test]
fn wood_eval_pdf_and_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(19);
    for (name, wood) in woods() {
        let cases: Vec<ChiangCase> = (0..6000).map(|k| surface_case(&mut rng, k)).collect();
        let got = model_probe::wood(gpu, &wood, &cases).unwrap();
        surface_matches_the_cpu(&format!("wood {name}"), &wood, &cases, &got);
        let mut mirrored = 0;
        for (c, g) in cases.iter().zip(&got) {
            let cpu = wood.sample(dvec(c.wo), c.u.map(f64::from));
            if g.sample_pdf < 0.0 {
                let s = cpu.unwrap_or_else(|| panic!("wood {name}: GPU mirror sample, none on the CPU at {c:?}"));
                assert!(s.delta && (dvec(g.sample_wi) - s.wi).length() < 1e-6, "wood {name}: {c:?}");
                assert!((f64::from(g.sample_weight[0]) / s.weight[0] - 1.0).abs() < 1e-4, "wood {name}: {c:?}");
                mirrored += 1;
            } else {
                assert!(!cpu.is_some_and(|s| s.delta), "wood {name}: CPU mirror sample, not on the GPU at {c:?}");
            }
        }
        eprintln!("wood {name}: {mirrored} mirror samples");
        assert_eq!(mirrored > 100, wood.properties().has_delta, "wood {name}: {mirrored} mirror samples");
    }
}

/// χ² of the GPU's wood samples against the CPU's pdf (the smooth finish's mirror samples
/// against the mass the pdf leaves out), each wood at a near-normal, oblique or grazing viewer.
#[test]
fn wood_gpu_samples_follow_the_cpu_pdf() {
    let Some(gpu) = common::gpu() else { return };
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 100_000, seed: 20, ..Default::default() };
    let directions = [
        DVec3::new(0.3, 0.1, 0.95),
        DVec3::new(-0.5, 0.6, 0.4),
        DVec3::new(0.6, 0.3, 0.5),
        DVec3::new(0.95, -0.2, 0.08),
        DVec3::new(0.1, 0.4, 0.7),
    ];
    for ((name, wood), wo) in woods().iter().zip(directions) {
        let wo = wo.normalize();
        let got: Vec<ChiangResult> = model_probe::wood(gpu, wood, &sample_cases(wo, 0.0, &cfg))
            .unwrap()
            .into_iter()
            .map(|g| ChiangResult { sample_wi: to_fiber(dvec(g.sample_wi)).as_vec3(), ..g })
            .collect();
        let wo_grid = to_fiber(dvec(wo.as_vec3()));
        gpu_samples_follow_the_cpu_pdf(&format!("wood {name}"), &AsFiberGrid(wood), wo_grid, 0.0, &got, &cfg);
    }
}

/// The Sadeghi et al. 2013 cloth (each fabric of the paper's table: one to eight offsets per
/// family, velvet's at ±90°), as `surface_matches_the_cpu` checks, over random direction pairs
/// on the whole sphere (the pdf also below the surface, where the thread lobes reach).
#[test]
fn sadeghi_eval_pdf_and_samples_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(21);
    for name in SADEGHI_PRESETS {
        let cloth = Sadeghi2013::preset(name).unwrap();
        let cases: Vec<ChiangCase> = (0..6000).map(|k| surface_case(&mut rng, k)).collect();
        let got = model_probe::sadeghi(gpu, &cloth, &cases).unwrap();
        surface_matches_the_cpu(&format!("sadeghi-2013 {name}"), &cloth, &cases, &got);
    }
}

/// χ² of the GPU's cloth samples against the CPU's pdf, three fabrics at a near-normal, an
/// oblique and a grazing viewer.
#[test]
fn sadeghi_gpu_samples_follow_the_cpu_pdf() {
    let Some(gpu) = common::gpu() else { return };
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 100_000, seed: 22, ..Default::default() };
    let directions = [DVec3::new(0.3, 0.1, 0.95), DVec3::new(-0.5, 0.6, 0.4), DVec3::new(0.95, -0.2, 0.08)];
    for (name, wo) in ["linen-plain", "polyester-satin-charmeuse", "velvet"].into_iter().zip(directions) {
        let cloth = Sadeghi2013::preset(name).unwrap();
        let wo = wo.normalize();
        let got: Vec<ChiangResult> = model_probe::sadeghi(gpu, &cloth, &sample_cases(wo, 0.0, &cfg))
            .unwrap()
            .into_iter()
            .map(|g| ChiangResult { sample_wi: to_fiber(dvec(g.sample_wi)).as_vec3(), ..g })
            .collect();
        let wo_grid = to_fiber(dvec(wo.as_vec3()));
        gpu_samples_follow_the_cpu_pdf(&format!("sadeghi-2013 {name}"), &AsFiberGrid(&cloth), wo_grid, 0.0, &got, &cfg);
    }
}

/// The CPU model whose `sample` hands out the GPU's samples of the same uniforms, in order:
/// the harness's χ² then tests the GPU's sampling against the CPU's pdf.
struct GpuSamples<'a, M: ScatteringFunction> {
    cpu: &'a M,
    samples: Vec<Option<DVec3>>,
    next: AtomicUsize,
}

impl<M: ScatteringFunction> ScatteringFunction for GpuSamples<'_, M> {
    fn properties(&self) -> Properties {
        self.cpu.properties()
    }
    fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
        self.cpu.eval(wi, wo, h)
    }
    fn pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> f64 {
        self.cpu.pdf(wi, wo, h)
    }
    fn sample(&self, _wo: DVec3, _h: f64, _u: [f64; 4]) -> Option<Sample> {
        let k = self.next.fetch_add(1, Ordering::Relaxed);
        let wi = self.samples[k]?;
        Some(Sample { wi, weight: Rgb::ONE, pdf: 1.0, delta: false, lobe: 0 })
    }
}

/// χ² of the GPU's samples against the CPU's pdf, per fiber at two camera directions.
#[test]
fn chiang_gpu_samples_follow_the_cpu_pdf() {
    let Some(gpu) = common::gpu() else { return };
    let cfg = Chi2Config { bins_theta: 24, bins_phi: 48, sub: 4, samples: 200_000, seed: 9, ..Default::default() };
    for (name, fiber) in fibers() {
        for (theta_o, h) in [(0.35, 0.3), (-1.1, -0.85)] {
            let wo = direction(theta_o, FRAC_PI_2);
            let got = model_probe::chiang(gpu, &fiber, &sample_cases(wo, h, &cfg)).unwrap();
            gpu_samples_follow_the_cpu_pdf(&format!("{name} θ_o {theta_o} h {h}"), &fiber, wo, h, &got, &cfg);
        }
    }
}

/// The GPU sampler gives the CPU's values to their 24 leading bits, for random pixels, sample
/// indices (up to 2³²) and dimension pairs.
#[test]
fn sampler_matches_the_cpu_to_24_bits() {
    let Some(gpu) = common::gpu() else { return };
    let mut rng = TestRng::new(3);
    for seed in [0u64, 7, u64::MAX] {
        let cases: Vec<(u32, u32, u32, u32)> = (0..2000u32)
            .map(|k| {
                let u = rng.u4();
                let index = if k.is_multiple_of(3) { (u[2] * 64.0) as u32 } else { (u[2] * 4_294_967_295.0) as u32 };
                ((u[0] * 4096.0) as u32, (u[1] * 4096.0) as u32, index, (u[3] * 300.0) as u32)
            })
            .collect();
        let got = model_probe::sampler(gpu, seed, &cases).unwrap();
        for (&(x, y, index, pair), g) in cases.iter().zip(&got) {
            let mut s = PixelSampler::new(x, y, seed);
            s.start(u64::from(index));
            let mut v = [0.0; 2];
            for _ in 0..=pair {
                v = s.next_2d();
            }
            for k in 0..2 {
                let want = (v[k] * 16_777_216.0).floor() / 16_777_216.0;
                assert_eq!(f64::from(g[k]), want, "seed {seed} pixel ({x}, {y}) sample {index} pair {pair}");
            }
        }
    }
}
