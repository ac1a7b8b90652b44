//! A render scene as the GPU reads it: the BVHs of every fiber set and mesh flattened into one
//! node buffer (geometry's `FlatBvh`, references shifted), segment and triangle records,
//! and a table of words for spheres, materials, lights and the light picker's emitters
//! (layouts in the shaders' comments). What the GPU path tracer cannot render yet is refused
//! here, with the material or light named.

use fiberlab_geometry::bvh::FlatBvh;
use fiberlab_math::Rgb;
use fiberlab_render::light::{EnvironmentMap, Light};
use fiberlab_render::scene::{Scene, SurfaceMaterial};
use fiberlab_render::surface_material::{ModelMaterial, TexturedParameter};
use fiberlab_render::texture::Wrap;
use fiberlab_scatter::Model;
use fiberlab_scatter::chiang_2016::Chiang;
use fiberlab_scatter::deon_2011::{AzimuthalInclination, Deon, TABLE_ROWS};
use fiberlab_scatter::hair::roughness::{lobe_variances, logistic_scale};
use fiberlab_scatter::hair::tilt::lobe_tilts;
use fiberlab_scatter::hollow_fiber::HollowFiber;
use fiberlab_scatter::huang_2022::{Huang, Orientation};
use fiberlab_scatter::ideal_specular::Azimuth;
use fiberlab_scatter::irawan_2012::{Irawan2012, Variation, YarnKind};
use fiberlab_scatter::kajiya_kay_1989::KajiyaKay;
use fiberlab_scatter::lambert_1760::Lambertian;
use fiberlab_scatter::leaf::Leaf;
use fiberlab_scatter::marschner_2003::Marschner;
use fiberlab_scatter::marschner_2005::Wood;
use fiberlab_scatter::sadeghi_2013::{MAX_OFFSETS, Sadeghi2013};
use fiberlab_scatter::yan_2017::YanFur;
use fiberlab_scatter::{Field, ScatteringFunction, SurfaceModel};
use std::f64::consts::PI;

/// Why a scene cannot be rendered on the GPU.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum Unsupported {
    /// A fiber model without a GPU implementation.
    #[error(
        "fiber model `{0}` is not implemented on the GPU (supported: chiang, deon, huang-2022, kajiya-kay, marschner, yan-fur, hollow-fiber with field = near, diffuse, lambertian-cylinder, specular, goldman); render with --device cpu"
    )]
    FiberModel(String),
    /// A surface material without a GPU implementation.
    #[error(
        "surface material `{0}` is not implemented on the GPU (supported: lambert, mirror, leaf, lambertian, wood, sadeghi-2013, irawan-2012); render with --device cpu"
    )]
    SurfaceModel(String),
    /// A surface material with an option the GPU does not implement.
    #[error("surface material `{0}` with {1} is not implemented on the GPU; render with --device cpu")]
    SurfaceOption(String, &'static str),
    /// The dual-scattering integrator.
    #[error(
        "the dual-scattering integrator is not implemented on the GPU (path tracing only); render with --device cpu"
    )]
    Integrator,
    /// Too much geometry for one buffer of this adapter.
    #[error("the scene's {what} take {bytes} bytes, more than the {limit} bytes this GPU binds in one buffer")]
    TooLarge {
        /// Which buffer.
        what: &'static str,
        /// Its size.
        bytes: u64,
        /// The adapter's limit.
        limit: u64,
    },
}

/// Words per material (`MATERIAL_*` in the shaders).
const MATERIAL_WORDS: usize = 32;
const MATERIAL_LAMBERT: u32 = 0;
const MATERIAL_DIFFUSE_FIBER: u32 = 20;
const MATERIAL_LAMBERTIAN_CYLINDER: u32 = 21;
const MATERIAL_SPECULAR_FIBER: u32 = 22;
const MATERIAL_GOLDMAN: u32 = 23;
const MATERIAL_MIRROR: u32 = 1;
const MATERIAL_CHIANG: u32 = 2;
const MATERIAL_KAJIYA_KAY: u32 = 3;
const MATERIAL_MARSCHNER: u32 = 4;
const MATERIAL_DEON: u32 = 5;
const MATERIAL_YAN_FUR: u32 = 6;
const MATERIAL_LEAF: u32 = 7;
const MATERIAL_LAMBERTIAN: u32 = 8;
const MATERIAL_WOOD: u32 = 9;
const MATERIAL_SADEGHI: u32 = 10;
const MATERIAL_IRAWAN: u32 = 12;
const MATERIAL_HOLLOW_FIBER: u32 = 13;
const MATERIAL_HUANG: u32 = 14;
/// Primitive kinds of the objects (as the shaders' `KIND_*`).
const KIND_SEGMENT: u32 = 1;
const KIND_TRIANGLE: u32 = 3;

/// The scene's GPU buffers' contents.
#[derive(Clone, Debug, Default)]
pub struct SceneBuffers {
    /// Axis-aligned then oriented nodes.
    pub nodes: Vec<u32>,
    /// Where the oriented nodes start, in words.
    pub oriented_base: u32,
    /// Leaf primitive lists.
    pub prims: Vec<u32>,
    /// Segments, 16 words each.
    pub segments: Vec<u32>,
    /// Triangles, 12 words each.
    pub triangles: Vec<u32>,
    /// Spheres, objects, materials, lights, emitters.
    pub words: Vec<u32>,
    /// Offsets (in words) and counts of the tables in `words`.
    pub sphere_base: u32,
    /// Spheres.
    pub sphere_count: u32,
    /// Objects (one per fiber set and mesh: kind, root).
    pub object_base: u32,
    /// Objects.
    pub object_count: u32,
    /// Materials.
    pub material_base: u32,
    /// Lights at infinity.
    pub light_base: u32,
    /// Lights at infinity.
    pub light_count: u32,
    /// Next-event emitters in the picker's order.
    pub emitter_base: u32,
    /// Emitters.
    pub emitter_count: u32,
}

fn f(x: f64) -> u32 {
    (x as f32).to_bits()
}

fn rgb(c: Rgb) -> [u32; 3] {
    [f(c[0]), f(c[1]), f(c[2])]
}

/// The words of a Chiang material (the order of `load_chiang` in the shaders).
#[must_use]
pub fn chiang_words(c: &Chiang) -> [u32; MATERIAL_WORDS] {
    let p = c.params();
    near_field_words(MATERIAL_CHIANG, p.eta, c.sigma_a(), c.logistic_scale(), p.beta_m, p.alpha)
}

/// The words of a near-field fiber built from Chiang's lobes (the order of `load_chiang`): index
/// η, absorption σ_a, logistic scale s, roughness β_m and tilt α.
fn near_field_words(kind: u32, eta: f64, sigma_a: Rgb, s: f64, beta_m: f64, alpha: f64) -> [u32; MATERIAL_WORDS] {
    let cdf = |x: f64| fiberlab_math::special::logistic_cdf(x, s);
    let v = lobe_variances(beta_m);
    let tilt = lobe_tilts(alpha);
    let mut w = [0u32; MATERIAL_WORDS];
    w[0] = kind;
    w[1] = f(eta);
    w[2..5].copy_from_slice(&rgb(sigma_a));
    w[5] = f(s);
    w[6] = f(1.0 / (cdf(PI) - cdf(-PI)));
    w[7] = f(cdf(-PI));
    w[8] = f(cdf(PI));
    for k in 0..4 {
        let expm1 = (-2.0 / v[k]).exp_m1();
        w[9 + k] = f(v[k]);
        w[13 + k] = f(1.0 / (v[k] * -expm1));
        w[17 + k] = f(expm1);
        w[21 + k] = f(tilt[k].0);
        w[25 + k] = f(tilt[k].1);
    }
    w
}

/// The words of a Kajiya–Kay material (the order of `load_kajiya_kay` in the shaders) whose
/// lobe table starts at word `table_at`, and that table: the CPU's CDF normalised to 1 at the
/// cell boundaries, then each cell's density (normalised mass per radian), so that the
/// density keeps f32's relative precision in the lobe's tails.
#[must_use]
pub fn kajiya_kay_words(k: &KajiyaKay, table_at: u32) -> ([u32; MATERIAL_WORDS], Vec<u32>) {
    let lobe = k.lobe_table();
    let cdf = lobe.cdf_values();
    let (x0, dx) = lobe.grid();
    let total = cdf[cdf.len() - 1];
    let cells = cdf.len() - 1;
    let mut w = [0u32; MATERIAL_WORDS];
    w[0] = MATERIAL_KAJIYA_KAY;
    w[1..4].copy_from_slice(&rgb(k.k_d()));
    w[4..7].copy_from_slice(&rgb(k.k_s()));
    w[7] = f(k.p());
    w[8] = f(PI * PI * k.k_d().luminance());
    w[9] = f(2.0 * PI * k.k_s().luminance() * total);
    w[10] = table_at;
    w[11] = cells as u32;
    w[12] = f(x0);
    w[13] = f(dx);
    let mut table: Vec<u32> = cdf.iter().map(|c| f(c / total)).collect();
    table.extend(cdf.windows(2).map(|c| f((c[1] - c[0]) / total / dx)));
    (w, table)
}

/// The words of a reference fiber (`diffuse`, `lambertian-cylinder`, `specular`, `goldman`; the
/// order of `load_reference_fiber` in the shaders) whose table — Goldman's Kajiya–Kay lobe —
/// starts at word `table_at`, and that table; `None` for any other model.
#[must_use]
pub fn reference_fiber_words(model: &Model, table_at: u32) -> Option<([u32; MATERIAL_WORDS], Vec<u32>)> {
    let mut w = [0u32; MATERIAL_WORDS];
    let mut table = Vec::new();
    match model {
        Model::Diffuse(d) => {
            w[0] = MATERIAL_DIFFUSE_FIBER;
            w[1..4].copy_from_slice(&rgb(d.albedo()));
        }
        Model::LambertianCylinder(c) => {
            w[0] = MATERIAL_LAMBERTIAN_CYLINDER;
            w[1..4].copy_from_slice(&rgb(c.albedo()));
        }
        Model::Specular(s) => {
            w[0] = MATERIAL_SPECULAR_FIBER;
            w[9] = f(s.fresnel_eta().unwrap_or(0.0));
            w[10] = u32::from(s.azimuth() == Azimuth::Mirror);
        }
        Model::Goldman(g) => {
            let (rho_r, rho_t) = g.directional_weights();
            let (lr, lt) = (rho_r.luminance(), rho_t.luminance());
            let (kk, kk_table) = kajiya_kay_words(g.kajiya_kay(), table_at);
            w[0] = MATERIAL_GOLDMAN;
            w[1..4].copy_from_slice(&rgb(rho_r));
            w[4..7].copy_from_slice(&rgb(rho_t));
            w[7] = f(0.5 * (lr + lt));
            w[8] = f(0.5 * (lr - lt));
            // The table's first word where `SceneBuffers::new` makes it absolute; the Kajiya–Kay
            // words after word 16 (their own table word is not read).
            w[10] = table_at;
            w[16..].copy_from_slice(&kk[..MATERIAL_WORDS - 16]);
            table = kk_table;
        }
        _ => return None,
    }
    Some((w, table))
}

/// The words of a Marschner material (the order of `load_marschner` in the shaders) whose lobe
/// table starts at word `table_at`, and that table: the CPU sampler's unnormalized lobe weights,
/// three per row.
#[must_use]
pub fn marschner_words(m: &Marschner, table_at: u32) -> ([u32; MATERIAL_WORDS], Vec<u32>) {
    use fiberlab_scatter::hair::attenuation::PathLength;
    use fiberlab_scatter::hair::normal_plane::RootMode;
    let p = m.params();
    let lobes = m.gaussian_lobes();
    let (e1, e2) = m.eccentric_indices();
    let mut flags = 0;
    if p.roots == RootMode::Cubic {
        flags |= 1;
    }
    if p.glints {
        flags |= 2;
    }
    if p.absorption == PathLength::Paper {
        flags |= 4;
    }
    for (k, &on) in p.lobes.iter().enumerate() {
        if on {
            flags |= 8 << k;
        }
    }
    let mut w = [0u32; MATERIAL_WORDS];
    w[0] = MATERIAL_MARSCHNER;
    w[1] = f(p.eta);
    w[2..5].copy_from_slice(&rgb(p.sigma_a));
    w[5] = f(lobes.k_m);
    w[6] = f(p.k_g);
    w[7] = f(p.w_c);
    w[8] = f(p.delta_eta);
    w[9] = f(p.delta_h_m);
    w[10] = table_at;
    w[11] = flags;
    w[12] = f(p.eccentricity);
    w[13] = f(e1);
    w[14] = f(e2);
    for k in 0..3 {
        w[15 + k] = f(lobes.alpha[k]);
        w[18 + k] = f(lobes.beta[k]);
    }
    let table = m.sampling_lobe_table().iter().flatten().map(|&x| f(x)).collect();
    (w, table)
}

/// The words of a d'Eon material (the order of `load_deon` in the shaders) whose table starts at
/// word `table_at`, and that table: per lobe its longitudinal constants and tilt, then the CPU's
/// azimuthal table (values, luminances, CDFs, residual masses) as `eval` and `sample` read it.
#[must_use]
pub fn deon_words(d: &Deon, table_at: u32) -> ([u32; MATERIAL_WORDS], Vec<u32>) {
    let view = d.azimuthal_table();
    let p_max = d.p_max();
    let n = view.phi_nodes;
    let mut table = Vec::with_capacity(6 * (p_max + 1) + 5 * view.lum.len() + view.cdf.len() + 3 * TABLE_ROWS);
    for p in 0..=p_max {
        let (m, (sin_tau, cos_tau)) = d.lobe(p);
        let v = m.v();
        let expm1 = (-2.0 / v).exp_m1();
        table.extend([f(v), f(1.0 / (v * -expm1)), f(expm1), f(sin_tau), f(cos_tau), 0]);
    }
    let values = table.len();
    table.extend(view.values.iter().flat_map(|&c| rgb(c)));
    let lum = table.len();
    table.extend(view.lum.iter().map(|&x| f(x)));
    let cdf = table.len();
    table.extend(view.cdf.iter().map(|&x| f(x)));
    let residual = table.len();
    table.extend(view.residual.iter().flat_map(|&c| rgb(c)));
    let mut w = [0u32; MATERIAL_WORDS];
    w[0] = MATERIAL_DEON;
    w[1] = u32::from(d.azimuthal_inclination() == AzimuthalInclination::Difference);
    w[2] = p_max as u32;
    w[3] = n as u32;
    w[4] = f(std::f64::consts::TAU / n as f64);
    w[5] = values as u32;
    w[6] = lum as u32;
    w[7] = cdf as u32;
    w[8] = residual as u32;
    w[10] = table_at;
    (w, table)
}

/// The words of a Yan fur material (the order of `load_yan_fur` in the shaders) whose table
/// starts at word `table_at`, and that table: the starts of the medulla's arrays, the far
/// field's Gauss–Legendre nodes and weights, then the medulla tables' values and cumulative
/// masses (`azimuth`, `azimuth_mean`, `profiles`, `profiles_mean`) as scatter's `eval` and
/// `sample` read them.
#[must_use]
pub fn yan_fur_words(y: &YanFur, table_at: u32) -> ([u32; MATERIAL_WORDS], Vec<u32>) {
    use fiberlab_scatter::hair::tilt::marschner_ratio_tilts;
    let p = y.params();
    let nodes = y.far_nodes();
    let mut table = vec![0u32; 8];
    table.extend(nodes.iter().flat_map(|&(x, w)| [f(x), f(w)]));
    let mut flags = 0;
    for (k, &on) in p.lobes.iter().enumerate() {
        if on {
            flags |= 1 << k;
        }
    }
    if y.properties().field == Field::Far {
        flags |= 32;
    }
    let mut w = [0u32; MATERIAL_WORDS];
    if let Some(tables) = y.medulla_tables() {
        flags |= 64;
        let view = tables.view();
        let slices = [view.azimuth, view.azimuth_mean, view.profiles, view.profiles_mean];
        for (k, s) in slices.iter().enumerate() {
            table[2 * k] = table.len() as u32;
            table.extend(s.values.iter().map(|&x| f(x)));
            table[2 * k + 1] = table.len() as u32;
            table.extend(s.cumulative.iter().map(|&x| f(x)));
        }
        let r = tables.resolution();
        w[23] = f(tables.params().sigma_s());
        w[24] = f(r.max_sin_theta_t);
        w[25..30].copy_from_slice(&[
            r.inclinations as u32,
            r.offsets as u32,
            r.azimuths as u32,
            r.exit_inclinations as u32,
            r.profile_azimuths as u32,
        ]);
    }
    w[0] = MATERIAL_YAN_FUR;
    w[1] = f(p.eta);
    w[2..5].copy_from_slice(&rgb(y.sigma_c_a()));
    w[5] = f(p.kappa);
    w[6] = f(p.sigma_m_s + p.sigma_m_a);
    w[7] = f(p.layers);
    w[8] = flags;
    w[9] = nodes.len() as u32;
    w[10] = table_at;
    let (bm, bn) = (p.beta_m, p.beta_n);
    let beta = [bm, 0.5 * bm, 1.5 * bm];
    let beta_n = [bn, bn * 2f64.sqrt(), bn * 3f64.sqrt()];
    for (k, (sin_tau, cos_tau)) in marschner_ratio_tilts(p.alpha).into_iter().enumerate() {
        w[11 + k] = f(beta[k]);
        w[14 + k] = f(beta_n[k]);
        w[17 + 2 * k] = f(sin_tau);
        w[18 + 2 * k] = f(cos_tau);
    }
    (w, table)
}

/// The words of a near-field hollow fiber (the order of `hollow_fiber.wgsl`): Chiang's constants
/// of its wall, then κ, η_l and the enabled lobes.
#[must_use]
pub fn hollow_fiber_words(h: &HollowFiber) -> [u32; MATERIAL_WORDS] {
    let p = h.params();
    let mut w =
        near_field_words(MATERIAL_HOLLOW_FIBER, p.eta, h.sigma_a(), logistic_scale(p.beta_n), p.beta_m, p.alpha);
    w[29] = f(p.kappa);
    w[30] = f(p.lumen_eta);
    w[31] = p.lobes.iter().enumerate().map(|(k, &on)| u32::from(on) << k).sum();
    w
}

/// The words of a Huang 2022 material (the order of `load_huang` in the shaders) whose table
/// starts at word `table_at`, and that table: the h-shift rates split for f32 (`r₁` a multiple
/// of 4 below 8192, so 11 significant bits; `r₂ = rate − r₁`; `fract(2·rate)`), then the inside
/// interface's `E_R` and `E_T` tables.
#[must_use]
pub fn huang_words(hg: &Huang, table_at: u32) -> ([u32; MATERIAL_WORDS], Vec<u32>) {
    use fiberlab_scatter::hair::rough_interface::{CHORD_OFFSETS, NODES};
    use fiberlab_scatter::huang_2022::{ENTRY_SIDE, INTERNAL_SIDE, R2, RESIDUAL_FLOOR, SHIFT_RATES, UNIFORM_SHARE};
    const { assert!(INTERNAL_SIDE == 1, "huang_2022.wgsl draws one internal microfacet per entry path") };
    const { assert!(NODES == 33, "huang_2022.wgsl's HUANG_NODES") };
    let p = hg.params();
    let r1 = SHIFT_RATES.map(|r| (r / 4.0).floor() * 4.0);
    let mut table: Vec<u32> = r1.iter().map(|&x| f(x)).collect();
    table.extend(SHIFT_RATES.iter().zip(&r1).map(|(r, a)| f(r - a)));
    table.extend(SHIFT_RATES.iter().map(|r| f((2.0 * r).fract())));
    let (e_r, e_t) = hg.inside_albedo().tables();
    table.extend(e_r.iter().chain(e_t).map(|&x| f(x)));
    let mut w = [0u32; MATERIAL_WORDS];
    w[0] = MATERIAL_HUANG;
    w[1] = f(p.eta);
    w[2..5].copy_from_slice(&rgb(hg.sigma_a()));
    w[5] = f(p.roughness);
    w[6] = f(p.aspect);
    let psi = match p.orientation {
        Orientation::Fixed(psi) => psi,
        Orientation::Average => {
            w[9] = 1;
            0.0
        }
    };
    w[7] = f(psi.cos());
    w[8] = f(psi.sin());
    w[10] = table_at;
    w[11] = f(p.alpha.sin());
    w[12] = f(p.alpha.cos());
    w[13] = f(hg.mean_chord());
    w[14] = f(hg.mean_half_width());
    w[15] = f(p.reflection);
    w[16] = f(p.transmission);
    w[17] = f(p.secondary_reflection);
    let v = 4.0 * p.roughness * p.roughness;
    let expm1 = (-2.0 / v).exp_m1();
    w[18] = f(v);
    w[19] = f(1.0 / (v * -expm1));
    w[20] = f(expm1);
    w[21] = ENTRY_SIDE as u32;
    w[22] = f(R2[0]);
    w[23] = f(R2[1]);
    w[24] = f(RESIDUAL_FLOOR);
    w[25] = f(UNIFORM_SHARE);
    w[26] = CHORD_OFFSETS as u32;
    (w, table)
}

/// A fiber material's words and its table (empty for most), whose first word is at
/// `table_at`.
fn fiber_material(model: &Model, table_at: u32) -> Result<([u32; MATERIAL_WORDS], Vec<u32>), Unsupported> {
    match model {
        Model::Chiang(c) => Ok((chiang_words(c), Vec::new())),
        Model::KajiyaKay(k) => Ok(kajiya_kay_words(k, table_at)),
        Model::Marschner(m) => Ok(marschner_words(m, table_at)),
        Model::Deon(d) => Ok(deon_words(d, table_at)),
        Model::YanFur(y) => Ok(yan_fur_words(y, table_at)),
        Model::Diffuse(_) | Model::LambertianCylinder(_) | Model::Specular(_) | Model::Goldman(_) => {
            Ok(reference_fiber_words(model, table_at).expect("a reference fiber"))
        }
        Model::HollowFiber(h) if h.params().field == Field::Near => Ok((hollow_fiber_words(h), Vec::new())),
        Model::Huang(hg) => Ok(huang_words(hg, table_at)),
        other => Err(Unsupported::FiberModel(other.name().to_string())),
    }
}

/// The data of an environment map as `lights.wgsl` reads them, from word 0: each cell's
/// radiance (3 words, rows from the top), each cell's probability, the row CDF normalised to 1
/// (height + 1), then per row its column CDF normalised to 1 (width + 1).
#[must_use]
pub fn environment_map_words(map: &EnvironmentMap) -> Vec<u32> {
    let (w, h) = map.size();
    let mut words = Vec::with_capacity(4 * w * h + (h + 1) + h * (w + 1));
    for y in 0..h {
        for x in 0..w {
            words.extend(rgb(map.cell_radiance(x, y)));
        }
    }
    for y in 0..h {
        words.extend((0..w).map(|x| f(map.cell_probability(x, y))));
    }
    let normalised = |c: &[f64]| {
        let last = c[c.len() - 1];
        c.iter().map(|v| f(if last > 0.0 { v / last } else { 0.0 })).collect::<Vec<_>>()
    };
    words.extend(normalised(map.row_cdf()));
    for y in 0..h {
        words.extend(normalised(map.column_cdf(y)));
    }
    words
}

/// The words of a leaf material (the order of `load_leaf` in the shaders) whose table starts at
/// word `table_at`, and that table: the cuticle's albedo table (33 values).
#[must_use]
pub fn leaf_words(leaf: &Leaf, table_at: u32) -> ([u32; MATERIAL_WORDS], Vec<u32>) {
    let (r_b, t_b) = leaf.body();
    let p = leaf.params();
    let mut w = [0u32; MATERIAL_WORDS];
    w[0] = MATERIAL_LEAF;
    w[1..4].copy_from_slice(&rgb(r_b));
    w[4..7].copy_from_slice(&rgb(t_b));
    w[7] = f(p.roughness);
    w[8] = f(p.eta);
    w[9] = f(leaf.body_normalization());
    w[10] = table_at;
    (w, leaf.cuticle_albedo_table().iter().map(|&x| f(x)).collect())
}

/// The words of a `lambertian` material (the order of `lambertian.wgsl`) whose table starts at
/// word `table_at`, and that table: the `k_d` texture's texels of its material `m` (rgb, rows
/// from the top), if any.
#[must_use]
pub fn lambertian_words(l: &Lambertian, m: Option<&ModelMaterial>, table_at: u32) -> ([u32; MATERIAL_WORDS], Vec<u32>) {
    let mut w = [0u32; MATERIAL_WORDS];
    w[0] = MATERIAL_LAMBERTIAN;
    w[1..4].copy_from_slice(&rgb(l.k_d()));
    w[10] = table_at;
    let mut table = Vec::new();
    // `k_d` is Lambertian's only texturable parameter (a colour: the texels as they are).
    if let Some(t) = m.and_then(|m| m.textures().iter().find(|t| t.key() == "k_d")) {
        let tex = t.texture();
        for y in 0..tex.height() {
            for x in 0..tex.width() {
                table.extend(tex.texel(x, y).map(f));
            }
        }
        w[13] = 1;
        w[14] = tex.width() as u32;
        w[15] = tex.height() as u32;
        w[16] = u32::from(tex.wrap() == Wrap::Clamp);
        w[17] = f(tex.scale()[0]);
        w[18] = f(tex.scale()[1]);
    }
    (w, table)
}

/// The words of an `irawan-2012` material (the order of `irawan_2012.wgsl`) at the uv scale
/// `uv_scale` of its position, whose table starts at word `table_at`, and that table: the
/// tile's 0-based yarn ids, then per yarn its record (the spine radius, the area share and the
/// colours with their scales computed here in f64).
#[must_use]
pub fn irawan_words(m: &Irawan2012, uv_scale: [f64; 2], table_at: u32) -> ([u32; MATERIAL_WORDS], Vec<u32>) {
    let p = m.pattern();
    let (alpha, beta) = m.alpha_beta();
    let (k_d_scale, k_s_scale) = m.colour_scales();
    let mut w = [0u32; MATERIAL_WORDS];
    w[0] = MATERIAL_IRAWAN;
    w[1] = f(alpha);
    w[2] = f(beta);
    w[3] = f(m.normalisation());
    w[4] = f(1.0 / (2.0 * PI * fiberlab_math::special::i0e(beta)));
    w[5] = p.width as u32;
    w[6] = p.height as u32;
    w[7] = p.cells.len() as u32;
    w[8] = f(p.ss);
    w[9] = f(p.h_width);
    w[10] = table_at;
    w[13] = f(uv_scale[0]);
    w[14] = f(uv_scale[1]);
    w[15] = f(m.position()[0]);
    w[16] = f(m.position()[1]);
    let mut table: Vec<u32> = p.cells.iter().map(|&id| id as u32 - 1).collect();
    for y in &p.yarns {
        let area = match y.kind {
            YarnKind::Warp => p.warp_area,
            YarnKind::Weft => p.weft_area,
        };
        table.extend([u32::from(y.kind == YarnKind::Weft), f(y.psi.tan()), f(y.psi.sin().abs()), f(y.u_max)]);
        table.extend([f(y.width), f(y.length), f(y.center[0]), f(y.center[1])]);
        table.extend([f(0.5 * y.length / y.u_max.sin()), f((p.warp_area + p.weft_area) / area)]);
        table.extend(rgb(y.k_d * k_d_scale));
        table.extend(rgb(y.k_s * k_s_scale));
    }
    (w, table)
}

/// A texture of a surface model's parameter as `textures.wgsl`'s `texture_at` reads it: width,
/// height, wrapping (0 repeat, 1 clamp), uv scale, then the texels as the parameter's values
/// (`TexturedParameter::value`: a scalar's red channel on all three, degrees as radians), rgb,
/// rows from the top.
#[must_use]
pub fn texture_words(t: &TexturedParameter) -> Vec<u32> {
    let tex = t.texture();
    let (w, h) = (tex.width(), tex.height());
    let mut words = Vec::with_capacity(5 + 3 * w * h);
    words.extend([w as u32, h as u32, u32::from(tex.wrap() == Wrap::Clamp), f(tex.scale()[0]), f(tex.scale()[1])]);
    for y in 0..h {
        for x in 0..w {
            words.extend(rgb(t.value(tex.texel(x, y))));
        }
    }
    words
}

/// The words of a `wood` material (the order of `wood.wgsl`) whose table starts at word
/// `table_at`, and that table: the textures of its material `m` (`texture_words`), if any.
#[must_use]
pub fn wood_words(wood: &Wood, m: Option<&ModelMaterial>, table_at: u32) -> ([u32; MATERIAL_WORDS], Vec<u32>) {
    let p = wood.params();
    let mut w = [0u32; MATERIAL_WORDS];
    w[0] = MATERIAL_WOOD;
    w[1..4].copy_from_slice(&rgb(p.k_d));
    w[4..7].copy_from_slice(&rgb(p.k_f));
    w[7] = f(p.eta);
    w[8] = f(p.roughness);
    w[9] = f(p.beta);
    w[10] = table_at;
    w[13] = f(p.fiber_angle);
    w[14] = f(p.fiber_dip);
    let mut table = Vec::new();
    for t in m.map_or(&[][..], ModelMaterial::textures) {
        // The texturable keys in the order of words 20–24.
        if let Some(k) = ["k_d", "k_f", "beta", "fiber_angle", "fiber_dip"].iter().position(|&key| key == t.key()) {
            w[20 + k] = 1 + table.len() as u32;
            table.extend(texture_words(t));
        }
    }
    (w, table)
}

/// The words of a `sadeghi-2013` material (the order of `sadeghi.wgsl`) whose table starts at
/// word `table_at`, and that table: its two thread families, 25 words each (the thread's
/// parameters, the coverage, the number of offsets and each offset's sine and cosine), then
/// the textures of its material `m` (`texture_words`), if any.
#[must_use]
pub fn sadeghi_words(
    cloth: &Sadeghi2013,
    m: Option<&ModelMaterial>,
    table_at: u32,
) -> ([u32; MATERIAL_WORDS], Vec<u32>) {
    let mut w = [0u32; MATERIAL_WORDS];
    w[0] = MATERIAL_SADEGHI;
    w[10] = table_at;
    let mut table = Vec::with_capacity(2 * (9 + 2 * MAX_OFFSETS));
    for fam in cloth.families() {
        let t = fam.thread;
        table.extend([f(t.eta), f(t.k_d)]);
        table.extend(rgb(t.albedo));
        table.extend([f(t.gamma_s), f(t.gamma_v), f(fam.coverage), fam.count as u32]);
        for k in 0..MAX_OFFSETS {
            let (s, c) = fam.offsets[k].sin_cos();
            table.extend([f(s), f(c)]);
        }
    }
    // The texturable keys in the order of words 20–29.
    let keys = ["eta", "k_d", "albedo", "gamma_s", "gamma_v"];
    for t in m.map_or(&[][..], ModelMaterial::textures) {
        if let Some((name, family)) = t.key().rsplit_once('_')
            && let Some(k) = keys.iter().position(|&key| key == name)
            && let Some(j) = ["1", "2"].iter().position(|&x| x == family)
        {
            w[20 + 5 * j + k] = 1 + table.len() as u32;
            table.extend(texture_words(t));
        }
    }
    (w, table)
}

/// The shading records of a mesh's triangles, 18 words each: the tangent along u, the three
/// corners' shading normals (zero without them), then their texture coordinates (zero without
/// them), as
/// `geometry::shapes::TriangleMesh::intersect_point` reads them.
fn triangle_shading_words(mesh: &fiberlab_geometry::TriangleMesh) -> Vec<u32> {
    let (normals, uvs) = (mesh.normals(), mesh.uvs());
    let mut words = Vec::with_capacity(18 * mesh.len());
    for (i, t) in mesh.tangents().iter().enumerate() {
        words.extend([f(t.x), f(t.y), f(t.z)]);
        let n = normals.get(i).copied().unwrap_or([fiberlab_math::DVec3::ZERO; 3]);
        words.extend(n.iter().flat_map(|c| [f(c.x), f(c.y), f(c.z)]));
        let uv = uvs.get(i).copied().unwrap_or([[0.0; 2]; 3]);
        words.extend(uv.iter().flat_map(|c| [f(c[0]), f(c[1])]));
    }
    words
}

/// A surface material's words and its table (empty for Lambert and mirror), whose first word
/// is at `table_at`. A mesh's surface models get its triangles' shading records after their
/// own table (word 11: where they start, relative to the table; word 12, set by the caller: the
/// mesh's first triangle).
fn surface_material(
    m: &SurfaceMaterial,
    mesh: Option<&fiberlab_geometry::TriangleMesh>,
    table_at: u32,
) -> Result<([u32; MATERIAL_WORDS], Vec<u32>), Unsupported> {
    let mut w = [0u32; MATERIAL_WORDS];
    match m {
        SurfaceMaterial::Lambert(albedo) => {
            w[0] = MATERIAL_LAMBERT;
            w[1..4].copy_from_slice(&rgb(*albedo));
        }
        SurfaceMaterial::Mirror(r) => {
            w[0] = MATERIAL_MIRROR;
            w[1..4].copy_from_slice(&rgb(*r));
        }
        SurfaceMaterial::Model(m) => {
            let (mut w, mut table) = match m.model() {
                SurfaceModel::Leaf(leaf) if m.textures().is_empty() && m.uv_scale().is_none() => {
                    leaf_words(leaf, table_at)
                }
                SurfaceModel::Lambertian(l) if m.uv_scale().is_none() => lambertian_words(l, Some(m), table_at),
                SurfaceModel::Irawan(i) => {
                    let refuse = |what| Err(Unsupported::SurfaceOption(m.model_name().to_string(), what));
                    if !m.textures().is_empty() {
                        return refuse("textured parameters");
                    }
                    if i.options() != Variation::default() {
                        return refuse("spine = \"conic\", fineness or umax_noise (the circular spine only)");
                    }
                    irawan_words(i, m.uv_scale().unwrap_or([1.0, 1.0]), table_at)
                }
                SurfaceModel::Wood(wood) => wood_words(wood, Some(m), table_at),
                SurfaceModel::Sadeghi(cloth) => sadeghi_words(cloth, Some(m), table_at),
                SurfaceModel::Leaf(_) | SurfaceModel::Lambertian(_) => {
                    let what = "textured parameters other than lambertian's k_d, or uv_scale";
                    return Err(Unsupported::SurfaceOption(m.model_name().to_string(), what));
                }
                _ => return Err(Unsupported::SurfaceModel(m.model_name().to_string())),
            };
            // Spheres always have texture coordinates; a mesh may not.
            w[19] = u32::from(mesh.is_none_or(fiberlab_geometry::TriangleMesh::has_uvs));
            if let Some(mesh) = mesh {
                w[11] = table.len() as u32;
                table.extend(triangle_shading_words(mesh));
            }
            return Ok((w, table));
        }
    }
    Ok((w, Vec::new()))
}

/// Appends a tree: nodes (references shifted), its primitives offset by `prim_offset`; returns
/// the shifted root.
fn append_tree(
    flat: FlatBvh,
    prim_offset: u32,
    aabb: &mut Vec<u32>,
    oriented: &mut Vec<u32>,
    prims: &mut Vec<u32>,
) -> u32 {
    let shift_aabb = (aabb.len() / FlatBvh::AABB_WORDS) as u32;
    let shift_oriented = (oriented.len() / FlatBvh::ORIENTED_WORDS) as u32;
    let shift_prims = prims.len() as u32;
    let shift = |r: u32| FlatBvh::shift(r, shift_aabb, shift_oriented, shift_prims);
    for (k, node) in flat.aabb.chunks_exact(FlatBvh::AABB_WORDS).enumerate() {
        let _ = k;
        let start = aabb.len();
        aabb.extend_from_slice(node);
        for r in &mut aabb[start + 20..start + 28] {
            *r = shift(*r);
        }
    }
    for node in flat.oriented.chunks_exact(FlatBvh::ORIENTED_WORDS) {
        let start = oriented.len();
        oriented.extend_from_slice(node);
        for r in &mut oriented[start + 70..start + 78] {
            *r = shift(*r);
        }
    }
    prims.extend(flat.prims.iter().map(|p| p + prim_offset));
    shift(flat.root)
}

impl SceneBuffers {
    /// The scene's buffers; an error names what the GPU cannot render.
    pub fn new(scene: &Scene) -> Result<Self, Unsupported> {
        let mut b = SceneBuffers::default();
        let (mut aabb, mut oriented) = (Vec::new(), Vec::new());
        let mut materials: Vec<[u32; MATERIAL_WORDS]> = Vec::new();
        let mut objects: Vec<[u32; 2]> = Vec::new();
        // Materials' tables (after every other word; their offsets are made absolute below).
        let (mut tables, mut tabled) = (Vec::new(), Vec::new());
        for fibers in scene.fibers() {
            let material = materials.len() as u32;
            let (words, table) = fiber_material(scene.fiber_model(fibers.material()), tables.len() as u32)?;
            if !table.is_empty() {
                tabled.push(materials.len());
                tables.extend(table);
            }
            materials.push(words);
            let curves = fibers.curves();
            let base = (b.segments.len() / 16) as u32;
            let mut words = curves.segment_words();
            for seg in words.chunks_exact_mut(16) {
                seg[15] = material;
            }
            b.segments.extend_from_slice(&words);
            let root = append_tree(curves.bvh().flatten(), base, &mut aabb, &mut oriented, &mut b.prims);
            objects.push([KIND_SEGMENT, root]);
        }
        for mesh in scene.meshes() {
            let material = materials.len() as u32;
            let base = (b.triangles.len() / 12) as u32;
            let (mut words, table) =
                surface_material(scene.surface_material(mesh.material()), Some(mesh.mesh()), tables.len() as u32)?;
            if !table.is_empty() {
                // Its triangles' shading records are found from their index less the first's.
                words[12] = base;
                tabled.push(materials.len());
                tables.extend(table);
            }
            materials.push(words);
            for tri in mesh.mesh().triangles() {
                for (k, corner) in tri.iter().enumerate() {
                    let w = if k == 0 { material } else { 0 };
                    b.triangles.extend([f(corner.x), f(corner.y), f(corner.z), w]);
                }
            }
            let root = append_tree(mesh.mesh().bvh().flatten(), base, &mut aabb, &mut oriented, &mut b.prims);
            objects.push([KIND_TRIANGLE, root]);
        }
        let picker = scene.light_picker();
        let mut spheres = Vec::new();
        let mut emitters: Vec<[u32; 2]> = Vec::new();
        for i in 0..scene.lights().len() {
            emitters.push([0, i as u32]);
        }
        for (i, s) in scene.spheres().iter().enumerate() {
            let material = materials.len() as u32;
            let (words, table) = surface_material(scene.surface_material(s.material()), None, tables.len() as u32)?;
            if !table.is_empty() {
                tabled.push(materials.len());
                tables.extend(table);
            }
            materials.push(words);
            let c = s.center();
            let light = s.light();
            let emission = light.map_or(Rgb::ZERO, |l| l.radiance);
            let e = rgb(emission);
            spheres.extend([f(c.x), f(c.y), f(c.z), f(s.radius()), e[0], e[1], e[2], material]);
            spheres.extend([u32::from(light.is_some()), f(picker.sphere_probability(i)), 0, 0]);
            if light.is_some() {
                emitters.push([1, i as u32]);
            }
        }
        let mut lights = Vec::new();
        // Words of `lights` that hold a map's offset into `tables`.
        let mut mapped = Vec::new();
        for (i, light) in scene.lights().iter().enumerate() {
            let p = f(picker.light_probability(i));
            let words: [u32; 12] = match light {
                Light::Constant { radiance } => {
                    let r = rgb(*radiance);
                    [0, p, 0, 0, r[0], r[1], r[2], 0, 0, 0, 0, 0]
                }
                Light::Sun { direction, cos_max, radiance } => {
                    let r = rgb(*radiance);
                    let d = direction.normalize();
                    [1, p, 0, 0, r[0], r[1], r[2], f(*cos_max), f(d.x), f(d.y), f(d.z), f(1.0 - cos_max)]
                }
                Light::Distant { direction, irradiance } => {
                    let r = rgb(*irradiance);
                    let d = direction.normalize();
                    [2, p, 0, 0, r[0], r[1], r[2], 0, f(d.x), f(d.y), f(d.z), 0]
                }
                Light::Map(map) => {
                    let (w, h) = map.size();
                    mapped.push(lights.len() + 9);
                    let at = tables.len() as u32;
                    tables.extend(environment_map_words(map));
                    [3, p, 0, 0, 0, 0, 0, w as u32, h as u32, at, 0, 0]
                }
            };
            lights.extend(words);
        }
        b.oriented_base = aabb.len() as u32;
        b.nodes = aabb;
        b.nodes.extend_from_slice(&oriented);
        let mut words = Vec::new();
        b.sphere_base = words.len() as u32;
        b.sphere_count = scene.spheres().len() as u32;
        words.extend_from_slice(&spheres);
        b.object_base = words.len() as u32;
        b.object_count = objects.len() as u32;
        words.extend(objects.iter().flatten());
        b.material_base = words.len() as u32;
        words.extend(materials.iter().flatten());
        b.light_base = words.len() as u32;
        b.light_count = scene.lights().len() as u32;
        words.extend_from_slice(&lights);
        b.emitter_base = words.len() as u32;
        b.emitter_count = emitters.len() as u32;
        words.extend(emitters.iter().flatten());
        let table_base = words.len() as u32;
        for m in tabled {
            words[b.material_base as usize + MATERIAL_WORDS * m + 10] += table_base;
        }
        for at in mapped {
            words[b.light_base as usize + at] += table_base;
        }
        words.extend(tables);
        b.words = words;
        Ok(b)
    }

    /// Bytes of all the scene's buffers.
    #[must_use]
    pub fn bytes(&self) -> u64 {
        4 * (self.nodes.len() + self.prims.len() + self.segments.len() + self.triangles.len() + self.words.len()) as u64
    }
}
