// Test kernels: the GPU's Chiang model and sampler on given inputs, for comparison with the
// CPU's (`model_probe.rs`).

@group(0) @binding(0) var<storage, read> probe_material: array<u32>;
/// Per case: (ω_o local, h), (ω_i local, 0), (u0..u3).
@group(0) @binding(1) var<storage, read> probe_in: array<vec4<f32>>;
/// Per case: (f_s rgb, pdf), (sampled ω_i, its pdf), (its weight, 0).
@group(0) @binding(2) var<storage, read_write> probe_out: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> sobol_bytes: array<u32>;

fn probe_f(i: u32) -> f32 {
    return bitcast<f32>(probe_material[i]);
}

/// The material's words as `kajiya_kay.wgsl`, `marschner.wgsl` and `deon.wgsl` read them.
fn word_f(i: u32) -> f32 {
    return bitcast<f32>(probe_material[i]);
}

fn word_u(i: u32) -> u32 {
    return probe_material[i];
}

fn word_v3(i: u32) -> vec3<f32> {
    return vec3<f32>(word_f(i), word_f(i + 1u), word_f(i + 2u));
}

fn probe_chiang() -> Chiang {
    var c: Chiang;
    c.eta = probe_f(1u);
    c.sigma_a = vec3<f32>(probe_f(2u), probe_f(3u), probe_f(4u));
    c.s = probe_f(5u);
    c.logistic_norm = probe_f(6u);
    c.cdf_lo = probe_f(7u);
    c.cdf_hi = probe_f(8u);
    c.v = vec4<f32>(probe_f(9u), probe_f(10u), probe_f(11u), probe_f(12u));
    c.inv_norm = vec4<f32>(probe_f(13u), probe_f(14u), probe_f(15u), probe_f(16u));
    c.expm1_neg = vec4<f32>(probe_f(17u), probe_f(18u), probe_f(19u), probe_f(20u));
    c.tilt_sin = vec4<f32>(probe_f(21u), probe_f(22u), probe_f(23u), probe_f(24u));
    c.tilt_cos = vec4<f32>(probe_f(25u), probe_f(26u), probe_f(27u), probe_f(28u));
    return c;
}

@compute @workgroup_size(64)
fn probe_chiang_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let m = probe_chiang();
    let a = probe_in[3u * i];
    let wi = probe_in[3u * i + 1u].xyz;
    let u = probe_in[3u * i + 2u];
    let v = chiang_at_vertex(m, a.xyz, a.w);
    probe_out[3u * i] = chiang_eval(m, v, wi);
    let s = chiang_sample(m, v, u);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}

/// As `probe_chiang_cases` for the hollow fiber at word 0 (Chiang's constants, then κ, η_l and
/// the lobes).
@compute @workgroup_size(64)
fn probe_hollow_fiber_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let m = probe_chiang();
    let a = probe_in[3u * i];
    let wi = probe_in[3u * i + 1u].xyz;
    let u = probe_in[3u * i + 2u];
    let v = hollow_at_vertex(m, 0u, a.xyz, a.w);
    probe_out[3u * i] = hollow_eval(m, v, wi);
    let s = hollow_sample(m, v, u);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}

/// As `probe_chiang_cases` for the Kajiya–Kay material at word 0 (its table after it).
@compute @workgroup_size(64)
fn probe_kajiya_kay_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let m = load_kajiya_kay(0u);
    let a = probe_in[3u * i];
    let wi = probe_in[3u * i + 1u].xyz;
    let u = probe_in[3u * i + 2u];
    probe_out[3u * i] = kk_eval(m, wi, a.xyz);
    let s = kk_sample(m, a.xyz, u);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}

/// As `probe_chiang_cases` for the Marschner material at word 0 (its table after it).
@compute @workgroup_size(64)
fn probe_marschner_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let m = load_marschner(0u);
    let a = probe_in[3u * i];
    let wi = probe_in[3u * i + 1u].xyz;
    let u = probe_in[3u * i + 2u];
    probe_out[3u * i] = ms_eval(m, wi, a.xyz);
    let s = ms_sample(m, a.xyz, u);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}

/// As `probe_chiang_cases` for the d'Eon material at word 0 (its table after it).
@compute @workgroup_size(64)
fn probe_deon_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let m = load_deon(0u);
    let a = probe_in[3u * i];
    let wi = probe_in[3u * i + 1u].xyz;
    let u = probe_in[3u * i + 2u];
    probe_out[3u * i] = deon_eval(m, wi, a.xyz);
    let s = deon_sample(m, a.xyz, u);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}

/// As `probe_chiang_cases` for the Yan fur material at word 0 (its table after it).
@compute @workgroup_size(64)
fn probe_yan_fur_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let m = load_yan_fur(0u);
    let a = probe_in[3u * i];
    let wi = probe_in[3u * i + 1u].xyz;
    let u = probe_in[3u * i + 2u];
    probe_out[3u * i] = yan_eval(m, wi, a.xyz, a.w);
    let s = yan_sample(m, a.xyz, a.w, u);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}

/// As `probe_chiang_cases` for the Huang 2022 material at word 0 (its table after it).
@compute @workgroup_size(64)
fn probe_huang_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let m = load_huang(0u);
    let a = probe_in[3u * i];
    let v = huang_at_vertex(m, a.xyz, a.w);
    probe_out[3u * i] = huang_eval(m, v, probe_in[3u * i + 1u].xyz);
    let s = huang_sample(m, v, probe_in[3u * i + 2u]);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}

/// As `probe_chiang_cases` for the leaf material at word 0 (its table after it), in the
/// surface's local frame.
@compute @workgroup_size(64)
fn probe_leaf_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let m = load_leaf(0u);
    let wo = probe_in[3u * i].xyz;
    let wi = probe_in[3u * i + 1u].xyz;
    let u = probe_in[3u * i + 2u];
    probe_out[3u * i] = leaf_eval(m, wi, wo);
    let s = leaf_sample(m, wo, u);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}

/// As `probe_chiang_cases` for the untextured `lambertian` material at word 0, in the surface's
/// local frame.
@compute @workgroup_size(64)
fn probe_lambertian_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let k_d = vec3<f32>(word_f(1u), word_f(2u), word_f(3u));
    let wo = probe_in[3u * i].xyz;
    let wi = probe_in[3u * i + 1u].xyz;
    let u = probe_in[3u * i + 2u];
    probe_out[3u * i] = lambertian_eval(k_d, wi, wo);
    let s = lambertian_sample(k_d, wo, u);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}

/// As `probe_chiang_cases` for the `irawan-2012` material at word 0 (its table after it), in the
/// surface's local frame, at the tile position (ω_o's w, ω_i's w).
@compute @workgroup_size(64)
fn probe_irawan_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let a = probe_in[3u * i];
    let b = probe_in[3u * i + 1u];
    let u = probe_in[3u * i + 2u];
    let m = irawan_at(0u, vec2<f32>(a.w, b.w));
    probe_out[3u * i] = irawan_eval(m, b.xyz, a.xyz);
    let s = irawan_sample(m, a.xyz, u);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}

/// As `probe_chiang_cases` for the untextured `wood` material at word 0, in the surface's local
/// frame (a mirror sample of the smooth finish has pdf −1).
@compute @workgroup_size(64)
fn probe_wood_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let m = load_wood(0u, vec2<f32>(0.0), false);
    let wo = probe_in[3u * i].xyz;
    let wi = probe_in[3u * i + 1u].xyz;
    let u = probe_in[3u * i + 2u];
    probe_out[3u * i] = wood_eval(m, wi, wo);
    let s = wood_sample(m, wo, u);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}

/// As `probe_chiang_cases` for the untextured `sadeghi-2013` material at word 0 (its families after it),
/// in the surface's local frame.
@compute @workgroup_size(64)
fn probe_sadeghi_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let wo = probe_in[3u * i].xyz;
    let wi = probe_in[3u * i + 1u].xyz;
    let u = probe_in[3u * i + 2u];
    let c = load_sadeghi(0u, vec2<f32>(0.0), false);
    probe_out[3u * i] = sadeghi_eval(c, wi, wo);
    let s = sadeghi_sample(c, wo, u);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}

/// Per case in: (x, y, sample index, pair) as bits, (seed hash low, high, 0, 0); out: the pair.
@compute @workgroup_size(64)
fn probe_sampler_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let a = bitcast<vec4<u32>>(probe_in[3u * i]);
    let seed = bitcast<vec4<u32>>(probe_in[3u * i + 1u]);
    let key = pixel_key(seed.xy, a.x, a.y);
    probe_out[3u * i] = vec4<f32>(next_2d(key, a.z, a.w), 0.0, 0.0);
}

/// As `probe_chiang_cases` for the reference fiber at word 0 (Goldman's table after it).
@compute @workgroup_size(64)
fn probe_reference_fiber_cases(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if 3u * i >= arrayLength(&probe_in) {
        return;
    }
    let m = load_reference_fiber(0u);
    let a = probe_in[3u * i];
    let wi = probe_in[3u * i + 1u].xyz;
    let u = probe_in[3u * i + 2u];
    probe_out[3u * i] = reference_fiber_eval(m, wi, a.xyz);
    let s = reference_fiber_sample(m, a.xyz, u);
    probe_out[3u * i + 1u] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * i + 2u] = vec4<f32>(s.weight, 0.0);
}
