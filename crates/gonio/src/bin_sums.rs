//! The power a goniophotometer tallies into its direction bins, per class of path and in all,
//! and the tables it becomes: the mean power through a bin over the bin's (cosine-weighted)
//! solid angle, with its Monte Carlo standard error. Shared by the fiber goniophotometer
//! ([`crate::measure`]), the fiber slab ([`crate::fiber_slab`]) and the woven patch of the
//! render crate.

use crate::LobeTable;
use fiberlab_math::Rgb;

/// Sums of weights and of squared weights per bin, for `classes` classes and their total.
#[derive(Clone, Debug)]
pub struct BinSums {
    classes: usize,
    bins: usize,
    sums: Vec<[Rgb; 2]>,
}

impl BinSums {
    /// Empty sums for `classes` classes of `bins` bins each, plus the total (class `classes`).
    #[must_use]
    pub fn new(classes: usize, bins: usize) -> Self {
        Self { classes, bins, sums: vec![[Rgb::ZERO; 2]; (classes + 1) * bins] }
    }

    /// Adds a path of weight `w` leaving through `bin` to its `class` and to the total.
    pub fn add(&mut self, class: usize, bin: usize, w: Rgb) {
        debug_assert!(class < self.classes && bin < self.bins);
        for c in [class, self.classes] {
            let cell = &mut self.sums[c * self.bins + bin];
            cell[0] += w;
            cell[1] += w * w;
        }
    }

    /// The tables of every class and then the total, after `traced` paths, on a grid of
    /// `nt` rows of `np` bins whose row `i` has the (cosine-weighted) solid angle `omega(i)` per bin.
    #[must_use]
    pub fn tables(&self, traced: usize, nt: usize, np: usize, omega: impl Fn(usize) -> f64) -> Vec<LobeTable> {
        debug_assert_eq!(nt * np, self.bins);
        let n = traced.max(1) as f64;
        (0..=self.classes)
            .map(|class| {
                let mut f = Vec::with_capacity(self.bins);
                let mut std = Vec::with_capacity(self.bins);
                let mut albedo = Rgb::ZERO;
                for i in 0..nt {
                    let omega = omega(i);
                    for j in 0..np {
                        let [s, s2] = self.sums[class * self.bins + i * np + j];
                        let mean = s / n;
                        albedo += mean;
                        let var = (s2 / n - mean * mean).map(|v| v.max(0.0)) / n;
                        f.push(mean / omega);
                        std.push(var.map(f64::sqrt) / omega);
                    }
                }
                LobeTable { f, std, albedo }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_are_means_over_solid_angle_with_their_standard_errors() {
        // Two classes, 1 × 2 bins; 4 paths: weights 1 and 3 in class 0 bin 0, 2 in class 1 bin 1,
        // one path lost.
        let mut s = BinSums::new(2, 2);
        s.add(0, 0, Rgb::splat(1.0));
        s.add(0, 0, Rgb::splat(3.0));
        s.add(1, 1, Rgb::splat(2.0));
        let t = s.tables(4, 1, 2, |_| 0.5);
        assert_eq!(t.len(), 3);
        // Class 0, bin 0: mean 1, f = 2; E[w²] = 10/4, variance of the mean (2.5 − 1)/4.
        assert_eq!(t[0].f[0], Rgb::splat(2.0));
        assert!((t[0].std[0].0[0] - (1.5f64 / 4.0).sqrt() / 0.5).abs() < 1e-15);
        assert_eq!(t[0].albedo, Rgb::splat(1.0));
        assert_eq!(t[1].f, vec![Rgb::ZERO, Rgb::splat(1.0)]);
        // The total holds both classes.
        assert_eq!(t[2].f, vec![Rgb::splat(2.0), Rgb::splat(1.0)]);
        assert_eq!(t[2].albedo, Rgb::splat(1.5));
    }
}
