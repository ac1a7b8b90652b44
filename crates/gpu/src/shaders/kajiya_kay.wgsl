// Kajiya & Kay 1989 as a fiber scattering function (scatter/src/kajiya_kay_1989.rs) in f32:
// f_s = k_d + k_s max(0, cos(θ_i + θ_o))^p / cosθ_i, no φ dependence; sampled as on the CPU —
// a mixture of the diffuse-fiber lobe (density 2cos²θ_i/π in θ_i) and the specular lobe, whose
// x = θ_i + θ_o follows the CPU's tabulated cos^p x (its cells copied from the CPU's table,
// `scene_buffers.rs::kajiya_kay_words`), φ uniform, the drawn θ_i through the pole taper
// (`pole_taper.wgsl`); the pdf is the density of the samples.
//
// Words at `b` (32 per material): 0 kind, 1–3 k_d, 4–6 k_s, 7 p, 8 π² lum(k_d), 9 2π lum(k_s)
// × the table's total mass, 10 the table's first word, 11 cells n, 12 x0, 13 cell width.
// The table: n + 1 CDF values normalised to 1, then n cell densities (mass/total/width).
// `word_f` and `word_u` read the material's buffer (the scene's words, or the probe's).

const MATERIAL_KAJIYA_KAY: u32 = 3u;
const HALF_PI: f32 = 1.57079632679490;

struct KajiyaKay {
    k_d: vec3<f32>,
    k_s: vec3<f32>,
    p: f32,
    w_d: f32,
    w_s: f32,
    table: u32,
    cells: u32,
    x0: f32,
    dx: f32,
}

fn load_kajiya_kay(b: u32) -> KajiyaKay {
    var m: KajiyaKay;
    m.k_d = vec3<f32>(word_f(b + 1u), word_f(b + 2u), word_f(b + 3u));
    m.k_s = vec3<f32>(word_f(b + 4u), word_f(b + 5u), word_f(b + 6u));
    m.p = word_f(b + 7u);
    m.w_d = word_f(b + 8u);
    m.w_s = word_f(b + 9u);
    m.table = word_u(b + 10u);
    m.cells = word_u(b + 11u);
    m.x0 = word_f(b + 12u);
    m.dx = word_f(b + 13u);
    return m;
}

/// The normalised CDF of the lobe at x (linear within a cell), clamped to the domain.
fn kk_cdf(m: KajiyaKay, x: f32) -> f32 {
    let t = clamp((x - m.x0) / m.dx, 0.0, f32(m.cells));
    let i = min(u32(t), m.cells - 1u);
    let c0 = word_f(m.table + i);
    return c0 + (t - f32(i)) * (word_f(m.table + i + 1u) - c0);
}

/// The normalised density of the lobe at x (its cell's), zero outside the domain.
fn kk_density(m: KajiyaKay, x: f32) -> f32 {
    let t = (x - m.x0) / m.dx;
    if !(t >= 0.0 && t <= f32(m.cells)) {
        return 0.0;
    }
    let i = min(u32(t), m.cells - 1u);
    return word_f(m.table + m.cells + 1u + i);
}

/// The range of x = θ_i + θ_o with θ_i ∈ [−π/2, π/2] and the lobe non-zero.
fn kk_lobe_range(theta_o: f32) -> vec2<f32> {
    return vec2<f32>(max(theta_o - HALF_PI, -HALF_PI), min(theta_o + HALF_PI, HALF_PI));
}

/// The probability of the diffuse lobe given θ_o.
fn kk_diffuse_weight(m: KajiyaKay, theta_o: f32) -> f32 {
    let r = kk_lobe_range(theta_o);
    let w_s = m.w_s * (kk_cdf(m, r.y) - kk_cdf(m, r.x));
    if m.w_d + w_s > 0.0 {
        return m.w_d / (m.w_d + w_s);
    }
    return 1.0;
}

/// The density of the sampled θ_i (per radian) given θ_o: the mixture's at the tapered W(θ_i)
/// times W′(θ_i).
fn kk_theta_pdf(m: KajiyaKay, theta_i: f32, theta_o: f32) -> f32 {
    let slope = taper_derivative(theta_i);
    if !(slope > 0.0) {
        return 0.0;
    }
    let t = taper(theta_i);
    let cos_t = sin_cos_f(t).y;
    let w_d = kk_diffuse_weight(m, theta_o);
    let diffuse = 2.0 * cos_t * cos_t / PI;
    var specular = 0.0;
    let r = kk_lobe_range(theta_o);
    let x = t + theta_o;
    if w_d < 1.0 && x >= r.x && x <= r.y {
        let mass = kk_cdf(m, r.y) - kk_cdf(m, r.x);
        if mass > 0.0 {
            specular = kk_density(m, x) / mass;
        }
    }
    return (w_d * diffuse + (1.0 - w_d) * specular) * slope;
}

/// (f_s rgb, pdf) at ω_i for the camera direction ω_o, both local.
fn kk_eval(m: KajiyaKay, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    let sin_i = local_sin_theta(wi);
    let cos_i = local_cos_theta(wi);
    let sin_o = local_sin_theta(wo);
    let cos_o = local_cos_theta(wo);
    let cone = cos_i * cos_o - sin_i * sin_o;
    var f = m.k_d;
    if cone > 0.0 {
        f += m.k_s * (pow(cone, m.p) / max(cos_i, MIN_COS));
    }
    let theta_i = atan2_f(sin_i, cos_i);
    let theta_o = atan2_f(sin_o, cos_o);
    let pdf = kk_theta_pdf(m, theta_i, theta_o) / (TAU * max(cos_i, MIN_COS));
    return vec4<f32>(f, pdf);
}

/// x in [a, b] from the lobe's CDF at u; x0 − 1 when [a, b] has no mass.
fn kk_sample_lobe(m: KajiyaKay, a: f32, b: f32, u: f32) -> f32 {
    let ca = kk_cdf(m, a);
    let mass = kk_cdf(m, b) - ca;
    if !(mass > 0.0) {
        return m.x0 - 1.0;
    }
    let goal = ca + u * mass;
    // The first boundary with cdf > goal (binary search), as a cell index.
    var lo = 0u;
    var hi = m.cells + 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if word_f(m.table + mid) <= goal {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let i = clamp(lo, 1u, m.cells) - 1u;
    let c0 = word_f(m.table + i);
    let cell = word_f(m.table + i + 1u) - c0;
    var frac = 0.5;
    if cell > 0.0 {
        frac = clamp((goal - c0) / cell, 0.0, 1.0);
    }
    return clamp(m.x0 + (f32(i) + frac) * m.dx, a, b);
}

/// θ_i drawn as the CPU's `sample_theta` with u = (lobe, θ, θ) given θ_o; −10 when the chosen
/// lobe has no mass.
fn kk_sample_theta(m: KajiyaKay, theta_o: f32, u: vec3<f32>) -> f32 {
    if u.x < kk_diffuse_weight(m, theta_o) {
        let sc = sin_cos_f(TAU * u.z);
        return untaper(asin_f(clamp(sqrt(u.y) * sc.y, -1.0, 1.0)));
    }
    let r = kk_lobe_range(theta_o);
    let x = kk_sample_lobe(m, r.x, r.y, u.y);
    if x < m.x0 {
        return -10.0;
    }
    return untaper(clamp(x - theta_o, -HALF_PI, HALF_PI));
}

/// A sample of ω_i (local) with u = (lobe, θ, θ, φ) as the CPU's `sample`.
fn kk_sample(m: KajiyaKay, wo: vec3<f32>, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    let theta_o = atan2_f(local_sin_theta(wo), local_cos_theta(wo));
    let theta_i = kk_sample_theta(m, theta_o, u.xyz);
    if theta_i < -2.0 {
        return out;
    }
    let wi = fiber_direction(theta_i, local_phi(wo) - PI * (2.0 * u.w - 1.0));
    return fiber_sample_at(wi, kk_eval(m, wi, wo));
}
