// The two-sided leaf surface model (scatter/src/leaf.rs) in f32, in the local shading frame
// (z the normal): a GGX cuticle (Walter et al. 2007) with Smith's height-correlated shadowing
// on both faces over a diffusing body that reflects R_b and transmits T_b (PROSPECT-D's body
// values, computed on the CPU), f_d = (R_b or T_b)(1 − E(μ_i))(1 − E(μ_o))/(π(1 − Ē)) with the
// CPU's cuticle albedo table E (copied). Sampled as on the CPU: a lobe by E(μ_o),
// (1 − E)Y(R_b), (1 − E)Y(T_b), then GGX visible normals (Heitz 2018) or the cosine on either
// side; the pdf is the mixture's. The GGX functions are in `ggx.wgsl`.
//
// Words at `b` (32 per material): 0 kind, 1–3 R_b, 4–6 T_b, 7 α, 8 η, 9 1/(π(1 − Ē)), 10 the
// table's first word (E(k/32), k = 0..32, then a mesh's per-triangle shading records,
// `scene_buffers.rs`, 18 words each: the tangent along u, the corners' normals and texture
// coordinates), 11 where a mesh's shading records start (relative to the table), 12 the mesh's
// first triangle.

const MATERIAL_LEAF: u32 = 7u;
const LEAF_E_INTERVALS: u32 = 32u;

struct Leaf {
    r_b: vec3<f32>,
    t_b: vec3<f32>,
    alpha: f32,
    eta: f32,
    body_norm: f32,
    table: u32,
}

fn load_leaf(b: u32) -> Leaf {
    var m: Leaf;
    m.r_b = vec3<f32>(word_f(b + 1u), word_f(b + 2u), word_f(b + 3u));
    m.t_b = vec3<f32>(word_f(b + 4u), word_f(b + 5u), word_f(b + 6u));
    m.alpha = word_f(b + 7u);
    m.eta = word_f(b + 8u);
    m.body_norm = word_f(b + 9u);
    m.table = word_u(b + 10u);
    return m;
}

/// The cuticle's directional albedo E(μ), interpolated linearly in the table.
fn leaf_albedo(m: Leaf, mu: f32) -> f32 {
    let x = clamp(mu, 0.0, 1.0) * f32(LEAF_E_INTERVALS);
    let k = min(u32(x), LEAF_E_INTERVALS - 1u);
    let t = x - f32(k);
    return word_f(m.table + k) * (1.0 - t) + word_f(m.table + k + 1u) * t;
}

/// Lobe probabilities (cuticle, body reflection, body transmission) for a viewer at μ_o.
fn leaf_lobe_weights(m: Leaf, mu_o: f32) -> vec3<f32> {
    let e = leaf_albedo(m, mu_o);
    let w = vec3<f32>(e, (1.0 - e) * luminance(m.r_b), (1.0 - e) * luminance(m.t_b));
    let sum = w.x + w.y + w.z;
    if sum > 0.0 {
        return w / sum;
    }
    return vec3<f32>(0.0);
}

/// (f_s rgb, pdf) at ω_i for ω_o, both local; pairs are mirrored so that ω_o is on the upper
/// side (both faces are alike).
fn leaf_eval(m: Leaf, wi0: vec3<f32>, wo0: vec3<f32>) -> vec4<f32> {
    if wi0.z == 0.0 || wo0.z == 0.0 {
        return vec4<f32>(0.0);
    }
    let s = select(1.0, -1.0, wo0.z < 0.0);
    let wi = vec3<f32>(wi0.xy, s * wi0.z);
    let wo = vec3<f32>(wo0.xy, s * wo0.z);
    let body = (1.0 - leaf_albedo(m, abs(wi.z))) * (1.0 - leaf_albedo(m, wo.z)) * m.body_norm;
    let w = leaf_lobe_weights(m, wo.z);
    let cosine = abs(wi.z) / PI;
    if wi.z > 0.0 {
        return vec4<f32>(vec3<f32>(ggx_reflection(m.alpha, m.eta, wi, wo)) + m.r_b * body, w.x * ggx_reflection_pdf(m.alpha, wi, wo) + w.y * cosine);
    }
    return vec4<f32>(m.t_b * body, w.z * cosine);
}

/// A sample of ω_i (local) with u = (lobe, u₁, u₂, –) as the CPU's `sample`.
fn leaf_sample(m: Leaf, wo: vec3<f32>, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    if wo.z == 0.0 {
        return out;
    }
    let flip = wo.z < 0.0;
    let wo_up = vec3<f32>(wo.xy, abs(wo.z));
    let w = leaf_lobe_weights(m, wo_up.z);
    var lobe = 2u;
    if u.x < w.x {
        lobe = 0u;
    } else if u.x < w.x + w.y {
        lobe = 1u;
    }
    var wi_up: vec3<f32>;
    if lobe == 0u {
        let h = ggx_sample_visible(m.alpha, wo_up, u.y, u.z);
        wi_up = h * (2.0 * dot(wo_up, h)) - wo_up;
    } else {
        wi_up = cosine_direction(u.y, u.z);
        if lobe == 2u {
            wi_up.z = -wi_up.z;
        }
    }
    if wi_up.z == 0.0 || (lobe == 0u && wi_up.z < 0.0) {
        return out;
    }
    let wi = vec3<f32>(wi_up.xy, select(wi_up.z, -wi_up.z, flip));
    let e = leaf_eval(m, wi, wo);
    if !(e.w > 0.0) || not_finite(e.w) {
        return out;
    }
    out.wi = wi;
    out.weight = e.xyz * (abs(wi.z) / e.w);
    out.pdf = e.w;
    return out;
}
