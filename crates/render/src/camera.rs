//! A pinhole camera: look-at, vertical field of view, resolution. Pixel (0, 0) is the top-left.

use fiberlab_geometry::Ray;
use fiberlab_math::DVec3;

/// A pinhole camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    tan_half: f64,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
}

impl Camera {
    /// A camera at `eye` looking at `target` with `up` roughly up and vertical field of view
    /// `fov_deg` degrees. `None` if the frame is degenerate.
    #[must_use]
    pub fn look_at(eye: DVec3, target: DVec3, up: DVec3, fov_deg: f64, width: u32, height: u32) -> Option<Self> {
        let forward = (target - eye).try_normalize()?;
        let right = forward.cross(up).try_normalize()?;
        let up = right.cross(forward);
        let ok = fov_deg > 0.0 && fov_deg < 180.0 && width > 0 && height > 0;
        ok.then(|| Self { eye, forward, right, up, tan_half: (0.5 * fov_deg.to_radians()).tan(), width, height })
    }

    /// The eye, the unit forward, right and up vectors and tan(fov/2): what [`Camera::ray`]
    /// computes with (for a GPU that makes the same rays).
    #[must_use]
    pub fn basis(&self) -> (DVec3, DVec3, DVec3, DVec3, f64) {
        (self.eye, self.forward, self.right, self.up, self.tan_half)
    }

    /// The ray through image position `(px, py)` in pixels (continuous; pixel centres at +0.5).
    #[must_use]
    pub fn ray(&self, px: f64, py: f64) -> Ray {
        let aspect = f64::from(self.width) / f64::from(self.height);
        let sx = (2.0 * px / f64::from(self.width) - 1.0) * self.tan_half * aspect;
        let sy = (1.0 - 2.0 * py / f64::from(self.height)) * self.tan_half;
        Ray::new(self.eye, (self.forward + self.right * sx + self.up * sy).normalize())
    }
}
