use super::pattern::*;
use super::presets::*;
use super::variation::*;
use super::*;
use crate::SurfaceScattering;
use fiberlab_math::split_mix::SplitMix64;
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

fn hemisphere(theta: f64, phi: f64) -> DVec3 {
    let (s, c) = theta.sin_cos();
    DVec3::new(s * phi.cos(), s * phi.sin(), c)
}

#[test]
fn presets_validate_and_fill_their_tiles() {
    for name in IRAWAN_PRESETS {
        let p = WeavePattern::preset(name).unwrap();
        p.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(p.cells.iter().all(|&c| c >= 1), "{name}");
        // Every yarn covers exactly the cells its length × width says.
        for (k, y) in p.yarns.iter().enumerate() {
            let covered = p.cells.iter().filter(|&&c| c == k + 1).count() as f64;
            assert_eq!(covered, y.width * y.length, "{name} yarn {}", k + 1);
        }
    }
}

#[test]
fn validation_names_the_field() {
    let mut p = WeavePattern::preset("polyester-lining").unwrap();
    p.cells.pop();
    assert!(matches!(p.validate(), Err(PatternError::GridSize { found: 3, expected: 4, .. })));
    let mut p = WeavePattern::preset("polyester-lining").unwrap();
    p.cells[2] = 9;
    assert!(matches!(p.validate(), Err(PatternError::YarnId { id: 9, .. })));
    let mut p = WeavePattern::preset("polyester-lining").unwrap();
    p.yarns[1].u_max = f64::NAN;
    let e = p.validate().unwrap_err().to_string();
    assert!(e.contains("yarn 2: umax"), "{e}");
}

/// The filament highlight sits where a mirror on the yarn's spine would put it: for a
/// warp yarn (along v, i.e. y) and directions in the y–z plane, the specular inclination
/// is the half-vector's tilt, `u* = (θ_o − θ_i)/2` for ω_i at −θ_i, ω_o at +θ_o; the
/// point at y = u*/u_max·l/2 lights up and a point far from it does not.
#[test]
fn filament_highlight_location_follows_the_half_vector() {
    let mut m = Irawan2012::preset("polyester-lining").unwrap();
    // Cell (0, 0) is a warp segment centred at (0.5, 0.5) cells, u_max = 22°, l = 1.
    let (ti, to) = (0.5_f64, 0.2_f64);
    let wi = DVec3::new(0.0, -ti.sin(), ti.cos());
    let wo = DVec3::new(0.0, to.sin(), to.cos());
    let u_star = 0.5 * (to - ti);
    let y_star = u_star / 22f64.to_radians() * 0.5;
    m.set_position(0.25, (0.5 + y_star) / 2.0);
    assert!(m.integrand(wi, wo) > 0.0);
    m.set_position(0.25, (0.5 - y_star) / 2.0);
    assert_eq!(m.integrand(wi, wo), 0.0);
}

/// `π·E[k_s-free specular]` under diffuse light is 1 with the normalisation, estimated
/// with samples independent of those that built it — also after α and β are changed as a
/// texture would.
#[test]
fn normalisation_makes_the_diffuse_light_average_one() {
    for (name, alpha, beta) in [("cotton-denim", None, None), ("silk-charmeuse", Some(0.3), Some(2.2))] {
        let mut m = Irawan2012::preset(name).unwrap();
        if let Some(a) = alpha {
            m.set_parameter("alpha", Rgb::splat(a)).unwrap();
            m.set_parameter("beta", Rgb::splat(beta.unwrap())).unwrap();
        }
        let mut rng = SplitMix64::new(77);
        let n = 200_000;
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..n {
            let wi = cosine_direction(rng.next_f64(), rng.next_f64());
            let wo = cosine_direction(rng.next_f64(), rng.next_f64());
            m.set_position(rng.next_f64(), rng.next_f64());
            let x = PI * m.integrand(wi, wo) * m.normalisation();
            sum += x;
            sum2 += x * x;
        }
        let mean = sum / n as f64;
        let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        // Both estimates carry MC error: allow 4σ of each plus the β interpolation.
        assert!((mean - 1.0).abs() < 8.0 * sigma + 0.01, "{name}: {mean} ± {sigma}");
    }
}

#[test]
fn every_preset_conserves_energy_on_a_grid() {
    for name in IRAWAN_PRESETS {
        let mut m = Irawan2012::preset(name).unwrap();
        let mut worst: f64 = 0.0;
        for &(pu, pv) in &[(0.1, 0.1), (0.37, 0.62), (0.8, 0.45), (0.55, 0.9)] {
            m.set_position(pu, pv);
            for &t in &[0.0, 0.5, 1.0, 1.4] {
                for &ph in &[0.0, 0.8, 1.7, 3.0] {
                    let wi = hemisphere(t, ph);
                    let (nt, np) = (90, 180);
                    let (dt, dp) = (FRAC_PI_2 / nt as f64, TAU / np as f64);
                    let mut sum = Rgb::ZERO;
                    for a in 0..nt {
                        let th = (a as f64 + 0.5) * dt;
                        for b in 0..np {
                            let wo = hemisphere(th, (b as f64 + 0.5) * dp);
                            sum += m.eval(wi, wo) * (th.cos() * th.sin() * dt * dp);
                        }
                    }
                    worst = worst.max(sum.max_component());
                }
            }
        }
        eprintln!("{name}: largest albedo {worst:.4}");
        assert!(worst <= 1.0 && worst > 0.0, "{name}: {worst}");
    }
}

/// Radius of curvature of the explicit curve `p(t)` at `t`, by central differences.
fn curvature_radius(p: impl Fn(f64) -> [f64; 2], t: f64) -> f64 {
    let h = 1e-4;
    let (a, b, c) = (p(t - h), p(t), p(t + h));
    let d1 = [(c[0] - a[0]) / (2.0 * h), (c[1] - a[1]) / (2.0 * h)];
    let d2 = [(c[0] - 2.0 * b[0] + a[0]) / (h * h), (c[1] - 2.0 * b[1] + a[1]) / (h * h)];
    (d1[0] * d1[0] + d1[1] * d1[1]).powf(1.5) / (d1[0] * d2[1] - d1[1] * d2[0]).abs()
}

/// Finds `t` in `[0, t_hi]` where the curve's inclination `atan(|dz/dx|)` is `u` (bisection).
fn where_inclined(p: &impl Fn(f64) -> [f64; 2], u: f64, t_hi: f64) -> f64 {
    let incl = |t: f64| {
        let h = 1e-6;
        let (a, c) = (p(t - h), p(t + h));
        ((c[1] - a[1]) / (c[0] - a[0])).abs().atan()
    };
    let (mut lo, mut hi) = (0.0, t_hi);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if incl(mid) < u { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}

/// The conic spines against explicit curves: an ellipse, a parabola and a hyperbola through
/// the chord's ends with end inclination `u_max`, their radius of curvature measured by
/// finite differences at the point of inclination `u`; r̂ = 1 is the circle of the default
/// spine, and the radius is continuous through the parabola (r̂ → 0 from both sides).
#[test]
fn conic_spines_match_explicit_curves() {
    let (half, u_max) = (2.0, 0.6_f64);
    for r_hat in [0.4, 1.0, 2.5] {
        // Ellipse x = A sin t, z = B cos t with B = A/r̂: its end slope fixes t_max.
        let t_max = (r_hat * u_max.tan()).atan();
        let a = half / t_max.sin();
        let curve = |t: f64| [a * t.sin(), a / r_hat * t.cos()];
        assert!((curve(t_max)[0] - half).abs() < 1e-12);
        for u in [0.0, 0.2, 0.45] {
            let t = where_inclined(&curve, u, t_max);
            let (expected, got) = (curvature_radius(curve, t), conic_radius(r_hat, half, u_max, u));
            assert!((got / expected - 1.0).abs() < 1e-5, "ellipse r̂ {r_hat} u {u}: {got} vs {expected}");
        }
    }
    assert!((conic_radius(1.0, half, u_max, 0.3) - half / u_max.sin()).abs() < 1e-12, "r̂ = 1 is the circle");
    // Parabola z = −x²/(2p), end slope tan u_max at x = half.
    let p = half / u_max.tan();
    let parabola = |t: f64| [t, -t * t / (2.0 * p)];
    let t = where_inclined(&parabola, 0.3, half);
    assert!((conic_radius(0.0, half, u_max, 0.3) / curvature_radius(parabola, t) - 1.0).abs() < 1e-5);
    // Hyperbola x = A sinh t, z = −B cosh t, B = A/|r̂|.
    let q = 1.2;
    let t_max = (q * u_max.tan()).atanh();
    let a = half / t_max.sinh();
    let hyperbola = |t: f64| [a * t.sinh(), -a / q * t.cosh()];
    let t = where_inclined(&hyperbola, 0.4, t_max);
    assert!((conic_radius(-q, half, u_max, 0.4) / curvature_radius(hyperbola, t) - 1.0).abs() < 1e-5);
    let near = |r: f64| conic_radius(r, half, u_max, 0.3);
    assert!((near(1e-7) / near(0.0) - 1.0).abs() < 1e-5 && (near(-1e-7) / near(0.0) - 1.0).abs() < 1e-5);
}

/// With `spine=conic`, a yarn of κ = 0 (r̂ = 1) gives the circle's values; the silk
/// charmeuse warp (κ = 2, a flatter crest) changes them; every κ > −1 gives a valid
/// hyperbola.
#[test]
fn the_conic_spine_changes_only_curved_yarns() {
    let conic = Variation { spine: Spine::Conic, ..Variation::default() };
    let denim = WeavePattern::preset("cotton-denim").unwrap();
    let (mut a, mut b) = (Irawan2012::new(denim.clone()).unwrap(), Irawan2012::with_variation(denim, conic).unwrap());
    let wi = hemisphere(0.6, 0.3);
    let wo = hemisphere(0.5, 2.9);
    let mut lit = 0;
    for k in 0..400 {
        let (u, v) = ((k % 20) as f64 / 20.0 + 0.01, (k / 20) as f64 / 20.0 + 0.01);
        a.set_position(u, v);
        b.set_position(u, v);
        let (x, y) = (a.integrand(wi, wo), b.integrand(wi, wo));
        lit += usize::from(x > 0.0);
        assert!((x - y).abs() <= 1e-9 * x.abs(), "κ = 0 at ({u}, {v}): {x} vs {y}");
    }
    assert!(lit > 0, "some highlight on the grid");
    let silk = WeavePattern::preset("silk-charmeuse").unwrap();
    let (a, b) = (Irawan2012::new(silk.clone()).unwrap(), Irawan2012::with_variation(silk.clone(), conic).unwrap());
    assert!((a.normalisation() / b.normalisation() - 1.0).abs() > 1e-3, "κ = 2 changes the fabric");
    // Every valid κ (> −1) gives a hyperbola whose asymptotes are steeper than u_max.
    for k in 1..200 {
        let kappa = -1.0 + f64::from(k) * 0.005;
        for d in 1..90 {
            let u_max = f64::from(d).to_radians();
            let r = spine_shape(kappa, u_max);
            assert!(r >= 0.0 || -r * u_max.tan() < 1.0, "κ {kappa} u_max {d}°");
        }
    }
}

/// Fineness: the factor is the same along a fiber (the direction at the twist ψ to the yarn
/// axis) and changes across fibers; its mean is `1 − e⁻¹⁰` (exponential); the
/// normalisation still makes the diffuse-light average 1.
#[test]
fn fineness_varies_per_fiber_and_keeps_the_average() {
    let pattern = WeavePattern::preset("wool-gabardine").unwrap(); // staple, ψ = 30°
    let var = Variation { fineness: 40.0, ..Variation::default() };
    let yarn = pattern.yarns[0];
    let (s, c) = yarn.psi.sin_cos();
    let at = |x: f64, y: f64| Located { yarn: &yarn, id: 1, x, y, instance: [0, 0] };
    let (mut same, mut changes) = (0, 0);
    for k in 0..200 {
        let x0 = (k as f64 + 0.5) / 40.0 / c - 0.5; // strip centres across the fibers
        let here = var.fiber_factor(&at(x0, 0.0));
        // Along the fiber: direction (sin ψ, cos ψ) keeps x cos ψ − y sin ψ.
        let along = var.fiber_factor(&at(x0 + 0.5 * s, 0.5 * c));
        same += usize::from(here == along);
        changes += usize::from(here != var.fiber_factor(&at(x0 + 1.0 / 40.0 / c, 0.0)));
    }
    assert_eq!(same, 200);
    assert!(changes > 190, "{changes}");
    let n = 100_000;
    let (mut sum, mut sum2) = (0.0, 0.0);
    for k in 0..n {
        let f = var.fiber_factor(&Located { yarn: &yarn, id: 1 + k % 3, x: 0.0, y: 0.0, instance: [k as i64 / 3, 7] });
        sum += f;
        sum2 += f * f;
    }
    let mean = sum / n as f64;
    let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
    assert!((mean - 1.0).abs() < 4.0 * sigma, "{mean} ± {sigma}");
    assert_diffuse_average_is_one(&Irawan2012::with_variation(pattern, var).unwrap(), 1.0);
}

/// u_max noise: bounded by its amplitude, smooth (a small step in UV changes it little),
/// not constant, different for warp and weft, and the normalisation includes it.
#[test]
fn umax_noise_is_smooth_bounded_and_normalised() {
    let amp = 8f64.to_radians();
    let var = Variation { umax_noise: amp, umax_noise_period: 0.5, ..Variation::default() };
    let pattern = WeavePattern::preset("polyester-lining").unwrap();
    let (warp, weft) = (pattern.yarns[0], pattern.yarns[1]);
    let (mut lo, mut hi, mut differ) = (f64::INFINITY, f64::NEG_INFINITY, 0);
    for k in 0..2000 {
        let (u, v) = (k as f64 * 0.0137, k as f64 * 0.0071);
        let d = var.u_max(&warp, u, v) - warp.u_max;
        assert!(d.abs() <= amp, "{d}");
        let step = var.u_max(&warp, u + 1e-4, v) - warp.u_max;
        assert!((step - d).abs() < 20.0 * amp * 1e-4 / 0.5, "smooth: {d} → {step}");
        (lo, hi) = (lo.min(d), hi.max(d));
        differ += usize::from((var.u_max(&weft, u, v) - weft.u_max - d).abs() > 1e-9);
    }
    assert!(hi - lo > amp, "the noise spans its range: [{lo}, {hi}]");
    assert!(differ > 1900);
    assert_diffuse_average_is_one(&Irawan2012::with_variation(pattern, var).unwrap(), var.extent());
}

/// `π·E[X·s_n]` under diffuse light over UV in `[0, extent)²` is 1 (independent samples).
fn assert_diffuse_average_is_one(m: &Irawan2012, extent: f64) {
    let mut m = m.clone();
    let mut rng = SplitMix64::new(4242);
    let n = 200_000;
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..n {
        let wi = cosine_direction(rng.next_f64(), rng.next_f64());
        let wo = cosine_direction(rng.next_f64(), rng.next_f64());
        m.set_position(rng.next_f64() * extent, rng.next_f64() * extent);
        let x = PI * m.integrand(wi, wo) * m.normalisation();
        sum += x;
        sum2 += x * x;
    }
    let mean = sum / n as f64;
    let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
    assert!((mean - 1.0).abs() < 8.0 * sigma + 0.01, "{mean} ± {sigma}");
}
