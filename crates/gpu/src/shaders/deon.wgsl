// d'Eon, Francois, Hill, Letteri & Aubry 2011 hair (scatter/src/deon_2011.rs) in f32, backward
// form: f_s = [Σ_{p<p_max} M_p(θ_i, θ_o^(p)) N_p(φ; θ_n) + M_res Ā_res(θ_n)/2π]/cosθ_i, with
// d'Eon's M_p (`longitudinal` of chiang.wgsl) about the tilted camera direction and N_p read
// from the CPU's table (copied, `scene_buffers.rs::deon_words`), interpolated bilinearly in
// (cosθ_n, φ) as on the CPU. Sampled as on the CPU: the lobe by the luminance of the lobe
// masses at cosθ_o, sinθ_i from M_p by inversion, φ by exact inversion of the CDF of the
// row-interpolated piecewise-linear table (uniform for the residual); the pdf is the density
// of the samples.
//
// Words at `b` (32 per material): 0 kind, 1 θ_n (0 camera, 1 difference), 2 p_max, 3 φ nodes n,
// 4 node spacing 2π/n, 5–8 where the values, luminances, CDFs and residual masses start
// (relative to the table), 10 the table's first word. The table: per lobe p ≤ p_max the words
// (v, 1/(v(1 − e^{−2/v})), e^{−2/v} − 1, sin τ_p, cos τ_p, 0); then N_p (rgb) at
// ((p·64 + row)·n + node), its luminance at the same index, the CDF at
// ((p·64 + row)·(n + 1) + node), and the residual mass (rgb) per row.

const MATERIAL_DEON: u32 = 5u;
const DEON_ROWS: u32 = 64u;
const DEON_LOBE_WORDS: u32 = 6u;

struct Deon {
    difference: bool,
    p_max: u32,
    n_phi: u32,
    dphi: f32,
    table: u32,
    values: u32,
    lum: u32,
    cdf: u32,
    residual: u32,
}

fn load_deon(b: u32) -> Deon {
    var m: Deon;
    m.difference = word_u(b + 1u) != 0u;
    m.p_max = word_u(b + 2u);
    m.n_phi = word_u(b + 3u);
    m.dphi = word_f(b + 4u);
    m.table = word_u(b + 10u);
    m.values = m.table + word_u(b + 5u);
    m.lum = m.table + word_u(b + 6u);
    m.cdf = m.table + word_u(b + 7u);
    m.residual = m.table + word_u(b + 8u);
    return m;
}

/// Position between table rows (j0, j0 + 1, t) or between φ nodes (k0, k1, t).
struct DeonAt {
    i0: u32,
    i1: u32,
    t: f32,
}

fn deon_rows(cos_d: f32) -> DeonAt {
    var r: DeonAt;
    let x = clamp(cos_d, 0.0, 1.0) * f32(DEON_ROWS - 1u);
    r.i0 = min(u32(x), DEON_ROWS - 2u);
    r.i1 = r.i0 + 1u;
    r.t = x - f32(r.i0);
    return r;
}

fn deon_nodes(m: Deon, phi: f32) -> DeonAt {
    var r: DeonAt;
    let x = (wrap_few_turns(phi) + PI) / m.dphi;
    r.i0 = min(u32(max(x, 0.0)), m.n_phi - 1u);
    r.i1 = (r.i0 + 1u) % m.n_phi;
    r.t = clamp(x - f32(r.i0), 0.0, 1.0);
    return r;
}

fn deon_value_at(m: Deon, row: u32, k: u32) -> vec4<f32> {
    let i = row * m.n_phi + k;
    let v = m.values + 3u * i;
    return vec4<f32>(word_f(v), word_f(v + 1u), word_f(v + 2u), word_f(m.lum + i));
}

/// Bilinearly interpolated N_p (rgb) and its luminance (w).
fn deon_value(m: Deon, p: u32, rows: DeonAt, nodes: DeonAt) -> vec4<f32> {
    let a = p * DEON_ROWS + rows.i0;
    let b = p * DEON_ROWS + rows.i1;
    let va = deon_value_at(m, a, nodes.i0) * (1.0 - nodes.t) + deon_value_at(m, a, nodes.i1) * nodes.t;
    let vb = deon_value_at(m, b, nodes.i0) * (1.0 - nodes.t) + deon_value_at(m, b, nodes.i1) * nodes.t;
    return va * (1.0 - rows.t) + vb * rows.t;
}

fn deon_cdf(m: Deon, row: u32, k: u32) -> f32 {
    return word_f(m.cdf + row * (m.n_phi + 1u) + k);
}

/// The luminance mass ∫N_p dφ between rows (the CDF totals).
fn deon_mass_luminance(m: Deon, p: u32, rows: DeonAt) -> f32 {
    return deon_cdf(m, p * DEON_ROWS + rows.i0, m.n_phi) * (1.0 - rows.t)
        + deon_cdf(m, p * DEON_ROWS + rows.i1, m.n_phi) * rows.t;
}

fn deon_residual(m: Deon, rows: DeonAt) -> vec3<f32> {
    let a = m.residual + 3u * rows.i0;
    let b = m.residual + 3u * rows.i1;
    return vec3<f32>(word_f(a), word_f(a + 1u), word_f(a + 2u)) * (1.0 - rows.t)
        + vec3<f32>(word_f(b), word_f(b + 1u), word_f(b + 2u)) * rows.t;
}

fn deon_lobe_luminance(m: Deon, p: u32, rows: DeonAt) -> f32 {
    if p < m.p_max {
        return deon_mass_luminance(m, p, rows);
    }
    return luminance(deon_residual(m, rows));
}

/// Σ_p of the lobes' luminances at the camera's rows: what lobe selection draws from.
fn deon_total_luminance(m: Deon, rows: DeonAt) -> f32 {
    var total = 0.0;
    for (var p = 0u; p <= m.p_max; p++) {
        total += deon_lobe_luminance(m, p, rows);
    }
    return total;
}

/// cosθ_n for the pair: the camera's, or cos((θ_o − θ_i)/2).
fn deon_cos_theta_n(m: Deon, sin_i: f32, cos_i: f32, sin_o: f32, cos_o: f32) -> f32 {
    if m.difference {
        return safe_sqrt(0.5 * (1.0 + cos_i * cos_o + sin_i * sin_o));
    }
    return cos_o;
}

/// M_p(θ_i, θ_o^(p)) with lobe p's constants and tilt.
fn deon_longitudinal(m: Deon, p: u32, sin_i: f32, cos_i: f32, sin_o: f32, cos_o: f32) -> f32 {
    let l = m.table + DEON_LOBE_WORDS * p;
    let ts = word_f(l + 3u);
    let tc = word_f(l + 4u);
    let so = sin_o * tc + cos_o * ts;
    let co = abs(cos_o * tc - sin_o * ts);
    return longitudinal(word_f(l), word_f(l + 1u), sin_i, cos_i, so, co);
}

/// (Σ_p M_p N_p rgb, pdf): the integrand f_s cosθ_i and the sampling density at ω_i.
fn deon_integrand_and_pdf(m: Deon, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    let sin_i = local_sin_theta(wi);
    let cos_i = local_cos_theta(wi);
    let sin_o = local_sin_theta(wo);
    let cos_o = local_cos_theta(wo);
    let rows_o = deon_rows(cos_o);
    let total = deon_total_luminance(m, rows_o);
    if !(total > 0.0) {
        return vec4<f32>(0.0);
    }
    let rows_d = deon_rows(deon_cos_theta_n(m, sin_i, cos_i, sin_o, cos_o));
    let nodes = deon_nodes(m, local_phi(wi) - local_phi(wo));
    var g = vec3<f32>(0.0);
    var pdf = 0.0;
    for (var p = 0u; p <= m.p_max; p++) {
        let mp = deon_longitudinal(m, p, sin_i, cos_i, sin_o, cos_o);
        let w = deon_lobe_luminance(m, p, rows_o) / total;
        if p < m.p_max {
            let n = deon_value(m, p, rows_d, nodes);
            let mass = deon_mass_luminance(m, p, rows_d);
            g += n.xyz * mp;
            pdf += w * mp * select(1.0 / TAU, n.w / mass, mass > 0.0);
        } else {
            g += deon_residual(m, rows_d) * (mp / TAU);
            pdf += w * mp / TAU;
        }
    }
    return vec4<f32>(g, pdf);
}

/// (f_s rgb, pdf) at the light direction ω_i for the camera direction ω_o, both local.
fn deon_eval(m: Deon, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    let r = deon_integrand_and_pdf(m, wi, wo);
    return vec4<f32>(r.xyz / max(local_cos_theta(wi), MIN_COS), r.w);
}

/// φ ∈ [−π, π) from the luminance of lobe p's row-interpolated, piecewise-linear N_p by exact
/// inversion of its CDF; uniform where the lobe has no mass.
fn deon_sample_phi(m: Deon, p: u32, rows: DeonAt, u: f32) -> f32 {
    let n = m.n_phi;
    let ra = p * DEON_ROWS + rows.i0;
    let rb = p * DEON_ROWS + rows.i1;
    let total = deon_cdf(m, ra, n) * (1.0 - rows.t) + deon_cdf(m, rb, n) * rows.t;
    if !(total > 0.0) {
        return -PI + TAU * u;
    }
    let goal = u * total;
    var lo = 0u;
    var hi = n;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if deon_cdf(m, ra, mid) * (1.0 - rows.t) + deon_cdf(m, rb, mid) * rows.t <= goal {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let k = lo;
    let k1 = (k + 1u) % n;
    let n0 = word_f(m.lum + ra * n + k) * (1.0 - rows.t) + word_f(m.lum + rb * n + k) * rows.t;
    let n1 = word_f(m.lum + ra * n + k1) * (1.0 - rows.t) + word_f(m.lum + rb * n + k1) * rows.t;
    let r = max(goal - (deon_cdf(m, ra, k) * (1.0 - rows.t) + deon_cdf(m, rb, k) * rows.t), 0.0);
    let slope = (n1 - n0) / m.dphi;
    var x = 2.0 * r / (n0 + safe_sqrt(n0 * n0 + 2.0 * slope * r));
    if not_finite(x) || x != x {
        x = 0.5 * m.dphi;
    }
    return -PI + f32(k) * m.dphi + clamp(x, 0.0, m.dphi);
}

/// A sample of ω_i (local) with u = (lobe, θ, θ, φ) as the CPU's `sample`.
fn deon_sample(m: Deon, wo: vec3<f32>, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    let sin_o = local_sin_theta(wo);
    let cos_o = local_cos_theta(wo);
    let rows_o = deon_rows(cos_o);
    let total = deon_total_luminance(m, rows_o);
    if !(total > 0.0) {
        return out;
    }
    let goal = u.x * total;
    var acc = 0.0;
    var chosen = m.p_max + 1u;
    for (var p = 0u; p <= m.p_max; p++) {
        let w = deon_lobe_luminance(m, p, rows_o);
        if w > 0.0 {
            chosen = p;
            acc += w;
            if goal < acc {
                break;
            }
        }
    }
    if chosen > m.p_max {
        return out;
    }
    let l = m.table + DEON_LOBE_WORDS * chosen;
    let v = word_f(l);
    let ts = word_f(l + 3u);
    let tc = word_f(l + 4u);
    let so = sin_o * tc + cos_o * ts;
    let co = abs(cos_o * tc - sin_o * ts);
    let cc = max(1.0 + v * log1p((1.0 - u.y) * word_f(l + 2u)), -1.0);
    let ss = safe_sqrt(1.0 - cc * cc);
    let sin_i = clamp(-cc * so + ss * sin_cos_f(TAU * u.z).y * co, -1.0, 1.0);
    let cos_i = safe_sqrt(1.0 - sin_i * sin_i);
    var dphi = -PI + TAU * u.w;
    if chosen < m.p_max {
        dphi = deon_sample_phi(m, chosen, deon_rows(deon_cos_theta_n(m, sin_i, cos_i, sin_o, cos_o)), u.w);
    }
    let sc = sin_cos_f(local_phi(wo) + dphi);
    let wi = vec3<f32>(sin_i, cos_i * sc.y, cos_i * sc.x);
    let r = deon_integrand_and_pdf(m, wi, wo);
    if !(r.w > 0.0) || not_finite(r.w) {
        return out;
    }
    out.wi = wi;
    out.weight = r.xyz / r.w;
    out.pdf = r.w;
    return out;
}
