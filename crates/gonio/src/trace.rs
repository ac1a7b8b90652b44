//! Tracing one ray through the explicit fiber: Fresnel splitting at every interface by
//! stochastic branch selection (reflect with probability F, so weights stay 1; on a rough
//! outer interface at a visible microfacet normal, with the masking weight of
//! [`crate::interface`]), total internal reflection, path-length absorption, Henyey–Greenstein scattering in the
//! medulla, refraction at a lumen's boundary, and classification of the path by its sequence
//! of events at the outer surface (events at the medulla's or lumen's boundary do not change
//! the class: a TT path is one that entered and left the fiber without an internal
//! reflection at the outer surface, whatever it met inside).

use crate::fiber::{Fiber, SurfaceKind};
use crate::interface::{Crossing, cross};
use crate::surface::Surface;
use fiberlab_math::microfacet::Ggx;
use fiberlab_math::phase::sample_henyey_greenstein;
use fiberlab_math::{DVec3, FiberFrame, Rgb, fresnel};
use rand::Rng;
use std::f64::consts::TAU;

/// Path classes (p = 0, 1, 2 and the rest; docs/theory/hair.md, "Lobes and notation").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    /// One external reflection.
    R = 0,
    /// Refract in, refract out.
    TT = 1,
    /// Refract in, one internal reflection, refract out.
    TRT = 2,
    /// Any other sequence without medulla scattering.
    Higher = 3,
    /// At least one scattering event in the medulla.
    Medulla = 4,
}

impl Lobe {
    /// All classes, in index order.
    pub const ALL: [Lobe; 5] = [Lobe::R, Lobe::TT, Lobe::TRT, Lobe::Higher, Lobe::Medulla];

    /// Lower-case name used in tables (`r`, `tt`, `trt`, `higher`, `medulla`).
    #[must_use]
    pub fn name(self) -> &'static str {
        ["r", "tt", "trt", "higher", "medulla"][self as usize]
    }
}

/// A ray leaving the fiber for good.
#[derive(Clone, Copy, Debug)]
pub struct Exit {
    /// Exit direction (unit, fiber frame).
    pub direction: DVec3,
    /// Throughput after absorption.
    pub weight: Rgb,
    /// Path class.
    pub lobe: Lobe,
}

/// Outcome of one traced ray.
#[derive(Clone, Copy, Debug)]
pub enum Outcome {
    /// The ray missed the fiber.
    Missed,
    /// The path exceeded [`MAX_EVENTS`] interactions and was dropped (its power is lost).
    Dropped,
    /// The ray left the fiber.
    Exit(Exit),
    /// A rough interface sent the path back into its microsurface (single-scattering
    /// microfacet loss, [`crate::interface::Crossing::Masked`]); its power is lost.
    Masked,
}

/// Interactions after which a path is dropped (reported as lost energy).
pub const MAX_EVENTS: usize = 200;
/// Self-intersection guard (radii).
const EPS: f64 = 1e-7;

/// Refraction of `d` through a surface whose unit normal `n` faces the incident side,
/// with `eta = n_incident/n_transmitted`; `None` under total internal reflection.
fn refract(d: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = -d.dot(n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    Some((d * eta + n * (eta * cos_i - (1.0 - sin2_t).sqrt())).normalize())
}

/// Cosine-weighted direction about the frame's first axis.
fn cosine_about(frame: &FiberFrame, u0: f64, u1: f64) -> DVec3 {
    let r = u0.sqrt();
    let (sp, cp) = (TAU * u1).sin_cos();
    frame.to_world(DVec3::new((1.0 - u0).max(0.0).sqrt(), r * cp, r * sp))
}

/// Event counts along a path.
#[derive(Default)]
struct Events {
    external_reflections: u32,
    transmissions: u32,
    internal_reflections: u32,
    medulla: bool,
}

impl Events {
    fn lobe(&self) -> Lobe {
        match (self.medulla, self.external_reflections, self.transmissions, self.internal_reflections) {
            (true, ..) => Lobe::Medulla,
            (false, 1, 0, 0) => Lobe::R,
            (false, 0, 2, 0) => Lobe::TT,
            (false, 0, 2, 1) => Lobe::TRT,
            _ => Lobe::Higher,
        }
    }
}

/// The concentric core a path may cross: a medulla (index-matched: its boundary changes
/// nothing; it scatters and absorbs) or a lumen (another index: Fresnel at its boundary; clear).
struct Core {
    surface: Surface,
    /// `n_core/n_wall` (1 for a medulla).
    ratio: f64,
    sigma_s: f64,
    sigma_a: Rgb,
    g: f64,
}

impl Core {
    fn of(fiber: &Fiber, surface: &Surface) -> Option<Self> {
        if let Some(m) = fiber.medulla {
            return Some(Self {
                surface: Surface::new_smooth_scaled(surface, m.radius),
                ratio: 1.0,
                sigma_s: m.sigma_s,
                sigma_a: m.sigma_a,
                g: m.g,
            });
        }
        fiber.lumen.map(|l| Self {
            surface: Surface::new_smooth_scaled(surface, l.radius),
            ratio: l.eta / fiber.eta,
            sigma_s: 0.0,
            sigma_a: Rgb::ZERO,
            g: 0.0,
        })
    }

    /// At the core's boundary (outward normal `normal`, `None` for a tangent exit), coming
    /// from inside (`inside`) or outside: crosses it (flipping `inside`, refracting `d`) or,
    /// with Fresnel's probability, reflects. An index-matched boundary is always crossed
    /// straight, without drawing a number.
    fn cross(&self, d: &mut DVec3, normal: Option<DVec3>, inside: &mut bool, rng: &mut impl Rng) {
        let Some(n) = normal.filter(|_| self.ratio != 1.0) else {
            *inside = !*inside;
            return;
        };
        // Facing normal and the index ratio n_incident/n_transmitted.
        let (facing, eta) = if *inside { (-n, self.ratio) } else { (n, 1.0 / self.ratio) };
        let cos_i = -d.dot(facing);
        if cos_i <= 0.0 {
            *inside = !*inside; // a tangent graze: on past the boundary, unchanged
            return;
        }
        if rng.random::<f64>() >= fresnel::dielectric(cos_i, 1.0 / eta)
            && let Some(t) = refract(*d, facing, eta)
        {
            *d = t;
            *inside = !*inside;
            return;
        }
        *d = (*d + facing * (2.0 * cos_i)).normalize();
    }
}

/// Traces a ray from `origin` along `dir` (outside the fiber) until it leaves for good.
pub fn trace(fiber: &Fiber, surface: &Surface, origin: DVec3, dir: DVec3, rng: &mut impl Rng) -> Outcome {
    let (mut p, mut d) = (origin, dir);
    let mut weight = Rgb::ONE;
    let mut ev = Events::default();
    let mut outside = true;
    let mut in_core = false;
    let core = Core::of(fiber, surface);
    let ggx = (fiber.roughness > 0.0).then(|| Ggx::new(fiber.roughness));
    for _ in 0..MAX_EVENTS {
        if outside {
            let Some(hit) = surface.intersect(p, d, EPS) else {
                if ev.transmissions == 0 && ev.external_reflections == 0 {
                    return Outcome::Missed;
                }
                return Outcome::Exit(Exit { direction: d, weight, lobe: ev.lobe() });
            };
            p += d * hit.t;
            if let SurfaceKind::Lambertian(albedo) = fiber.surface {
                // Opaque diffuse surface: cosine-weighted reflection about the normal.
                let frame = FiberFrame::from_tangent(hit.normal);
                d = cosine_about(&frame, rng.random(), rng.random());
                weight *= albedo;
                ev.external_reflections += 1;
                continue;
            }
            match cross(d, hit.normal, fiber.eta, ggx.as_ref(), rng) {
                Crossing::Reflected { direction, weight: w } => {
                    (d, weight) = (direction, weight * w);
                    ev.external_reflections += 1;
                }
                Crossing::Refracted { direction, weight: w } => {
                    (d, weight) = (direction, weight * w);
                    ev.transmissions += 1;
                    outside = false;
                }
                Crossing::Masked => return Outcome::Masked,
            }
            continue;
        }
        // Inside: the next surface hit, unless the medulla scatters first.
        let Some(hit) = surface.intersect(p, d, EPS) else { return Outcome::Dropped };
        if let Some(m) = &core {
            // Which medium the path is in is state, flipped at each crossing of the core's
            // boundary: a point just placed on that boundary is on neither side to rounding
            // error, so it must not be inferred from the position.
            let boundary = m.surface.intersect(p, d, EPS);
            let (t_b, normal) = boundary.map_or((f64::INFINITY, None), |h| (h.t, Some(h.normal)));
            if in_core {
                // A path inside always meets the boundary ahead; a tangent entry whose exit is
                // within EPS leaves at once.
                let leave = if t_b.is_finite() { t_b } else { 0.0 };
                let t_s = if m.sigma_s > 0.0 { -(1.0 - rng.random::<f64>()).ln() / m.sigma_s } else { f64::INFINITY };
                if t_s < leave {
                    weight *= (m.sigma_a * -t_s).exp();
                    p += d * t_s;
                    d = sample_henyey_greenstein(d, m.g, rng.random(), rng.random());
                    ev.medulla = true;
                } else {
                    weight *= (m.sigma_a * -leave).exp();
                    p += d * leave;
                    m.cross(&mut d, normal, &mut in_core, rng);
                }
                continue;
            } else if t_b < hit.t {
                weight *= (fiber.sigma_a * -t_b).exp();
                p += d * t_b;
                m.cross(&mut d, normal, &mut in_core, rng);
                continue;
            }
        }
        weight *= (fiber.sigma_a * -hit.t).exp();
        p += d * hit.t;
        if d.dot(hit.normal) <= 0.0 {
            // Grazing or numerically inward at the wall: a mirror reflection keeps it inside.
            d = (d - hit.normal * (2.0 * d.dot(hit.normal))).normalize();
            ev.internal_reflections += 1;
            continue;
        }
        match cross(d, -hit.normal, 1.0 / fiber.eta, ggx.as_ref(), rng) {
            Crossing::Reflected { direction, weight: w } => {
                (d, weight) = (direction, weight * w);
                ev.internal_reflections += 1;
            }
            Crossing::Refracted { direction, weight: w } => {
                (d, weight) = (direction, weight * w);
                ev.transmissions += 1;
                outside = true;
            }
            Crossing::Masked => return Outcome::Masked,
        }
    }
    Outcome::Dropped
}
