//! Russian roulette, the one rule of the slab and cloth goniophotometers' path tracers: a
//! path whose weight fell below ¼ survives with probability `4·max(weight)`, a long one (past
//! `after` events: light guided along fibers by total internal reflection, or trapped between
//! layers) with probability 0.99 per event; a survivor's weight is divided by its survival
//! probability, so every estimate stays unbiased.

use fiberlab_math::Rgb;

/// The probability that a path of `weight` survives scattering event `event` (0-based).
#[must_use]
pub fn survival(weight: Rgb, event: usize, after: usize) -> f64 {
    if weight.max_component() < 0.25 {
        4.0 * weight.max_component()
    } else if event >= after {
        0.99
    } else {
        1.0
    }
}

/// Plays the roulette for a path of `weight` at event `event`: `false` ends the path,
/// `true` keeps it with its weight divided by the survival probability. `random` (uniform in
/// [0, 1)) is drawn only when that probability is below 1, so a tracer's random stream is
/// consumed only then.
pub fn survives(weight: &mut Rgb, event: usize, after: usize, random: impl FnOnce() -> f64) -> bool {
    let q = survival(*weight, event, after);
    if q < 1.0 {
        if random() >= q {
            return false;
        }
        *weight *= 1.0 / q;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// E[weight after roulette] = weight: over stratified uniforms the survivors' total
    /// weight equals the paths' total weight, for weights below ¼, long paths and neither.
    #[test]
    fn roulette_is_unbiased_and_draws_only_when_it_plays() {
        let n = 100_000;
        for (w, event) in [(Rgb::new(0.1, 0.02, 0.05), 3), (Rgb::splat(0.8), 70), (Rgb::new(0.3, 1.5, 0.2), 0)] {
            let mut total = Rgb::ZERO;
            let mut draws = 0;
            for k in 0..n {
                let mut weight = w;
                let u = (k as f64 + 0.5) / n as f64;
                if survives(&mut weight, event, 64, || {
                    draws += 1;
                    u
                }) {
                    total += weight;
                }
            }
            let mean = total * (1.0 / n as f64);
            for c in 0..3 {
                assert!((mean[c] - w[c]).abs() <= 1e-4 * w[c], "{w:?} at {event}: {mean:?}");
            }
            assert_eq!(draws > 0, survival(w, event, 64) < 1.0, "{w:?} at {event}");
        }
        assert_eq!(survival(Rgb::splat(0.1), 0, 64), 0.4);
        assert_eq!(survival(Rgb::splat(0.5), 64, 64), 0.99);
        assert_eq!(survival(Rgb::splat(0.5), 63, 64), 1.0);
    }
}
