// Irawan & Marschner 2012's woven cloth (scatter/src/irawan_2012/) in f32, in the local shading
// frame (z the normal): the weave tile's cell under the hit names a yarn segment; in its frame
// (y along the yarn, x across) the specular integrand X is the closed-form highlight of a
// filament (ψ = 0) or staple yarn on a circular spine, times (α + von Mises in the scattering
// angle) and the kind's area share; f_s = k_d/π + k_s·X·s_n on the upper side. Sampled as on the
// CPU: half cosine about z, half the lobe (n + 1)/(2π)·cos^n (n = 8) about the mirror direction
// of ω_o; the pdf is the mixture's. The normalisation s_n, the von Mises constant and each
// yarn's spine radius and area share are computed in f64 on the CPU (`scene_buffers.rs`).
//
// Words at `b` (32 per material): 0 kind, 1 α, 2 β, 3 s_n, 4 1/(2π I₀(β)) scaled (with
// e^{β(cos s − 1)}), 5 tile width, 6 tile height (cells), 7 where the yarn records start
// (relative to the table), 8 ss, 9 h_width, 10 the table's first word (the tile's 0-based yarn
// ids, row-major, then 16 words per yarn: 0 weft?, 1 tanψ, 2 |sinψ|, 3 u_max, 4 w, 5 l, 6–7 its
// centre, 8 the spine radius R, 9 the area share, 10–12 k_d, 13–15 k_s, colour scales applied;
// then a mesh's shading records), 11 where a mesh's shading records start (relative to the
// table), 12 the mesh's first triangle, 13–14 the uv scale, 15–16 the position without texture
// coordinates, 19 1 when the surface has texture coordinates.

const MATERIAL_IRAWAN: u32 = 12u;
const IRAWAN_YARN_WORDS: u32 = 16u;

/// The fabric at one point: the material, its yarn record, the point across (x) and along (y)
/// the yarn in cells, and the yarn's colours.
struct Irawan {
    b: u32,
    yarn: u32,
    x: f32,
    y: f32,
    k_d: vec3<f32>,
    k_s: vec3<f32>,
}

/// Rounds half away from zero (Rust's `f64::round`).
fn round_away(x: f32) -> f32 {
    return sign(x) * floor(abs(x) + 0.5);
}

/// The fabric of material `b` at tile position `p` (the CPU's `WeavePattern::locate`).
fn irawan_at(b: u32, p: vec2<f32>) -> Irawan {
    let w = word_u(b + 5u);
    let h = word_u(b + 6u);
    let size = vec2<f32>(f32(w), f32(h));
    let c = (p - floor(p)) * size;
    let table = word_u(b + 10u);
    let cell = min(u32(c.y), h - 1u) * w + min(u32(c.x), w - 1u);
    var m: Irawan;
    m.b = b;
    m.yarn = table + word_u(b + 7u) + IRAWAN_YARN_WORDS * word_u(table + cell);
    let d = c - vec2<f32>(word_f(m.yarn + 6u), word_f(m.yarn + 7u));
    let wrapped = d - size * vec2<f32>(round_away(d.x / size.x), round_away(d.y / size.y));
    if word_u(m.yarn) == 0u {
        m.x = wrapped.x;
        m.y = wrapped.y;
    } else {
        m.x = -wrapped.y;
        m.y = wrapped.x;
    }
    m.k_d = word_v3(m.yarn + 10u);
    m.k_s = word_v3(m.yarn + 13u) * word_f(b + 3u);
    return m;
}

/// Seeliger's c_i c_o/(4π(c_i + c_o)) at the highlight's normal n.
fn irawan_seeliger(n: vec3<f32>, li: vec3<f32>, lo: vec3<f32>) -> f32 {
    let ci = max(dot(n, li), 0.0);
    let co = max(dot(n, lo), 0.0);
    if ci + co > 0.0 {
        return ci * co / (4.0 * PI * (ci + co));
    }
    return 0.0;
}

/// The specular integrand X (before k_s and s_n), both directions on the upper side.
fn irawan_integrand(m: Irawan, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let yb = m.yarn;
    var li = wi;
    var lo = wo;
    if word_u(yb) != 0u {
        li = vec3<f32>(-wi.y, wi.x, wi.z);
        lo = vec3<f32>(-wo.y, wo.x, wo.z);
    }
    let sum = li + lo;
    let len = length(sum);
    if len < 1e-12 {
        return 0.0;
    }
    let hv = sum / len;
    let tan_psi = word_f(yb + 1u);
    let u_max = word_f(yb + 3u);
    let width = word_f(yb + 4u);
    let l = word_f(yb + 5u);
    let radius = word_f(yb + 8u);
    let h_width = word_f(m.b + 9u);
    let a = 0.5 * width;
    var value: f32;
    if tan_psi == 0.0 {
        // Filament: the highlight's inclination along the yarn.
        let u_star = atan2_f(hv.y, hv.z);
        let delta_y = l * h_width;
        if abs(u_star) >= u_max || abs(u_star / u_max * (0.5 * l) - m.y) >= 0.5 * delta_y {
            return 0.0;
        }
        let sv = sin_cos_f(clamp(m.x * PI / width, -HALF_PI, HALF_PI));
        let su = sin_cos_f(u_star);
        let n = vec3<f32>(sv.x, su.x * sv.y, su.y * sv.y);
        let txh = abs(su.y * hv.z + su.x * hv.y);
        if txh < 1e-12 {
            return 0.0;
        }
        let ss = word_f(m.b + 8u);
        let fade = (1.0 - ss) + ss * min((u_max - abs(u_star)) / (0.1 * u_max), 1.0);
        value = a * (radius + a * sv.y) / (len * txh) * irawan_seeliger(n, li, lo) * fade * PI * l / delta_y;
    } else {
        // Staple: the highlight's angle across the yarn at this inclination.
        let su = sin_cos_f(clamp(m.y / (0.5 * l) * u_max, -u_max, u_max));
        let q = hv.y * su.x + hv.z * su.y;
        let denom = sqrt(hv.x * hv.x + q * q) * tan_psi;
        if denom == 0.0 {
            return 0.0;
        }
        let d = (hv.y * su.y - hv.z * su.x) / denom;
        if abs(d) >= 1.0 {
            return 0.0;
        }
        var v_star = atan2_f(-q, hv.x) + acos_f(d);
        if v_star > PI {
            v_star -= TAU;
        }
        let delta_x = width * h_width;
        if abs(v_star) >= HALF_PI || abs(v_star * width / PI - m.x) >= 0.5 * delta_x {
            return 0.0;
        }
        let sv = sin_cos_f(v_star);
        let n = vec3<f32>(sv.x, su.x * sv.y, su.y * sv.y);
        let nh = dot(n, hv);
        if nh <= 0.0 {
            return 0.0;
        }
        value = a * (radius + a * sv.y) / (len * nh * word_f(yb + 2u)) * irawan_seeliger(n, li, lo) * 2.0 * width * u_max
            / delta_x;
    }
    let von_mises = exp(word_f(m.b + 2u) * (-dot(wi, wo) - 1.0)) * word_f(m.b + 4u);
    return value * word_f(yb + 9u) * (word_f(m.b + 1u) + von_mises);
}

/// The sampler's density: half cosine, half the lobe about the mirror direction of ω_o.
fn irawan_pdf(wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let c = max(dot(wi, vec3<f32>(-wo.x, -wo.y, wo.z)), 0.0);
    let c2 = c * c;
    let c4 = c2 * c2;
    return 0.5 * max(wi.z, 0.0) / PI + 0.5 * 9.0 / TAU * (c4 * c4);
}

/// (f_s rgb, pdf) at ω_i for ω_o, both local.
fn irawan_eval(m: Irawan, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    let pdf = irawan_pdf(wi, wo);
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return vec4<f32>(0.0, 0.0, 0.0, pdf);
    }
    return vec4<f32>(m.k_d / PI + m.k_s * irawan_integrand(m, wi, wo), pdf);
}

/// A sample of ω_i (local) with u = (lobe, u₁, u₂, –) as the CPU's `sample`.
fn irawan_sample(m: Irawan, wo: vec3<f32>, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    if wo.z <= 0.0 {
        return out;
    }
    var wi: vec3<f32>;
    if u.x < 0.5 {
        wi = cosine_direction(u.y, u.z);
    } else {
        let axis = vec3<f32>(-wo.x, -wo.y, wo.z);
        let cos_t = select(exp2(log2(u.y) / 9.0), 0.0, u.y <= 0.0);
        let sin_t = safe_sqrt(1.0 - cos_t * cos_t);
        let e = orthonormal_pair(axis);
        let sc = sin_cos_f(TAU * u.z);
        wi = normalize(axis * cos_t + e[0] * (sin_t * sc.y) + e[1] * (sin_t * sc.x));
    }
    let e = irawan_eval(m, wi, wo);
    if !(e.w > 0.0) || not_finite(e.w) {
        return out;
    }
    out.wi = wi;
    out.pdf = e.w;
    out.weight = select(vec3<f32>(0.0), e.xyz * (wi.z / e.w), wi.z > 0.0);
    return out;
}
