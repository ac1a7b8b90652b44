//! Rays: an origin, a unit direction and the open interval of accepted distances.

use fiberlab_math::DVec3;

/// A ray `o + t·d` restricted to `t_min < t < t_max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin, scene units.
    pub o: DVec3,
    /// Unit direction.
    pub d: DVec3,
    /// Smallest accepted distance (excludes self-intersection at the origin).
    pub t_min: f64,
    /// Largest accepted distance.
    pub t_max: f64,
}

impl Ray {
    /// A ray from `o` along unit `d` over (0, ∞).
    #[must_use]
    pub fn new(o: DVec3, d: DVec3) -> Self {
        Self { o, d, t_min: 0.0, t_max: f64::INFINITY }
    }

    /// The point at distance `t`.
    #[must_use]
    pub fn at(&self, t: f64) -> DVec3 {
        self.o + self.d * t
    }
}
