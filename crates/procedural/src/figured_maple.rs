//! A procedural fiber map of figured ("curly") maple for the wood surface model: the in-plane
//! fiber angle, the fiber dip and the diffuse colour over a board, as textures.
//!
//! Curly figure is a fiber that rises and falls through the board in a wave whose crests run
//! across the grain (Marschner et al. 2005 call it out as the dip of the fiber axis); its
//! stripes move as the light moves because the fiber highlight of a dipping fiber shifts with
//! the dip. The map here:
//! - grain along `u` (the board's length): `fiber_angle = A_angle · n₁(u, v)` with `n₁` a
//!   smooth value noise in `[−1, 1]` (wavy grain);
//! - `fiber_dip = A_dip · sin(2π (f·u + w·n₂(u, v)))`: stripes across the grain, `f` stripes per
//!   unit `u`, wavering by `w` periods;
//! - `k_d`: a pale maple colour darkened along growth-ring lines that run with the grain.
//!
//! Angles are in degrees (the wood model's unit at the file edge); `fiberlab texture wood`
//! writes them as linear 16-bit PNGs over ±90° and the colour as an sRGB PNG.

use fiberlab_io::LinearImage;
use fiberlab_math::noise::value_noise;
use std::f64::consts::TAU;

/// What the figure looks like.
#[derive(Clone, Debug, PartialEq)]
pub struct MapleFigure {
    /// Texels along `u` (the grain).
    pub width: usize,
    /// Texels along `v`.
    pub height: usize,
    /// Curl stripes per unit `u`.
    pub stripes: f64,
    /// Largest dip, degrees.
    pub dip_amplitude_deg: f64,
    /// Largest in-plane deviation of the grain, degrees.
    pub angle_amplitude_deg: f64,
    /// Waver of the stripes, periods.
    pub waver: f64,
    /// Diffuse colour of the wood between ring lines (linear RGB).
    pub k_d: [f64; 3],
    /// Noise seed.
    pub seed: u64,
}

impl Default for MapleFigure {
    fn default() -> Self {
        Self {
            width: 512,
            height: 128,
            stripes: 12.0,
            dip_amplitude_deg: 30.0,
            angle_amplitude_deg: 4.0,
            waver: 0.35,
            k_d: [0.42, 0.27, 0.13],
            seed: 1,
        }
    }
}

/// The three maps (see the module documentation).
#[derive(Clone, Debug)]
pub struct MapleMaps {
    /// In-plane fiber angle, degrees (all channels equal).
    pub fiber_angle: LinearImage,
    /// Fiber dip, degrees (all channels equal).
    pub fiber_dip: LinearImage,
    /// Diffuse colour, linear RGB.
    pub k_d: LinearImage,
}

impl MapleFigure {
    /// The dip at texture coordinates `(u, v)`, degrees.
    #[must_use]
    pub fn dip_deg(&self, u: f64, v: f64) -> f64 {
        let phase = self.stripes * u + self.waver * value_noise(self.seed ^ 2, 3.0 * u, 6.0 * v, 3);
        self.dip_amplitude_deg * (TAU * phase).sin()
    }

    /// The in-plane angle at `(u, v)`, degrees.
    #[must_use]
    pub fn angle_deg(&self, u: f64, v: f64) -> f64 {
        self.angle_amplitude_deg * value_noise(self.seed ^ 1, 2.0 * u, 4.0 * v, 3)
    }

    /// The diffuse colour at `(u, v)`.
    #[must_use]
    pub fn k_d(&self, u: f64, v: f64) -> [f64; 3] {
        let ring = 0.5 + 0.5 * (TAU * (9.0 * v + 0.8 * value_noise(self.seed ^ 3, 1.5 * u, 3.0 * v, 4))).sin();
        let darken = 1.0 - 0.25 * ring.powi(6) + 0.06 * value_noise(self.seed ^ 4, 40.0 * u, 10.0 * v, 2);
        self.k_d.map(|c| (c * darken).clamp(0.0, 1.0))
    }

    /// The maps over `u, v ∈ [0, 1]` at texel centres (row 0 at `v = 1`, as
    /// `fiberlab_render::texture` reads them).
    #[must_use]
    pub fn maps(&self) -> MapleMaps {
        let (w, h) = (self.width, self.height);
        let mut out = [LinearImage::new(w, h), LinearImage::new(w, h), LinearImage::new(w, h)];
        for y in 0..h {
            for x in 0..w {
                let (u, v) = ((x as f64 + 0.5) / w as f64, 1.0 - (y as f64 + 0.5) / h as f64);
                let (a, d) = (self.angle_deg(u, v) as f32, self.dip_deg(u, v) as f32);
                out[0].set(x, y, [a; 3]);
                out[1].set(x, y, [d; 3]);
                out[2].set(x, y, self.k_d(u, v).map(|c| c as f32));
            }
        }
        let [fiber_angle, fiber_dip, k_d] = out;
        MapleMaps { fiber_angle, fiber_dip, k_d }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_bounded_smooth_and_seeded() {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..2000 {
            let (x, y) = (k as f64 * 0.137, k as f64 * 0.071);
            let n = value_noise(5, x, y, 3);
            lo = lo.min(n);
            hi = hi.max(n);
            // Continuity: a small step changes little.
            assert!((value_noise(5, x + 1e-6, y, 3) - n).abs() < 1e-4);
        }
        assert!(lo >= -1.0 && hi <= 1.0 && hi - lo > 0.8, "{lo} {hi}");
        assert_ne!(value_noise(5, 0.3, 0.4, 3), value_noise(6, 0.3, 0.4, 3));
    }

    /// The dip map is the stripe function: its zero crossings along `u` are `stripes` per unit
    /// (two per period), and it stays within its amplitude; the texels are where the functions
    /// say.
    #[test]
    fn dip_stripes_have_the_requested_frequency_and_amplitude() {
        let fig = MapleFigure { width: 256, height: 16, ..MapleFigure::default() };
        let maps = fig.maps();
        let row = 8;
        let dips: Vec<f64> = (0..fig.width).map(|x| f64::from(maps.fiber_dip.get(x, row)[0])).collect();
        let crossings = dips.windows(2).filter(|w| w[0].signum() != w[1].signum()).count() as f64;
        assert!((crossings - 2.0 * fig.stripes).abs() <= 3.0, "{crossings} crossings");
        assert!(dips.iter().all(|d| d.abs() <= fig.dip_amplitude_deg + 1e-4));
        let v = 1.0 - (row as f64 + 0.5) / 16.0;
        assert!((dips[100] - fig.dip_deg(100.5 / 256.0, v)).abs() < 1e-4);
        let a = f64::from(maps.fiber_angle.get(3, 2)[0]);
        assert!(a.abs() <= fig.angle_amplitude_deg + 1e-6);
        assert!(maps.k_d.pixels().iter().all(|p| p.iter().all(|c| (0.0..=1.0).contains(c))));
    }
}
