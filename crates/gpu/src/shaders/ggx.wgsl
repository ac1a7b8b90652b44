// GGX (Trowbridge–Reitz) microfacets in f32, shared by the surface models with a rough
// dielectric interface (`leaf.wgsl`, `wood.wgsl`; scatter's leaf and marschner_2005): the
// normal distribution D, Smith's Λ for the height-correlated shadowing, visible-normal
// sampling (Heitz 2018) and the half vector.

/// GGX D(m) for cosθ_m.
fn ggx_d(alpha: f32, cos_m: f32) -> f32 {
    let a2 = alpha * alpha;
    let t = cos_m * cos_m * (a2 - 1.0) + 1.0;
    return a2 / (PI * t * t);
}

/// Smith's Λ for a direction with cosθ = c.
fn ggx_lambda(alpha: f32, c: f32) -> f32 {
    let c2 = c * c;
    let tan2 = max(1.0 - c2, 0.0) / max(c2, MIN_COS * MIN_COS);
    return 0.5 * (sqrt(1.0 + alpha * alpha * tan2) - 1.0);
}

/// A GGX visible normal for v (upper side) from two uniforms (Heitz 2018).
fn ggx_sample_visible(alpha: f32, v: vec3<f32>, u1: f32, u2: f32) -> vec3<f32> {
    let vh = normalize(vec3<f32>(alpha * v.x, alpha * v.y, v.z));
    let len2 = vh.x * vh.x + vh.y * vh.y;
    var t1 = vec3<f32>(1.0, 0.0, 0.0);
    if len2 > 0.0 {
        t1 = vec3<f32>(-vh.y, vh.x, 0.0) / sqrt(len2);
    }
    let t2 = cross(vh, t1);
    let r = sqrt(u1);
    let sc = sin_cos_f(TAU * u2);
    let p1 = r * sc.y;
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * safe_sqrt(1.0 - p1 * p1) + s * r * sc.x;
    let n = t1 * p1 + t2 * p2 + vh * safe_sqrt(1.0 - p1 * p1 - p2 * p2);
    return normalize(vec3<f32>(alpha * n.x, alpha * n.y, max(n.z, 1e-12)));
}

/// The half vector of two directions (0 for opposite ones).
fn half_vector(wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let s = wi + wo;
    let l = length(s);
    if !(l > 0.0) {
        return vec3<f32>(0.0);
    }
    return s / l;
}

/// f_s of reflection by a GGX dielectric interface of index eta with the height-correlated
/// shadowing (Walter et al. 2007), both directions on the upper side.
fn ggx_reflection(alpha: f32, eta: f32, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let h = half_vector(wi, wo);
    if h.z <= 0.0 || wi.z <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    let g2 = 1.0 / (1.0 + ggx_lambda(alpha, wi.z) + ggx_lambda(alpha, wo.z));
    return fresnel_dielectric(max(dot(wi, h), 0.0), eta) * ggx_d(alpha, h.z) * g2
        / (4.0 * max(wi.z, MIN_COS) * max(wo.z, MIN_COS));
}

/// The density of wi reflected about a visible normal of wo (`ggx_sample_visible`), both on
/// the upper side.
fn ggx_reflection_pdf(alpha: f32, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let h = half_vector(wi, wo);
    if h.z <= 0.0 || dot(wo, h) <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let g1 = 1.0 / (1.0 + ggx_lambda(alpha, wo.z));
    return g1 * ggx_d(alpha, h.z) / (4.0 * max(wo.z, MIN_COS));
}
