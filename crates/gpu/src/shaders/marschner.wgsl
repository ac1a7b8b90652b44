// Marschner, Jensen, Cammarano, Worley & Hanrahan 2003 hair (scatter/src/marschner_2003/) in
// f32: S = Σ_p M_p(θ_h) N_p(η′(θ_d), φ)/cos²θ_d with the Gaussian M_p of Table 1, N_p summed
// over the exact (or the paper's cubic) roots of Φ(p, γ) = φ found by bracketing and
// safeguarded Newton on the monotone pieces of Φ, A_p from the 3D Fresnel and the chord (or
// printed) path, the TRT glints and the eccentric TRT index η*. Sampled as on the CPU
// (`sampling.rs`): the lobe from the CPU's table of weights over |θ_r| (copied,
// `scene_buffers.rs::marschner_words`), θ_h from the truncated Gaussian by inversion, θ_i through
// the pole taper, φ from the mixture of the h-map, the tent-smoothed TRT h-map, the glint
// Gaussians and a uniform part; the pdf is that mixture's density. The one difference in form:
// the smoothed TRT density `½∫(ε − |φ − Φ(2, h)|)⁺ dh / ε²` is integrated by Gauss–Legendre
// between the roots of Φ = φ, φ ± ε (its integrand is smooth there), where the CPU differences
// a closed-form primitive, which would cancel to 10⁻³ in f32.
//
// Words at `b` (32 per material): 0 kind, 1 η, 2–4 σ_a, 5 k_M, 6 k_G, 7 w_c, 8 Δη′, 9 Δh_M,
// 10 the lobe table's first word, 11 flags (1 cubic roots, 2 glints, 4 printed absorption path,
// 8 << p lobe p enabled), 12 eccentricity a, 13–14 η*₁, η*₂, 15–17 α_p, 18–20 β_p.
// The table: 65 rows of the three unnormalized lobe weights at |θ_r| = kπ/128.

const MATERIAL_MARSCHNER: u32 = 4u;
const MS_FLAG_CUBIC: u32 = 1u;
const MS_FLAG_GLINTS: u32 = 2u;
const MS_FLAG_PAPER_PATH: u32 = 4u;
const MS_FLAG_LOBE0: u32 = 8u;
/// `MIN_COS_THETA_D`, `MIN_DPHI`, `LOBE_CUTOFF_SIGMAS`, `LOBE_FLOOR` of the CPU model.
const MS_MIN_COS_THETA_D: f32 = 1e-6;
const MS_MIN_DPHI: f32 = 1e-12;
const MS_LOBE_CUTOFF_SIGMAS: f32 = 12.0;
const MS_LOBE_FLOOR: f32 = 0.02;
const MS_TABLE_INTERVALS: u32 = 64u;
/// The sampler's TRT φ-mixture constants (`sampling.rs`).
const MS_TRT_UNIFORM_CIRCULAR: f32 = 0.05;
const MS_TRT_UNIFORM_ECCENTRIC: f32 = 0.2;
const MS_TRT_SMOOTHING: f32 = 0.10471975511965977;
const MS_TRT_GLINT_MAX: f32 = 0.8;
/// |Φ − goal| at which the root solve stops: a few f32 ulps of 3π.
const MS_ROOT_TOLERANCE: f32 = 2e-6;
const MS_MAX_ROOT_ITERATIONS: u32 = 60u;
const SQRT_TAU: f32 = 2.5066282746310002;

struct Marschner {
    eta: f32,
    sigma_a: vec3<f32>,
    k_m: f32,
    k_g: f32,
    w_c: f32,
    delta_eta: f32,
    delta_h_m: f32,
    table: u32,
    flags: u32,
    eccentricity: f32,
    eta_star: vec2<f32>,
    alpha: vec3<f32>,
    beta: vec3<f32>,
}

fn load_marschner(b: u32) -> Marschner {
    var m: Marschner;
    m.eta = word_f(b + 1u);
    m.sigma_a = vec3<f32>(word_f(b + 2u), word_f(b + 3u), word_f(b + 4u));
    m.k_m = word_f(b + 5u);
    m.k_g = word_f(b + 6u);
    m.w_c = word_f(b + 7u);
    m.delta_eta = word_f(b + 8u);
    m.delta_h_m = word_f(b + 9u);
    m.table = word_u(b + 10u);
    m.flags = word_u(b + 11u);
    m.eccentricity = word_f(b + 12u);
    m.eta_star = vec2<f32>(word_f(b + 13u), word_f(b + 14u));
    m.alpha = vec3<f32>(word_f(b + 15u), word_f(b + 16u), word_f(b + 17u));
    m.beta = vec3<f32>(word_f(b + 18u), word_f(b + 19u), word_f(b + 20u));
    return m;
}

fn ms_lobe_on(m: Marschner, p: u32) -> bool {
    return (m.flags & (MS_FLAG_LOBE0 << p)) != 0u;
}

/// Unit-area Gaussian g(σ; x).
fn gaussian_f(sigma: f32, x: f32) -> f32 {
    let z = x / sigma;
    return exp(-0.5 * z * z) / (sigma * SQRT_TAU);
}

/// The wrapped Gaussian (math's `wrapped_gaussian`: images |k| ≤ ⌈6σ/2π⌉ + 1).
fn wrapped_gaussian_f(sigma: f32, x0: f32) -> f32 {
    let x = wrap_few_turns(x0);
    let k_max = i32(ceil(6.0 * sigma / TAU)) + 1;
    var sum = 0.0;
    for (var k = -k_max; k <= k_max; k++) {
        sum += gaussian_f(sigma, x + TAU * f32(k));
    }
    return sum;
}

fn smoothstep_f(a: f32, b: f32, x: f32) -> f32 {
    let t = clamp((x - a) / (b - a), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

/// `e^{z²} erfc(z)` for z ≥ 0 (Numerical Recipes' Chebyshev fit of erfc, relative error below
/// 1.2·10⁻⁷ everywhere), so that tails keep their relative precision.
fn erfcx_positive(z: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -1.26551223 + t * (1.00002368 + t * (0.37409196 + t * (0.09678418 + t * (-0.18628806
        + t * (0.27886807 + t * (-1.13520398 + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277))))))));
    return t * exp(poly);
}

fn erfc_f(x: f32) -> f32 {
    let z = abs(x);
    let r = erfcx_positive(z) * exp(-z * z);
    return select(2.0 - r, r, x >= 0.0);
}

fn normal_cdf_f(z: f32) -> f32 {
    return 0.5 * erfc_f(-z * 0.70710678118654752);
}

fn normal_sf_f(z: f32) -> f32 {
    return 0.5 * erfc_f(z * 0.70710678118654752);
}

/// Mass of the standard normal on [zl, zu], on the side that keeps relative precision.
fn normal_mass_f(zl: f32, zu: f32) -> f32 {
    var m: f32;
    if zl >= 0.0 {
        m = normal_sf_f(zl) - normal_sf_f(zu);
    } else if zu <= 0.0 {
        m = normal_cdf_f(zu) - normal_cdf_f(zl);
    } else {
        m = 1.0 - normal_cdf_f(zl) - normal_sf_f(zu);
    }
    return max(m, 0.0);
}

/// Φ⁻¹(p): Acklam's rational approximation and one Halley step, as math's `inverse_normal_cdf`.
fn inverse_normal_cdf_f(p: f32) -> f32 {
    if p <= 0.0 {
        return -1e30;
    }
    if p >= 1.0 {
        return 1e30;
    }
    var x: f32;
    if p < 0.02425 || p > 1.0 - 0.02425 {
        let q = select(p, 1.0 - p, p > 0.5);
        let r = sqrt(-2.0 * log(q));
        let t = (((((-7.784894002430293e-3 * r - 3.223964580411365e-1) * r - 2.400758277161838) * r
            - 2.549732539343734) * r + 4.374664141464968) * r + 2.938163982698783)
            / ((((7.784695709041462e-3 * r + 3.224671290700398e-1) * r + 2.445134137142996) * r
            + 3.754408661907416) * r + 1.0);
        x = select(t, -t, p > 0.5);
    } else {
        let q = p - 0.5;
        let r = q * q;
        x = (((((-3.969683028665376e1 * r + 2.209460984245205e2) * r - 2.759285104469687e2) * r
            + 1.38357751867269e2) * r - 3.066479806614716e1) * r + 2.506628277459239) * q
            / (((((-5.447609879822406e1 * r + 1.615858368580409e2) * r - 1.556989798598866e2) * r
            + 6.680131188771972e1) * r - 1.328068155288572e1) * r + 1.0);
    }
    var e: f32;
    if p < 0.5 {
        e = normal_cdf_f(x) - p;
    } else {
        e = (1.0 - p) - normal_sf_f(x);
    }
    let u = e * SQRT_TAU * exp(0.5 * x * x);
    let refined = x - u / (1.0 + 0.5 * x * u);
    return select(x, refined, !not_finite(refined));
}

/// z from the standard normal truncated to [zl, zu] by inversion with u (math's
/// `sample_truncated_normal`).
fn sample_truncated_normal_f(u: f32, zl: f32, zu: f32) -> f32 {
    let mass = normal_mass_f(zl, zu);
    var z: f32;
    if zl >= 0.0 {
        z = -inverse_normal_cdf_f(normal_sf_f(zl) - u * mass);
    } else {
        let p = normal_cdf_f(zl) + u * mass;
        if p <= 0.5 {
            z = inverse_normal_cdf_f(p);
        } else {
            z = -inverse_normal_cdf_f(normal_sf_f(zu) + (1.0 - u) * mass);
        }
    }
    if z != z {
        return 0.5 * (zl + zu);
    }
    return clamp(z, zl, zu);
}

/// The normal-plane problem of one inclination and index (scatter's `NormalPlane`).
struct MsPlane {
    eta: f32,
    cos_theta_d: f32,
    /// `1/η′ = cosθ_d/√(η² − sin²θ_d)`.
    inv_eta_prime: f32,
    /// `asin(1/η′)`, the cubic's parameter.
    c: f32,
    cos_theta_t: f32,
    cubic: bool,
}

fn ms_plane(eta: f32, sin_td: f32, cos_td: f32, cubic: bool) -> MsPlane {
    var pl: MsPlane;
    pl.eta = eta;
    pl.cos_theta_d = cos_td;
    pl.inv_eta_prime = cos_td / sqrt(eta * eta - sin_td * sin_td);
    pl.c = asin_f(pl.inv_eta_prime);
    let st = sin_td / eta;
    pl.cos_theta_t = safe_sqrt(1.0 - st * st);
    pl.cubic = cubic;
    return pl;
}

fn acos_f(x: f32) -> f32 {
    let c = clamp(x, -1.0, 1.0);
    return atan2_f(sqrt((1.0 - c) * (1.0 + c)), c);
}

/// `(a, b)` of the cubic `Φ̂(p, γ) = aγ³ + bγ + pπ`.
fn ms_cubic_coefficients(pl: MsPlane, p: u32) -> vec2<f32> {
    let pc = f32(p) * pl.c;
    return vec2<f32>(-8.0 * pc / (PI * PI * PI), 6.0 * pc / PI - 2.0);
}

/// (Φ(p, γ) not reduced, dΦ/dγ) in the plane's root mode.
fn ms_phi(pl: MsPlane, p: u32, gamma: f32) -> vec2<f32> {
    let pf = f32(p);
    if pl.cubic {
        let ab = ms_cubic_coefficients(pl, p);
        return vec2<f32>(ab.x * gamma * gamma * gamma + ab.y * gamma + pf * PI, 3.0 * ab.x * gamma * gamma + ab.y);
    }
    let sc = sin_cos_f(gamma);
    let st = sc.x * pl.inv_eta_prime;
    let phi = 2.0 * pf * asin_f(st) - 2.0 * gamma + pf * PI;
    let d = 2.0 * pf * pl.inv_eta_prime * sc.y / safe_sqrt(1.0 - st * st) - 2.0;
    return vec2<f32>(phi, d);
}

/// The stationary point γ_s ∈ (0, π/2) of Φ(p, ·), or −1 when there is none.
fn ms_stationary(pl: MsPlane, p: u32) -> f32 {
    if pl.cubic {
        let ab = ms_cubic_coefficients(pl, p);
        if p == 0u || ab.y <= 0.0 || ab.x >= 0.0 {
            return -1.0;
        }
        let g = sqrt(-ab.y / (3.0 * ab.x));
        return select(-1.0, g, g < HALF_PI);
    }
    let inv2 = pl.inv_eta_prime * pl.inv_eta_prime;
    if p < 2u || inv2 <= 0.0 {
        return -1.0;
    }
    let cos2 = (1.0 - inv2) / (f32(p * p - 1u) * inv2);
    if cos2 < 1.0 && cos2 > 0.0 {
        return acos_f(sqrt(cos2));
    }
    return -1.0;
}

/// (γ, 1) with Φ(p, γ) = goal on a piece [lo, hi] where Φ is monotone (Φ(lo) = phi_lo,
/// Φ(hi) = phi_hi), or (0, 0) when the piece has no root: regula falsi start, then Newton
/// steps kept inside the bracket.
fn ms_solve_monotone(pl: MsPlane, p: u32, goal: f32, lo: f32, hi: f32, phi_lo: f32, phi_hi: f32) -> vec2<f32> {
    let f_lo = phi_lo - goal;
    let f_hi = phi_hi - goal;
    if f_lo == 0.0 {
        return vec2<f32>(lo, 1.0);
    }
    if f_hi == 0.0 {
        return vec2<f32>(hi, 1.0);
    }
    if (f_lo > 0.0) == (f_hi > 0.0) {
        return vec2<f32>(0.0, 0.0);
    }
    let increasing = f_hi > f_lo;
    var a = lo;
    var b = hi;
    var x = lo + (hi - lo) * f_lo / (f_lo - f_hi);
    for (var k = 0u; k < MS_MAX_ROOT_ITERATIONS; k++) {
        let pd = ms_phi(pl, p, x);
        let f = pd.x - goal;
        if abs(f) <= MS_ROOT_TOLERANCE {
            break;
        }
        if (f > 0.0) == increasing {
            b = x;
        } else {
            a = x;
        }
        let newton = x - f / pd.y;
        var next = 0.5 * (a + b);
        if newton > a && newton < b {
            next = newton;
        }
        let step = abs(next - x);
        x = next;
        if step <= 1e-7 * (1.0 + abs(x)) || b - a <= 1e-7 {
            break;
        }
    }
    return vec2<f32>(x, 1.0);
}

/// The roots γ of Φ(p, γ) = goal (goal in (pπ − π, pπ + π]): up to three, count in `n`.
struct MsRoots {
    g: vec3<f32>,
    n: u32,
}

fn ms_push(r: ptr<function, MsRoots>, found: vec2<f32>) {
    if found.y > 0.0 && (*r).n < 3u {
        (*r).g[(*r).n] = found.x;
        (*r).n += 1u;
    }
}

fn ms_roots(pl: MsPlane, p: u32, goal: f32) -> MsRoots {
    var r: MsRoots;
    r.n = 0u;
    if p == 0u {
        let g = -0.5 * goal;
        if abs(g) <= HALF_PI {
            ms_push(&r, vec2<f32>(g, 1.0));
        }
        return r;
    }
    let pi_p = f32(p) * PI;
    let end = 2.0 * f32(p) * pl.c - PI;
    let gs = ms_stationary(pl, p);
    if gs < 0.0 {
        ms_push(&r, ms_solve_monotone(pl, p, goal, -HALF_PI, HALF_PI, -end + pi_p, end + pi_p));
    } else {
        let mid = ms_phi(pl, p, gs).x - pi_p;
        ms_push(&r, ms_solve_monotone(pl, p, goal, -HALF_PI, -gs, -end + pi_p, -mid + pi_p));
        ms_push(&r, ms_solve_monotone(pl, p, goal, -gs, gs, -mid + pi_p, mid + pi_p));
        ms_push(&r, ms_solve_monotone(pl, p, goal, gs, HALF_PI, mid + pi_p, end + pi_p));
    }
    return r;
}

/// The representative of φ modulo 2π in (pπ − π, pπ + π].
fn ms_representative(p: u32, phi: f32) -> f32 {
    if p == 0u {
        return phi;
    }
    if p == 1u {
        return select(phi + TAU, phi, phi > 0.0);
    }
    return phi + TAU;
}

/// The TRT caustic: (h_c, φ_c, d²Φ/dh² at h_c, fade t); h_c = 0 once the caustics merged.
fn ms_caustic(pl: MsPlane, delta_eta: f32) -> vec4<f32> {
    let gc = ms_stationary(pl, 2u);
    if gc >= 0.0 {
        let h_c = sin_cos_f(gc).x;
        let phi_c = ms_phi(pl, 2u, gc).x - TAU;
        var d2: f32;
        if pl.cubic {
            let a = ms_cubic_coefficients(pl, 2u).x;
            let cg = sin_cos_f(gc).y;
            d2 = 6.0 * a * gc / (cg * cg);
        } else {
            let hi = h_c * pl.inv_eta_prime;
            let inv3 = pl.inv_eta_prime * pl.inv_eta_prime * pl.inv_eta_prime;
            let a = 1.0 - hi * hi;
            let b = 1.0 - h_c * h_c;
            d2 = 4.0 * h_c * inv3 / (a * sqrt(a)) - 2.0 * h_c / (b * sqrt(b));
        }
        return vec4<f32>(h_c, phi_c, d2, 1.0);
    }
    var t = 0.0;
    if pl.inv_eta_prime > 0.0 {
        t = 1.0 - smoothstep_f(2.0, 2.0 + delta_eta, 1.0 / pl.inv_eta_prime);
    }
    return vec4<f32>(0.0, 0.0, 0.0, t);
}

/// The glint's half-width Δh for a caustic.
fn ms_glint_width(m: Marschner, c: vec4<f32>) -> f32 {
    if c.x > 0.0 {
        return min(m.delta_h_m, 2.0 * sqrt(2.0 * m.w_c / abs(c.z)));
    }
    return m.delta_h_m;
}

/// A(p, γ) in the plane (whose η is the lobe's): A_0 = F, A_p = (1 − F)² F^{p−1} T^p.
fn ms_attenuation(m: Marschner, pl: MsPlane, p: u32, gamma: f32) -> vec3<f32> {
    let sc = sin_cos_f(gamma);
    let f = fresnel_dielectric(pl.cos_theta_d * sc.y, pl.eta);
    if p == 0u {
        return vec3<f32>(f);
    }
    let st = sc.x * pl.inv_eta_prime;
    let cos_gamma_t = safe_sqrt(1.0 - st * st);
    var path = 2.0 * cos_gamma_t / pl.cos_theta_t;
    if (m.flags & MS_FLAG_PAPER_PATH) != 0u {
        path = 4.0 * cos_gamma_t * cos_gamma_t / pl.cos_theta_t;
    }
    let t = exp(-m.sigma_a * path);
    var a = t * ((1.0 - f) * (1.0 - f));
    for (var k = 1u; k < p; k++) {
        a = a * t * f;
    }
    return a;
}

/// The smallest |dΦ/dγ| used in N_p and the h-map density. The CPU's is MIN_DPHI; in f32 a
/// root within Φ's rounding of a caustic lands anywhere within about √(2δ/|Φ_γγ|) of the
/// stationary point γ_s, where |dΦ/dγ| ranges from 0 to √(2|Φ_γγ|δ), so |dΦ/dγ| is clamped at
/// that value, `cosγ_s·√(2|d²Φ/dh²|·δ)` with δ = MS_CAUSTIC_ROUNDING (it acts only within δ of
/// the caustic's azimuth, where the exact density is itself f32 noise).
const MS_CAUSTIC_ROUNDING: f32 = 4e-6;

fn ms_min_dphi(pl: MsPlane, p: u32) -> f32 {
    if p != 2u {
        return MS_MIN_DPHI;
    }
    let c = ms_caustic(pl, 0.0);
    if c.x <= 0.0 {
        return MS_MIN_DPHI;
    }
    return max(safe_sqrt(1.0 - c.x * c.x) * sqrt(2.0 * abs(c.z) * MS_CAUSTIC_ROUNDING), MS_MIN_DPHI);
}

/// N_P(p, φ) = Σ_roots A cosγ/(2|dΦ/dγ|), without the glints.
fn ms_azimuthal_without_glints(m: Marschner, pl: MsPlane, p: u32, phi: f32) -> vec3<f32> {
    let r = ms_roots(pl, p, ms_representative(p, phi));
    let min_d = ms_min_dphi(pl, p);
    var n = vec3<f32>(0.0);
    for (var k = 0u; k < r.n; k++) {
        let g = r.g[k];
        let d = max(abs(ms_phi(pl, p, g).y), min_d);
        n += ms_attenuation(m, pl, p, g) * (sin_cos_f(g).y / (2.0 * d));
    }
    return n;
}

/// `1 − t·e^{−y}` for y ≥ 0 without cancellation when t = 1 and y is small (the glints'
/// suppression next to the caustic, multiplied there by a nearly singular N_P).
fn ms_one_minus_t_exp(t: f32, y: f32) -> f32 {
    var one_minus_exp = 1.0 - exp(-y);
    if y < 1e-2 {
        one_minus_exp = y * (1.0 - y * (0.5 - y / 6.0));
    }
    return (1.0 - t) + t * one_minus_exp;
}

/// N_p(φ) in the plane, the TRT glints included.
fn ms_azimuthal(m: Marschner, pl: MsPlane, p: u32, phi: f32) -> vec3<f32> {
    let n_p = ms_azimuthal_without_glints(m, pl, p, phi);
    if p != 2u || (m.flags & MS_FLAG_GLINTS) == 0u {
        return n_p;
    }
    let c = ms_caustic(pl, m.delta_eta);
    if c.w <= 0.0 {
        return n_p;
    }
    let dh = ms_glint_width(m, c);
    let w = m.w_c;
    let xm = wrap_few_turns(phi - c.y);
    let xp = wrap_few_turns(phi + c.y);
    let suppress = ms_one_minus_t_exp(c.w, 0.5 * (xm / w) * (xm / w)) * ms_one_minus_t_exp(c.w, 0.5 * (xp / w) * (xp / w));
    let a_c = ms_attenuation(m, pl, 2u, asin_f(c.x));
    return n_p * suppress + a_c * (c.w * m.k_g * dh * (gaussian_f(w, xm) + gaussian_f(w, xp)));
}

/// The angles of a direction pair (scatter's `PairAngles`).
struct MsAngles {
    theta_i: f32,
    theta_r: f32,
    theta_h: f32,
    sin_theta_d: f32,
    cos_theta_d: f32,
    phi: f32,
    cos_2phi_h: f32,
}

fn ms_angles(wi: vec3<f32>, wr: vec3<f32>) -> MsAngles {
    var a: MsAngles;
    a.theta_i = atan2_f(local_sin_theta(wi), local_cos_theta(wi));
    a.theta_r = atan2_f(local_sin_theta(wr), local_cos_theta(wr));
    let phi_i = local_phi(wi);
    let phi_r = local_phi(wr);
    let sc = sin_cos_f(0.5 * (a.theta_r - a.theta_i));
    a.sin_theta_d = sc.x;
    a.cos_theta_d = sc.y;
    a.theta_h = 0.5 * (a.theta_i + a.theta_r);
    a.phi = wrap_few_turns(phi_r - phi_i);
    a.cos_2phi_h = sin_cos_f(phi_i + phi_r).y;
    return a;
}

fn ms_cubic(m: Marschner) -> bool {
    return (m.flags & MS_FLAG_CUBIC) != 0u;
}

/// S(ω_i, ω_r) (sr⁻¹).
fn ms_value(m: Marschner, an: MsAngles) -> vec3<f32> {
    let c = max(an.cos_theta_d, MS_MIN_COS_THETA_D);
    let inv_c2 = 1.0 / (c * c);
    let circular = ms_plane(m.eta, an.sin_theta_d, an.cos_theta_d, ms_cubic(m));
    var s = vec3<f32>(0.0);
    for (var p = 0u; p < 3u; p++) {
        if !ms_lobe_on(m, p) || abs(an.theta_h - m.alpha[p]) > MS_LOBE_CUTOFF_SIGMAS * m.beta[p] {
            continue;
        }
        let mp = m.k_m * gaussian_f(m.beta[p], an.theta_h - m.alpha[p]);
        var pl = circular;
        if p == 2u && m.eccentricity < 1.0 {
            let e = m.eta_star;
            let eta = 0.5 * ((e.x + e.y) + an.cos_2phi_h * (e.x - e.y));
            pl = ms_plane(eta, an.sin_theta_d, an.cos_theta_d, ms_cubic(m));
        }
        s += ms_azimuthal(m, pl, p, an.phi) * (mp * inv_c2);
    }
    return s;
}

/// The lobe-selection probabilities given θ_r (the table, floored, normalized).
fn ms_lobe_weights(m: Marschner, theta_r: f32) -> vec3<f32> {
    let x = min(abs(theta_r) / HALF_PI, 1.0) * f32(MS_TABLE_INTERVALS);
    let k = min(u32(x), MS_TABLE_INTERVALS - 1u);
    let f = x - f32(k);
    var w: vec3<f32>;
    for (var p = 0u; p < 3u; p++) {
        w[p] = (1.0 - f) * word_f(m.table + 3u * k + p) + f * word_f(m.table + 3u * (k + 1u) + p);
    }
    let total = w.x + w.y + w.z;
    var sum = 0.0;
    for (var p = 0u; p < 3u; p++) {
        if ms_lobe_on(m, p) {
            w[p] = max(max(w[p], MS_LOBE_FLOOR * total), 1.17549435e-38);
            sum += w[p];
        }
    }
    return w / sum;
}

/// A standard normal truncated to [zl, zu], its mass held as `scaled·e^{−z_ref²/2}` (z_ref the
/// end nearer 0, or 0 when the interval holds 0): at a grazing viewer a narrow lobe's interval
/// can lie 20σ and more in a tail, where e^{−z²/2} leaves f32's range but the density
/// `φ(z)/mass` of the truncated normal does not.
struct MsTruncated {
    zl: f32,
    zu: f32,
    z_ref: f32,
    scaled: f32,
}

fn ms_truncated(zl: f32, zu: f32) -> MsTruncated {
    var t: MsTruncated;
    t.zl = zl;
    t.zu = zu;
    let r = 0.70710678118654752;
    if zl >= 0.0 {
        t.z_ref = zl;
        t.scaled = 0.5 * (erfcx_positive(zl * r) - erfcx_positive(zu * r) * exp(-0.5 * (zu - zl) * (zu + zl)));
    } else if zu <= 0.0 {
        t.z_ref = zu;
        t.scaled = 0.5 * (erfcx_positive(-zu * r) - erfcx_positive(-zl * r) * exp(-0.5 * (zu - zl) * (-zl - zu)));
    } else {
        t.z_ref = 0.0;
        t.scaled = normal_mass_f(zl, zu);
    }
    t.scaled = max(t.scaled, 0.0);
    return t;
}

/// The truncated normal's density φ(z)/mass.
fn ms_truncated_density(t: MsTruncated, z: f32) -> f32 {
    return exp(-0.5 * (z - t.z_ref) * (z + t.z_ref)) / (SQRT_TAU * t.scaled);
}

/// z ∈ [a, b], a ≥ 0 far in the upper tail, with Q(z) = Q(a) − v·(Q(a) − Q(b)) (Q the upper
/// tail of the standard normal), by Newton on ln Q(z) − ln Q(a) written with erfcx.
fn ms_tail_inverse(a: f32, b: f32, v: f32) -> f32 {
    let r = 0.70710678118654752;
    let ea = erfcx_positive(a * r);
    let ratio_b = erfcx_positive(b * r) / ea * exp(-0.5 * (b - a) * (b + a));
    let level = log1p(-v * (1.0 - ratio_b));
    if not_finite(level) {
        return b;
    }
    var z = clamp(sqrt(a * a - 2.0 * level), a, b);
    for (var k = 0u; k < 6u; k++) {
        let e = erfcx_positive(z * r);
        let g = -0.5 * (z - a) * (z + a) + log(e / ea) - level;
        z = clamp(z + g * e / 0.79788456080286536, a, b);
    }
    return z;
}

/// z from the truncated normal by inversion with u (the CPU's `sample_truncated_normal`; in the
/// far tails through [`ms_tail_inverse`]).
fn ms_sample_truncated(t: MsTruncated, u: f32) -> f32 {
    if t.zl >= 3.0 {
        return ms_tail_inverse(t.zl, t.zu, u);
    }
    if t.zu <= -3.0 {
        return -ms_tail_inverse(-t.zu, -t.zl, 1.0 - u);
    }
    return sample_truncated_normal_f(u, t.zl, t.zu);
}

/// The truncation of z = (θ_h − α_p)/β_p keeping θ_i ∈ [−π/2, π/2].
fn ms_theta_h_interval(m: Marschner, p: u32, theta_r: f32) -> MsTruncated {
    let zl = (0.5 * (theta_r - HALF_PI) - m.alpha[p]) / m.beta[p];
    let zu = (0.5 * (theta_r + HALF_PI) - m.alpha[p]) / m.beta[p];
    return ms_truncated(zl, zu);
}

/// The φ-mixture of lobe p: (uniform share, glint share, caustic of the plane).
struct MsMixture {
    q_u: f32,
    q_g: f32,
    caustic: vec4<f32>,
}

fn ms_phi_mixture(m: Marschner, p: u32, pl: MsPlane) -> MsMixture {
    var x: MsMixture;
    x.q_u = 0.0;
    x.q_g = 0.0;
    x.caustic = vec4<f32>(0.0);
    if p != 2u {
        return x;
    }
    let eccentric = m.eccentricity < 1.0;
    if (m.flags & MS_FLAG_GLINTS) == 0u || m.k_g == 0.0 {
        x.q_u = select(0.0, MS_TRT_UNIFORM_ECCENTRIC, eccentric);
        return x;
    }
    let c = ms_caustic(pl, m.delta_eta);
    let dh = ms_glint_width(m, c);
    x.caustic = c;
    x.q_u = select(MS_TRT_UNIFORM_CIRCULAR * c.w, MS_TRT_UNIFORM_ECCENTRIC, eccentric);
    let share = m.k_g * dh / (m.k_g * dh + 0.5);
    x.q_g = (1.0 - x.q_u) * min(c.w * share, MS_TRT_GLINT_MAX);
    return x;
}

/// The density in φ of "h uniform, φ = Φ(p, asin h)".
fn ms_h_map_density(pl: MsPlane, p: u32, phi: f32) -> f32 {
    let r = ms_roots(pl, p, ms_representative(p, phi));
    let min_d = ms_min_dphi(pl, p);
    var d = 0.0;
    for (var k = 0u; k < r.n; k++) {
        let g = r.g[k];
        d += sin_cos_f(g).y / (2.0 * max(abs(ms_phi(pl, p, g).y), min_d));
    }
    return d;
}

/// The γ in the monotone piece [g0, g1] (Φ = f0, f1 at its ends) where Φ(2, γ) = level, or the
/// end beyond which the level lies.
fn ms_level_in_piece(pl: MsPlane, g0: f32, g1: f32, f0: f32, f1: f32, level: f32) -> f32 {
    if f1 > f0 {
        if level <= f0 {
            return g0;
        }
        if level >= f1 {
            return g1;
        }
    } else {
        if level >= f0 {
            return g0;
        }
        if level <= f1 {
            return g1;
        }
    }
    return ms_solve_monotone(pl, 2u, level, g0, g1, f0, f1).x;
}

/// `∫ (ε − |y − Φ(2, γ)|)⁺ cosγ dγ` between a and b (in either order), where Φ stays within ε
/// of y: 8-point Gauss–Legendre (the integrand is smooth there).
fn ms_tent_integral(pl: MsPlane, y: f32, a: f32, b: f32) -> f32 {
    let half = 0.5 * abs(b - a);
    if half <= 0.0 {
        return 0.0;
    }
    let mid = 0.5 * (a + b);
    let x = vec4<f32>(0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363);
    let w = vec4<f32>(0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763);
    var sum = 0.0;
    for (var k = 0u; k < 4u; k++) {
        for (var s = 0u; s < 2u; s++) {
            let g = mid + select(-1.0, 1.0, s == 0u) * half * x[k];
            let v = max(MS_TRT_SMOOTHING - abs(y - ms_phi(pl, 2u, g).x), 0.0);
            sum += w[k] * v * sin_cos_f(g).y;
        }
    }
    return sum * half;
}

/// The density in φ of the TRT h-map smoothed by the tent of half-width ε:
/// `½∫(ε − |φ − Φ(2, asin h)|)⁺ dh / ε²` over the images of φ in Φ's range [π, 3π].
fn ms_smoothed_trt_density(pl: MsPlane, phi: f32) -> f32 {
    let e = MS_TRT_SMOOTHING;
    let x = phi + TAU;
    var edges = array<f32, 4>(-HALF_PI, HALF_PI, HALF_PI, HALF_PI);
    var pieces = 1u;
    let gs = ms_stationary(pl, 2u);
    if gs >= 0.0 {
        edges = array<f32, 4>(-HALF_PI, -gs, gs, HALF_PI);
        pieces = 3u;
    }
    var values: array<f32, 4>;
    for (var k = 0u; k <= pieces; k++) {
        values[k] = ms_phi(pl, 2u, edges[k]).x;
    }
    var sum = 0.0;
    for (var image = 0u; image < 3u; image++) {
        let y = x + TAU * (f32(image) - 1.0);
        if !(y + e > PI && y - e < 3.0 * PI) {
            continue;
        }
        for (var k = 0u; k < pieces; k++) {
            let g0 = edges[k];
            let g1 = edges[k + 1u];
            let f0 = values[k];
            let f1 = values[k + 1u];
            if max(f0, f1) <= y - e || min(f0, f1) >= y + e {
                continue;
            }
            let ra = ms_level_in_piece(pl, g0, g1, f0, f1, y - e);
            let rm = ms_level_in_piece(pl, g0, g1, f0, f1, y);
            let rb = ms_level_in_piece(pl, g0, g1, f0, f1, y + e);
            sum += ms_tent_integral(pl, y, ra, rm) + ms_tent_integral(pl, y, rm, rb);
        }
    }
    return max(0.5 * sum / (e * e), 0.0);
}

/// The sampler's density per dθ_i dφ (not yet divided by cosθ_i).
fn ms_angular_density(m: Marschner, an: MsAngles) -> f32 {
    let slope = taper_derivative(an.theta_i);
    if !(slope > 0.0) {
        return 0.0;
    }
    let theta_h = 0.5 * (taper(an.theta_i) + an.theta_r);
    let w = ms_lobe_weights(m, an.theta_r);
    let pl = ms_plane(m.eta, an.sin_theta_d, an.cos_theta_d, ms_cubic(m));
    var q = 0.0;
    for (var p = 0u; p < 3u; p++) {
        if !(w[p] > 0.0) {
            continue;
        }
        let interval = ms_theta_h_interval(m, p, an.theta_r);
        if !(interval.scaled > 0.0) {
            continue;
        }
        let z = (theta_h - m.alpha[p]) / m.beta[p];
        let p_theta = 0.5 * ms_truncated_density(interval, z) / m.beta[p] * slope;
        if p_theta == 0.0 {
            continue;
        }
        let mix = ms_phi_mixture(m, p, pl);
        var h_map: f32;
        if p == 2u {
            h_map = ms_smoothed_trt_density(pl, an.phi);
        } else {
            h_map = ms_h_map_density(pl, p, an.phi);
        }
        var p_phi = (1.0 - mix.q_u - mix.q_g) * h_map + mix.q_u / TAU;
        if mix.q_g > 0.0 {
            let phi_c = mix.caustic.y;
            p_phi += mix.q_g * 0.5
                * (wrapped_gaussian_f(m.w_c, an.phi - phi_c) + wrapped_gaussian_f(m.w_c, an.phi + phi_c));
        }
        q += w[p] * p_theta * p_phi;
    }
    return q;
}

/// (f_s rgb, pdf) at the light direction ω_i for the camera direction ω_r, both local.
fn ms_eval(m: Marschner, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    let an = ms_angles(wi, wo);
    let pdf = ms_angular_density(m, an) / max(local_cos_theta(wi), MIN_COS);
    return vec4<f32>(ms_value(m, an), pdf);
}

/// The relative azimuth φ drawn for lobe p in the plane: the mixture component from
/// `u_component`, its position from (u2, u3).
fn ms_sample_phi(m: Marschner, p: u32, pl: MsPlane, u_component: f32, u2: f32, u3: f32) -> f32 {
    let mix = ms_phi_mixture(m, p, pl);
    if u_component < mix.q_u {
        return PI * (2.0 * u2 - 1.0);
    }
    if u_component < mix.q_u + mix.q_g {
        var side = 1.0;
        var v = 2.0 * u3;
        if u3 >= 0.5 {
            side = -1.0;
            v = 2.0 * u3 - 1.0;
        }
        let x = sqrt(-2.0 * log(1.0 - u2)) * sin_cos_f(TAU * v).y;
        return wrap_few_turns(side * mix.caustic.y + m.w_c * x);
    }
    let gamma = asin_f(clamp(2.0 * u2 - 1.0, -1.0, 1.0));
    var jitter = 0.0;
    if p == 2u {
        if u3 < 0.5 {
            jitter = MS_TRT_SMOOTHING * (sqrt(2.0 * u3) - 1.0);
        } else {
            jitter = MS_TRT_SMOOTHING * (1.0 - sqrt(2.0 - 2.0 * u3));
        }
    }
    return wrap_few_turns(ms_phi(pl, p, gamma).x + jitter);
}

/// A sample of ω_i (local) with u = (lobe and φ component, θ_h, φ, φ) as the CPU's `sample`.
fn ms_sample(m: Marschner, wo: vec3<f32>, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    let theta_r = atan2_f(local_sin_theta(wo), local_cos_theta(wo));
    let w = ms_lobe_weights(m, theta_r);
    var lobe = 3u;
    var lo = 0.0;
    var acc = 0.0;
    for (var p = 0u; p < 3u; p++) {
        if !(w[p] > 0.0) {
            continue;
        }
        lobe = p;
        lo = acc;
        if u.x < acc + w[p] {
            break;
        }
        acc += w[p];
    }
    if lobe == 3u {
        return out;
    }
    let u_component = clamp((u.x - lo) / w[lobe], 0.0, 1.0);
    let interval = ms_theta_h_interval(m, lobe, theta_r);
    if !(interval.scaled > 0.0) {
        return out;
    }
    let z = ms_sample_truncated(interval, u.y);
    let theta_h = m.alpha[lobe] + m.beta[lobe] * z;
    let theta_i = untaper(clamp(2.0 * theta_h - theta_r, -HALF_PI, HALF_PI));
    let d = sin_cos_f(0.5 * (theta_r - theta_i));
    let pl = ms_plane(m.eta, d.x, d.y, ms_cubic(m));
    let phi_rel = ms_sample_phi(m, lobe, pl, u_component, u.z, u.w);
    let st = sin_cos_f(theta_i);
    let sp = sin_cos_f(local_phi(wo) - phi_rel);
    let wi = vec3<f32>(st.x, st.y * sp.y, st.y * sp.x);
    let an = ms_angles(wi, wo);
    let q = ms_angular_density(m, an);
    if !(q > 0.0) || not_finite(q) {
        return out;
    }
    let cos_i = local_cos_theta(wi);
    out.wi = wi;
    out.weight = ms_value(m, an) * (cos_i * cos_i / q);
    out.pdf = q / max(cos_i, MIN_COS);
    return out;
}
