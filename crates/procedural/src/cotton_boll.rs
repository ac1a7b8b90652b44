//! An open cotton boll: `locks` fluffy locks of lint fibres, each a ball of wandering fibres
//! around its seeds, as polylines of constant diameter for a fiber model (normally
//! `hollow-fiber`: a cotton fibre is a cellulose wall around a collapsed lumen).
//!
//! Deterministic for a seed: fibre `i` draws from its own stream
//! (`SplitMix64::stream(seed, i)`), so a fibre does not depend on the others or on thread count.
//!
//! # The boll
//! * **Locks**: lock `k` of `L` has its centre `c_k = (R − r)·(cos a_k cos ε, sin ε, sin a_k cos ε)`,
//!   `a_k = 2πk/L`, `ε = 20°` (the locks burst out of the capsule slightly upward), radius `r`
//!   (`lock_radius`); `R` is the boll's `radius`, so every lock reaches the boll's outline.
//! * **A fibre** belongs to lock `i mod L`. Its root (the seed it grows from) is uniform in the
//!   ball of radius `r/2` about `c_k`; its first direction uniform on the sphere; its length
//!   `ℓ = length·(1 − length_jitter·ξ)`.
//! * **Its path**: `segments` equal steps `h = ℓ/segments`. At each step the direction `d` turns
//!   by `curl·h` toward a uniformly random direction perpendicular to it,
//!   `d ← normalise(d + curl·h·(cos φ e₁ + sin φ e₂))` (a worm-like chain of persistence length
//!   about `1/curl²`: cotton's convolutions), and where the next point would leave the lock's
//!   ball, `d` is mirrored off the ball's surface (`d ← d − 2(d·n)n`, `n` outward at the
//!   current point; from outside the ball, where the mirrored step would still leave it,
//!   `d = −n`), so the fibres wander inside their lock: every point lies within `r + h` of
//!   `c_k`.
//!
//! Each ξ and φ is a fresh uniform number of the fibre's stream.

use fiberlab_io::HairFile;
use fiberlab_math::DVec3;
use fiberlab_math::split_mix::SplitMix64;
use serde::Deserialize;
use std::f64::consts::TAU;

/// Most points one boll may have (16 bytes each in the file, 40 while grown).
pub const MAX_POINTS: u64 = 50_000_000;

/// Elevation of the locks' centres above the boll's equator, degrees.
pub const LOCK_ELEVATION_DEG: f64 = 20.0;

/// Parameters of a cotton boll (module docs). In a scene file:
/// `[[hair]] cotton = { fibers = 6000, … }`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CottonBollParams {
    /// Number of locks, 1–8.
    pub locks: usize,
    /// Number of fibres, all locks together.
    pub fibers: usize,
    /// Segments per fibre, 1–1000.
    pub segments: usize,
    /// The boll's radius `R` (its locks reach it).
    pub radius: f64,
    /// A lock's radius `r`, in (0, R].
    pub lock_radius: f64,
    /// Longest fibre.
    pub length: f64,
    /// Fibre lengths are uniform in `[length·(1 − length_jitter), length]`; [0, 1).
    pub length_jitter: f64,
    /// Fibre diameter, in (0, lock_radius].
    pub diameter: f64,
    /// Turn of a fibre's direction per unit length, radians, [0, 1e4].
    pub curl: f64,
    /// Random seed.
    pub seed: u64,
}

impl Default for CottonBollParams {
    /// A four-lock boll of radius 0.5 with 8000 fibres 1.2 long (about five lock radii: they
    /// wander), 0.002 thick, curling about 10 radians per unit length.
    fn default() -> Self {
        Self {
            locks: 4,
            fibers: 8000,
            segments: 40,
            radius: 0.5,
            lock_radius: 0.24,
            length: 1.2,
            length_jitter: 0.3,
            diameter: 0.002,
            curl: 10.0,
            seed: 1,
        }
    }
}

/// Why parameters were rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("cotton: `{key}` = {value} is invalid; expected {expected}")]
pub struct CottonBollError {
    /// Parameter name.
    pub key: &'static str,
    /// Value given.
    pub value: String,
    /// Valid range.
    pub expected: String,
}

impl CottonBollParams {
    /// Checks every parameter's range and the point count against [`MAX_POINTS`].
    pub fn validate(&self) -> Result<(), CottonBollError> {
        let bad = |key, value: String, expected: &str| Err(CottonBollError { key, value, expected: expected.into() });
        let positive = |key, v: f64, max: f64| {
            if v.is_finite() && v > 0.0 && v <= max {
                Ok(())
            } else {
                bad(key, format!("{v:?}"), &format!("finite, > 0 and at most {max}"))
            }
        };
        if !(1..=8).contains(&self.locks) {
            return bad("locks", self.locks.to_string(), "1 to 8");
        }
        if !(1..=1000).contains(&self.segments) {
            return bad("segments", self.segments.to_string(), "1 to 1000");
        }
        positive("radius", self.radius, 1e6)?;
        positive("lock_radius", self.lock_radius, self.radius)?;
        positive("length", self.length, 1e6)?;
        positive("diameter", self.diameter, self.lock_radius)?;
        if !(0.0..1.0).contains(&self.length_jitter) {
            return bad("length_jitter", format!("{:?}", self.length_jitter), "in [0, 1)");
        }
        if !(0.0..=1e4).contains(&self.curl) {
            return bad("curl", format!("{:?}", self.curl), "in [0, 1e4] radians per unit length");
        }
        let points = self.point_count();
        if self.fibers == 0 || points > MAX_POINTS {
            return bad(
                "fibers",
                self.fibers.to_string(),
                &format!("1 or more, with fibers × (segments + 1) ≤ {MAX_POINTS} points (this is {points})"),
            );
        }
        Ok(())
    }

    /// Points of all fibres.
    #[must_use]
    pub fn point_count(&self) -> u64 {
        (self.fibers as u64).saturating_mul(self.segments as u64 + 1)
    }

    /// Segments of all fibres.
    #[must_use]
    pub fn segment_count(&self) -> u64 {
        (self.fibers as u64).saturating_mul(self.segments as u64)
    }

    /// Peak bytes [`CottonBollParams::generate`] holds: 16 per point (point, and the segment
    /// counts' share), as the `.hair` file it makes.
    #[must_use]
    pub fn estimated_bytes(&self) -> u64 {
        self.point_count().saturating_mul(16).saturating_add((self.fibers as u64).saturating_mul(2))
    }

    /// The centre of lock `k` (module docs).
    #[must_use]
    pub fn lock_centre(&self, k: usize) -> DVec3 {
        let a = TAU * k as f64 / self.locks as f64;
        let e = LOCK_ELEVATION_DEG.to_radians();
        DVec3::new(a.cos() * e.cos(), e.sin(), a.sin() * e.cos()) * (self.radius - self.lock_radius)
    }

    /// Grows the boll.
    pub fn generate(&self) -> Result<HairFile, CottonBollError> {
        self.validate()?;
        let n = self.point_count() as usize;
        let mut points = Vec::with_capacity(n);
        let centres: Vec<DVec3> = (0..self.locks).map(|k| self.lock_centre(k)).collect();
        let r = self.lock_radius;
        for i in 0..self.fibers {
            let mut rng = SplitMix64::stream(self.seed, i as u64);
            let c = centres[i % self.locks];
            let mut p = c + uniform_in_ball(&mut rng) * (0.5 * r);
            let mut d = uniform_on_sphere(&mut rng);
            let h = self.length * (1.0 - self.length_jitter * rng.next_f64()) / self.segments as f64;
            points.push(p.as_vec3().to_array());
            for _ in 0..self.segments {
                let (e1, e2) = d.any_orthonormal_pair();
                let phi = TAU * rng.next_f64();
                d = (d + (e1 * phi.cos() + e2 * phi.sin()) * (self.curl * h)).normalize();
                if (p + d * h - c).length() > r
                    && let Some(out) = (p - c).try_normalize()
                {
                    let along = d.dot(out);
                    if along > 0.0 {
                        d -= out * (2.0 * along);
                    }
                    // From outside the ball (an earlier step's overshoot), a mirrored step that
                    // still leaves it goes straight back in instead.
                    if (p - c).length() > r && (p + d * h - c).length() > r {
                        d = -out;
                    }
                }
                p += d * h;
                points.push(p.as_vec3().to_array());
            }
        }
        let mut hair = HairFile {
            segments: None,
            points,
            thickness: None,
            strand_count: self.fibers as u32,
            default_segments: self.segments as u32,
            default_thickness: self.diameter as f32,
            ..HairFile::default()
        };
        hair.set_info(&format!("fiberlab cotton boll, {} locks, seed {}", self.locks, self.seed));
        Ok(hair)
    }
}

/// Uniform on the unit sphere.
fn uniform_on_sphere(rng: &mut SplitMix64) -> DVec3 {
    let z = 2.0 * rng.next_f64() - 1.0;
    let a = TAU * rng.next_f64();
    let s = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(s * a.cos(), s * a.sin(), z)
}

/// Uniform in the unit ball.
fn uniform_in_ball(rng: &mut SplitMix64) -> DVec3 {
    uniform_on_sphere(rng) * rng.next_f64().cbrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> CottonBollParams {
        CottonBollParams { fibers: 200, segments: 12, ..CottonBollParams::default() }
    }

    /// Same parameters, same points, bit for bit; another seed, other points; a fibre does not
    /// depend on how many follow it.
    #[test]
    fn generation_is_deterministic_and_fibres_are_independent() {
        let p = small();
        let (a, b) = (p.generate().unwrap(), p.generate().unwrap());
        assert_eq!(a.points, b.points);
        assert_ne!(a.points, CottonBollParams { seed: 2, ..p.clone() }.generate().unwrap().points);
        let fewer = CottonBollParams { fibers: 50, ..p.clone() }.generate().unwrap();
        assert_eq!(fewer.points[..], a.points[..fewer.points.len()]);
        assert_eq!(a.points.len() as u64, p.point_count());
        a.validate().unwrap();
    }

    /// Every fibre: its root within half a lock radius of its lock's centre, every point within
    /// a lock radius and a step of it, steps of the fibre's length over its segments (within the
    /// length range), and the locks' centres `R − r` from the boll's centre at 20° elevation.
    #[test]
    fn fibres_stay_in_their_locks_with_their_lengths() {
        for p in [small(), CottonBollParams { locks: 5, curl: 0.0, length_jitter: 0.0, ..small() }] {
            let hair = p.generate().unwrap();
            let per = p.segments + 1;
            for (i, fibre) in hair.points.chunks(per).enumerate() {
                let c = p.lock_centre(i % p.locks);
                let v = |a: &[f32; 3]| DVec3::new(a[0].into(), a[1].into(), a[2].into());
                assert!(v(&fibre[0]).distance(c) <= 0.5 * p.lock_radius + 1e-6, "fibre {i} root");
                let h = v(&fibre[1]).distance(v(&fibre[0]));
                assert!(h <= p.length / p.segments as f64 + 1e-6);
                assert!(h >= p.length * (1.0 - p.length_jitter) / p.segments as f64 - 1e-6);
                for (j, q) in fibre.iter().enumerate() {
                    assert!(v(q).distance(c) <= p.lock_radius + h + 1e-6, "fibre {i} point {j}");
                    if j > 0 {
                        assert!((v(q).distance(v(&fibre[j - 1])) - h).abs() < 1e-5, "fibre {i} step {j}");
                    }
                }
            }
            for k in 0..p.locks {
                let c = p.lock_centre(k);
                assert!((c.length() - (p.radius - p.lock_radius)).abs() < 1e-12);
                assert!((c.y / c.length() - LOCK_ELEVATION_DEG.to_radians().sin()).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn bad_parameters_are_refused_naming_the_key() {
        let cases: [(&str, CottonBollParams); 9] = [
            ("locks", CottonBollParams { locks: 0, ..small() }),
            ("segments", CottonBollParams { segments: 0, ..small() }),
            ("radius", CottonBollParams { radius: f64::NAN, ..small() }),
            ("lock_radius", CottonBollParams { lock_radius: 0.6, ..small() }),
            ("length", CottonBollParams { length: f64::INFINITY, ..small() }),
            ("diameter", CottonBollParams { diameter: -1.0, ..small() }),
            ("length_jitter", CottonBollParams { length_jitter: 1.0, ..small() }),
            ("curl", CottonBollParams { curl: f64::NAN, ..small() }),
            ("fibers", CottonBollParams { fibers: 10_000_000, segments: 1000, ..small() }),
        ];
        for (key, p) in cases {
            assert_eq!(p.generate().unwrap_err().key, key, "{key}");
        }
    }
}
