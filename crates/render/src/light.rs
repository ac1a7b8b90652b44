//! Lights: a constant environment, a lat-long environment map with importance sampling, a
//! distant sun with an angular radius, a delta distant light, spherical area lights
//! ([`SphereLight`], the emission of a scene's sphere) and the light picker of next-event
//! estimation ([`LightPicker`]).
//!
//! Every light can be sampled from a point (`sample`, density per steradian) and report the
//! density of a given direction (`pdf`), which the integrator needs for MIS.
//!
//! Environment map convention: `y` is up; a direction `d` maps to the polar angle
//! `θ = acos(d.y)` (row, top row = +y) and azimuth `φ = atan2(d.z, d.x)` (column
//! `(φ + π)/(2π)` of the width).

use fiberlab_io::LinearImage;
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::{PI, TAU};

/// A light sample seen from a point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction toward the light.
    pub wi: DVec3,
    /// Distance to the emitting surface (∞ for distant lights).
    pub distance: f64,
    /// Emitted radiance along `−wi`; for a delta light, the irradiance it delivers on a
    /// surface facing it.
    pub radiance: Rgb,
    /// Density of `wi` per steradian (1 for a delta light: the sample is certain).
    pub pdf: f64,
    /// True for a delta light: no other strategy can find it, so no MIS.
    pub delta: bool,
}

/// A lat-long environment map with a 2D piecewise-constant sampling distribution.
#[derive(Clone, Debug)]
pub struct EnvironmentMap {
    image: LinearImage,
    scale: Rgb,
    /// Per row: the conditional CDF over columns (width + 1 entries).
    conditional: Vec<Vec<f64>>,
    /// CDF over rows (height + 1 entries).
    marginal: Vec<f64>,
    /// Σ of all cell weights (normalization).
    total: f64,
    weights: Vec<f64>,
}

fn cdf(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut out = vec![0.0];
    let mut acc = 0.0;
    for v in values {
        acc += v;
        out.push(acc);
    }
    out
}

/// Index `i` with `c[i] ≤ x < c[i+1]` in a non-decreasing CDF (skipping empty cells).
fn find(c: &[f64], x: f64) -> usize {
    let i = c.partition_point(|&v| v <= x);
    i.clamp(1, c.len() - 1) - 1
}

impl EnvironmentMap {
    /// A map from an image, multiplied by `scale`.
    #[must_use]
    pub fn new(image: LinearImage, scale: Rgb) -> Self {
        let (w, h) = (image.width(), image.height());
        let mut weights = Vec::with_capacity(w * h);
        for y in 0..h {
            let sin_theta = (PI * (y as f64 + 0.5) / h as f64).sin();
            for x in 0..w {
                let p = image.get(x, y);
                let lum = Rgb::new(p[0].into(), p[1].into(), p[2].into()) * scale;
                weights.push(lum.average().max(0.0) * sin_theta);
            }
        }
        let conditional: Vec<Vec<f64>> = (0..h).map(|y| cdf(weights[y * w..(y + 1) * w].iter().copied())).collect();
        let marginal = cdf(conditional.iter().map(|c| c[w]));
        let total = marginal[h];
        Self { image, scale, conditional, marginal, total, weights }
    }

    fn cell(&self, d: DVec3) -> (usize, usize) {
        let (w, h) = (self.image.width(), self.image.height());
        let theta = d.y.clamp(-1.0, 1.0).acos();
        let phi = d.z.atan2(d.x);
        let x = (((phi + PI) / TAU) * w as f64) as usize;
        let y = ((theta / PI) * h as f64) as usize;
        (x.min(w - 1), y.min(h - 1))
    }

    /// Width and height in cells (pixels).
    #[must_use]
    pub fn size(&self) -> (usize, usize) {
        (self.image.width(), self.image.height())
    }

    /// The radiance of cell (x, y) (the pixel times the scale).
    #[must_use]
    pub fn cell_radiance(&self, x: usize, y: usize) -> Rgb {
        let p = self.image.get(x, y);
        Rgb::new(p[0].into(), p[1].into(), p[2].into()) * self.scale
    }

    /// The probability that [`EnvironmentMap::sample`] picks cell (x, y).
    #[must_use]
    pub fn cell_probability(&self, x: usize, y: usize) -> f64 {
        if self.total > 0.0 { self.weights[y * self.image.width() + x] / self.total } else { 0.0 }
    }

    /// The CDF over rows (height + 1 entries, the last the total weight).
    #[must_use]
    pub fn row_cdf(&self) -> &[f64] {
        &self.marginal
    }

    /// Row `y`'s CDF over columns (width + 1 entries, the last the row's weight).
    #[must_use]
    pub fn column_cdf(&self, y: usize) -> &[f64] {
        &self.conditional[y]
    }

    /// Radiance arriving from direction `d` (toward the environment).
    #[must_use]
    pub fn radiance(&self, d: DVec3) -> Rgb {
        let (x, y) = self.cell(d);
        let p = self.image.get(x, y);
        Rgb::new(p[0].into(), p[1].into(), p[2].into()) * self.scale
    }

    /// Density per steradian of [`EnvironmentMap::sample`] returning `d`.
    #[must_use]
    pub fn pdf(&self, d: DVec3) -> f64 {
        if self.total <= 0.0 {
            return 0.0;
        }
        let (w, h) = (self.image.width(), self.image.height());
        let (x, y) = self.cell(d);
        let sin_theta = (PI * (y as f64 + 0.5) / h as f64).sin();
        // Cell probability × cells per unit (u, v) area / Jacobian 2π²·sinθ (uniform in the
        // cell's u, v; the cell's sinθ is the constant used in its weight).
        let p_cell = self.weights[y * w + x] / self.total;
        p_cell * (w * h) as f64 / (2.0 * PI * PI * sin_theta)
    }

    /// Radiance averaged over the sphere of directions (channel mean).
    #[must_use]
    pub fn mean_radiance(&self) -> f64 {
        // Cell weights are mean radiance × sinθ; a cell spans (2π/w)(π/h) in (φ, θ).
        let (w, h) = (self.image.width() as f64, self.image.height() as f64);
        self.total * 2.0 * PI * PI / (w * h) / (4.0 * PI)
    }

    /// Draws a direction with density proportional to the map's luminance.
    #[must_use]
    pub fn sample(&self, u: [f64; 2]) -> Option<LightSample> {
        if self.total <= 0.0 {
            return None;
        }
        let (w, h) = (self.image.width(), self.image.height());
        let ty = u[0] * self.total;
        let y = find(&self.marginal, ty);
        let row = &self.conditional[y];
        let tx = u[1] * row[w];
        let x = find(row, tx);
        let fy = ((ty - self.marginal[y]) / (self.marginal[y + 1] - self.marginal[y])).clamp(0.0, 1.0);
        let fx = ((tx - row[x]) / (row[x + 1] - row[x])).clamp(0.0, 1.0);
        // Uniform within the cell in (u, v) for the same pdf as `pdf` uses; keep away from the
        // cell edges so the direction maps back to the same cell.
        let uu = (x as f64 + fx.clamp(1e-6, 1.0 - 1e-6)) / w as f64;
        let vv = (y as f64 + fy.clamp(1e-6, 1.0 - 1e-6)) / h as f64;
        let theta = PI * vv;
        let phi = TAU * uu - PI;
        let wi = DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
        let pdf = self.pdf(wi);
        (pdf > 0.0).then(|| LightSample { wi, distance: f64::INFINITY, radiance: self.radiance(wi), pdf, delta: false })
    }
}

/// A light at infinity (environments, suns, distant lights); an emitting sphere is a
/// [`crate::scene::Sphere`] with emission, whose light is a [`SphereLight`].
#[derive(Clone, Debug)]
pub enum Light {
    /// Uniform radiance from every direction.
    Constant {
        /// Radiance.
        radiance: Rgb,
    },
    /// A lat-long environment map.
    Map(Box<EnvironmentMap>),
    /// A distant disc of angular radius `acos(cos_max)` around `direction`.
    Sun {
        /// Unit direction toward the sun.
        direction: DVec3,
        /// Cosine of the angular radius.
        cos_max: f64,
        /// Radiance of the disc.
        radiance: Rgb,
    },
    /// Parallel light from one direction (a delta distribution: Mitsuba's `directional`, a
    /// Cycles sun of angle 0); rays never hit it.
    Distant {
        /// Unit direction toward the light.
        direction: DVec3,
        /// Irradiance on a surface facing the light.
        irradiance: Rgb,
    },
}

/// The emission of an emitting sphere of the scene: uniform radiance over its surface. Not
/// stored: made on demand from the sphere (its one description, see
/// [`crate::scene::Sphere::light`]), so geometry and light cannot disagree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereLight {
    /// Centre.
    pub center: DVec3,
    /// Radius.
    pub radius: f64,
    /// Radiance.
    pub radiance: Rgb,
}

impl SphereLight {
    /// Weight in next-event light selection: π × L, the irradiance at the sphere's surface.
    #[must_use]
    pub fn selection_weight(&self) -> f64 {
        (PI * self.radiance.average()).max(0.0)
    }

    /// Samples a direction toward the sphere from `p`: uniform in the cone it subtends.
    #[must_use]
    pub fn sample(&self, p: DVec3, u: [f64; 2]) -> Option<LightSample> {
        let (center, radius) = (self.center, self.radius);
        let to = center - p;
        let d2 = to.length_squared();
        if d2 <= radius * radius {
            return None;
        }
        let cos_max = (1.0 - radius * radius / d2).max(0.0).sqrt();
        let axis = to / d2.sqrt();
        let wi = sample_cone(axis, cos_max, u);
        let distance = fiberlab_geometry::shapes::sphere_entry(p, wi, center, radius)?;
        Some(LightSample { wi, distance, radiance: self.radiance, pdf: cone_pdf(cos_max), delta: false })
    }

    /// Density per steradian with which [`SphereLight::sample`] from `p` returns `wi`.
    #[must_use]
    pub fn pdf(&self, p: DVec3, wi: DVec3) -> f64 {
        let (center, radius) = (self.center, self.radius);
        let to = center - p;
        let d2 = to.length_squared();
        if d2 <= radius * radius {
            return 0.0;
        }
        let cos_max = (1.0 - radius * radius / d2).max(0.0).sqrt();
        if wi.dot(to / d2.sqrt()) >= cos_max { cone_pdf(cos_max) } else { 0.0 }
    }
}

/// One source of next-event estimation: a light at infinity (index into the scene's lights)
/// or an emitting sphere (index into its spheres).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Emitter {
    /// `Scene::lights()[i]`.
    Light(usize),
    /// `Scene::spheres()[i]`, which emits.
    Sphere(usize),
}

/// Chooses the emitter for next-event estimation with probability proportional to its
/// selection weight (uniformly when every weight is zero). Built once per scene.
#[derive(Clone, Debug)]
pub struct LightPicker {
    /// Every emitter with its selection probability, in picking order.
    emitters: Vec<(Emitter, f64)>,
    /// Selection probability per light / per sphere (0 for spheres that do not emit).
    light_probability: Vec<f64>,
    sphere_probability: Vec<f64>,
}

impl LightPicker {
    /// The picker for emitters with their selection weights, in picking order; `lights` and
    /// `spheres` are the lengths of the scene's lists the emitters index.
    #[must_use]
    pub fn new(weighted: &[(Emitter, f64)], lights: usize, spheres: usize) -> Self {
        let total: f64 = weighted.iter().map(|(_, w)| *w).sum();
        let uniform = if weighted.is_empty() { 0.0 } else { 1.0 / weighted.len() as f64 };
        let emitters: Vec<(Emitter, f64)> =
            weighted.iter().map(|&(e, w)| (e, if total > 0.0 { w / total } else { uniform })).collect();
        let (mut light_probability, mut sphere_probability) = (vec![0.0; lights], vec![0.0; spheres]);
        for &(e, p) in &emitters {
            match e {
                Emitter::Light(i) => light_probability[i] = p,
                Emitter::Sphere(i) => sphere_probability[i] = p,
            }
        }
        Self { emitters, light_probability, sphere_probability }
    }

    /// Probability that `pick` returns light `i`.
    #[must_use]
    pub fn light_probability(&self, i: usize) -> f64 {
        self.light_probability[i]
    }

    /// Probability that `pick` returns sphere `i` (0 when it does not emit).
    #[must_use]
    pub fn sphere_probability(&self, i: usize) -> f64 {
        self.sphere_probability[i]
    }

    /// An emitter and its selection probability, from one uniform.
    #[must_use]
    pub fn pick(&self, u: f64) -> Option<(Emitter, f64)> {
        let mut acc = 0.0;
        for &(e, p) in &self.emitters {
            acc += p;
            if u < acc && p > 0.0 {
                return Some((e, p));
            }
        }
        // Rounding left u above the last sum: the last emitter with a chance.
        self.emitters.iter().rev().copied().find(|&(_, p)| p > 0.0)
    }
}

fn cone_pdf(cos_max: f64) -> f64 {
    1.0 / (TAU * (1.0 - cos_max))
}

/// A uniform direction in the cone of half-angle acos(cos_max) around `axis`.
fn sample_cone(axis: DVec3, cos_max: f64, u: [f64; 2]) -> DVec3 {
    let cos_t = 1.0 - u[0] * (1.0 - cos_max);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let (b1, b2) = axis.any_orthonormal_pair();
    let phi = TAU * u[1];
    (axis * cos_t + (b1 * phi.cos() + b2 * phi.sin()) * sin_t).normalize()
}

impl Light {
    /// A sun of angular radius `radius_rad` whose disc delivers irradiance `irradiance` on a
    /// surface facing it: radiance `E/(π sin²α)` (the cosine-weighted solid angle of the disc).
    #[must_use]
    pub fn sun(direction: DVec3, radius_rad: f64, irradiance: Rgb) -> Self {
        let s = radius_rad.sin();
        Light::Sun { direction: direction.normalize(), cos_max: radius_rad.cos(), radiance: irradiance / (PI * s * s) }
    }

    /// Weight in next-event light selection: the irradiance the light delivers on a surface
    /// facing it (π × mean radiance for environments, `E` for a sun or distant light),
    /// averaged over colour channels (see also [`SphereLight::selection_weight`]).
    #[must_use]
    pub fn selection_weight(&self) -> f64 {
        match self {
            Light::Constant { radiance } => PI * radiance.average(),
            Light::Map(m) => PI * m.mean_radiance(),
            Light::Sun { cos_max, radiance, .. } => PI * (1.0 - cos_max * cos_max) * radiance.average(),
            Light::Distant { irradiance, .. } => irradiance.average(),
        }
        .max(0.0)
    }

    /// Radiance from an infinite light along escaping direction `d`.
    #[must_use]
    pub fn escaped(&self, d: DVec3) -> Rgb {
        match self {
            Light::Constant { radiance } => *radiance,
            Light::Map(m) => m.radiance(d),
            Light::Sun { direction, cos_max, radiance } => {
                if d.dot(*direction) >= *cos_max {
                    *radiance
                } else {
                    Rgb::ZERO
                }
            }
            Light::Distant { .. } => Rgb::ZERO,
        }
    }

    /// Samples a direction toward the light (the same from every point: it is at infinity).
    #[must_use]
    pub fn sample(&self, u: [f64; 2]) -> Option<LightSample> {
        match self {
            Light::Constant { radiance } => {
                let z = 1.0 - 2.0 * u[0];
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = TAU * u[1];
                let wi = DVec3::new(r * phi.cos(), z, r * phi.sin());
                Some(LightSample {
                    wi,
                    distance: f64::INFINITY,
                    radiance: *radiance,
                    pdf: 1.0 / (4.0 * PI),
                    delta: false,
                })
            }
            Light::Map(m) => m.sample(u),
            Light::Sun { direction, cos_max, radiance } => Some(LightSample {
                wi: sample_cone(*direction, *cos_max, u),
                distance: f64::INFINITY,
                radiance: *radiance,
                pdf: cone_pdf(*cos_max),
                delta: false,
            }),
            Light::Distant { direction, irradiance } => Some(LightSample {
                wi: *direction,
                distance: f64::INFINITY,
                radiance: *irradiance,
                pdf: 1.0,
                delta: true,
            }),
        }
    }

    /// Density per steradian with which [`Light::sample`] returns `wi`.
    #[must_use]
    pub fn pdf(&self, wi: DVec3) -> f64 {
        match self {
            Light::Constant { .. } => 1.0 / (4.0 * PI),
            Light::Map(m) => m.pdf(wi),
            Light::Sun { direction, cos_max, .. } => {
                if wi.dot(*direction) >= *cos_max {
                    cone_pdf(*cos_max)
                } else {
                    0.0
                }
            }
            Light::Distant { .. } => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn environment_map_pdf_integrates_to_one_and_matches_samples() {
        let (w, h) = (16, 8);
        let px = (0..w * h).map(|i| if i % 7 == 0 { [5.0, 4.0, 3.0] } else { [0.1, 0.2, 0.3] }).collect();
        let map = EnvironmentMap::new(LinearImage::from_pixels(w, h, px).unwrap(), Rgb::ONE);
        // ∫ pdf dω by a fine midpoint rule in (θ, φ).
        let (nt, np) = (400, 800);
        let mut integral = 0.0;
        for i in 0..nt {
            let t = PI * (i as f64 + 0.5) / nt as f64;
            for j in 0..np {
                let p = TAU * (j as f64 + 0.5) / np as f64 - PI;
                let d = DVec3::new(t.sin() * p.cos(), t.cos(), t.sin() * p.sin());
                integral += map.pdf(d) * t.sin() * (PI / nt as f64) * (TAU / np as f64);
            }
        }
        assert!((integral - 1.0).abs() < 1e-2, "∫pdf = {integral}");
        // Samples land in cells with the frequency the pdf predicts (bright cell 0).
        let mut g = fiberlab_procedural::generator::SplitMix64::new(3);
        let n = 200_000;
        let bright = (0..n)
            .filter(|_| {
                let s = map.sample([g.next_f64(), g.next_f64()]).unwrap();
                assert!((s.pdf - map.pdf(s.wi)).abs() < 1e-9 * s.pdf);
                map.cell(s.wi) == (0, 0)
            })
            .count();
        let expected = map.weights[0] / map.total;
        let got = bright as f64 / n as f64;
        assert!((got - expected).abs() < 5.0 * (expected / n as f64).sqrt() + 1e-4, "{got} vs {expected}");
    }

    #[test]
    fn sun_delivers_its_irradiance() {
        let sun = Light::sun(DVec3::Y, 0.02, Rgb::splat(3.0));
        // E = ∫_cone L cosθ dω, by Monte Carlo over the light's own samples.
        let mut g = fiberlab_procedural::generator::SplitMix64::new(1);
        let n = 20000;
        let mut e = 0.0;
        for _ in 0..n {
            let s = sun.sample([g.next_f64(), g.next_f64()]).unwrap();
            e += s.radiance[0] * s.wi.y / s.pdf;
        }
        assert!((e / n as f64 - 3.0).abs() < 1e-3, "{}", e / n as f64);
    }

    /// Light selection follows the irradiance weights: a distant light of E = 3 against a sky
    /// of L = 0.5 (π L ≈ 1.57) is picked with probability 3/4.57, and `pick` agrees with the
    /// probabilities; black lights only are picked uniformly; a sphere of radiance L has
    /// weight π L.
    #[test]
    fn lights_are_picked_in_proportion_to_their_irradiance() {
        let lights = [
            Light::Constant { radiance: Rgb::splat(0.5) },
            Light::Distant { direction: DVec3::Y, irradiance: Rgb::splat(3.0) },
        ];
        let weighted: Vec<(Emitter, f64)> =
            lights.iter().enumerate().map(|(i, l)| (Emitter::Light(i), l.selection_weight())).collect();
        let picker = LightPicker::new(&weighted, 2, 0);
        let expected = 3.0 / (3.0 + 0.5 * PI);
        assert!((picker.light_probability(1) - expected).abs() < 1e-12);
        let n = 100_000;
        let picked = (0..n)
            .filter(|i| {
                let (e, p) = picker.pick((f64::from(*i) + 0.5) / f64::from(n)).unwrap();
                let Emitter::Light(k) = e else { panic!("{e:?}") };
                assert_eq!(p, picker.light_probability(k));
                k == 1
            })
            .count();
        assert!((picked as f64 / f64::from(n) - expected).abs() < 1e-4);
        let dark =
            [(Emitter::Light(0), 0.0), (Emitter::Sphere(0), 0.0), (Emitter::Sphere(2), 0.0), (Emitter::Light(1), 0.0)];
        let picker = LightPicker::new(&dark, 2, 3);
        assert_eq!((picker.light_probability(1), picker.sphere_probability(2)), (0.25, 0.25));
        assert_eq!(picker.sphere_probability(1), 0.0, "a sphere that does not emit");
        let sphere = SphereLight { center: DVec3::ZERO, radius: 1.0, radiance: Rgb::splat(2.0) };
        assert!((sphere.selection_weight() - 2.0 * PI).abs() < 1e-12);
    }
}
