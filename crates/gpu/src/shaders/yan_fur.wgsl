// Yan, Tseng, Jensen & Ramamoorthi 2015 / Yan, Jensen & Ramamoorthi 2017 fur
// (scatter/src/yan_2017.rs) in f32, backward near-field form:
// f_s(ω_i, ω_o; h) = Σ_p A_p M_p(θ_i) N_p(φ; h) / cos²θ_i over the unscattered R, TT, TRT
// (truncated Gaussians in θ_i about the tilted mirror direction, wrapped Gaussians in φ about
// Φ(p, h)) and the medulla-scattered TT^s, TRT^s, read from the medulla's random-walk tables
// (scatter/src/hair/medulla.rs; copied, `scene_buffers.rs::yan_fur_words`) as on the CPU:
// the azimuthal exit density N(θ_t, h′/κ, φ_q) = S · (bilinear in sinθ_t, h′ of the
// piecewise-linear N/S) and the θ profile M(θ_e, φ_q, θ_i) (bilinear in sinθ_e, |φ_q|).
// Sampled as on the CPU: the lobe by the luminance of its mass, θ_i through the pole taper
// (truncated-normal inversion, or the tables' inverse CDFs), φ from a wrapped Gaussian deviate
// or uniform near the axis; the pdf is the density of the samples. `field = far` integrates
// over h by the CPU's Gauss–Legendre nodes (copied) on the same smooth pieces, and samples h
// uniformly.
//
// Words at `b` (32 per material): 0 kind, 1 η, 2–4 σ_c^a, 5 κ, 6 σ_m^s + σ_m^a, 7 cuticle
// interfaces, 8 flags (bits 0–4 the lobes R, TT, TRT, TT^s, TRT^s; 5 far field; 6 medulla
// tables present), 9 Gauss–Legendre nodes n, 10 the table's first word, 11–13 β_p, 14–16
// β_n,p, 17–22 (sin τ_p, cos τ_p), 23 the tables' σ_s (per medulla radius), 24 their largest
// sinθ_t, 25–29 their node counts (sinθ_t, h′, φ_q, θ_o, |φ_q| profiles). The table: 8 words
// with the starts (relative to the table) of the values and cumulative masses of `azimuth`,
// `azimuth_mean`, `profiles`, `profiles_mean` (scatter's `MedullaTablesView`), then the n
// Gauss–Legendre (node, weight) pairs, then those arrays.

const MATERIAL_YAN_FUR: u32 = 6u;
const YAN_FLAG_FAR: u32 = 32u;
const YAN_FLAG_TABLES: u32 = 64u;
const YAN_AZIMUTH_SAMPLE_SIGMAS: f32 = 12.0;

struct YanFur {
    eta: f32,
    sigma_c_a: vec3<f32>,
    kappa: f32,
    sigma_m_e: f32,
    layers: f32,
    flags: u32,
    n_gl: u32,
    /// First word of the Gauss–Legendre pairs.
    gl: u32,
    beta: vec3<f32>,
    beta_n: vec3<f32>,
    tilt_sin: vec3<f32>,
    tilt_cos: vec3<f32>,
    /// The medulla tables' medium and grid.
    sigma_s: f32,
    max_sin: f32,
    na: u32,
    ni: u32,
    nphi: u32,
    nth: u32,
    nq: u32,
    /// Absolute starts of (values, cumulative masses) of azimuth, azimuth_mean, profiles,
    /// profiles_mean.
    azimuth: vec2<u32>,
    azimuth_mean: vec2<u32>,
    profiles: vec2<u32>,
    profiles_mean: vec2<u32>,
}

fn load_yan_fur(b: u32) -> YanFur {
    var m: YanFur;
    m.eta = word_f(b + 1u);
    m.sigma_c_a = vec3<f32>(word_f(b + 2u), word_f(b + 3u), word_f(b + 4u));
    m.kappa = word_f(b + 5u);
    m.sigma_m_e = word_f(b + 6u);
    m.layers = word_f(b + 7u);
    m.flags = word_u(b + 8u);
    m.n_gl = word_u(b + 9u);
    let t = word_u(b + 10u);
    m.gl = t + 8u;
    m.beta = vec3<f32>(word_f(b + 11u), word_f(b + 12u), word_f(b + 13u));
    m.beta_n = vec3<f32>(word_f(b + 14u), word_f(b + 15u), word_f(b + 16u));
    m.tilt_sin = vec3<f32>(word_f(b + 17u), word_f(b + 19u), word_f(b + 21u));
    m.tilt_cos = vec3<f32>(word_f(b + 18u), word_f(b + 20u), word_f(b + 22u));
    m.sigma_s = word_f(b + 23u);
    m.max_sin = word_f(b + 24u);
    m.na = word_u(b + 25u);
    m.ni = word_u(b + 26u);
    m.nphi = word_u(b + 27u);
    m.nth = word_u(b + 28u);
    m.nq = word_u(b + 29u);
    m.azimuth = vec2<u32>(t + word_u(t), t + word_u(t + 1u));
    m.azimuth_mean = vec2<u32>(t + word_u(t + 2u), t + word_u(t + 3u));
    m.profiles = vec2<u32>(t + word_u(t + 4u), t + word_u(t + 5u));
    m.profiles_mean = vec2<u32>(t + word_u(t + 6u), t + word_u(t + 7u));
    return m;
}

fn yan_lobe_on(m: YanFur, p: u32) -> bool {
    return (m.flags & (1u << p)) != 0u;
}

/// `e^x − 1`, accurate for small x (Kahan's ratio, as `log1p`).
fn expm1_f(x: f32) -> f32 {
    let u = exp(x);
    if u == 1.0 {
        return x;
    }
    let um1 = u - 1.0;
    if um1 == -1.0 {
        return -1.0;
    }
    return um1 * x / log(u);
}

// ---- The medulla tables: piecewise-linear densities on uniform grids (scatter's
// `LinearSlices`), `nodes` values per slice and `segments + 1` cumulative masses.

struct YanGrid {
    /// (values, cumulative masses).
    at: vec2<u32>,
    nodes: u32,
    periodic: bool,
    start: f32,
    step: f32,
}

/// The φ_q grid (periodic from −π) or the θ_o grid (from −π/2 to π/2) of an array pair.
fn yan_phi_grid(m: YanFur, at: vec2<u32>) -> YanGrid {
    return YanGrid(at, m.nphi, true, -PI, TAU / f32(m.nphi));
}

fn yan_theta_grid(m: YanFur, at: vec2<u32>) -> YanGrid {
    return YanGrid(at, m.nth, false, -HALF_PI, PI / f32(m.nth - 1u));
}

fn yan_segments(g: YanGrid) -> u32 {
    return select(g.nodes - 1u, g.nodes, g.periodic);
}

/// The segment of x and the fraction across it (x = −1: outside a non-periodic grid).
fn yan_locate(g: YanGrid, x: f32) -> vec2<f32> {
    var u = (x - g.start) / g.step;
    let n = f32(g.nodes);
    if g.periodic {
        u = u - n * floor(u / n);
    } else if !(u >= 0.0 && u <= n - 1.0) {
        return vec2<f32>(-1.0, 0.0);
    }
    let j = min(u32(max(floor(u), 0.0)), yan_segments(g) - 1u);
    return vec2<f32>(f32(j), clamp(u - f32(j), 0.0, 1.0));
}

fn yan_value_in(g: YanGrid, slice: u32, cell: vec2<f32>) -> f32 {
    let j = u32(cell.x);
    let v = g.at.x + slice * g.nodes;
    return word_f(v + j) * (1.0 - cell.y) + word_f(v + (j + 1u) % g.nodes) * cell.y;
}

fn yan_value(g: YanGrid, slice: u32, x: f32) -> f32 {
    let cell = yan_locate(g, x);
    if cell.x < 0.0 {
        return 0.0;
    }
    return yan_value_in(g, slice, cell);
}

fn yan_cumulative(g: YanGrid, slice: u32, k: u32) -> f32 {
    return word_f(g.at.y + slice * (yan_segments(g) + 1u) + k);
}

fn yan_mass(g: YanGrid, slice: u32) -> f32 {
    return yan_cumulative(g, slice, yan_segments(g));
}

/// Inverse CDF of one slice at u (x < start: an empty slice).
fn yan_sample_slice(g: YanGrid, slice: u32, u: f32) -> f32 {
    let n = yan_segments(g);
    let total = yan_mass(g, slice);
    if !(total > 0.0) {
        return g.start - 1.0;
    }
    let goal = clamp(u, 0.0, 1.0) * total;
    // The first segment j whose upper cumulative mass exceeds the goal.
    var lo = 0u;
    var hi = n;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if yan_cumulative(g, slice, mid + 1u) <= goal {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let j = min(lo, n - 1u);
    let v = g.at.x + slice * g.nodes;
    let v0 = word_f(v + j);
    let v1 = word_f(v + (j + 1u) % g.nodes);
    let c0 = yan_cumulative(g, slice, j);
    let xi = clamp(goal - c0, 0.0, max(yan_cumulative(g, slice, j + 1u) - c0, 0.0));
    let a = (v1 - v0) / (2.0 * g.step);
    let denom = v0 + safe_sqrt(v0 * v0 + 4.0 * a * xi);
    var x = 0.0;
    if denom > 0.0 {
        x = clamp(2.0 * xi / denom, 0.0, g.step);
    }
    return g.start + f32(j) * g.step + x;
}

/// Four interpolation corners: slices and weights (`ok` false: none).
struct YanCorners {
    k: vec4<u32>,
    w: vec4<f32>,
    ok: bool,
}

/// Density at x of the corners' mixture: interpolated value over interpolated mass.
fn yan_blend_pdf(g: YanGrid, c: YanCorners, x: f32) -> f32 {
    var total = 0.0;
    var value = 0.0;
    for (var k = 0u; k < 4u; k++) {
        total += c.w[k] * yan_mass(g, c.k[k]);
        value += c.w[k] * yan_value(g, c.k[k], x);
    }
    if !(total > 0.0) {
        return 0.0;
    }
    return value / total;
}

/// A draw from the mixture of `yan_blend_pdf`: a corner by its weighted mass, then its inverse
/// CDF with u rescaled (x < start: none).
fn yan_blend_sample(g: YanGrid, c: YanCorners, u: f32) -> f32 {
    var masses: array<f32, 4>;
    var total = 0.0;
    var last = 4u;
    for (var k = 0u; k < 4u; k++) {
        masses[k] = c.w[k] * yan_mass(g, c.k[k]);
        total += masses[k];
        if masses[k] > 0.0 {
            last = k;
        }
    }
    if !(total > 0.0) || last == 4u {
        return g.start - 1.0;
    }
    let goal = clamp(u, 0.0, 1.0) * total;
    var below = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let mk = masses[k];
        if mk > 0.0 && (goal < below + mk || k == last) {
            let v = clamp((goal - below) / mk, 0.0, 0.99999994);
            return yan_sample_slice(g, c.k[k], v);
        }
        below += mk;
    }
    return g.start - 1.0;
}

/// Bilinear corners in (|sinθ_t|, h′): slices a·offsets + i of one channel.
fn yan_corners(m: YanFur, abs_sin_t: f32, h: f32) -> YanCorners {
    var c: YanCorners;
    c.ok = false;
    if !(abs(h) <= 1.0) {
        return c;
    }
    return yan_grid_corners(m, abs_sin_t, (h + 1.0) * 0.5 * f32(m.ni - 1u), m.ni);
}

/// Bilinear corners of a table with rows in |sinθ| (m.na of them, up to m.max_sin) and `n`
/// columns, at |sinθ| = `abs_sin` and the fractional column `ub`: slices a·n + b.
fn yan_grid_corners(m: YanFur, abs_sin: f32, ub: f32, n: u32) -> YanCorners {
    var c: YanCorners;
    let ua = min(abs_sin / m.max_sin * f32(m.na - 1u), f32(m.na - 1u));
    let a = min(u32(ua), m.na - 2u);
    let fa = ua - f32(a);
    let b = min(u32(max(ub, 0.0)), n - 2u);
    let fb = clamp(ub - f32(b), 0.0, 1.0);
    c.k = vec4<u32>(a * n + b, a * n + b + 1u, (a + 1u) * n + b, (a + 1u) * n + b + 1u);
    c.w = vec4<f32>((1.0 - fa) * (1.0 - fb), (1.0 - fa) * fb, fa * (1.0 - fb), fa * fb);
    c.ok = true;
    return c;
}

/// Bilinear corners in (|sinθ_e|, |φ_q|) of the θ profiles: slices a·profile_azimuths + q.
fn yan_profile_corners(m: YanFur, abs_sin_e: f32, phi_q: f32) -> YanCorners {
    return yan_grid_corners(m, abs_sin_e, min(abs(wrap_few_turns(phi_q)) / PI, 1.0) * f32(m.nq - 1u), m.nq);
}

/// The closed-form fraction that scatters on the chord: 1 − exp(−σ_s·2√(1 − h′²)/cosθ_t).
fn yan_scattered_fraction(m: YanFur, cos_t: f32, h: f32) -> f32 {
    if !(abs(h) < 1.0) {
        return 0.0;
    }
    if !(cos_t > 0.0) {
        return select(0.0, 1.0, m.sigma_s > 0.0);
    }
    return -expm1_f(-m.sigma_s * 2.0 * safe_sqrt(1.0 - h * h) / cos_t);
}

/// Per channel, the light entering at (θ_t, h′) that scatters and escapes: ∫ N dφ_q.
fn yan_escaping(m: YanFur, abs_sin_t: f32, cos_t: f32, h: f32) -> vec3<f32> {
    let c = yan_corners(m, abs_sin_t, h);
    if !c.ok {
        return vec3<f32>(0.0);
    }
    let s = yan_scattered_fraction(m, cos_t, h);
    let g = yan_phi_grid(m, m.azimuth);
    let per_node = m.na * m.ni;
    var e = vec3<f32>(0.0);
    for (var ch = 0u; ch < 3u; ch++) {
        var sum = 0.0;
        for (var k = 0u; k < 4u; k++) {
            sum += c.w[k] * yan_mass(g, ch * per_node + c.k[k]);
        }
        e[ch] = s * sum;
    }
    return e;
}

/// The azimuthal exit density N(θ_t, h′, φ_q) per channel (rad⁻¹).
fn yan_azimuthal(m: YanFur, abs_sin_t: f32, cos_t: f32, h: f32, phi_q: f32) -> vec3<f32> {
    let c = yan_corners(m, abs_sin_t, h);
    let g = yan_phi_grid(m, m.azimuth);
    let cell = yan_locate(g, phi_q);
    if !c.ok || cell.x < 0.0 {
        return vec3<f32>(0.0);
    }
    let s = yan_scattered_fraction(m, cos_t, h);
    let per_node = m.na * m.ni;
    var n = vec3<f32>(0.0);
    for (var ch = 0u; ch < 3u; ch++) {
        var sum = 0.0;
        for (var k = 0u; k < 4u; k++) {
            sum += c.w[k] * yan_value_in(g, ch * per_node + c.k[k], cell);
        }
        n[ch] = s * sum;
    }
    return n;
}

/// The θ profile M(θ_e, θ_o | φ_q) per channel (rad⁻¹ in θ_o), θ_e given by its sine.
fn yan_longitudinal_table(m: YanFur, sin_e: f32, phi_q: f32, theta_o: f32) -> vec3<f32> {
    let c = yan_profile_corners(m, abs(sin_e), phi_q);
    let g = yan_theta_grid(m, m.profiles);
    let cell = yan_locate(g, select(theta_o, -theta_o, sin_e < 0.0));
    if cell.x < 0.0 {
        return vec3<f32>(0.0);
    }
    let per_channel = m.na * m.nq;
    var v = vec3<f32>(0.0);
    for (var ch = 0u; ch < 3u; ch++) {
        var sum = 0.0;
        for (var k = 0u; k < 4u; k++) {
            sum += c.w[k] * yan_value_in(g, ch * per_channel + c.k[k], cell);
        }
        v[ch] = sum;
    }
    return v;
}

// ---- The fiber.

/// Geometry and attenuations of one camera hit (scatter's `FurHit`).
struct YanHit {
    gamma_o: f32,
    gamma_t: f32,
    /// The masses of R, TT, TRT, TT^s, TRT^s.
    mass: array<vec3<f32>, 5>,
    a: array<vec3<f32>, 3>,
    a_s: array<vec3<f32>, 2>,
    /// |sinθ_t| and cosθ_t of the refracted camera ray.
    abs_sin_t: f32,
    cos_t: f32,
    /// h′/κ, when the chord crosses the medulla.
    in_medulla: bool,
    h_medulla: f32,
}

/// The cuticle's reflectance: l·F/(1 + (l − 1)F).
fn yan_cuticle_reflectance(layers: f32, f: f32) -> f32 {
    let d = 1.0 + (layers - 1.0) * f;
    if d > 0.0 {
        return clamp(layers * f / d, 0.0, 1.0);
    }
    return 0.0;
}

fn yan_hit(m: YanFur, sin_o: f32, cos_o: f32, h0: f32) -> YanHit {
    var r: YanHit;
    let h = clamp(h0, -1.0, 1.0);
    let f = yan_cuticle_reflectance(m.layers, fresnel_dielectric(cos_o * safe_sqrt(1.0 - h * h), m.eta));
    let sin_gamma_t = h * cos_o / sqrt(m.eta * m.eta - sin_o * sin_o);
    let s_t = sin_o / m.eta;
    let cos_t = safe_sqrt(1.0 - s_t * s_t);
    // The chord's cortex and medulla lengths.
    let s2 = sin_gamma_t * sin_gamma_t;
    let outer = safe_sqrt(1.0 - s2);
    var inner = 0.0;
    if abs(sin_gamma_t) < m.kappa {
        inner = safe_sqrt(m.kappa * m.kappa - s2);
    }
    let cortex = 2.0 * (outer - inner) / cos_t;
    let core = 2.0 * inner / cos_t;
    let t = exp(-m.sigma_c_a * cortex) * exp(-m.sigma_m_e * core);
    r.a[0] = vec3<f32>(f);
    r.a[1] = t * ((1.0 - f) * (1.0 - f));
    r.a[2] = r.a[1] * t * f;
    r.abs_sin_t = abs(s_t);
    r.cos_t = cos_t;
    r.in_medulla = m.kappa > 0.0 && abs(sin_gamma_t) < m.kappa;
    r.h_medulla = select(0.0, sin_gamma_t / m.kappa, r.in_medulla);
    let outside = exp(-m.sigma_c_a * (0.5 * cortex + (1.0 - m.kappa) / cos_t)) * (1.0 - f);
    r.a_s[0] = outside;
    r.a_s[1] = outside * t * f;
    var escaping = vec3<f32>(0.0);
    if (m.flags & YAN_FLAG_TABLES) != 0u && r.in_medulla {
        escaping = yan_escaping(m, r.abs_sin_t, cos_t, r.h_medulla);
    }
    r.gamma_o = asin_f(h);
    r.gamma_t = asin_f(sin_gamma_t);
    r.mass[0] = r.a[0];
    r.mass[1] = r.a[1];
    r.mass[2] = r.a[2];
    r.mass[3] = r.a_s[0] * escaping;
    r.mass[4] = r.a_s[1] * escaping;
    return r;
}

/// Azimuth offset of scattered lobe q: the refracted entry direction, turned by an internal
/// reflection for TRT^s.
fn yan_scattered_shift(hit: YanHit, q: u32) -> f32 {
    return (hit.gamma_t - hit.gamma_o) + f32(q) * (PI + 2.0 * hit.gamma_t);
}

/// Lobe-selection probabilities ∝ the luminance of the enabled lobes' masses (all 0: none).
struct YanWeights {
    w: array<f32, 5>,
    ok: bool,
}

fn yan_lobe_weights(m: YanFur, hit: YanHit) -> YanWeights {
    var r: YanWeights;
    var total = 0.0;
    for (var p = 0u; p < 5u; p++) {
        r.w[p] = select(0.0, luminance(hit.mass[p]), yan_lobe_on(m, p));
        total += r.w[p];
    }
    r.ok = total > 0.0;
    if r.ok {
        for (var p = 0u; p < 5u; p++) {
            r.w[p] = r.w[p] / total;
        }
    }
    return r;
}

/// Lobe p's longitudinal Gaussian: centre θ_c, width β_p and truncated mass.
fn yan_longitudinal_lobe(m: YanFur, p: u32, sin_o: f32, cos_o: f32) -> vec3<f32> {
    let so = sin_o * m.tilt_cos[p] + cos_o * m.tilt_sin[p];
    let co = abs(cos_o * m.tilt_cos[p] - sin_o * m.tilt_sin[p]);
    let centre = -atan2_f(so, co);
    let b = m.beta[p];
    return vec3<f32>(centre, b, normal_mass_f((-HALF_PI - centre) / b, (HALF_PI - centre) / b));
}

/// M_p(θ_i; θ_o): density in θ_i.
fn yan_longitudinal(m: YanFur, p: u32, theta_i: f32, sin_o: f32, cos_o: f32) -> f32 {
    let l = yan_longitudinal_lobe(m, p, sin_o, cos_o);
    return gaussian_f(l.y, theta_i - l.x) / l.z;
}

/// Φ(p, h) = 2pγ_t − 2γ_o + pπ.
fn yan_exit_azimuth(p: u32, gamma_o: f32, gamma_t: f32) -> f32 {
    let q = f32(p);
    return 2.0 * q * gamma_t - 2.0 * gamma_o + q * PI;
}

/// (Σ A_p M_p N_p, Σ w_p (density in θ_i, φ)): the density's θ part at the tapered W(θ_i)
/// times W′(θ_i), as the sampler draws it.
fn yan_integrand_and_pdf(m: YanFur, wi: vec3<f32>, wo: vec3<f32>, hit: YanHit, w: YanWeights) -> vec4<f32> {
    let sin_o = local_sin_theta(wo);
    let cos_o = local_cos_theta(wo);
    let theta_i = atan2_f(local_sin_theta(wi), local_cos_theta(wi));
    let theta_star = taper(theta_i);
    let slope = taper_derivative(theta_i);
    let blend = clamp(1.0 - slope, 0.0, 1.0);
    let dphi = local_phi(wi) - local_phi(wo);
    let tables = (m.flags & YAN_FLAG_TABLES) != 0u && hit.in_medulla;
    var g = vec3<f32>(0.0);
    var pdf = 0.0;
    for (var p = 0u; p < 5u; p++) {
        if !yan_lobe_on(m, p) {
            continue;
        }
        let w_p = w.w[p];
        if p >= 3u {
            if !tables {
                continue;
            }
            let phi_q = wrap_few_turns(dphi - yan_scattered_shift(hit, p - 3u));
            // θ_e = −θ_o: sinθ_e = −sinθ_o.
            let n = yan_azimuthal(m, hit.abs_sin_t, hit.cos_t, hit.h_medulla, phi_q);
            let l = yan_longitudinal_table(m, -sin_o, phi_q, theta_i);
            g += hit.a_s[p - 3u] * n * l;
            if w_p > 0.0 && slope > 0.0 {
                let az = yan_blend_pdf(yan_phi_grid(m, m.azimuth_mean), yan_corners(m, hit.abs_sin_t, hit.h_medulla), phi_q);
                let pc = yan_profile_corners(m, abs(sin_o), phi_q);
                let x = select(theta_star, -theta_star, -sin_o < 0.0);
                let inc = yan_blend_pdf(yan_theta_grid(m, m.profiles_mean), pc, x);
                pdf += w_p * az * inc * slope;
            }
            continue;
        }
        let mp = yan_longitudinal(m, p, theta_i, sin_o, cos_o);
        let n = wrapped_gaussian_f(m.beta_n[p], dphi - yan_exit_azimuth(p, hit.gamma_o, hit.gamma_t));
        g += hit.a[p] * (mp * n);
        if w_p > 0.0 && slope > 0.0 {
            let n_sampled = (1.0 - blend) * n + blend / TAU;
            pdf += w_p * yan_longitudinal(m, p, theta_star, sin_o, cos_o) * slope * n_sampled;
        }
    }
    return vec4<f32>(g, pdf);
}

/// Near field: (f_s rgb, pdf per steradian) at offset h.
fn yan_near_eval(m: YanFur, wi: vec3<f32>, wo: vec3<f32>, h: f32) -> vec4<f32> {
    let hit = yan_hit(m, local_sin_theta(wo), local_cos_theta(wo), h);
    let w = yan_lobe_weights(m, hit);
    if !w.ok {
        return vec4<f32>(0.0);
    }
    let r = yan_integrand_and_pdf(m, wi, wo, hit, w);
    let c = max(local_cos_theta(wi), MIN_COS);
    return vec4<f32>(r.xyz / (c * c), r.w / c);
}

/// (f_s rgb, pdf) at the light direction ω_i for the camera direction ω_o at offset h, both
/// local. The far field ignores h: ½∫_{−1}^{1} (f_s, pdf)(h) dh by the Gauss–Legendre nodes on
/// the pieces where the integrand is smooth (inside the medulla in ψ with h = h_b sinψ,
/// outside in γ = asin h). One loop for both fields, so the near-field code is compiled once.
fn yan_eval(m: YanFur, wi: vec3<f32>, wo: vec3<f32>, h: f32) -> vec4<f32> {
    let far = (m.flags & YAN_FLAG_FAR) != 0u;
    // Pieces of t: [lo, hi] with h = scale·sin t.
    var lo = array<f32, 3>(-HALF_PI, 0.0, 0.0);
    var hi = array<f32, 3>(HALF_PI, 0.0, 0.0);
    var scale = array<f32, 3>(1.0, 1.0, 1.0);
    var pieces = 1u;
    if far {
        let sin_o = local_sin_theta(wo);
        let inv_eta_prime = local_cos_theta(wo) / sqrt(m.eta * m.eta - sin_o * sin_o);
        if m.kappa > 0.0 && m.kappa < inv_eta_prime {
            let h_b = m.kappa / inv_eta_prime;
            let gamma_b = asin_f(min(h_b, 1.0));
            scale[0] = h_b;
            lo[1] = gamma_b;
            hi[1] = HALF_PI;
            lo[2] = -HALF_PI;
            hi[2] = -gamma_b;
            pieces = 3u;
        }
    }
    let nodes = select(1u, m.n_gl, far);
    var sum = vec4<f32>(0.0);
    for (var piece = 0u; piece < pieces; piece++) {
        let mid = 0.5 * (hi[piece] + lo[piece]);
        let half = 0.5 * (hi[piece] - lo[piece]);
        for (var k = 0u; k < nodes; k++) {
            var hk = h;
            var wk = 1.0;
            if far {
                let sc = sin_cos_f(mid + half * word_f(m.gl + 2u * k));
                hk = scale[piece] * sc.x;
                wk = 0.5 * word_f(m.gl + 2u * k + 1u) * half * scale[piece] * sc.y;
            }
            sum += yan_near_eval(m, wi, wo, hk) * wk;
        }
    }
    return sum;
}

/// A direction ω_i (local; w = 0: none) drawn as the CPU's `sample_near` at offset h with
/// u = (lobe, θ, –, φ).
fn yan_sample_direction(m: YanFur, wo: vec3<f32>, h: f32, u: vec4<f32>) -> vec4<f32> {
    let none = vec4<f32>(0.0);
    let sin_o = local_sin_theta(wo);
    let cos_o = local_cos_theta(wo);
    let hit = yan_hit(m, sin_o, cos_o, h);
    let w = yan_lobe_weights(m, hit);
    if !w.ok {
        return none;
    }
    var p = 0u;
    var acc = w.w[0];
    while p < 4u && (u.x >= acc || w.w[p] == 0.0) {
        p += 1u;
        acc += w.w[p];
    }
    while w.w[p] == 0.0 && p > 0u {
        p -= 1u;
    }
    var theta_i: f32;
    var dphi: f32;
    if p >= 3u {
        if (m.flags & YAN_FLAG_TABLES) == 0u || !hit.in_medulla {
            return none;
        }
        // φ_q given (θ_t, h′/κ), then the exit inclination given (θ_e, φ_q).
        let corners = yan_corners(m, hit.abs_sin_t, hit.h_medulla);
        let az_grid = yan_phi_grid(m, m.azimuth_mean);
        let drawn = yan_blend_sample(az_grid, corners, u.w);
        if drawn < az_grid.start {
            return none;
        }
        let phi_q = wrap_few_turns(drawn);
        if !(yan_blend_pdf(az_grid, corners, phi_q) > 0.0) {
            return none;
        }
        let th_grid = yan_theta_grid(m, m.profiles_mean);
        let pc = yan_profile_corners(m, abs(sin_o), phi_q);
        let x = yan_blend_sample(th_grid, pc, u.y);
        if x < th_grid.start || !(yan_blend_pdf(th_grid, pc, x) > 0.0) {
            return none;
        }
        // θ_e = −θ_o < 0 when sinθ_o > 0: the profile is read mirrored.
        let t = select(x, -x, -sin_o < 0.0);
        theta_i = untaper(clamp(t, -HALF_PI, HALF_PI));
        dphi = phi_q + yan_scattered_shift(hit, p - 3u);
    } else {
        let l = yan_longitudinal_lobe(m, p, sin_o, cos_o);
        let z = sample_truncated_normal_f(u.y, (-HALF_PI - l.x) / l.y, (HALF_PI - l.x) / l.y);
        theta_i = untaper(clamp(l.x + l.y * z, -HALF_PI, HALF_PI));
        // Near the axis, φ uniform with probability W's blend (u.w split in two).
        let blend = clamp(1.0 - taper_derivative(theta_i), 0.0, 1.0);
        if u.w < blend {
            dphi = TAU * (u.w / blend) - PI;
        } else {
            let v = clamp((u.w - blend) / (1.0 - blend), 0.0, 1.0);
            let dev = sample_truncated_normal_f(v, -YAN_AZIMUTH_SAMPLE_SIGMAS, YAN_AZIMUTH_SAMPLE_SIGMAS);
            dphi = yan_exit_azimuth(p, hit.gamma_o, hit.gamma_t) + m.beta_n[p] * dev;
        }
    }
    let st = sin_cos_f(theta_i);
    let sc = sin_cos_f(local_phi(wo) + dphi);
    let c = max(st.y, 0.0);
    return vec4<f32>(st.x, c * sc.y, c * sc.x, 1.0);
}

/// A sample of ω_i (local) with u = (lobe, θ, h in the far field, φ) as the CPU's `sample`:
/// the direction of the near-field sampler (at h, or at h = 2u₂ − 1 in the far field), with
/// the density and value of `yan_eval` there.
fn yan_sample(m: YanFur, wo: vec3<f32>, h: f32, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    let far = (m.flags & YAN_FLAG_FAR) != 0u;
    let d = yan_sample_direction(m, wo, select(h, 2.0 * u.z - 1.0, far), u);
    if d.w == 0.0 {
        return out;
    }
    let r = yan_eval(m, d.xyz, wo, h);
    if !(r.w > 0.0) || not_finite(r.w) {
        return out;
    }
    let c = local_cos_theta(d.xyz);
    out.wi = d.xyz;
    out.weight = r.xyz * (select(max(c, MIN_COS), c, far) / r.w);
    out.pdf = r.w;
    return out;
}
