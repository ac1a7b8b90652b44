// Finished wood and chatoyant minerals (scatter/src/marschner_2005.rs, Marschner et al. 2005)
// in f32, in the local shading frame (z the normal): a finish of index η over a diffuse matrix
// with a subsurface fiber highlight; both directions are refracted into the wood,
// f_r = f_finish + (T_i T_o/η²)(k_d/π + k_f g(β; ψ_i + ψ_o)/cos²(ψ_d/2)), ψ the angle of a
// refracted direction from the fiber axis u's normal plane. The finish is a mirror (α = 0: a
// delta lobe, left out of eval and returned by `wood_sample` with pdf −1) or a GGX reflection
// (`ggx.wgsl`). Sampled exactly as on the CPU: a lobe by F(cosθ_o), T_o·mean(k_d),
// T_o·2π·mean(k_f); the fiber lobe draws ψ_h from the truncated Gaussian and the azimuth about
// u uniform on the arc of that cone that leaves through the finish.
//
// Words at `b` (32 per material): 0 kind, 1–3 k_d, 4–6 k_f, 7 η, 8 α, 9 β, 10 the table's first
// word (the textures, then a mesh's shading records as in `leaf.wgsl`), 11 where the records
// start (relative to the table), 12 the mesh's first triangle, 13 the fiber angle, 14 its dip
// (radians), 19 1 when the surface has texture coordinates, 20–24 the textures of k_d, k_f, β,
// fiber angle and dip: 1 + their offset in the table (`texture_at`), 0 when untextured.

const MATERIAL_WOOD: u32 = 9u;

struct Wood {
    k_d: vec3<f32>,
    k_f: vec3<f32>,
    eta: f32,
    alpha: f32,
    beta: f32,
    /// The fiber axis.
    u: vec3<f32>,
}

/// Parameter `k` of the material at `b`: word `at`, or its texture's value at uv.
fn wood_param(b: u32, at: u32, k: u32, uv: vec2<f32>, has_uv: bool) -> vec3<f32> {
    let t = word_u(b + 20u + k);
    if t != 0u && has_uv {
        return texture_at(word_u(b + 10u) + t - 1u, uv);
    }
    return vec3<f32>(word_f(b + at), word_f(b + at + 1u), word_f(b + at + 2u));
}

/// The material at `b`, its textured parameters read at uv where the surface has coordinates.
fn load_wood(b: u32, uv: vec2<f32>, has_uv: bool) -> Wood {
    var m: Wood;
    m.k_d = wood_param(b, 1u, 0u, uv, has_uv);
    m.k_f = wood_param(b, 4u, 1u, uv, has_uv);
    m.eta = word_f(b + 7u);
    m.alpha = word_f(b + 8u);
    m.beta = wood_param(b, 9u, 2u, uv, has_uv).x;
    let a = sin_cos_f(wood_param(b, 13u, 3u, uv, has_uv).x);
    let d = sin_cos_f(wood_param(b, 14u, 4u, uv, has_uv).x);
    m.u = vec3<f32>(d.y * a.y, d.y * a.x, -d.x);
    return m;
}

/// ω refracted into the wood, pointing back up.
fn wood_refract_in(m: Wood, w: vec3<f32>) -> vec3<f32> {
    let t = w.xy / m.eta;
    return vec3<f32>(t, safe_sqrt(1.0 - dot(t, t)));
}

/// T = 1 − F for a direction outside with cosθ.
fn wood_transmittance(m: Wood, c: f32) -> f32 {
    return 1.0 - fresnel_dielectric(c, m.eta);
}

/// (ψ, cosψ, sinψ) of an internal direction.
fn wood_psi(m: Wood, w: vec3<f32>) -> vec3<f32> {
    let s = clamp(dot(w, m.u), -1.0, 1.0);
    return vec3<f32>(asin_f(s), safe_sqrt(1.0 - s * s), s);
}

/// Lobe probabilities (finish, diffuse, fiber) for a viewer with cosθ_o.
fn wood_lobe_weights(m: Wood, cos_o: f32) -> vec3<f32> {
    let f = fresnel_dielectric(cos_o, m.eta);
    let t = 1.0 - f;
    let w = vec3<f32>(f, t * dot(m.k_d, vec3<f32>(1.0 / 3.0)), t * TAU * dot(m.k_f, vec3<f32>(1.0 / 3.0)));
    let sum = w.x + w.y + w.z;
    if sum > 0.0 {
        return w / sum;
    }
    return vec3<f32>(0.0);
}

/// Half-width of the arc of the cone ω′·u = sinψ that leaves through the finish (z′ above the
/// critical cosθ_c), centred on φ = 0 of `wood_sample`'s basis: z′ = sinψ u_z + cosψ cosδ cosφ.
fn wood_escape_arc(m: Wood, sin_psi: f32, cos_psi: f32) -> f32 {
    let z_c = safe_sqrt(1.0 - 1.0 / (m.eta * m.eta));
    let a = sin_psi * m.u.z;
    let b = cos_psi * safe_sqrt(1.0 - m.u.z * m.u.z);
    if b <= 1e-12 {
        return select(0.0, PI, a > z_c);
    }
    return acos_f(clamp((z_c - a) / b, -1.0, 1.0));
}

/// (f_s rgb, pdf) at ω_i for ω_o, both local.
fn wood_eval(m: Wood, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return vec4<f32>(0.0);
    }
    let wi_in = wood_refract_in(m, wi);
    let pi = wood_psi(m, wi_in);
    let po = wood_psi(m, wood_refract_in(m, wo)).x;
    let c = sin_cos_f(0.5 * (po - pi.x)).y;
    let g = gaussian_f(m.beta, pi.x + po);
    let t = wood_transmittance(m, wi.z) * wood_transmittance(m, wo.z) / (m.eta * m.eta);
    var f = (m.k_d / PI + m.k_f * (g / max(c * c, MIN_COS * MIN_COS))) * t;
    let w = wood_lobe_weights(m, wo.z);
    var pdf = w.y * wi.z / PI;
    if m.alpha > 0.0 {
        f += vec3<f32>(ggx_reflection(m.alpha, m.eta, wi, wo));
        pdf += w.x * ggx_reflection_pdf(m.alpha, wi, wo);
    }
    // The fiber sampler: ψ_h's truncated Gaussian, the escaping arc, the refraction's Jacobian.
    let mass = normal_mass_f((po - HALF_PI) / m.beta, (po + HALF_PI) / m.beta);
    let half_width = wood_escape_arc(m, pi.z, pi.y);
    if w.z > 0.0 && mass > 0.0 && half_width > 0.0 {
        let internal = g / (mass * 2.0 * half_width * max(pi.y, MIN_COS));
        pdf += w.z * internal * wi.z / (m.eta * m.eta * max(wi_in.z, MIN_COS));
    }
    return vec4<f32>(f, pdf);
}

/// A sample of ω_i (local) with u = (lobe, u₁, u₂, –) as the CPU's `sample`; the finish's mirror
/// lobe (α = 0) returns pdf −1 and the weight F/P(finish).
fn wood_sample(m: Wood, wo: vec3<f32>, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    if wo.z <= 0.0 {
        return out;
    }
    let w = wood_lobe_weights(m, wo.z);
    var wi: vec3<f32>;
    if u.x < w.x {
        if m.alpha == 0.0 {
            out.wi = vec3<f32>(-wo.xy, wo.z);
            out.weight = vec3<f32>(fresnel_dielectric(wo.z, m.eta) / w.x);
            out.pdf = -1.0;
            return out;
        }
        let h = ggx_sample_visible(m.alpha, wo, u.y, u.z);
        wi = h * (2.0 * dot(wo, h)) - wo;
    } else if u.x < w.x + w.y {
        wi = cosine_direction(u.y, u.z);
    } else if w.z > 0.0 {
        let po = wood_psi(m, wood_refract_in(m, wo)).x;
        let z = sample_truncated_normal_f(u.y, (po - HALF_PI) / m.beta, (po + HALF_PI) / m.beta);
        let sp = sin_cos_f(clamp(m.beta * z - po, -HALF_PI, HALF_PI));
        let half_width = wood_escape_arc(m, sp.x, sp.y);
        if half_width <= 0.0 {
            return out;
        }
        // The cone's basis: e1 the normal's part across u (where z′ is largest), e2 = u × e1.
        let cd = safe_sqrt(1.0 - m.u.z * m.u.z);
        var e1 = vec3<f32>(1.0, 0.0, 0.0);
        if cd > 1e-6 {
            e1 = (vec3<f32>(0.0, 0.0, 1.0) - m.u * m.u.z) / cd;
        }
        let phi = sin_cos_f(half_width * (2.0 * u.z - 1.0));
        let wi_in = m.u * sp.x + (e1 * phi.y + cross(m.u, e1) * phi.x) * sp.y;
        let t = wi_in.xy * m.eta;
        let z2 = 1.0 - dot(t, t);
        if !(z2 > 0.0 && wi_in.z > 0.0) {
            return out;
        }
        wi = vec3<f32>(t, sqrt(z2));
    } else {
        return out;
    }
    if wi.z <= 0.0 || not_finite3(wi) {
        return out;
    }
    wi = normalize(wi);
    let e = wood_eval(m, wi, wo);
    if !(e.w > 0.0) || not_finite(e.w) {
        return out;
    }
    out.wi = wi;
    out.weight = e.xyz * (wi.z / e.w);
    out.pdf = e.w;
    return out;
}
