//! Spectral quantities. fiberlab computes in linear RGB (Rec. 709 primaries); every model
//! is written against [`Spectrum`], so a sampled-spectral type can replace [`Rgb`] later.

use std::ops::{Add, AddAssign, Div, Index, Mul, MulAssign, Sub};

/// Rec. 709 luminance weights of linear r, g, b (the one copy: images, fits and models use it).
pub const LUMINANCE_WEIGHTS: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// The spectral type the models use (linear Rec. 709 RGB today).
pub type Spectrum = Rgb;

/// A linear RGB triple: reflectances, absorption coefficients or radiometric quantities.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rgb(pub [f64; 3]);

impl Rgb {
    /// All components zero.
    pub const ZERO: Self = Self([0.0; 3]);
    /// All components one.
    pub const ONE: Self = Self([1.0; 3]);

    /// A triple from its components.
    #[must_use]
    pub const fn new(r: f64, g: f64, b: f64) -> Self {
        Self([r, g, b])
    }

    /// The same value in every channel.
    #[must_use]
    pub const fn splat(x: f64) -> Self {
        Self([x; 3])
    }

    /// Rec. 709 luminance `0.2126 r + 0.7152 g + 0.0722 b` ([`LUMINANCE_WEIGHTS`]).
    #[must_use]
    pub fn luminance(self) -> f64 {
        let [r, g, b] = LUMINANCE_WEIGHTS;
        r * self.0[0] + g * self.0[1] + b * self.0[2]
    }

    /// Arithmetic mean of the channels.
    #[must_use]
    pub fn average(self) -> f64 {
        (self.0[0] + self.0[1] + self.0[2]) / 3.0
    }

    /// Largest channel.
    #[must_use]
    pub fn max_component(self) -> f64 {
        self.0[0].max(self.0[1]).max(self.0[2])
    }

    /// Smallest channel.
    #[must_use]
    pub fn min_component(self) -> f64 {
        self.0[0].min(self.0[1]).min(self.0[2])
    }

    /// True when every channel is finite.
    #[must_use]
    pub fn is_finite(self) -> bool {
        self.0.iter().all(|c| c.is_finite())
    }

    /// True when every channel is zero.
    #[must_use]
    pub fn is_black(self) -> bool {
        self.0.iter().all(|&c| c == 0.0)
    }

    /// Applies `f` to each channel.
    #[must_use]
    pub fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Self([f(self.0[0]), f(self.0[1]), f(self.0[2])])
    }

    /// Channel-wise `e^x`.
    #[must_use]
    pub fn exp(self) -> Self {
        self.map(f64::exp)
    }

    /// Channel-wise power.
    #[must_use]
    pub fn powf(self, p: f64) -> Self {
        self.map(|c| c.powf(p))
    }
}

impl Index<usize> for Rgb {
    type Output = f64;
    fn index(&self, i: usize) -> &f64 {
        &self.0[i]
    }
}

macro_rules! rgb_binop {
    ($trait:ident, $fn:ident, $op:tt) => {
        impl $trait for Rgb {
            type Output = Rgb;
            #[inline]
            fn $fn(self, o: Rgb) -> Rgb {
                Rgb([self.0[0] $op o.0[0], self.0[1] $op o.0[1], self.0[2] $op o.0[2]])
            }
        }
        impl $trait<f64> for Rgb {
            type Output = Rgb;
            #[inline]
            fn $fn(self, o: f64) -> Rgb {
                Rgb([self.0[0] $op o, self.0[1] $op o, self.0[2] $op o])
            }
        }
    };
}
rgb_binop!(Add, add, +);
rgb_binop!(Sub, sub, -);
rgb_binop!(Mul, mul, *);
rgb_binop!(Div, div, /);

impl Mul<Rgb> for f64 {
    type Output = Rgb;
    #[inline]
    fn mul(self, o: Rgb) -> Rgb {
        o * self
    }
}

impl AddAssign for Rgb {
    #[inline]
    fn add_assign(&mut self, o: Rgb) {
        *self = *self + o;
    }
}

impl MulAssign<f64> for Rgb {
    #[inline]
    fn mul_assign(&mut self, o: f64) {
        *self = *self * o;
    }
}

impl MulAssign for Rgb {
    #[inline]
    fn mul_assign(&mut self, o: Rgb) {
        *self = *self * o;
    }
}

impl std::fmt::Display for Rgb {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{},{},{}", self.0[0], self.0[1], self.0[2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn luminance_of_white_is_one() {
        assert!((Rgb::ONE.luminance() - 1.0).abs() < 1e-15);
        assert_eq!((Rgb::new(1.0, 2.0, 3.0) * 2.0)[2], 6.0);
    }
}
