//! The directional albedos of a rough dielectric interface under single scattering
//! (`fiberlab_math::microfacet`: GGX visible normals, Fresnel at the microfacet, masking
//! `G₂/G₁`, light sent back into the microsurface lost): the fractions `E_R(μ)` reflected and
//! `E_T(μ)` transmitted of light arriving at `cos θ = μ` from the side of relative index
//! `eta` = n_transmitted/n_incident. Tabulated once per (α, η) by a lattice quadrature of
//! the visible normals and interpolated linearly in μ; `1 − E_R − E_T` is what the single
//! microfacet interaction loses (`docs/theory/hair.md`, "Microfacet fibers (Huang 2022)").
//! The rough hair models use them for the orders of scattering they do not trace
//! (Huang 2022's TRRT+) and to weigh their sampling.

use fiberlab_math::microfacet::{Ggx, reflect, refract};
use fiberlab_math::{DVec3, fresnel};

/// Nodes of the table in μ ∈ [0, 1] (equally spaced, both ends included).
pub const NODES: usize = 33;
/// Midpoint offsets of [`InterfaceAlbedo::across_chords`]' average.
pub const CHORD_OFFSETS: usize = 16;
/// Side of the lattice of visible normals per node.
const LATTICE: usize = 48;

/// `E_R(μ)`, `E_T(μ)` of one interface, tabulated.
#[derive(Clone, Debug, PartialEq)]
pub struct InterfaceAlbedo {
    reflected: [f64; NODES],
    transmitted: [f64; NODES],
}

impl InterfaceAlbedo {
    /// The table for roughness `ggx` and relative index `eta` (n_transmitted/n_incident).
    #[must_use]
    pub fn new(ggx: &Ggx, eta: f64) -> Self {
        let mut reflected = [0.0; NODES];
        let mut transmitted = [0.0; NODES];
        for k in 0..NODES {
            // μ = 0 itself is grazing: its limit is taken at a tiny positive cosine.
            let mu = (k as f64 / (NODES - 1) as f64).max(1e-4);
            (reflected[k], transmitted[k]) = Self::albedos(ggx, eta, mu);
        }
        Self { reflected, transmitted }
    }

    /// `(E_R, E_T)` at `cos θ = mu` by the lattice quadrature.
    #[must_use]
    pub fn albedos(ggx: &Ggx, eta: f64, mu: f64) -> (f64, f64) {
        let v = DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
        let lambda_v = ggx.lambda(mu);
        let (mut r, mut t) = (0.0, 0.0);
        for i in 0..LATTICE {
            for j in 0..LATTICE {
                let u1 = (i as f64 + 0.5) / LATTICE as f64;
                let u2 = (j as f64 + 0.5) / LATTICE as f64;
                let m = ggx.sample_visible_local(v, u1, u2);
                let c = v.dot(m);
                if c <= 0.0 {
                    continue;
                }
                let f = fresnel::dielectric(c, eta);
                let out = reflect(-v, m);
                if out.z > 0.0 {
                    r += f * (1.0 + lambda_v) / (1.0 + lambda_v + ggx.lambda(out.z));
                }
                if let Some(tr) = refract(-v, m, 1.0 / eta)
                    && tr.z < 0.0
                {
                    t += (1.0 - f) * (1.0 + lambda_v) / (1.0 + lambda_v + ggx.lambda(tr.z));
                }
            }
        }
        let n = (LATTICE * LATTICE) as f64;
        (r / n, t / n)
    }

    /// Linear interpolation of a table at `mu` ∈ [0, 1] (clamped).
    fn at(table: &[f64; NODES], mu: f64) -> f64 {
        let x = mu.clamp(0.0, 1.0) * (NODES - 1) as f64;
        let k = (x as usize).min(NODES - 2);
        let f = x - k as f64;
        table[k] * (1.0 - f) + table[k + 1] * f
    }

    /// The tables `(E_R, E_T)` at the [`NODES`] equally spaced μ (for copies, e.g. the GPU's).
    #[must_use]
    pub fn tables(&self) -> (&[f64; NODES], &[f64; NODES]) {
        (&self.reflected, &self.transmitted)
    }

    /// The reflected fraction `E_R(μ)`.
    #[must_use]
    pub fn reflected(&self, mu: f64) -> f64 {
        Self::at(&self.reflected, mu)
    }

    /// The transmitted fraction `E_T(μ)`.
    #[must_use]
    pub fn transmitted(&self, mu: f64) -> f64 {
        Self::at(&self.transmitted, mu)
    }

    /// `(Ē_R, Ē_T)` met by an internal ray of normal-plane cosine `cos_theta` (= cosθ of its
    /// direction) on chords of every offset: the albedos at `μ = cosθ·√(1 − s²)` averaged over
    /// the offset s ∈ [0, 1] (16 midpoints), the incidences a ray keeps meeting once rough
    /// reflections have spread its offsets while the cylinder keeps its inclination.
    #[must_use]
    pub fn across_chords(&self, cos_theta: f64) -> (f64, f64) {
        let n = CHORD_OFFSETS;
        let (mut r, mut t) = (0.0, 0.0);
        for k in 0..n {
            let s = (k as f64 + 0.5) / n as f64;
            let mu = cos_theta * (1.0 - s * s).sqrt();
            r += self.reflected(mu);
            t += self.transmitted(mu);
        }
        (r / n as f64, t / n as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A nearly smooth interface reflects and transmits by Fresnel (and total internal
    /// reflection from the dense side); a rough one loses a little, never gains.
    #[test]
    fn smooth_limit_is_fresnel_and_rough_interfaces_lose_energy() {
        let smooth = Ggx::new(1e-3);
        for &(eta, mu) in &[(1.55, 0.9), (1.55, 0.3), (1.0 / 1.55, 0.9), (1.0 / 1.55, 0.5)] {
            let (r, t) = InterfaceAlbedo::albedos(&smooth, eta, mu);
            let f = fresnel::dielectric(mu, eta);
            assert!((r - f).abs() < 1e-3 && (t - (1.0 - f)).abs() < 1e-3, "η {eta} μ {mu}: {r} {t} vs F {f}");
        }
        let table = InterfaceAlbedo::new(&Ggx::new(0.5), 1.0 / 1.55);
        for k in 0..=20 {
            let mu = k as f64 / 20.0;
            let (r, t) = (table.reflected(mu), table.transmitted(mu));
            assert!(r >= 0.0 && t >= 0.0 && r + t <= 1.0 + 1e-12, "μ {mu}: {r} + {t}");
        }
        assert!(table.reflected(0.3) > table.transmitted(0.3), "beyond the critical angle mostly reflected");
    }
}
