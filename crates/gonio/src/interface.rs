//! One crossing of the fiber's dielectric interface, smooth or rough.
//!
//! Smooth: reflect with probability `F` (the exact dielectric Fresnel), refract otherwise
//! (total internal reflection reflects). Rough (GGX roughness α > 0, the surface of Walter et
//! al. 2007): a microfacet normal `m` is drawn from the normals visible from the incident
//! direction (Heitz 2018), the ray reflects with probability `F(v·m)` or refracts through
//! `m`, and carries the masking of the outgoing direction as a weight `G₂/G₁(v)` (Smith,
//! height-correlated, `fiberlab_math::microfacet`). An outgoing direction on the wrong side
//! of the geometric (macro) normal — a reflection into the surface or a refraction back out
//! of it — ends the path ([`Crossing::Masked`]): as in the single-scattering microfacet model,
//! light that would hit the microsurface again is lost. With this rule the distribution of
//! the outgoing directions is exactly Walter's BRDF and BTDF times the cosine (tested in
//! `tests/rough_interface.rs` against the closed forms).

use fiberlab_math::DVec3;
use fiberlab_math::fresnel;
use fiberlab_math::microfacet::{Ggx, reflect, refract};
use rand::Rng;

/// What one crossing did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Crossing {
    /// Reflected into `direction` (unit), throughput multiplied by `weight`.
    Reflected {
        /// New travel direction.
        direction: DVec3,
        /// Masking weight `G₂/G₁` (1 on a smooth interface).
        weight: f64,
    },
    /// Refracted into `direction` (unit), throughput multiplied by `weight`.
    Refracted {
        /// New travel direction.
        direction: DVec3,
        /// Masking weight `G₂/G₁` (1 on a smooth interface).
        weight: f64,
    },
    /// The outgoing direction would re-enter the microsurface: the path ends.
    Masked,
}

/// A ray travelling along `d` meets the interface whose unit normal `n` faces it (`d·n < 0`);
/// `eta` = n_transmitted/n_incident; `ggx`: the roughness (`None`: smooth).
pub fn cross(d: DVec3, n: DVec3, eta: f64, ggx: Option<&Ggx>, rng: &mut impl Rng) -> Crossing {
    let v = -d;
    let cos_v = v.dot(n);
    let Some(g) = ggx else {
        return if rng.random::<f64>() < fresnel::dielectric(cos_v, eta) {
            Crossing::Reflected { direction: reflect(d, n).normalize(), weight: 1.0 }
        } else {
            match refract(d, n, 1.0 / eta) {
                Some(t) => Crossing::Refracted { direction: t, weight: 1.0 },
                None => Crossing::Reflected { direction: reflect(d, n).normalize(), weight: 1.0 },
            }
        };
    };
    let m = g.sample_visible(n, v, rng.random(), rng.random());
    let cos_vm = v.dot(m);
    let reflected = rng.random::<f64>() < fresnel::dielectric(cos_vm, eta);
    let (direction, reflected) = match (reflected, refract(d, m, 1.0 / eta)) {
        (false, Some(t)) => (t, false),
        _ => (reflect(d, m).normalize(), true),
    };
    let cos_out = direction.dot(n);
    if (reflected && cos_out <= 0.0) || (!reflected && cos_out >= 0.0) {
        return Crossing::Masked;
    }
    let lambda_v = g.lambda(cos_v);
    let weight = (1.0 + lambda_v) / (1.0 + lambda_v + g.lambda(cos_out));
    if reflected { Crossing::Reflected { direction, weight } } else { Crossing::Refracted { direction, weight } }
}
