//! The TOML scene format, its errors (file, line, column, the bad key or value) and the
//! built-in default scene ([`DEFAULT_SCENE`], a documented example of every section).
//!
//! ```toml
//! [camera]            # eye, target, up, fov (vertical, degrees), width, height
//! [render]            # spp, max_depth, seed, exposure (stops, for the PNG),
//!                     # integrator = "path" | "dual-scattering", fiber_count = "exact" | "grid"
//! [materials.NAME]    # model = "<scatter model>", params = { key = value }   (fibers)
//!                     # or model = "<surface model>", params = { key = value | texture }
//!                     #   (texture: "x.png" | "x.exr" | { file, wrap, scale, remap,
//!                     #   encoding, size }: crate::surface_material)
//!                     # or lambert = [r, g, b] | mirror = [r, g, b]            (surfaces)
//!                     # uv_scale = [su, sv]: pattern repeats of a model with a position u, v
//! [[hair]]            # material; file = "x.hair" | "x.pbrt" | "x.pbrt.gz" | "x.usda"
//!                     # or generator = { … HairParams … }
//!                     # or cotton = { … CottonBollParams … }; segments_per_curve (cubic
//!                     # curves, default 8) (strand diameters: crate::strand_diameters);
//!                     # basis = "linear" | "bspline" | "catmull-rom" | "bezier": how the
//!                     # points of a .hair file or the generator make curves (default linear)
//!                     # a surface material on a ribbon or flat curve file (pbrt ribbon/flat,
//!                     # USD with normals) renders it as ribbons (crate::ribbon_curves)
//! [[sphere]]          # center, radius, material, optional emission = [r, g, b] (a light)
//! [[mesh]]            # file = "x.obj", material, scale, translate; or floor = y;
//!                     # or cabochon = { radius, height, rings, sectors }, translate
//!                     # or grass = { … GrassParams … }, translate (blades as two-sided
//!                     #   ribbons: give them a transmitting surface model such as "leaf")
//! [[light]]           # type = "environment" (radiance) | "envmap" (file, scale)
//!                     #      | "sun" (direction, angular_radius_deg, irradiance)
//!                     #      | "distant" (direction, irradiance: a delta light)
//! ```
//! Relative paths are resolved against the scene file's directory.

use crate::camera::Camera;
use crate::integrator::RenderSettings;
use crate::light::{EnvironmentMap, Light};
use crate::model_loader::{LoadError, load_model, load_surface_model};
use crate::scene::{FiberMaterialId, Scene, SceneBuilder, SurfaceMaterial, SurfaceMaterialId};
use crate::strand_diameters;
use crate::surface_material::{ModelMaterial, takes_uv_position, texture_source};
use crate::toml_params::raw_pairs;
use fiberlab_geometry::curves::{CubicBasis, CurveSet};
use fiberlab_geometry::shapes::TriangleMesh;
use fiberlab_io::Basis;
use fiberlab_io::{HairFile, LinearImage};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_procedural::cotton_boll::CottonBollParams;
use fiberlab_procedural::generator::HairParams;
use fiberlab_procedural::grass::GrassParams;
use fiberlab_scatter::{Model, ModelError};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// The built-in default scene: a head sphere with ~20k generated wavy strands (Kajiya–Kay,
/// brown), a sky-blue environment and a warm sun.
pub const DEFAULT_SCENE: &str = r#"
[camera]
eye = [4.0, 1.3, -4.3]
target = [0.0, -0.45, 0.0]
up = [0.0, 1.0, 0.0]
fov = 38.0
width = 512
height = 512

[render]
spp = 32
max_depth = 64
seed = 0
exposure = 0.0
# integrator = "path"      # or "dual-scattering": Zinke et al. 2008 at fiber hits (needs a far-field
#                          # hair model such as "chiang" or "marschner"; surfaces stay path traced)
# fiber_count = "exact"    # with dual scattering: "exact" (a walk through the BVH) or "grid" (a density grid)

[materials.hair]
model = "kajiya-kay"
params = { k_d = [0.03, 0.014, 0.006], k_s = 0.025, p = 60 }

[materials.skin]
lambert = [0.62, 0.45, 0.36]

[materials.ground]
lambert = [0.35, 0.35, 0.35]

[[hair]]
material = "hair"
generator = { strands = 20000, segments = 24, style = "wavy", length = 1.6, seed = 1 }

[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "skin"

[[mesh]]
floor = -2.2
material = "ground"

[[light]]
type = "environment"
radiance = [0.35, 0.45, 0.6]

[[light]]
type = "sun"
direction = [1.0, 1.3, -0.5]
angular_radius_deg = 2.0
irradiance = [4.0, 3.7, 3.2]
"#;

/// A scene file error with its location (`path:line:column: message`; `path: message` for
/// an error of the whole file, e.g. one that cannot be read).
#[derive(Debug, thiserror::Error)]
pub struct SceneError {
    /// Scene file (`<default scene>` for the built-in one).
    pub path: PathBuf,
    /// 1-based line (0: the error is not at a place in the file).
    pub line: usize,
    /// 1-based column.
    pub column: usize,
    /// What is wrong, naming the key or value.
    pub message: String,
}

impl std::fmt::Display for SceneError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line == 0 {
            write!(f, "{}: {}", self.path.display(), self.message)
        } else {
            write!(f, "{}:{}:{}: {}", self.path.display(), self.line, self.column, self.message)
        }
    }
}

/// Exactly three numbers: an array of another length is an error at its place, not cut to
/// its first three (serde's arrays would drop a fourth number without a word).
fn three<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    let v = Vec::<f64>::deserialize(d)?;
    <[f64; 3]>::try_from(v.as_slice())
        .map_err(|_| serde::de::Error::invalid_length(v.len(), &"an array of three numbers [x, y, z]"))
}

/// [`three`] for an optional key.
fn three_optional<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<[f64; 3]>, D::Error> {
    three(d).map(Some)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDesc {
    #[serde(deserialize_with = "three")]
    eye: [f64; 3],
    #[serde(deserialize_with = "three")]
    target: [f64; 3],
    #[serde(default = "default_up", deserialize_with = "three")]
    up: [f64; 3],
    fov: f64,
    width: u32,
    height: u32,
}

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}

/// `[render]`: sampling settings (all optional).
#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields, default)]
pub struct RenderDesc {
    /// Samples per pixel.
    pub spp: u32,
    /// Maximum path depth.
    pub max_depth: u32,
    /// Seed.
    pub seed: u64,
    /// Exposure for the PNG, stops.
    pub exposure: f64,
    /// `"path"` or `"dual-scattering"` ([`crate::dual_scattering`]).
    pub integrator: String,
    /// With dual scattering: `"exact"` or `"grid"` ([`crate::fiber_count`]).
    pub fiber_count: String,
}

impl Default for RenderDesc {
    fn default() -> Self {
        Self { spp: 16, max_depth: 64, seed: 0, exposure: 0.0, integrator: "path".into(), fiber_count: "exact".into() }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialDesc {
    model: Option<Spanned<String>>,
    params: Option<Spanned<toml::Table>>,
    #[serde(default, deserialize_with = "three_optional")]
    lambert: Option<[f64; 3]>,
    #[serde(default, deserialize_with = "three_optional")]
    mirror: Option<[f64; 3]>,
    /// uv scale of a model's position `u`, `v` ([`crate::surface_material`]): two numbers
    /// (checked where it is used, at its place).
    uv_scale: Option<Spanned<Vec<f64>>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct HairDesc {
    material: Spanned<String>,
    file: Option<Spanned<String>>,
    generator: Option<Spanned<HairParams>>,
    /// A generated cotton boll ([`fiberlab_procedural::cotton_boll`]).
    cotton: Option<Spanned<CottonBollParams>>,
    /// Polyline segments each span of a cubic curve file becomes (default
    /// [`DEFAULT_SEGMENTS_PER_CURVE`]); linear files and `.hair` are not subdivided.
    segments_per_curve: Option<Spanned<usize>>,
    /// How the points of a `.hair` file or of the generator make curves (default linear: the
    /// polylines through them); pbrt and USD files carry their own basis.
    basis: Option<Spanned<String>>,
}

/// Segments per span of cubic curves (pbrt, USD) when `[[hair]]` does not say: the chord
/// of a span of a hair (a few curvature radii long) then deviates from the curve by well under
/// a diameter.
pub const DEFAULT_SEGMENTS_PER_CURVE: usize = 8;

/// Largest `segments_per_curve`.
pub const MAX_SEGMENTS_PER_CURVE: usize = 1024;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereDesc {
    #[serde(deserialize_with = "three")]
    center: [f64; 3],
    radius: f64,
    material: Spanned<String>,
    #[serde(default, deserialize_with = "three_optional")]
    emission: Option<[f64; 3]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshDesc {
    file: Option<Spanned<String>>,
    floor: Option<f64>,
    cabochon: Option<Spanned<CabochonDesc>>,
    /// A generated grass patch ([`fiberlab_procedural::grass`]).
    grass: Option<Spanned<GrassParams>>,
    material: Spanned<String>,
    /// For `file` only (default 1).
    scale: Option<f64>,
    /// For `file` only (default 0).
    #[serde(default, deserialize_with = "three_optional")]
    translate: Option<[f64; 3]>,
}

/// `[[mesh]] cabochon = { … }`: a sphere-cap dome ([`fiberlab_procedural::cabochon`]).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CabochonDesc {
    radius: f64,
    height: f64,
    #[serde(default = "default_rings")]
    rings: usize,
    #[serde(default = "default_sectors")]
    sectors: usize,
}

fn default_rings() -> usize {
    48
}

fn default_sectors() -> usize {
    128
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum LightDesc {
    Environment { radiance: [f64; 3] },
    Envmap { file: String, scale: Option<f64> },
    Sun { direction: [f64; 3], angular_radius_deg: f64, irradiance: [f64; 3] },
    Distant { direction: [f64; 3], irradiance: [f64; 3] },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneDesc {
    camera: Spanned<CameraDesc>,
    #[serde(default)]
    render: Option<Spanned<RenderDesc>>,
    #[serde(default)]
    materials: BTreeMap<String, Spanned<MaterialDesc>>,
    #[serde(default)]
    hair: Vec<Spanned<HairDesc>>,
    #[serde(default)]
    sphere: Vec<Spanned<SphereDesc>>,
    #[serde(default)]
    mesh: Vec<Spanned<MeshDesc>>,
    #[serde(default)]
    light: Vec<Spanned<LightDesc>>,
}

/// A parsed scene file, not yet built (geometry is loaded or generated by [`SceneFile::build`]).
#[derive(Debug)]
pub struct SceneFile {
    desc: SceneDesc,
    /// `[render]`, or its defaults when the file has none (checked when parsed).
    render: RenderDesc,
    text: String,
    path: PathBuf,
    base: PathBuf,
    hair_override: Option<PathBuf>,
}

fn rgb(c: [f64; 3]) -> Rgb {
    Rgb::new(c[0], c[1], c[2])
}

fn dvec(c: [f64; 3]) -> DVec3 {
    DVec3::from(c)
}

/// A material of the file by its name: fiber or surface, so that a reference can be checked.
#[derive(Clone, Copy, Debug)]
enum MaterialRef {
    Fiber(FiberMaterialId),
    Surface(SurfaceMaterialId),
}

/// The `[materials]` names.
type MaterialNames = BTreeMap<String, MaterialRef>;

/// Bytes per pixel of the renderer's state ([`crate::accumulation::BYTES_PER_PIXEL`]). The RGB
/// image it writes is counted apart ([`LinearImage::estimated_bytes`]).
pub const ACCUMULATOR_BYTES_PER_PIXEL: u64 = crate::accumulation::BYTES_PER_PIXEL;

/// What a scene will hold in memory once built, estimated from the file alone (of a `.hair`
/// file only its header is read): see [`SceneFile::memory_estimate`]. Byte counts are u64,
/// `None` where they overflow it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MemoryEstimate {
    /// The camera's image width, pixels.
    pub width: u32,
    /// The camera's image height, pixels.
    pub height: u32,
    /// The image: accumulators ([`ACCUMULATOR_BYTES_PER_PIXEL`]) and the written image.
    pub image_bytes: Option<u64>,
    /// One per `[[hair]]` entry, in file order.
    pub hair: Vec<HairEstimate>,
}

impl MemoryEstimate {
    /// The quantities of the estimate for the memory check ([`fiberlab_io::memory_budget`]):
    /// the image, then each `[[hair]]` entry's strands and BVH.
    #[must_use]
    pub fn needs(&self) -> Vec<fiberlab_io::memory_budget::Need> {
        use fiberlab_io::memory_budget::Need;
        let mut needs = vec![Need::new(format!("image {}×{}", self.width, self.height), self.image_bytes)];
        for h in &self.hair {
            needs.push(Need::new(
                format!("hair {} strands × {} segments ({})", h.strands, h.segments, h.source),
                h.hair_bytes,
            ));
            needs.push(Need::new(format!("BVH of {} segments", h.segments), h.bvh_bytes));
        }
        needs
    }
}

/// The strands of one `[[hair]]` entry and what they take.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HairEstimate {
    /// Where they come from: `generated`, or the `.hair` file's path.
    pub source: String,
    /// Strands.
    pub strands: u64,
    /// Segments of all strands.
    pub segments: u64,
    /// The strands as generated or read ([`HairParams::estimated_bytes`],
    /// [`fiberlab_io::HairHeader::read_bytes`]).
    pub hair_bytes: Option<u64>,
    /// Their tubes and BVH at the build's peak ([`CurveSet::estimated_bytes`]).
    pub bvh_bytes: Option<u64>,
}

impl SceneFile {
    /// Parses scene text; `path` names it in errors and anchors relative paths.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let mut file = Self {
            desc: SceneDesc::empty(),
            render: RenderDesc::default(),
            text: text.to_string(),
            path: path.into(),
            base,
            hair_override: None,
        };
        file.desc = toml::from_str(text).map_err(|e| {
            let span = e.span().unwrap_or(0..0);
            file.error(span, e.message().to_string())
        })?;
        if let Some(r) = &file.desc.render {
            let d = r.get_ref();
            if d.spp == 0 {
                return Err(file.error(r.span(), "render: spp = 0; give at least 1 sample per pixel".into()));
            }
            if !d.exposure.is_finite() {
                return Err(file.error(r.span(), format!("render: exposure = {:?} stops must be finite", d.exposure)));
            }
            if !matches!(d.integrator.as_str(), "path" | "dual-scattering") {
                let msg = format!("render: integrator = {:?}; known: \"path\", \"dual-scattering\"", d.integrator);
                return Err(file.error(r.span(), msg));
            }
            if let Err(e) = crate::fiber_count::FiberCount::parse(&d.fiber_count) {
                return Err(file.error(r.span(), format!("render: fiber_count: {e}")));
            }
            file.render = d.clone();
        }
        Ok(file)
    }

    /// Reads and parses a scene file.
    pub fn read(path: &Path) -> Result<Self, SceneError> {
        use fiberlab_io::input_file::{InputError, read_text};
        let text = read_text(path).map_err(|e| match e {
            InputError::NotUtf8 { line, column, byte, .. } => {
                SceneError { path: path.into(), line, column, message: format!("byte {byte}: not UTF-8 text") }
            }
            InputError::Io { error, .. } => {
                SceneError { path: path.into(), line: 0, column: 0, message: error.to_string() }
            }
            other => {
                let text = other.to_string();
                let message = text.strip_prefix(&format!("{}: ", path.display())).unwrap_or(&text).to_string();
                SceneError { path: path.into(), line: 0, column: 0, message }
            }
        })?;
        Self::parse(&text, path)
    }

    /// The built-in default scene.
    #[must_use]
    pub fn default_scene() -> Self {
        Self::parse(DEFAULT_SCENE, Path::new("<default scene>")).expect("the default scene parses")
    }

    /// Uses this `.hair` file for every `[[hair]]` entry instead of its own source; a scene
    /// without `[[hair]]` has no material to give it, which is an error.
    pub fn override_hair(&mut self, path: PathBuf) -> Result<(), SceneError> {
        if self.desc.hair.is_empty() {
            return Err(SceneError {
                path: self.path.clone(),
                line: 0,
                column: 0,
                message: format!(
                    "--hair {}: the scene has no [[hair]] entry whose strands it would replace; add one with a fiber material",
                    path.display()
                ),
            });
        }
        self.hair_override = Some(path);
        Ok(())
    }

    /// The `[render]` section.
    #[must_use]
    pub fn render_settings(&self) -> &RenderDesc {
        &self.render
    }

    /// Mutable `[render]` section (command-line overrides).
    pub fn render_settings_mut(&mut self) -> &mut RenderDesc {
        &mut self.render
    }

    fn error(&self, span: std::ops::Range<usize>, message: String) -> SceneError {
        let start = span.start.min(self.text.len());
        let before = &self.text[..start];
        let line = before.matches('\n').count() + 1;
        let column = before.rfind('\n').map_or(start, |i| start - i - 1) + 1;
        SceneError { path: self.path.clone(), line, column, message }
    }

    fn resolve(&self, p: &str) -> PathBuf {
        let p = Path::new(p);
        if p.is_absolute() { p.into() } else { self.base.join(p) }
    }

    /// Builds the scene: loads files, generates hair, builds BVHs and models. Sections are
    /// built in file order of their checks: camera, materials, hair, lights, spheres, meshes.
    pub fn build(&self) -> Result<(Scene, RenderSettings), SceneError> {
        let mut scene = SceneBuilder::new(self.camera()?);
        let names = self.materials(&mut scene)?;
        self.hair(&mut scene, &names)?;
        self.lights(&mut scene)?;
        self.spheres(&mut scene, &names)?;
        self.meshes(&mut scene, &names)?;
        Ok((scene.build(), self.sampling()))
    }

    /// The camera's size (`width`, `height`) as written, before anything is built: what
    /// command-line pixel rectangles are checked against.
    #[must_use]
    pub fn image_size(&self) -> (u32, u32) {
        let c = self.desc.camera.get_ref();
        (c.width, c.height)
    }

    /// Renders `width × height` pixels instead of the camera's own size (`fiberlab render
    /// --size`, for quick previews): the vertical field of view is kept, so a different aspect
    /// ratio shows more or less of the scene at the sides.
    pub fn override_image_size(&mut self, width: u32, height: u32) {
        let c = self.desc.camera.get_mut();
        (c.width, c.height) = (width, height);
    }

    /// The memory [`SceneFile::build`] and a render of the scene will take, estimated before
    /// anything is built: the image from the camera's size, the strands of each `[[hair]]`
    /// from its generator's counts or its `.hair` file's header (the `--hair` override's
    /// when set), and their BVH. A `.hair` header that cannot be read is an error at the entry.
    pub fn memory_estimate(&self) -> Result<MemoryEstimate, SceneError> {
        let (width, height) = self.image_size();
        let pixels = u64::from(width) * u64::from(height);
        let image_bytes = pixels
            .checked_mul(ACCUMULATOR_BYTES_PER_PIXEL)
            .zip(LinearImage::estimated_bytes(width.into(), height.into()))
            .and_then(|(a, b)| a.checked_add(b));
        let mut hair = Vec::new();
        for h in &self.desc.hair {
            let hd = h.get_ref();
            let per_curve = self.segments_per_curve(hd)?;
            let basis = self.basis(hd)?;
            let from_file = |path: &Path, span| {
                // `.hair`: its header; pbrt and USD text: a pass that counts the points.
                let mut c = fiberlab_io::strand_files::count(path).map_err(|e| self.error(span, e.to_string()))?;
                if c.basis == Basis::Linear && basis != Basis::Linear {
                    // `.hair` points read as the control points of `basis` (`build` checks the
                    // strands fit it).
                    c.spans = basis_spans(basis, c.strands, c.points);
                    c.basis = basis;
                }
                let segments = c.segments(per_curve);
                // A cubic file is also held as the polylines its diameters are checked on.
                let polylines = if c.basis == Basis::Linear { 0 } else { segments.saturating_mul(2 * 16) };
                Ok::<_, SceneError>(HairEstimate {
                    source: path.display().to_string(),
                    strands: c.strands,
                    segments,
                    hair_bytes: Some(c.read_bytes.saturating_add(polylines)),
                    bvh_bytes: CurveSet::estimated_bytes(segments),
                })
            };
            let estimate = match (&self.hair_override, &hd.file, &hd.generator) {
                (Some(p), _, _) => from_file(p, h.span())?,
                (None, None, None) if hd.cotton.is_some() && basis == Basis::Linear => {
                    let c = hd.cotton.as_ref().expect("checked").get_ref();
                    HairEstimate {
                        source: "cotton boll".into(),
                        strands: c.fibers as u64,
                        segments: c.segment_count(),
                        hair_bytes: Some(c.estimated_bytes()),
                        bvh_bytes: CurveSet::estimated_bytes(c.segment_count()),
                    }
                }
                (None, Some(f), None) => from_file(&self.resolve(f.get_ref()), f.span())?,
                (None, None, Some(g)) => {
                    let g = g.get_ref();
                    let strands = g.strands as u64;
                    // Overflow (`None`) shows as u64::MAX segments, whose BVH overflows too.
                    let segments = match (basis, g.segment_count()) {
                        (_, None) => None,
                        (Basis::Linear, Some(n)) => Some(n),
                        (b, Some(n)) => {
                            basis_spans(b, strands, n.saturating_add(strands)).checked_mul(per_curve as u64)
                        }
                    };
                    // Cubic curves are also held as their polylines (`.hair`-like, 16 bytes a point).
                    let polylines =
                        if basis == Basis::Linear { Some(0) } else { segments.and_then(|n| n.checked_mul(2 * 16)) };
                    HairEstimate {
                        source: "generated".into(),
                        strands,
                        segments: segments.unwrap_or(u64::MAX),
                        hair_bytes: g.estimated_bytes().zip(polylines).and_then(|(a, b)| a.checked_add(b)),
                        bvh_bytes: segments.and_then(CurveSet::estimated_bytes),
                    }
                }
                // Neither or both: `build` reports it.
                _ => continue,
            };
            hair.push(estimate);
        }
        Ok(MemoryEstimate { width, height, image_bytes, hair })
    }

    /// `[camera]`: each rule checked on its own, so that the error names the one that failed.
    fn camera(&self) -> Result<Camera, SceneError> {
        let d = &self.desc.camera;
        let c = d.get_ref();
        // Each error at the line of the key it is about.
        let fail =
            |key: &str, message: String| Err(self.error(self.key_span(d.span(), key), format!("camera: {message}")));
        for (key, v) in [("eye", c.eye), ("target", c.target), ("up", c.up)] {
            if !v.iter().all(|x| x.is_finite()) {
                return fail(key, format!("{key} = {v:?} must be finite"));
            }
        }
        let view = dvec(c.target) - dvec(c.eye);
        if c.eye == c.target {
            return fail("target", format!("eye and target are both {:?}; they must differ", c.eye));
        }
        if !view.length().is_finite() || view.try_normalize().is_none() {
            return fail(
                "eye",
                format!(
                    "eye = {:?} and target = {:?} are too far apart for double precision (|target − eye| is not \
                     finite); use smaller coordinates",
                    c.eye, c.target
                ),
            );
        }
        if view.normalize().cross(dvec(c.up)).try_normalize().is_none() {
            return fail("up", format!("up = {:?} is zero or parallel to the view direction (target − eye)", c.up));
        }
        if !(c.fov > 0.0 && c.fov < 180.0) {
            return fail("fov", format!("fov = {:?} must be in (0, 180) degrees", c.fov));
        }
        if c.width == 0 || c.height == 0 {
            let key = if c.width == 0 { "width" } else { "height" };
            return fail(key, format!("width and height must be > 0 (got {} × {})", c.width, c.height));
        }
        Camera::look_at(dvec(c.eye), dvec(c.target), dvec(c.up), c.fov, c.width, c.height)
            .map_or_else(|| fail("eye", "eye, target and up do not make a camera frame".into()), Ok)
    }

    /// The span of the line `key = …` of the table spanning `table`, or `table` itself when
    /// the key is not written there (a default, an inline table's key). A `[header]` table's
    /// span may cover only its header: its keys are searched up to the next header.
    fn key_span(&self, table: std::ops::Range<usize>, key: &str) -> std::ops::Range<usize> {
        let start = table.start.min(self.text.len());
        let rest = &self.text[start..];
        // An inline table `{ … }` is searched within its span; a `[header]` table to the next header.
        let body =
            if rest.starts_with('[') { rest } else { rest.get(..table.end.saturating_sub(start)).unwrap_or(rest) };
        let mut offset = start;
        for (k, line) in body.split_inclusive('\n').enumerate() {
            let trimmed = line.trim_start();
            if k > 0 && trimmed.starts_with('[') {
                break;
            }
            if let Some(after) = trimmed.strip_prefix(key)
                && after.trim_start().starts_with('=')
            {
                let at = offset + (line.len() - trimmed.len());
                return at..at + key.len();
            }
            offset += line.len();
        }
        table
    }

    /// `[render]`: the sampling settings (what [`SceneFile::build`] returns beside the scene).
    #[must_use]
    pub fn sampling(&self) -> RenderSettings {
        let r = &self.render;
        RenderSettings { spp: r.spp.max(1), max_depth: r.max_depth, seed: r.seed, ..RenderSettings::default() }
    }

    /// `[materials.NAME]`: each a fiber model or a surface, added to the scene by name.
    fn materials(&self, scene: &mut SceneBuilder) -> Result<MaterialNames, SceneError> {
        let mut names = MaterialNames::new();
        for (name, m) in &self.desc.materials {
            let md = m.get_ref();
            let kinds =
                usize::from(md.model.is_some()) + usize::from(md.lambert.is_some()) + usize::from(md.mirror.is_some());
            if kinds != 1 {
                return Err(
                    self.error(m.span(), format!("material `{name}`: give exactly one of model, lambert, mirror"))
                );
            }
            let surface_model = md.model.as_ref().filter(|m| {
                matches!(fiberlab_scatter::lookup(m.get_ref()), Ok(fiberlab_scatter::RegistryEntry::Surface(_)))
            });
            let material = if let Some(model) = surface_model {
                let material = self.surface_model(name, model, md.params.as_ref(), md.uv_scale.as_ref())?;
                MaterialRef::Surface(scene.surface_material(material))
            } else if let Some(uv_scale) = &md.uv_scale {
                return Err(self.error(
                    uv_scale.span(),
                    format!("material `{name}`: uv_scale is for surface models with a position (u, v)"),
                ));
            } else if let Some(model) = &md.model {
                MaterialRef::Fiber(scene.fiber_material(self.fiber_model(name, model, md.params.as_ref())?))
            } else {
                let (key, value, surface): (_, _, fn(Rgb) -> SurfaceMaterial) = match (md.lambert, md.mirror) {
                    (Some(a), _) => ("lambert", a, SurfaceMaterial::Lambert),
                    (None, r) => ("mirror", r.unwrap_or([1.0; 3]), SurfaceMaterial::Mirror),
                };
                if !value.iter().all(|x| (0.0..=1.0).contains(x)) {
                    return Err(self.error(m.span(), format!("material `{name}`: {key} = {value:?} must be in [0, 1]")));
                }
                MaterialRef::Surface(scene.surface_material(surface(rgb(value))))
            };
            names.insert(name.clone(), material);
        }
        Ok(names)
    }

    /// The model of material `name`: any registered model from its `params`, through the
    /// one model loader (a table path relative to the scene file).
    fn fiber_model(
        &self,
        name: &str,
        model: &Spanned<String>,
        params: Option<&Spanned<toml::Table>>,
    ) -> Result<Model, SceneError> {
        let pairs = match params {
            Some(p) => raw_pairs(p.get_ref()).map_err(|e| self.error(p.span(), format!("material `{name}`: {e}")))?,
            None => Vec::new(),
        };
        load_model(model.get_ref(), &pairs, &self.base).map_err(|e| {
            let span = match &e {
                LoadError::Model(ModelError::UnknownModel { .. } | ModelError::NeedsData { .. })
                | LoadError::Table(_) => model.span(),
                _ => params.map_or(model.span(), Spanned::span),
            };
            self.error(span, format!("material `{name}`: {e}"))
        })
    }

    /// The surface material `name` of a registered surface model: its `params` split into
    /// plain values (built through the registry) and textures (read and checked here).
    fn surface_model(
        &self,
        name: &str,
        model: &Spanned<String>,
        params: Option<&Spanned<toml::Table>>,
        uv_scale: Option<&Spanned<Vec<f64>>>,
    ) -> Result<SurfaceMaterial, SceneError> {
        let span = params.map_or(model.span(), Spanned::span);
        let fail = |message: String| self.error(span.clone(), format!("material `{name}`: {message}"));
        let (mut plain, mut textures) = (toml::Table::new(), Vec::new());
        for (key, value) in params.map(Spanned::get_ref).into_iter().flatten() {
            match texture_source(value, &|p| self.resolve(p)) {
                Some(source) => textures.push((key.clone(), source.map_err(|e| fail(format!("{key}: {e}")))?)),
                None => {
                    plain.insert(key.clone(), value.clone());
                }
            }
        }
        let pairs = raw_pairs(&plain).map_err(|e| fail(e.to_string()))?;
        let spec = fiberlab_scatter::find_surface(model.get_ref()).map_err(|e| fail(e.to_string()))?;
        // Through the one model loader: a weave-pattern file relative to the scene file.
        let built = load_surface_model(model.get_ref(), &pairs, &self.base).map_err(|e| fail(e.to_string()))?;
        let mut material =
            ModelMaterial::new(spec.name, spec.params, built, &textures).map_err(|e| fail(e.to_string()))?;
        if let Some(scale) = uv_scale {
            let fail = |message: String| self.error(scale.span(), format!("material `{name}`: {message}"));
            let pair = <[f64; 2]>::try_from(scale.get_ref().as_slice())
                .map_err(|_| fail(format!("uv_scale: expected two numbers [su, sv], got {}", scale.get_ref().len())))?;
            material = material.with_uv_scale(pair).map_err(|e| fail(e.to_string()))?;
        }
        Ok(SurfaceMaterial::Model(Box::new(material)))
    }

    /// True when material `m` gives some parameter as a texture, or is a surface model that
    /// takes its position `u`, `v` from the texture coordinates.
    fn textured(&self, m: &Spanned<String>) -> bool {
        let desc = self.desc.materials.get(m.get_ref()).map(Spanned::get_ref);
        let params = desc.and_then(|d| d.params.as_ref());
        let positioned = desc.and_then(|d| d.model.as_ref()).is_some_and(|model| {
            fiberlab_scatter::find_surface(model.get_ref()).is_ok_and(|spec| takes_uv_position(spec.params))
        });
        positioned
            || params.is_some_and(|p| p.get_ref().values().any(|v| texture_source(v, &|p| self.resolve(p)).is_some()))
    }

    fn material(&self, names: &MaterialNames, m: &Spanned<String>) -> Result<MaterialRef, SceneError> {
        names.get(m.get_ref()).copied().ok_or_else(|| {
            let known: Vec<&str> = names.keys().map(String::as_str).collect();
            self.error(m.span(), format!("unknown material `{}`; defined: {}", m.get_ref(), known.join(", ")))
        })
    }

    /// The fiber material called `m` (an error for a surface material).
    fn fiber_material(&self, names: &MaterialNames, m: &Spanned<String>) -> Result<FiberMaterialId, SceneError> {
        match self.material(names, m)? {
            MaterialRef::Fiber(id) => Ok(id),
            MaterialRef::Surface(_) => Err(self.error(
                m.span(),
                format!(
                    "material `{}` is a surface (lambert, mirror or a surface model); hair needs a fiber model (model = …)",
                    m.get_ref()
                ),
            )),
        }
    }

    /// The surface material called `m` (an error for a fiber model).
    fn surface_material(&self, names: &MaterialNames, m: &Spanned<String>) -> Result<SurfaceMaterialId, SceneError> {
        match self.material(names, m)? {
            MaterialRef::Surface(id) => Ok(id),
            MaterialRef::Fiber(_) => Err(self.error(
                m.span(),
                format!(
                    "material `{}` is a fiber model; spheres and meshes need a surface (lambert, mirror or a surface model such as model = \"lambertian\")",
                    m.get_ref()
                ),
            )),
        }
    }

    /// `[[hair]]`: strands read from a file or generated, as tubes in a BVH; with a surface
    /// material, ribbon and flat curves from a file as a ribbon mesh.
    fn hair(&self, scene: &mut SceneBuilder, names: &MaterialNames) -> Result<(), SceneError> {
        for h in &self.desc.hair {
            let hd = h.get_ref();
            let per_curve = self.segments_per_curve(hd)?;
            if let MaterialRef::Surface(surface) = self.material(names, &hd.material)? {
                let mesh = self.ribbons(h, per_curve)?;
                scene.mesh(mesh, surface);
                continue;
            }
            let material = self.fiber_material(names, &hd.material)?;
            let basis = (self.basis(hd)?, hd.basis.as_ref().map_or(h.span(), Spanned::span));
            // The hair, where its errors are reported, and what it is called in them; cubic
            // curves come with their control points, the hair then holds their polylines.
            let (loaded, span, source) = if let Some(p) = &self.hair_override {
                let source = format!("--hair {}", p.display());
                (self.hair_file(p, h.span(), per_curve, basis, &source)?, h.span(), source)
            } else {
                match (&hd.file, &hd.generator, &hd.cotton) {
                    (Some(f), None, None) => {
                        let path = self.resolve(f.get_ref());
                        let source = format!("hair file {}", path.display());
                        (self.hair_file(&path, f.span(), per_curve, basis, &source)?, f.span(), source)
                    }
                    (None, Some(g), None) => {
                        let hair = g.get_ref().generate().map_err(|e| self.error(g.span(), e.to_string()))?;
                        let source = "hair generator".to_string();
                        (self.with_basis(hair, per_curve, basis, &source)?, g.span(), source)
                    }
                    (None, None, Some(c)) => {
                        let hair = c.get_ref().generate().map_err(|e| self.error(c.span(), e.to_string()))?;
                        let source = "cotton boll".to_string();
                        (self.with_basis(hair, per_curve, basis, &source)?, c.span(), source)
                    }
                    _ => return Err(self.error(h.span(), "hair: give exactly one of file, generator, cotton".into())),
                }
            };
            let (hair, cubic) = loaded;
            let segments = (hair.points.len() as u64).saturating_sub(hair.strand_count.into());
            if segments > CurveSet::MAX_SEGMENTS {
                return Err(self.error(
                    h.span(),
                    format!(
                        "hair: {} strands with {segments} segments; one [[hair]] entry holds at most {} (the BVH's 32-bit piece indices)",
                        hair.strand_count,
                        CurveSet::MAX_SEGMENTS
                    ),
                ));
            }
            strand_diameters::check(&hair).map_err(|e| self.error(span, format!("{source}: {e}")))?;
            let curves = match cubic {
                None => hair.into_curve_set(),
                Some(strands) => cubic_curves(&strands, per_curve),
            };
            scene.fibers(curves, material);
        }
        Ok(())
    }

    /// The ribbon mesh of a `[[hair]]` entry with a surface material: ribbon or flat curves
    /// from its file (or `--hair`), [`crate::ribbon_curves`].
    fn ribbons(&self, h: &Spanned<HairDesc>, per_curve: usize) -> Result<TriangleMesh, SceneError> {
        let hd = h.get_ref();
        let (path, span) = match (&self.hair_override, &hd.file, &hd.generator) {
            (Some(p), _, _) => (p.clone(), h.span()),
            (None, Some(f), None) => (self.resolve(f.get_ref()), f.span()),
            (None, None, Some(_)) | (None, None, None) if hd.generator.is_some() || hd.cotton.is_some() => {
                return Err(self.error(
                    hd.material.span(),
                    format!(
                        "material `{}` is a surface; the hair generator and the cotton boll grow round strands, which need a fiber \
                         model (a surface model goes on ribbon or flat curves from a file)",
                        hd.material.get_ref()
                    ),
                ));
            }
            _ => return Err(self.error(h.span(), "hair: give exactly one of file, generator".into())),
        };
        if hd.basis.is_some() {
            return Err(self.error(h.span(), "hair: basis applies to .hair files and the generator".into()));
        }
        let strands = fiberlab_io::strand_files::read(&path).map_err(|e| self.error(span.clone(), e.to_string()))?;
        let eye = dvec(self.desc.camera.get_ref().eye);
        crate::ribbon_curves::ribbon_mesh(&strands, per_curve, eye).map_err(|e| {
            self.error(span, format!("material `{}` (a surface): {}: {e}", hd.material.get_ref(), path.display()))
        })
    }

    /// `segments_per_curve` of a `[[hair]]` entry, checked.
    fn segments_per_curve(&self, hd: &HairDesc) -> Result<usize, SceneError> {
        match &hd.segments_per_curve {
            None => Ok(DEFAULT_SEGMENTS_PER_CURVE),
            Some(n) if (1..=MAX_SEGMENTS_PER_CURVE).contains(n.get_ref()) => Ok(*n.get_ref()),
            Some(n) => Err(self.error(
                n.span(),
                format!("hair: segments_per_curve = {} must be from 1 to {MAX_SEGMENTS_PER_CURVE}", n.get_ref()),
            )),
        }
    }

    /// `basis` of a `[[hair]]` entry, checked (default linear).
    fn basis(&self, hd: &HairDesc) -> Result<Basis, SceneError> {
        let Some(b) = &hd.basis else { return Ok(Basis::Linear) };
        match b.get_ref().as_str() {
            "linear" => Ok(Basis::Linear),
            "bspline" => Ok(Basis::BSpline),
            "catmull-rom" => Ok(Basis::CatmullRom),
            "bezier" => Ok(Basis::Bezier),
            other => Err(self.error(
                b.span(),
                format!("hair: basis = {other:?} must be one of \"linear\", \"bspline\", \"catmull-rom\", \"bezier\""),
            )),
        }
    }

    /// The points of a `.hair` file or of the generator as the control points of `basis`
    /// (its span: where a strand that does not fit it is reported): unchanged for linear,
    /// else their polylines of `per_curve` segments per span and the control points.
    fn with_basis(
        &self,
        hair: HairFile,
        per_curve: usize,
        (basis, span): (Basis, std::ops::Range<usize>),
        source: &str,
    ) -> Result<(HairFile, Option<fiberlab_io::Strands>), SceneError> {
        if basis == Basis::Linear {
            return Ok((hair, None));
        }
        let strands = fiberlab_io::Strands { basis, ..fiberlab_io::Strands::from(&hair) };
        let fail = |e: fiberlab_io::StrandsError| {
            self.error(span.clone(), format!("hair: basis = \"{basis}\": {source}: {e}"))
        };
        let lines = strands.to_polylines(per_curve).map_err(fail)?.to_hair().map_err(fail)?;
        Ok((lines, Some(strands)))
    }

    /// A hair file of any format, by extension: its polylines as a [`HairFile`] (what the
    /// diameters are checked on), and for cubic curves their control points too. `basis`
    /// applies to a `.hair` file's points; pbrt and USD files carry their own.
    fn hair_file(
        &self,
        path: &Path,
        span: std::ops::Range<usize>,
        per_curve: usize,
        basis: (Basis, std::ops::Range<usize>),
        source: &str,
    ) -> Result<(HairFile, Option<fiberlab_io::Strands>), SceneError> {
        let fail = |e: fiberlab_io::StrandsError| self.error(span.clone(), e.to_string());
        let fail_at = |e: fiberlab_io::StrandsError| self.error(span.clone(), format!("{}: {e}", path.display()));
        if fiberlab_io::Format::of(path).map_err(fail)? == fiberlab_io::Format::Hair {
            let hair = HairFile::read(path).map_err(|e| self.error(span.clone(), e.to_string()))?;
            return self.with_basis(hair, per_curve, basis, source);
        }
        let mut strands = fiberlab_io::strand_files::read(path).map_err(fail)?;
        // Round tubes: ribbon normals do not apply.
        strands.normals.clear();
        if basis.0 != Basis::Linear && basis.0 != strands.basis {
            return Err(self.error(
                basis.1,
                format!(
                    "hair: basis = \"{}\" applies to .hair files and the generator; {source} holds {} curves of its own",
                    basis.0, strands.basis
                ),
            ));
        }
        if strands.basis == Basis::Linear {
            return Ok((strands.to_hair().map_err(fail_at)?, None));
        }
        let lines = strands.to_polylines(per_curve).map_err(fail_at)?.to_hair().map_err(fail_at)?;
        Ok((lines, Some(strands)))
    }

    /// A radiometric colour (radiance, irradiance, emission, a scale): every channel finite
    /// and ≥ 0, else an error at `span` naming `what`.
    fn radiometric(&self, span: std::ops::Range<usize>, what: &str, c: [f64; 3]) -> Result<Rgb, SceneError> {
        if c.iter().all(|x| x.is_finite() && *x >= 0.0) {
            Ok(rgb(c))
        } else {
            Err(self.error(span, format!("{what} = {c:?} must be finite and ≥ 0 in every channel")))
        }
    }

    /// Three finite coordinates, else an error at `span` naming `what`.
    fn point(&self, span: std::ops::Range<usize>, what: &str, c: [f64; 3]) -> Result<DVec3, SceneError> {
        if c.iter().all(|x| x.is_finite()) {
            Ok(dvec(c))
        } else {
            Err(self.error(span, format!("{what} = {c:?} must be finite")))
        }
    }

    /// `[[light]]`: the lights at infinity.
    fn lights(&self, scene: &mut SceneBuilder) -> Result<(), SceneError> {
        for l in &self.desc.light {
            let light = match l.get_ref() {
                LightDesc::Environment { radiance } => {
                    Light::Constant { radiance: self.radiometric(l.span(), "environment: radiance", *radiance)? }
                }
                LightDesc::Envmap { file, scale } => {
                    let scale = self.radiometric(l.span(), "envmap: scale", [scale.unwrap_or(1.0); 3])?;
                    let path = self.resolve(file);
                    let img = LinearImage::read_exr(&path).map_err(|e| self.error(l.span(), e.to_string()))?;
                    if let Some(at) = img.pixels().iter().position(|p| p.iter().any(|c| !(c.is_finite() && *c >= 0.0)))
                    {
                        let (x, y) = (at % img.width(), at / img.width());
                        let p = img.pixels()[at];
                        return Err(self.error(
                            l.span(),
                            format!(
                                "envmap {}: pixel x = {x}, y = {y} is {p:?}; radiance must be finite and ≥ 0",
                                path.display()
                            ),
                        ));
                    }
                    Light::Map(Box::new(EnvironmentMap::new(img, scale)))
                }
                LightDesc::Sun { direction, angular_radius_deg, irradiance } => {
                    if !(*angular_radius_deg > 0.0 && *angular_radius_deg < 90.0) {
                        return Err(self.error(
                            l.span(),
                            format!("sun: angular_radius_deg = {angular_radius_deg:?} must be in (0, 90)"),
                        ));
                    }
                    let direction = self.point(l.span(), "sun: direction", *direction)?;
                    if direction.length() == 0.0 {
                        return Err(self.error(l.span(), "sun: direction must be non-zero".to_string()));
                    }
                    let irradiance = self.radiometric(l.span(), "sun: irradiance", *irradiance)?;
                    Light::sun(direction, angular_radius_deg.to_radians(), irradiance)
                }
                LightDesc::Distant { direction, irradiance } => {
                    let Some(direction) = dvec(*direction).try_normalize() else {
                        return Err(self.error(l.span(), "distant: direction must be non-zero and finite".to_string()));
                    };
                    Light::Distant {
                        direction,
                        irradiance: self.radiometric(l.span(), "distant: irradiance", *irradiance)?,
                    }
                }
            };
            scene.light(light);
        }
        Ok(())
    }

    /// `[[sphere]]`: spheres, emitting ones also lights.
    fn spheres(&self, scene: &mut SceneBuilder, names: &MaterialNames) -> Result<(), SceneError> {
        for s in &self.desc.sphere {
            let sd = s.get_ref();
            if !(sd.radius > 0.0 && sd.radius.is_finite()) {
                return Err(self.error(s.span(), format!("sphere: radius = {:?} must be finite and > 0", sd.radius)));
            }
            let material = self.surface_material(names, &sd.material)?;
            let center = self.point(s.span(), "sphere: center", sd.center)?;
            let emission = sd.emission.map(|e| self.radiometric(s.span(), "sphere: emission", e)).transpose()?;
            scene.sphere(center, sd.radius, material, emission);
        }
        Ok(())
    }

    /// `[[mesh]]`: OBJ files or an infinite-looking floor.
    fn meshes(&self, scene: &mut SceneBuilder, names: &MaterialNames) -> Result<(), SceneError> {
        for m in &self.desc.mesh {
            let md = m.get_ref();
            let material = self.surface_material(names, &md.material)?;
            if let Some(c) = &md.cabochon {
                if md.file.is_some() || md.floor.is_some() || md.scale.is_some() || md.grass.is_some() {
                    return Err(self.error(
                        m.span(),
                        "mesh: a cabochon takes translate only (no file, floor, scale, grass)".into(),
                    ));
                }
                let cd = c.get_ref();
                let translate = self.point(m.span(), "mesh: translate", md.translate.unwrap_or_default())?;
                let dome =
                    fiberlab_procedural::cabochon::cabochon(cd.radius, cd.height, cd.rings, cd.sectors, translate)
                        .map_err(|e| self.error(c.span(), format!("mesh: {e}")))?;
                scene.mesh(dome, material);
                continue;
            }
            if let Some(g) = &md.grass {
                if md.file.is_some() || md.floor.is_some() || md.scale.is_some() {
                    return Err(self.error(m.span(), "mesh: grass takes translate only (no file, floor, scale)".into()));
                }
                let translate = self.point(m.span(), "mesh: translate", md.translate.unwrap_or_default())?;
                // Sized and checked against its triangle limit before any is made.
                let blades = g.get_ref().generate().map_err(|e| self.error(g.span(), format!("mesh: {e}")))?;
                scene.mesh(blades.into_mesh(translate), material);
                continue;
            }
            let mesh = match (&md.file, md.floor) {
                (Some(f), None) => {
                    let scale = md.scale.unwrap_or(1.0);
                    if !(scale.is_finite() && scale > 0.0) {
                        return Err(self.error(m.span(), format!("mesh: scale = {scale:?} must be finite and > 0")));
                    }
                    let translate = self.point(m.span(), "mesh: translate", md.translate.unwrap_or_default())?;
                    // Vertices that the scale or translation makes infinite are refused there.
                    let path = self.resolve(f.get_ref());
                    let mesh = fiberlab_io::obj::read_obj(&path, scale, translate)
                        .map_err(|e| self.error(f.span(), format!("mesh: {e}")))?;
                    if !mesh.has_uvs() && self.textured(&md.material) {
                        return Err(self.error(
                            f.span(),
                            format!(
                                "mesh {}: material `{}` is textured but the mesh has no texture coordinates (vt)",
                                path.display(),
                                md.material.get_ref()
                            ),
                        ));
                    }
                    mesh
                }
                (None, Some(_)) if md.scale.is_some() || md.translate.is_some() => {
                    let (key, value) = match (md.scale, md.translate) {
                        (Some(v), _) => ("scale", format!("{v:?}")),
                        (None, t) => ("translate", format!("{:?}", t.unwrap_or_default())),
                    };
                    return Err(self.error(
                        m.span(),
                        format!(
                            "mesh: {key} = {value} is for OBJ files; a floor is the plane y = floor, give only floor"
                        ),
                    ));
                }
                (None, Some(y)) if y.is_finite() => TriangleMesh::floor(y, 100.0),
                (None, Some(y)) => return Err(self.error(m.span(), format!("mesh: floor = {y:?} must be finite"))),
                _ => return Err(self.error(m.span(), "mesh: give exactly one of file, floor, cabochon, grass".into())),
            };
            scene.mesh(mesh, material);
        }
        Ok(())
    }
}

impl SceneDesc {
    fn empty() -> Self {
        Self {
            camera: Spanned::new(
                0..0,
                CameraDesc { eye: [0.0; 3], target: [0.0; 3], up: [0.0; 3], fov: 0.0, width: 0, height: 0 },
            ),
            render: None,
            materials: BTreeMap::new(),
            hair: Vec::new(),
            sphere: Vec::new(),
            mesh: Vec::new(),
            light: Vec::new(),
        }
    }
}

/// Spans of `strands` strands of `points` control points in all, each read with a cubic
/// `basis` (module docs of `fiberlab_io::strands`; 0 where a strand is too short, as
/// `build` then refuses it).
fn basis_spans(basis: Basis, strands: u64, points: u64) -> u64 {
    match basis {
        Basis::Linear => points.saturating_sub(strands),
        Basis::Bezier => points.saturating_sub(strands) / 3,
        Basis::BSpline | Basis::CatmullRom => points.saturating_sub(strands.saturating_mul(3)),
    }
}

/// Tubes of cubic curves through [`CurveSet::from_cubic`], `per_curve` segments per span:
/// B-splines and Bézier curves as they are, Catmull–Rom spans as the Bézier spans of the same
/// curve (control points `c₁`, `c₁ + (c₂ − c₀)/6`, `c₂ − (c₃ − c₁)/6`, `c₂`, in `f64`).
fn cubic_curves(strands: &fiberlab_io::Strands, per_curve: usize) -> CurveSet {
    let point = |p: &[f32; 3]| DVec3::new(p[0].into(), p[1].into(), p[2].into());
    let mut controls: Vec<(Vec<DVec3>, Vec<f64>)> = Vec::with_capacity(strands.strand_count());
    for r in strands.strand_ranges() {
        let c: Vec<DVec3> = strands.points[r.clone()].iter().map(point).collect();
        let w: Vec<f64> = strands.widths[r].iter().map(|&w| 0.5 * f64::from(w)).collect();
        if strands.basis != Basis::CatmullRom {
            controls.push((c, w));
            continue;
        }
        let (mut bc, mut bw) = (vec![c[1]], vec![w[1]]);
        for i in 0..c.len().saturating_sub(3) {
            bc.extend([c[i + 1] + (c[i + 2] - c[i]) / 6.0, c[i + 2] - (c[i + 3] - c[i + 1]) / 6.0, c[i + 2]]);
            bw.extend([w[i + 1] + (w[i + 2] - w[i]) / 6.0, w[i + 2] - (w[i + 3] - w[i + 1]) / 6.0, w[i + 2]]);
        }
        controls.push((bc, bw));
    }
    let basis = if strands.basis == Basis::BSpline { CubicBasis::BSpline } else { CubicBasis::Bezier };
    CurveSet::from_cubic(basis, per_curve, controls.iter().map(|(c, w)| (c.as_slice(), w.as_slice())))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> SceneError {
        match SceneFile::parse(text, Path::new("s.toml")).and_then(|f| f.build().map(|_| ())) {
            Err(e) => e,
            Ok(()) => panic!("expected an error"),
        }
    }

    const CAMERA: &str = "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nfov = 30\nwidth = 8\nheight = 8\n";

    /// A scene in a temporary directory with one `.hair` file of two wavy strands of 7 points
    /// (radius 0.01) and a `[[hair]]` entry with `extra` keys.
    fn basis_scene(extra: &str) -> (tempfile::TempDir, SceneFile, Vec<Vec<DVec3>>) {
        let dir = tempfile::tempdir().unwrap();
        let strands: Vec<Vec<DVec3>> = (0..2)
            .map(|s| {
                (0..7)
                    .map(|k| {
                        let t = f64::from(k);
                        DVec3::new(
                            0.3 * (t + f64::from(s)).sin(),
                            0.25 * t - 0.8,
                            0.2 * (1.7 * t).cos() + f64::from(s) * 0.1,
                        )
                    })
                    .collect()
            })
            .collect();
        let hair = HairFile {
            segments: None,
            points: strands.iter().flatten().map(|p| p.as_vec3().to_array()).collect(),
            strand_count: 2,
            default_segments: 6,
            default_thickness: 0.02,
            ..HairFile::default()
        };
        hair.write(&dir.path().join("h.hair")).unwrap();
        let text = format!(
            "{CAMERA}[materials.h]\nmodel = \"chiang\"\n[[hair]]\nmaterial = \"h\"\nfile = \"h.hair\"\n{extra}"
        );
        let path = dir.path().join("s.toml");
        std::fs::write(&path, &text).unwrap();
        let f = SceneFile::parse(&text, &path).unwrap();
        (dir, f, strands)
    }

    /// `[[hair]] cotton = { … }` grows the boll's fibres as tubes (one fiber set of
    /// fibers × segments), counted by the memory estimate; with a generator too, or with a
    /// surface material, it is refused at the entry.
    #[test]
    fn a_cotton_boll_is_a_hair_entry() {
        let text = |extra: &str, material: &str| {
            format!(
                "{CAMERA}[materials.lint]\nmodel = \"hollow-fiber\"\n[materials.leaf]\nmodel = \"leaf\"\n[[hair]]\nmaterial = \"{material}\"\ncotton = {{ fibers = 30, segments = 10 }}\n{extra}"
            )
        };
        let f = SceneFile::parse(&text("", "lint"), Path::new("s.toml")).unwrap();
        let e = f.memory_estimate().unwrap();
        assert_eq!((e.hair[0].strands, e.hair[0].segments), (30, 300));
        let (scene, _) = f.build().unwrap();
        assert_eq!(scene.fibers().len(), 1);
        let e = err(&text("generator = { strands = 2 }\n", "lint")).to_string();
        assert!(e.contains("give exactly one of file, generator, cotton"), "{e}");
        let e = err(&text("", "leaf")).to_string();
        assert!(e.contains("the cotton boll grow round strands"), "{e}");
        let e = err(&text("", "lint").replace("segments = 10", "segments = 0")).to_string();
        assert!(e.contains("cotton: `segments` = 0"), "{e}");
    }

    /// A `[[hair]]` entry with a surface material renders ribbon curves from its file as a
    /// ribbon mesh (two triangles per polyline segment: 2 curves of 2 Bézier spans × 4
    /// segments), with a fiber material as tubes; round curves with a surface material, and
    /// the generator with one, are refused at the entry, naming the scene's line and the file.
    #[test]
    fn hair_files_of_ribbons_take_a_surface_model() {
        let dir = tempfile::tempdir().unwrap();
        let curves = |normals: &str| {
            format!(
                "#usda 1.0\ndef BasisCurves \"c\"\n{{\n    int[] curveVertexCounts = [7, 7]\n    point3f[] points = [(0, 0, 0), (0, 0.1, 0), (0, 0.2, 0), (0, 0.3, 0), (0, 0.4, 0), (0, 0.5, 0), (0, 0.6, 0), (0.2, 0, 0), (0.2, 0.1, 0), (0.2, 0.2, 0), (0.2, 0.3, 0), (0.2, 0.4, 0), (0.2, 0.5, 0), (0.3, 0.6, 0)]\n    float[] widths = [0.05] (interpolation = \"constant\")\n{normals}}}\n"
            )
        };
        std::fs::write(
            dir.path().join("r.usda"),
            curves("    normal3f[] normals = [(0, 0, 1)] (interpolation = \"constant\")\n"),
        )
        .unwrap();
        std::fs::write(dir.path().join("t.usda"), curves("")).unwrap();
        let scene = |file: &str, material: &str| {
            let text = format!(
                "{CAMERA}[materials.leaf]\nmodel = \"leaf\"\n[materials.hair]\nmodel = \"chiang\"\n[[hair]]\nmaterial = \"{material}\"\n{file}\nsegments_per_curve = 4\n"
            );
            let path = dir.path().join("s.toml");
            SceneFile::parse(&text, &path).and_then(|f| f.build())
        };
        let (ribbons, _) = scene("file = \"r.usda\"", "leaf").unwrap();
        assert_eq!((ribbons.meshes().len(), ribbons.fibers().len()), (1, 0));
        assert_eq!(ribbons.meshes()[0].mesh().len(), 2 * 2 * 2 * 4);
        // Facing +z (the normal), the first ribbon spans x in ±0.025 at y = 0.3.
        let hit = |x: f64| {
            ribbons.meshes()[0].mesh().intersect(&fiberlab_geometry::Ray::new(DVec3::new(x, 0.3, 1.0), DVec3::NEG_Z))
        };
        assert!(hit(0.02).is_some() && hit(-0.02).is_some() && hit(0.03).is_none());
        let (tubes, _) = scene("file = \"r.usda\"", "hair").unwrap();
        assert_eq!((tubes.meshes().len(), tubes.fibers().len()), (0, 1));
        let e = scene("file = \"t.usda\"", "leaf").unwrap_err().to_string();
        assert!(e.contains("s.toml:13:8: material `leaf` (a surface): ") && e.contains("round"), "{e}");
        let e = scene("generator = { strands = 2 }", "leaf").unwrap_err().to_string();
        assert!(e.contains("s.toml:12:12: material `leaf` is a surface; the hair generator"), "{e}");
    }

    /// `basis = "bspline"` on `.hair` points: the tubes' axis runs through the uniform cubic
    /// B-spline of the points, evaluated here in its matrix form (1/6 [−1 3 −3 1; 3 −6 3 0;
    /// −3 0 3 0; 1 4 1 0] times the span's four points, at t = j/4), independently of the
    /// crate's weight polynomials: 4 spans × 4 segments per strand, each segment from the
    /// blend at j/4 to the blend at (j+1)/4. Linear (the default) keeps the 6 segments of
    /// each polyline, with the points as ends.
    #[test]
    fn hair_basis_bspline_subdivides_the_points_as_a_b_spline() {
        let blend = |c: &[DVec3], t: f64| {
            let tt = [t * t * t, t * t, t, 1.0];
            let m = [[-1.0, 3.0, -3.0, 1.0], [3.0, -6.0, 3.0, 0.0], [-3.0, 0.0, 3.0, 0.0], [1.0, 4.0, 1.0, 0.0]];
            (0..4).map(|i| (0..4).map(|r| tt[r] * m[r][i]).sum::<f64>() / 6.0 * c[i]).sum::<DVec3>()
        };
        let (_dir, f, strands) = basis_scene("basis = \"bspline\"\nsegments_per_curve = 4\n");
        let (scene, _) = f.build().unwrap();
        let mut got = Vec::new();
        scene.fibers()[0].curves().each_segment(|a, b, r| got.push((a, b, r)));
        let mut want = Vec::new();
        for c in &strands {
            for span in 0..4 {
                for j in 0..4 {
                    let (t0, t1) = (f64::from(j) / 4.0, f64::from(j + 1) / 4.0);
                    want.push((blend(&c[span..span + 4], t0), blend(&c[span..span + 4], t1)));
                }
            }
        }
        assert_eq!(got.len(), want.len());
        for (k, ((a, b, r), (wa, wb))) in got.iter().zip(&want).enumerate() {
            assert!(a.distance(*wa) < 1e-6 && b.distance(*wb) < 1e-6, "segment {k}: {a} {b} vs {wa} {wb}");
            assert!((r - 0.01).abs() < 1e-8, "segment {k}: radius {r}");
        }
        // The spline does not pass through the points: the first segment starts off c₀ and c₁.
        assert!(got[0].0.distance(strands[0][0]) > 1e-3 && got[0].0.distance(strands[0][1]) > 1e-3);
        let (_dir, f, strands) = basis_scene("");
        let mut ends = Vec::new();
        f.build().unwrap().0.fibers()[0].curves().each_segment(|a, _, _| ends.push(a));
        assert_eq!(ends.len(), 12);
        assert!(ends[..6].iter().zip(&strands[0]).all(|(a, p)| a.distance(*p) < 1e-6));
        // The estimate counts the subdivided segments.
        let (_dir, f, _) = basis_scene("basis = \"catmull-rom\"\nsegments_per_curve = 5\n");
        assert_eq!(f.memory_estimate().unwrap().hair[0].segments, 2 * 4 * 5);
    }

    /// Bad `basis` values and strands that do not fit the basis are refused, naming the scene
    /// file, the line and column of the key and what is wrong; pbrt/USD files keep theirs.
    #[test]
    fn hair_basis_errors_name_the_scene_line() {
        let (_dir, f, _) = basis_scene("basis = \"cubic\"\n");
        let e = f.build().unwrap_err().to_string();
        assert!(e.contains("s.toml:12:9: hair: basis = \"cubic\" must be one of"), "{e}");
        // 7 points per strand fit Bézier (3k + 1, k = 2); 6 do not.
        let (_dir, f, _) = basis_scene("basis = \"bezier\"\n");
        assert!(f.build().is_ok());
        let e = err(&format!(
            "{CAMERA}[materials.h]\nmodel = \"chiang\"\n[[hair]]\nmaterial = \"h\"\nbasis = \"bezier\"\ngenerator = {{ strands = 2, segments = 5 }}\n"
        ))
        .to_string();
        assert!(
            e.starts_with("s.toml:11:9: hair: basis = \"bezier\": hair generator: strand 0 has 6 points: a Bézier strand needs 3k + 1 points"),
            "{e}"
        );
        let e = err(&format!(
            "{CAMERA}[materials.h]\nmodel = \"chiang\"\n[[hair]]\nmaterial = \"h\"\nbasis = \"bspline\"\ngenerator = {{ strands = 2, segments = 2 }}\n"
        ))
        .to_string();
        assert!(e.contains("s.toml:11:9: ") && e.contains("a B-spline strand needs at least 4 points"), "{e}");
        let (dir, _, _) = basis_scene("");
        std::fs::write(dir.path().join("c.usda"), "#usda 1.0\ndef BasisCurves \"c\" {\n uniform token type = \"cubic\"\n uniform token basis = \"bezier\"\n int[] curveVertexCounts = [4]\n point3f[] points = [(0,0,0), (0,1,0), (0,2,0), (0,3,0)]\n float[] widths = [0.1, 0.1, 0.1, 0.1]\n}\n").unwrap();
        let text = format!(
            "{CAMERA}[materials.h]\nmodel = \"chiang\"\n[[hair]]\nmaterial = \"h\"\nfile = \"c.usda\"\nbasis = \"bspline\"\n"
        );
        let path = dir.path().join("s.toml");
        let e = SceneFile::parse(&text, &path).unwrap().build().unwrap_err().to_string();
        assert!(
            e.contains("s.toml:12:9: hair: basis = \"bspline\" applies to .hair files")
                && e.contains("bezier curves of its own"),
            "{e}"
        );
    }

    /// `uv_scale` only where a model takes a position, finite and non-zero; such a material
    /// needs an OBJ with texture coordinates.
    #[test]
    fn uv_scale_is_refused_where_it_means_nothing() {
        for (material, says) in [
            ("lambert = [0.5, 0.5, 0.5]\nuv_scale = [2, 2]\n", "uv_scale is for surface models"),
            ("model = \"wood\"\nuv_scale = [2, 2]\n", "no position parameters"),
            ("model = \"irawan-2012\"\nuv_scale = [nan, 2]\n", "must be finite and non-zero"),
        ] {
            let e = err(&format!("{CAMERA}[materials.m]\n{material}")).to_string();
            assert!(e.starts_with("s.toml:") && e.contains(says), "{material}: {e}");
        }
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("t.obj"), "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\n").unwrap();
        let scene =
            format!("{CAMERA}[materials.m]\nmodel = \"irawan-2012\"\n[[mesh]]\nfile = \"t.obj\"\nmaterial = \"m\"\n");
        std::fs::write(dir.path().join("s.toml"), scene).unwrap();
        let e = SceneFile::read(&dir.path().join("s.toml")).unwrap().build().err().unwrap().to_string();
        assert!(e.contains("no texture coordinates"), "{e}");
    }

    #[test]
    fn non_finite_and_negative_scene_numbers_are_refused_where_they_are() {
        let base = format!("{CAMERA}[materials.m]\nlambert = [0.5, 0.5, 0.5]\n");
        for (extra, says) in [
            ("[[light]]\ntype = \"distant\"\ndirection = [0, 1, 0]\nirradiance = [1, nan, 1]\n", "distant: irradiance"),
            ("[[light]]\ntype = \"environment\"\nradiance = [0.1, -0.2, 0.3]\n", "environment: radiance"),
            (
                "[[light]]\ntype = \"sun\"\ndirection = [0, 1, 0]\nangular_radius_deg = 1\nirradiance = [-1, 1, 1]\n",
                "sun: irradiance",
            ),
            ("[[sphere]]\ncenter = [0, nan, 0]\nradius = 1\nmaterial = \"m\"\n", "sphere: center"),
            (
                "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\nemission = [1, inf, 1]\n",
                "sphere: emission",
            ),
            ("[[mesh]]\nfloor = nan\nmaterial = \"m\"\n", "mesh: floor"),
            ("[[mesh]]\nfloor = 0\nmaterial = \"m\"\nscale = nan\n", "mesh: scale = NaN is for OBJ files"),
            (
                "[[mesh]]\nfloor = 0\nmaterial = \"m\"\ntranslate = [0, 1, 0]\n",
                "mesh: translate = [0.0, 1.0, 0.0] is for",
            ),
            ("[[sphere]]\ncenter = [0, 0, 0]\nradius = -1e308\nmaterial = \"m\"\n", "sphere: radius = -1e308 must"),
            ("[[light]]\ntype = \"environment\"\nradiance = [1e308, -1, 0]\n", "= [1e308, -1.0, 0.0] must"),
            (
                "[[light]]\ntype = \"sun\"\ndirection = [0, 0, 0]\nangular_radius_deg = 1\nirradiance = [1, 1, 1]\n",
                "sun: direction must be non-zero",
            ),
        ] {
            let e = err(&format!("{base}{extra}")).to_string();
            assert!(e.starts_with("s.toml:") && e.contains(says), "{extra}: {e}");
        }
    }

    /// Each camera rule is reported alone: the message names the rule that failed and no other.
    #[test]
    fn camera_errors_name_only_the_rule_that_failed() {
        let camera = |eye: &str, up: &str, fov: &str, width: &str| {
            err(&format!(
                "[camera]\neye = {eye}\ntarget = [0, 0, 0]\nup = {up}\nfov = {fov}\nwidth = {width}\nheight = 8\n"
            ))
            .to_string()
        };
        let (eye, up) = ("[0, 0, 5]", "[0, 1, 0]");
        // Each error at the line of its key: eye 2, target 3, up 4, fov 5, width 6.
        for (e, at, says, not) in [
            (camera("[0, 0, 0]", up, "30", "8"), "s.toml:3:1:", "eye and target are both", "fov"),
            (camera(eye, "[0, 0, 2]", "30", "8"), "s.toml:4:1:", "parallel to the view", "fov"),
            (camera(eye, up, "180", "8"), "s.toml:5:1:", "fov = 180.0 must be in (0, 180) degrees", "up"),
            (camera(eye, up, "1e308", "8"), "s.toml:5:1:", "fov = 1e308 must", "width"),
            (camera(eye, up, "30", "0"), "s.toml:6:1:", "width and height must be > 0 (got 0 × 8)", "fov"),
            (camera("[0, nan, 5]", up, "30", "8"), "s.toml:2:1:", "eye = [0.0, NaN, 5.0] must be finite", "fov"),
            (camera("[1e300, 1e300, 5]", up, "30", "8"), "s.toml:2:1:", "too far apart", "must differ"),
        ] {
            assert!(e.starts_with(&format!("{at} camera: ")) && e.contains(says) && !e.contains(not), "{e}");
        }
        // A fourth number where three are meant is refused at its place, not dropped.
        let e = camera("[0, 0, 5, 7]", up, "30", "8");
        assert!(
            e.starts_with("s.toml:2:") && e.contains("invalid length 4, expected an array of three numbers"),
            "{e}"
        );
    }

    /// Strand diameters outside the accepted range (see `strand_diameters`) are errors naming
    /// the scene, the hair's source, the strand, the segment and the value.
    #[test]
    fn strand_diameters_out_of_range_name_source_strand_and_value() {
        let mats = "[materials.h]\nmodel = \"kajiya-kay\"\n";
        let e = err(&format!(
            "{CAMERA}{mats}[[hair]]\nmaterial = \"h\"\ngenerator = {{ strands = 3, root_diameter = 1e30 }}\n"
        ))
        .to_string();
        assert!(e.starts_with("s.toml:11:13: hair generator: strand 0, segment 0: diameter "), "{e}");
        assert!(e.contains("e29 is larger than 10 %"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let mut hair = HairParams { strands: 4, ..HairParams::default() }.generate().unwrap();
        hair.thickness.as_mut().unwrap().iter_mut().skip(25).take(2).for_each(|t| *t = 0.0);
        hair.write(&dir.path().join("thin.hair")).unwrap();
        let path = dir.path().join("s.toml");
        std::fs::write(&path, format!("{CAMERA}{mats}[[hair]]\nmaterial = \"h\"\nfile = \"thin.hair\"\n")).unwrap();
        let e = SceneFile::read(&path).unwrap().build().map(|_| ()).unwrap_err().to_string();
        assert!(e.contains("thin.hair: strand 1, segment 0: diameter 0.0 must be finite and > 0"), "{e}");
        assert!(e.contains(":11:8: hair file "), "{e}");
    }

    #[test]
    fn hair_override_needs_hair_and_bad_text_is_located() {
        let mut f = SceneFile::parse(CAMERA, Path::new("s.toml")).unwrap();
        let e = f.override_hair(PathBuf::from("h.hair")).unwrap_err().to_string();
        assert!(e.starts_with("s.toml: --hair h.hair: the scene has no [[hair]]"), "{e}");
        let mut d = SceneFile::default_scene();
        d.override_hair(PathBuf::from("h.hair")).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, b"[camera]\nfov = \xff30\n").unwrap();
        let e = SceneFile::read(&path).unwrap_err();
        assert_eq!((e.line, e.column), (2, 7), "{e}");
        assert!(e.to_string().contains("byte 15: not UTF-8"), "{e}");
        let e = SceneFile::read(&dir.path().join("none.toml")).unwrap_err().to_string();
        assert!(!e.contains(":0:0"), "{e}");
    }

    #[test]
    fn memory_estimate_counts_the_image_the_strands_and_their_bvh() {
        let mut f = SceneFile::default_scene();
        let e = f.memory_estimate().unwrap();
        // 512 × 512 pixels of 28 accumulator bytes and 15 of the written image.
        assert_eq!((e.width, e.height, e.image_bytes), (512, 512, Some(512 * 512 * (112 + 27))));
        // 20,000 generated strands of 24 segments: 25 points each of 40 bytes, 50 bytes per
        // strand, 1200 bytes per segment for the tubes and BVH.
        let h = &e.hair[0];
        assert_eq!((h.source.as_str(), h.strands, h.segments), ("generated", 20_000, 480_000));
        assert_eq!(h.hair_bytes, Some(20_000 * 25 * 40 + 20_000 * 50));
        assert_eq!(h.bvh_bytes, Some(480_000 * 1200));
        // A 100000×100000 camera and 4e9 strands are counted without overflow.
        f.desc.camera.get_mut().width = 100_000;
        f.desc.camera.get_mut().height = 100_000;
        f.desc.hair[0].get_mut().generator.as_mut().unwrap().get_mut().strands = 4_000_000_000;
        let e = f.memory_estimate().unwrap();
        assert_eq!(e.image_bytes, Some(10_000_000_000 * 139));
        assert_eq!(e.hair[0].segments, 96_000_000_000);
        // More than 2^22 segments are one BVH piece each: 160 bytes a segment.
        assert_eq!(e.hair[0].bvh_bytes, Some(96_000_000_000 * 160));
        // The largest camera does not fit u64: (2³² − 1)² · 139.
        f.desc.camera.get_mut().width = u32::MAX;
        f.desc.camera.get_mut().height = u32::MAX;
        assert_eq!(f.memory_estimate().unwrap().image_bytes, None);
    }

    #[test]
    fn memory_estimate_of_a_hair_file_reads_its_header_only() {
        let dir = tempfile::tempdir().unwrap();
        // A header claiming 1000 strands of 9 points, and no arrays: the estimate needs only
        // the header (the build would refuse the truncated file).
        let mut bytes = Vec::from(fiberlab_io::hair::MAGIC);
        for v in [1000u32, 9000, fiberlab_io::hair::FLAG_POINTS, 8] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        bytes.resize(fiberlab_io::hair::HEADER_BYTES, 0);
        std::fs::write(dir.path().join("h.hair"), &bytes).unwrap();
        let scene =
            format!("{CAMERA}[materials.h]\nmodel = \"diffuse\"\n[[hair]]\nmaterial = \"h\"\nfile = \"h.hair\"\n");
        let f = SceneFile::parse(&scene, &dir.path().join("s.toml")).unwrap();
        let h = &f.memory_estimate().unwrap().hair[0];
        assert_eq!((h.strands, h.segments), (1000, 8000));
        // Twice the file: 128 header bytes and 12 per point.
        assert_eq!(h.hair_bytes, Some(2 * (128 + 9000 * 12)));
        assert_eq!(h.bvh_bytes, Some(8000 * 1200));
        let f = SceneFile::parse(&scene.replace("h.hair", "missing.hair"), &dir.path().join("s.toml")).unwrap();
        let e = f.memory_estimate().unwrap_err().to_string();
        assert!(e.contains("missing.hair") && e.contains("s.toml:"), "{e}");
    }

    #[test]
    fn the_default_scenes_commented_integrator_keys_parse_when_uncommented() {
        // The template lists `integrator` and `fiber_count` as comments; with the comment marks
        // removed (and the other values they name) the scene must still parse.
        let open = DEFAULT_SCENE.replace("# integrator = \"path\"", "integrator = \"dual-scattering\"");
        let open = open.replace("# fiber_count = \"exact\"", "fiber_count = \"grid\"");
        assert_ne!(open, DEFAULT_SCENE);
        let f = SceneFile::parse(&open, Path::new("<test>")).unwrap();
        assert_eq!(f.render_settings().integrator, "dual-scattering");
        assert_eq!(f.render_settings().fiber_count, "grid");
    }

    #[test]
    fn default_scene_parses_and_builds_small() {
        let mut f = SceneFile::default_scene();
        // Shrink the generated hair for the test.
        if let Some(g) = f.desc.hair[0].get_mut().generator.as_mut() {
            g.get_mut().strands = 200;
        }
        let (scene, settings) = f.build().unwrap();
        assert_eq!(scene.fibers().len(), 1);
        assert_eq!(scene.fibers()[0].curves().strand_count(), 200);
        assert_eq!(scene.lights().len(), 2);
        assert_eq!(settings.max_depth, 64);
    }

    #[test]
    fn example_scenes_in_the_repository_build() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
        let made = tempfile::tempdir().unwrap();
        for entry in std::fs::read_dir(&dir).unwrap() {
            let mut path = entry.unwrap().path();
            // Scenes only (not the meshes and textures they use).
            if path.extension().is_none_or(|e| e != "toml") {
                continue;
            }
            // The explicit woven patch's fibers are made by `fiberlab mesh cloth-patch` and not
            // kept in the repository: that scene builds on one repeat of the default patch, made here.
            let text = std::fs::read_to_string(&path).unwrap();
            if text.contains("file = \"cloth_patch.usda\"") && !dir.join("cloth_patch.usda").exists() {
                let fibers = fiberlab_procedural::woven_patch::WovenPatch::default().fibers(1, 1).unwrap();
                fiberlab_io::strand_files::write(&made.path().join("cloth_patch.usda"), &fibers.strands(), 1).unwrap();
                path = made.path().join(path.file_name().unwrap());
                std::fs::write(&path, &text).unwrap();
            }
            // Likewise the grass ribbons of `fiberlab hair generate --style grass` (100 blades).
            if text.contains("file = \"grass_ribbons.usda\"") && !dir.join("grass_ribbons.usda").exists() {
                let blades = GrassParams { blades: 100, ..GrassParams::default() }.strands().unwrap();
                fiberlab_io::strand_files::write(&made.path().join("grass_ribbons.usda"), &blades, 1).unwrap();
                path = made.path().join(path.file_name().unwrap());
                std::fs::write(&path, &text).unwrap();
            }
            let mut f = SceneFile::read(&path).unwrap_or_else(|e| panic!("{e}"));
            for h in &mut f.desc.hair {
                if let Some(g) = h.get_mut().generator.as_mut() {
                    g.get_mut().strands = 100;
                }
                if let Some(c) = h.get_mut().cotton.as_mut() {
                    c.get_mut().fibers = 100;
                }
            }
            f.build().unwrap_or_else(|e| panic!("{e}"));
        }
    }

    #[test]
    fn syntax_error_has_line_and_column() {
        let e = err(&format!("{CAMERA}[render]\nspp = \"many\"\n"));
        assert_eq!((e.line, e.path.to_str().unwrap()), (8, "s.toml"), "{e}");
        assert!(e.to_string().starts_with("s.toml:8:"), "{e}");
    }

    #[test]
    fn render_section_numbers_are_checked() {
        let e = err(&format!("{CAMERA}[render]\nspp = 0\n"));
        assert!(e.line == 7 && e.to_string().contains("render: spp = 0; give at least 1"), "{e}");
        let e = err(&format!("{CAMERA}[render]\nexposure = nan\n"));
        assert!(e.line == 7 && e.to_string().contains("exposure = NaN stops must be finite"), "{e}");
        let f = SceneFile::parse(&format!("{CAMERA}[render]\nspp = 3\n"), Path::new("s.toml")).unwrap();
        assert_eq!((f.render_settings().spp, f.render_settings().max_depth), (3, 64));
        let e = err(&format!("{CAMERA}[render]\nintegrator = \"photon\"\n"));
        assert!(e.to_string().contains("integrator = \"photon\""), "{e}");
        let e = err(&format!("{CAMERA}[render]\nfiber_count = \"guess\"\n"));
        assert!(e.to_string().contains("unknown fiber count `guess`"), "{e}");
        let f = SceneFile::parse(
            &format!("{CAMERA}[render]\nintegrator = \"dual-scattering\"\nfiber_count = \"grid\"\n"),
            Path::new("s.toml"),
        )
        .unwrap();
        assert_eq!(
            (f.render_settings().integrator.as_str(), f.render_settings().fiber_count.as_str()),
            ("dual-scattering", "grid")
        );
    }

    #[test]
    fn unknown_key_is_named() {
        let e = err(&format!("{CAMERA}[render]\nsppp = 3\n"));
        assert!(e.to_string().contains("sppp") && e.line == 8, "{e}");
    }

    #[test]
    fn bad_model_and_parameter_are_named_with_location() {
        let e = err(&format!("{CAMERA}[materials.h]\nmodel = \"nope\"\n"));
        assert!(e.to_string().contains("nope") && e.line == 8 && e.column == 9, "{e}");
        let e = err(&format!("{CAMERA}[materials.h]\nmodel = \"diffuse\"\nparams = {{ albedo = 3 }}\n"));
        assert!(e.to_string().contains("albedo") && e.line == 9, "{e}");
        let e = err(&format!("{CAMERA}[materials.h]\nmodel = \"diffuse\"\nparams = {{ colour = 0.3 }}\n"));
        assert!(e.to_string().contains("colour"), "{e}");
    }

    #[test]
    fn envmap_obj_and_hair_files_resolve_relative_to_the_scene() {
        let dir = tempfile::tempdir().unwrap();
        let sky = LinearImage::from_pixels(8, 4, (0..32).map(|i| [i as f32 * 0.1, 0.5, 0.2]).collect()).unwrap();
        sky.write_exr(&dir.path().join("sky.exr")).unwrap();
        std::fs::write(dir.path().join("q.obj"), "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n").unwrap();
        let hair = HairParams { strands: 20, ..HairParams::default() }.generate().unwrap();
        hair.write(&dir.path().join("h.hair")).unwrap();
        let text = format!(
            "{CAMERA}[materials.h]\nmodel = \"chiang\"\nparams = {{ eumelanin = 0.5 }}\n[materials.s]\nmirror = [0.9, 0.9, 0.9]\n\
             [[hair]]\nmaterial = \"h\"\nfile = \"h.hair\"\n[[mesh]]\nfile = \"q.obj\"\nmaterial = \"s\"\n\
             [[sphere]]\ncenter = [0, 5, 0]\nradius = 0.5\nmaterial = \"s\"\nemission = [10, 10, 10]\n\
             [[light]]\ntype = \"envmap\"\nfile = \"sky.exr\"\nscale = 2.0\n"
        );
        let path = dir.path().join("s.toml");
        std::fs::write(&path, text).unwrap();
        let (scene, _) = SceneFile::read(&path).unwrap().build().unwrap();
        assert_eq!(scene.fibers()[0].curves().strand_count(), 20);
        assert_eq!(scene.meshes()[0].mesh().len(), 1);
        assert_eq!(scene.lights().len(), 1, "the envmap; the emitting sphere is a sphere");
        assert!(matches!(scene.lights()[0], Light::Map(_)));
        let light = scene.spheres()[0].light().expect("the sphere emits");
        assert_eq!((light.center, light.radius, light.radiance), (DVec3::new(0.0, 5.0, 0.0), 0.5, Rgb::splat(10.0)));
        let p = scene.light_picker();
        assert!(
            p.sphere_probability(0) > 0.0 && (p.sphere_probability(0) + p.light_probability(0) - 1.0).abs() < 1e-12
        );
    }

    #[test]
    fn unknown_material_reference_and_missing_file() {
        let e = err(&format!("{CAMERA}[[sphere]]\ncenter = [0,0,0]\nradius = 1\nmaterial = \"skin\"\n"));
        assert!(e.to_string().contains("unknown material `skin`") && e.line == 10, "{e}");
        let e = err(&format!(
            "{CAMERA}[materials.h]\nmodel = \"diffuse\"\n[[hair]]\nmaterial = \"h\"\nfile = \"no.hair\"\n"
        ));
        assert!(e.to_string().contains("no.hair") && e.line == 11, "{e}");
    }

    #[test]
    fn distant_light_needs_a_direction() {
        let e = err(&format!("{CAMERA}[[light]]\ntype = \"distant\"\ndirection = [0, 0, 0]\nirradiance = [1, 1, 1]\n"));
        assert!(e.to_string().contains("distant: direction") && e.line == 7, "{e}");
        let e = err(&format!("{CAMERA}[[light]]\ntype = \"distant\"\ndirection = [0, 1, 0]\n"));
        assert!(e.to_string().contains("irradiance"), "{e}");
    }

    /// A fiber model on a sphere or mesh, or a surface on hair, is an error at the reference,
    /// naming the file, line and both kinds (a scene cannot hold such a pairing).
    #[test]
    fn materials_of_the_wrong_kind_are_errors_at_their_reference() {
        let mats = "[materials.h]\nmodel = \"kajiya-kay\"\n[materials.s]\nlambert = [0.5, 0.5, 0.5]\n";
        let e = err(&format!("{CAMERA}{mats}[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"h\"\n"));
        assert!(e.to_string().starts_with("s.toml:14:12:"), "{e}");
        assert!(
            e.to_string().contains("`h` is a fiber model")
                && e.to_string().contains("lambert, mirror or a surface model"),
            "{e}"
        );
        let e = err(&format!("{CAMERA}{mats}[[mesh]]\nfloor = 0\nmaterial = \"h\"\n"));
        assert!(e.line == 13 && e.to_string().contains("`h` is a fiber model"), "{e}");
        let e = err(&format!("{CAMERA}{mats}[[hair]]\nmaterial = \"s\"\ngenerator = {{ strands = 2 }}\n"));
        assert!(e.line == 12 && e.to_string().contains("`s` is a surface"), "{e}");
    }

    /// Arrays and booleans in `params` mean what the same values mean on the command line:
    /// `lobes = ["r", "tt"]` ≡ `lobes=r,tt`, `glints = false` ≡ `glints=off`.
    #[test]
    fn model_params_arrays_and_booleans_convert_like_the_command_line() {
        let text = format!(
            "{CAMERA}[materials.h]\nmodel = \"marschner\"\nparams = {{ lobes = [\"r\", \"tt\"], glints = false, beta_r = 7 }}\n\
             [[hair]]\nmaterial = \"h\"\ngenerator = {{ strands = 2 }}\n"
        );
        let (scene, _) = SceneFile::parse(&text, Path::new("s.toml")).unwrap().build().unwrap();
        let from_text =
            fiberlab_scatter::build("marschner", &[("lobes", "r,tt"), ("glints", "off"), ("beta_r", "7")]).unwrap();
        let id = scene.fibers()[0].material();
        assert_eq!(format!("{:?}", scene.fiber_model(id)), format!("{from_text:?}"));
        let e = err(&format!("{CAMERA}[materials.h]\nmodel = \"marschner\"\nparams = {{ lobes = [\"r\", \"x\"] }}\n"));
        assert!(e.line == 9 && e.to_string().contains("lobes"), "{e}");
        let e = err(&format!("{CAMERA}[materials.h]\nmodel = \"marschner\"\nparams = {{ lobes = {{ r = 1 }} }}\n"));
        assert!(e.line == 9 && e.to_string().contains("`lobes`"), "{e}");
    }
}
