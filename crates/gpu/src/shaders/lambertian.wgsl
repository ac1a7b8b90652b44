// The `lambertian` surface model (scatter/src/lambert_1760.rs) in the local shading frame (z the
// normal): f_s = k_d/π on the upper side, sampled by the cosine about z with the frame's x as
// the CPU's `cosine_hemisphere(Z, X, …)`. k_d is a constant or a texture (`textures.wgsl`) read
// at the hit's texture coordinates.
//
// Words at `b` (32 per material): 0 kind, 1–3 k_d, 10 the table's first word (k_d's texels, then
// a mesh's per-triangle shading records), 11 where the records start (relative to the table),
// 12 the mesh's first triangle, 13 1 when k_d is textured and the surface has texture
// coordinates, 14 the texture's width, 15 its height, 16 its wrapping (0 repeat, 1 clamp),
// 17–18 its uv scale.

const MATERIAL_LAMBERTIAN: u32 = 8u;

/// (f_s rgb, pdf) at ω_i for ω_o, both local.
fn lambertian_eval(k_d: vec3<f32>, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    if wi.z > 0.0 && wo.z > 0.0 {
        return vec4<f32>(k_d / PI, wi.z / PI);
    }
    return vec4<f32>(0.0);
}

/// A cosine-weighted direction about z from (u₁, u₂), as the CPU's `cosine_hemisphere(Z, X, …)`:
/// radius √u₁ at the angle 2πu₂ in the xy plane, z = √(1 − u₁). The surface models' diffuse
/// lobes draw with it.
fn cosine_direction(u1: f32, u2: f32) -> vec3<f32> {
    let r = sqrt(u1);
    let sc = sin_cos_f(TAU * u2);
    return vec3<f32>(r * sc.y, r * sc.x, safe_sqrt(1.0 - u1));
}

/// A cosine-weighted sample of ω_i (local) with u = (u₀, u₁, –, –).
fn lambertian_sample(k_d: vec3<f32>, wo: vec3<f32>, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    if wo.z <= 0.0 {
        return out;
    }
    let wi = cosine_direction(u.x, u.y);
    if wi.z <= 0.0 {
        return out;
    }
    out.wi = wi;
    out.weight = k_d;
    out.pdf = wi.z / PI;
    return out;
}
