// The pole taper of the samplers at grazing viewers (scatter/src/hair/pole_taper.rs) in f32: a
// monotone map W of θ ∈ [−π/2, π/2] onto itself, the identity until POLE_TAPER_WIDTH from a
// pole, where W(θ) = ±(π/2 − w x²(2 − x)) with x = (π/2 − |θ|)/w, so W′ → 0 at the poles like
// cosθ and a density in W(θ) times W′ stays finite per steradian there.

const POLE_TAPER_WIDTH: f32 = 0.10471975511965977;

fn taper(theta: f32) -> f32 {
    let d = HALF_PI - abs(theta);
    if d >= POLE_TAPER_WIDTH {
        return theta;
    }
    let x = max(d, 0.0) / POLE_TAPER_WIDTH;
    return select(1.0, -1.0, theta < 0.0) * (HALF_PI - POLE_TAPER_WIDTH * x * x * (2.0 - x));
}

fn taper_derivative(theta: f32) -> f32 {
    let d = HALF_PI - abs(theta);
    if d >= POLE_TAPER_WIDTH {
        return 1.0;
    }
    let x = max(d, 0.0) / POLE_TAPER_WIDTH;
    return x * (4.0 - 3.0 * x);
}

/// W⁻¹: the root of x²(2 − x) = s in [0, 1] (trigonometric form, one Newton step).
fn untaper(theta_star: f32) -> f32 {
    let d = HALF_PI - abs(theta_star);
    if d >= POLE_TAPER_WIDTH {
        return theta_star;
    }
    let s = min(max(d, 0.0) / POLE_TAPER_WIDTH, 1.0);
    let c = clamp(1.0 - 27.0 * s / 16.0, -1.0, 1.0);
    let a = atan2_f(safe_sqrt((1.0 - c) * (1.0 + c)), c);
    var t = clamp(2.0 / 3.0 + 4.0 / 3.0 * sin_cos_f(a / 3.0 - 2.0 * PI / 3.0).y, 0.0, 1.0);
    let slope = t * (4.0 - 3.0 * t);
    if slope > 1e-6 {
        t = clamp(t - (t * t * (2.0 - t) - s) / slope, 0.0, 1.0);
    }
    return select(1.0, -1.0, theta_star < 0.0) * (HALF_PI - POLE_TAPER_WIDTH * t);
}
