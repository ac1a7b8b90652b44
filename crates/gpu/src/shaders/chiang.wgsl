// Chiang, Bitterli, Tappan & Burley 2016 near-field hair (scatter/src/chiang_2016.rs) in f32:
// d'Eon 2011's longitudinal M_p, trimmed logistic N_p about the exact exit azimuths Φ(p, h),
// A_p from the 3D Fresnel and chord absorption at the camera-side inclination, the residual
// p ≥ 3; sampled exactly (lobe by luminance of A_p, θ_i from M_p, φ_i from N_p). The material's
// constants are computed in f64 on the CPU (`materials.rs`): per lobe the variance v_p,
// 1/(v_p(1 − e^{−2/v_p})) and e^{−2/v_p} − 1, the tilt rotations, the logistic scale s,
// 1/(F_ℓ(π) − F_ℓ(−π)) and the CDF at ±π.

const PI: f32 = 3.14159265358979;
const TAU: f32 = 6.28318530717959;
/// The fiber axis rule's clamp of cosθ (scatter's `backward_form::MIN_COS`).
const MIN_COS: f32 = 1e-8;

/// True for NaN and ±∞ (by the exponent bits: no reliance on IEEE comparisons).
fn not_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) == 0x7f800000u;
}

fn not_finite3(v: vec3<f32>) -> bool {
    return not_finite(v.x) || not_finite(v.y) || not_finite(v.z);
}

/// `ln(1 + x)`, accurate for small x (the ratio corrects the rounding of 1 + x).
fn log1p(x: f32) -> f32 {
    let u = 1.0 + x;
    if u == 1.0 {
        return x;
    }
    return log(u) * x / (u - 1.0);
}

fn safe_sqrt(x: f32) -> f32 {
    return sqrt(max(x, 0.0));
}

/// `e^{−|x|} I₀(x)`: the polynomial approximations of Abramowitz & Stegun 9.8.1 (|x| ≤ 3.75,
/// |ε| < 1.6·10⁻⁷ of I₀) and 9.8.2 (above, |ε| < 1.9·10⁻⁷ of √x e^{−x} I₀): f32 precision.
fn i0e(x0: f32) -> f32 {
    let x = abs(x0);
    if x <= 3.75 {
        let t = (x / 3.75) * (x / 3.75);
        let i0 = 1.0 + t * (3.5156229 + t * (3.0899424 + t * (1.2067492 + t * (0.2659732 + t * (0.0360768 + t * 0.0045813)))));
        return i0 * exp(-x);
    }
    let t = 3.75 / x;
    let p = 0.39894228 + t * (0.01328592 + t * (0.00225319 + t * (-0.00157565 + t * (0.00916281
        + t * (-0.02057706 + t * (0.02635537 + t * (-0.01647633 + t * 0.00392377)))))));
    return p / sqrt(x);
}

// Trigonometry to f32 precision. Vulkan lets sin and cos be off by 2⁻¹¹ and atan by 4096 ulp
// (lavapipe's are), far too coarse for lobes a few hundredths of a radian wide; these are the
// classic Cephes single-precision polynomials (Moshier) with their range reductions.

/// (sin x, cos x): x reduced by multiples of π/2 in three parts (exact products), then the
/// minimax polynomials on [−π/4, π/4].
fn sin_cos_f(x: f32) -> vec2<f32> {
    let j = round(x * 0.63661977236758134);
    let r = ((x - j * 1.5703125) - j * 4.837512969970703125e-4) - j * 7.549789948768648e-8;
    let z = r * r;
    let s = r + r * z * (-1.6666654611e-1 + z * (8.3321608736e-3 + z * -1.9515295891e-4));
    let c = 1.0 - 0.5 * z + z * z * (4.166664568298827e-2 + z * (-1.388731625493765e-3 + z * 2.443315711809948e-5));
    let q = i32(j) & 3;
    if q == 0 {
        return vec2<f32>(s, c);
    } else if q == 1 {
        return vec2<f32>(c, -s);
    } else if q == 2 {
        return vec2<f32>(-s, -c);
    }
    return vec2<f32>(-c, s);
}

/// atan x for x ≥ 0: reduced to |x| ≤ tan(π/8), then the minimax polynomial.
fn atan_positive(x: f32) -> f32 {
    var y = 0.0;
    var t = x;
    if x > 2.414213562373095 {
        y = 1.5707963267948966;
        t = -1.0 / x;
    } else if x > 0.4142135623730950 {
        y = 0.7853981633974483;
        t = (x - 1.0) / (x + 1.0);
    }
    let z = t * t;
    return y + (((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z - 3.33329491539e-1) * z * t + t;
}

/// atan2(y, x) in (−π, π] (0 for the origin).
fn atan2_f(y: f32, x: f32) -> f32 {
    if x == 0.0 && y == 0.0 {
        return 0.0;
    }
    let ax = abs(x);
    let ay = abs(y);
    var a: f32;
    if ay <= ax {
        a = atan_positive(ay / ax);
    } else {
        a = 1.5707963267948966 - atan_positive(ax / ay);
    }
    if x < 0.0 {
        a = 3.141592653589793 - a;
    }
    return select(a, -a, y < 0.0);
}

fn asin_f(x: f32) -> f32 {
    let c = clamp(x, -1.0, 1.0);
    return atan2_f(c, sqrt((1.0 - c) * (1.0 + c)));
}

fn luminance(c: vec3<f32>) -> f32 {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

/// Fresnel reflectance of a dielectric of relative index `eta` at incidence cosine `cos_i`
/// (math/src/fresnel.rs).
fn fresnel_dielectric(cos_i0: f32, eta0: f32) -> f32 {
    var cos_i = cos_i0;
    var eta = eta0;
    if cos_i < 0.0 {
        cos_i = -cos_i;
        eta = 1.0 / eta;
    }
    cos_i = min(cos_i, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (r_s * r_s + r_p * r_p);
}

/// glam's `any_orthonormal_pair` (Duff et al. 2017), as the CPU samples cones with it
/// (the lights' cones, the frames about an axis of the fiber models).
fn orthonormal_pair(n: vec3<f32>) -> array<vec3<f32>, 2> {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return array<vec3<f32>, 2>(
        vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        vec3<f32>(b, sign + n.y * n.y * a, -n.y),
    );
}

// Local fiber coordinates: x along the tangent, ω = (sinθ, cosθ cosφ, cosθ sinφ).
fn local_sin_theta(w: vec3<f32>) -> f32 {
    return clamp(w.x, -1.0, 1.0);
}

fn local_cos_theta(w: vec3<f32>) -> f32 {
    return min(sqrt(w.y * w.y + w.z * w.z), 1.0);
}

fn local_phi(w: vec3<f32>) -> f32 {
    return atan2_f(w.z, w.y);
}

/// A Chiang material's constants (`materials.rs` writes them in this order).
struct Chiang {
    eta: f32,
    sigma_a: vec3<f32>,
    s: f32,
    logistic_norm: f32,
    cdf_lo: f32,
    cdf_hi: f32,
    v: vec4<f32>,
    inv_norm: vec4<f32>,
    expm1_neg: vec4<f32>,
    tilt_sin: vec4<f32>,
    tilt_cos: vec4<f32>,
}

/// d'Eon's M_p(θ_i, θ_o) in the cancellation-free form of scatter/src/hair/longitudinal.rs.
fn longitudinal(v: f32, inv_norm: f32, sin_i: f32, cos_i: f32, sin_o: f32, cos_o: f32) -> f32 {
    let a = cos_i * cos_o / v;
    let one_minus_cos = 0.5 * ((cos_i - cos_o) * (cos_i - cos_o) + (sin_i + sin_o) * (sin_i + sin_o));
    let e = exp(-one_minus_cos / v);
    if e == 0.0 {
        return 0.0;
    }
    return i0e(a) * e * inv_norm;
}

/// sinθ_i drawn from M(·, θ_o) of variance `v` (`expm1_neg` = e^{−2/v} − 1) by exact inversion
/// (`Longitudinal::sample_sin_theta`): the cosine to the mirror direction, then its azimuth.
fn longitudinal_sample_sin(v: f32, expm1_neg: f32, sin_o: f32, cos_o: f32, u1: f32, u2: f32) -> f32 {
    let cc = max(1.0 + v * log1p((1.0 - u1) * expm1_neg), -1.0);
    let ss = safe_sqrt(1.0 - cc * cc);
    return clamp(-cc * sin_o + ss * sin_cos_f(TAU * u2).y * cos_o, -1.0, 1.0);
}

fn logistic(x: f32, s: f32) -> f32 {
    let e = exp(-abs(x) / s);
    return e / (s * (1.0 + e) * (1.0 + e));
}

/// `x` wrapped to (−π, π] by whole turns (at most a few from the range).
fn wrap_few_turns(x: f32) -> f32 {
    var y = x;
    for (var k = 0; k < 16 && y > PI; k++) {
        y -= TAU;
    }
    for (var k = 0; k < 16 && y <= -PI; k++) {
        y += TAU;
    }
    return y;
}

/// The fiber at one path vertex (fixed ω_o and h): what `ChiangAtVertex` holds.
struct ChiangVertex {
    a0: vec3<f32>,
    a1: vec3<f32>,
    a2: vec3<f32>,
    a3: vec3<f32>,
    /// Lobe-selection weights (all 0 when every A_p vanishes).
    w: vec4<f32>,
    tilted_sin: vec4<f32>,
    tilted_cos: vec4<f32>,
    exit: vec3<f32>,
    phi_o: f32,
}

fn chiang_at_vertex(m: Chiang, wo: vec3<f32>, h0: f32) -> ChiangVertex {
    var out: ChiangVertex;
    let sin_o = local_sin_theta(wo);
    let cos_o = local_cos_theta(wo);
    let h = clamp(h0, -1.0, 1.0);
    let cos_gamma_o = safe_sqrt(1.0 - h * h);
    let f = fresnel_dielectric(cos_o * cos_gamma_o, m.eta);
    let sin_gamma_t = h * cos_o / sqrt(m.eta * m.eta - sin_o * sin_o);
    let cos_gamma_t = safe_sqrt(1.0 - sin_gamma_t * sin_gamma_t);
    let st = sin_o / m.eta;
    let cos_theta_t = safe_sqrt(1.0 - st * st);
    let t = exp(-m.sigma_a * (2.0 * cos_gamma_t / cos_theta_t));
    out.a0 = vec3<f32>(f);
    out.a1 = t * ((1.0 - f) * (1.0 - f));
    out.a2 = out.a1 * t * f;
    let ft = t * f;
    out.a3 = select(vec3<f32>(0.0), out.a2 * ft / (1.0 - ft), ft < vec3<f32>(1.0));
    let y = vec4<f32>(luminance(out.a0), luminance(out.a1), luminance(out.a2), luminance(out.a3));
    let total = y.x + y.y + y.z + y.w;
    out.w = select(vec4<f32>(0.0), y / total, total > 0.0);
    // Tilted camera-side inclinations: (sin(θ + τ), |cos(θ + τ)|).
    out.tilted_sin = sin_o * m.tilt_cos + cos_o * m.tilt_sin;
    out.tilted_cos = abs(cos_o * m.tilt_cos - sin_o * m.tilt_sin);
    let gamma_o = asin_f(h);
    let gamma_t = asin_f(sin_gamma_t);
    out.exit = vec3<f32>(-2.0 * gamma_o, 2.0 * gamma_t - 2.0 * gamma_o + PI, 4.0 * gamma_t - 2.0 * gamma_o + 2.0 * PI);
    out.phi_o = local_phi(wo);
    return out;
}

/// M_p N_p of lobe p at the light direction (sinθ_i, cosθ_i, φ = φ_i − φ_o).
fn chiang_m_n(m: Chiang, c: ChiangVertex, p: u32, sin_i: f32, cos_i: f32, dphi: f32) -> f32 {
    let mp = longitudinal(m.v[p], m.inv_norm[p], sin_i, cos_i, c.tilted_sin[p], c.tilted_cos[p]);
    var n = 1.0 / TAU;
    if p < 3u {
        n = logistic(wrap_few_turns(dphi - c.exit[p]), m.s) * m.logistic_norm;
    }
    return mp * n;
}

/// (g_h, pdf): the per-h integrand Σ M_p A_p N_p (rgb) and the sampling density (w).
fn chiang_integrand_and_pdf(m: Chiang, c: ChiangVertex, sin_i: f32, cos_i: f32, dphi: f32) -> vec4<f32> {
    if c.w.x + c.w.y + c.w.z + c.w.w <= 0.0 {
        return vec4<f32>(0.0);
    }
    let n0 = chiang_m_n(m, c, 0u, sin_i, cos_i, dphi);
    let n1 = chiang_m_n(m, c, 1u, sin_i, cos_i, dphi);
    let n2 = chiang_m_n(m, c, 2u, sin_i, cos_i, dphi);
    let n3 = chiang_m_n(m, c, 3u, sin_i, cos_i, dphi);
    let g = c.a0 * n0 + c.a1 * n1 + c.a2 * n2 + c.a3 * n3;
    let pdf = c.w.x * n0 + c.w.y * n1 + c.w.z * n2 + c.w.w * n3;
    return vec4<f32>(g, pdf);
}

/// (f_s, pdf) for the local light direction `wi`.
fn chiang_eval(m: Chiang, c: ChiangVertex, wi: vec3<f32>) -> vec4<f32> {
    let cos_i = local_cos_theta(wi);
    let r = chiang_integrand_and_pdf(m, c, local_sin_theta(wi), cos_i, local_phi(wi) - c.phi_o);
    return vec4<f32>(r.xyz / max(cos_i, MIN_COS), r.w);
}

/// A drawn direction: local `wi`, the weight f cosθ/pdf, the pdf (≤ 0: none drawn).
struct FiberSample {
    wi: vec3<f32>,
    weight: vec3<f32>,
    pdf: f32,
}

/// The local direction (sinθ, cosθ cosφ, cosθ sinφ) at inclination θ and azimuth φ.
fn fiber_direction(theta: f32, phi: f32) -> vec3<f32> {
    let st = sin_cos_f(theta);
    let sp = sin_cos_f(phi);
    return vec3<f32>(st.x, st.y * sp.y, st.y * sp.x);
}

/// The sample at ω_i given (f_s, pdf) there: weight f_s cosθ_i/pdf; none (pdf 0) where the pdf
/// is not positive and finite.
fn fiber_sample_at(wi: vec3<f32>, e: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    if !(e.w > 0.0) || not_finite(e.w) {
        return out;
    }
    out.wi = wi;
    out.pdf = e.w;
    out.weight = e.xyz * (local_cos_theta(wi) / e.w);
    return out;
}

/// sinθ_i drawn from lobe p's M_p about the tilted camera side (sinθ_o, cosθ_o) with u₁, u₂.
fn sample_longitudinal(m: Chiang, p: u32, so: f32, co: f32, u1: f32, u2: f32) -> f32 {
    return longitudinal_sample_sin(m.v[p], m.expm1_neg[p], so, co, u1, u2);
}

/// An offset from the trimmed logistic by its inverse CDF, in [−π, π].
fn sample_trimmed_logistic(m: Chiang, u: f32) -> f32 {
    let cdf = m.cdf_lo + u * (m.cdf_hi - m.cdf_lo);
    var x = m.s * (log(cdf) - log1p(-cdf));
    if not_finite(x) {
        x = select(select(0.0, PI, x > 0.0), -PI, x < 0.0);
        if x != x {
            x = 0.0;
        }
    }
    return clamp(x, -PI, PI);
}

fn chiang_sample(m: Chiang, c: ChiangVertex, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    if c.w.x + c.w.y + c.w.z + c.w.w <= 0.0 {
        return out;
    }
    var p = 0u;
    var acc = c.w.x;
    while p < 3u && u.x >= acc {
        p += 1u;
        acc += c.w[p];
    }
    while c.w[p] == 0.0 && p > 0u {
        p -= 1u;
    }
    // θ_i from M_p(·, θ_o^(p)).
    let sin_i = sample_longitudinal(m, p, c.tilted_sin[p], c.tilted_cos[p], u.y, u.z);
    let cos_i = safe_sqrt(1.0 - sin_i * sin_i);
    // φ_i from the trimmed logistic by its inverse CDF (uniform for p = 3).
    var dphi = TAU * u.w;
    if p < 3u {
        dphi = c.exit[p] + sample_trimmed_logistic(m, u.w);
    }
    let phi_i = c.phi_o + dphi;
    let sc = sin_cos_f(phi_i);
    out.wi = vec3<f32>(sin_i, cos_i * sc.y, cos_i * sc.x);
    let r = chiang_integrand_and_pdf(m, c, sin_i, cos_i, dphi);
    if not_finite(r.w) || r.w <= 0.0 {
        out.pdf = 0.0;
        return out;
    }
    out.weight = r.xyz / r.w;
    out.pdf = r.w;
    return out;
}
