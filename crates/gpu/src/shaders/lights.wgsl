// Lights as render/src/light.rs has them: a constant environment, a sun (a disc of directions)
// and a delta distant light at infinity, and emitting spheres; the next-event picker's
// emitters in its order with their probabilities.
//
// Words: a light at infinity is 12 words at `light_base + 12 i`: kind, its picker probability,
// 0, 0 | radiance (or irradiance) rgb, cos_max | unit direction xyz, 1 − cos_max. A sphere is 12
// words at `sphere_base + 12 i`: centre, radius | emission rgb, material | emits (0/1), its
// picker probability, 0, 0. An emitter is 2 words at `emitter_base + 2 k`: kind (0: light at
// infinity, 1: sphere), index.

const LIGHT_CONSTANT: u32 = 0u;
const LIGHT_SUN: u32 = 1u;
const LIGHT_DISTANT: u32 = 2u;
/// A lat-long environment map (render/src/light.rs, `EnvironmentMap`): words 7, 8 its width
/// and height, 9 where its data start (`scene_buffers.rs::environment_map_words`).
const LIGHT_MAP: u32 = 3u;
const INF: f32 = 3.4028235e38;

fn word_f(i: u32) -> f32 {
    return bitcast<f32>(scene_words[i]);
}

fn word_u(i: u32) -> u32 {
    return scene_words[i];
}

fn word_v3(i: u32) -> vec3<f32> {
    return vec3<f32>(word_f(i), word_f(i + 1u), word_f(i + 2u));
}

struct LightSample {
    wi: vec3<f32>,
    /// Distance to the emitting surface (INF at infinity).
    distance: f32,
    radiance: vec3<f32>,
    /// Density per steradian (1 for a delta light); ≤ 0: no sample.
    pdf: f32,
    delta: bool,
    /// The sphere aimed at (`prim_id`), NONE for lights at infinity.
    aim: u32,
}

/// A uniform direction in the cone around `axis` with 1 − cos of its half-angle `omc`.
fn sample_cone(axis: vec3<f32>, omc: f32, u: vec2<f32>) -> vec3<f32> {
    let x = u.x * omc;
    let cos_t = 1.0 - x;
    let sin_t = safe_sqrt(x * (2.0 - x));
    let b = orthonormal_pair(axis);
    let sc = sin_cos_f(TAU * u.y);
    return normalize(axis * cos_t + (b[0] * sc.y + b[1] * sc.x) * sin_t);
}

fn cone_pdf(omc: f32) -> f32 {
    return 1.0 / (TAU * omc);
}

fn light_kind(i: u32) -> u32 {
    return scene_words[params.light_base + 12u * i];
}

fn light_probability(i: u32) -> f32 {
    return word_f(params.light_base + 12u * i + 1u);
}

/// The map cell (x, y) of direction `d`: θ from +y down, φ = atan2(z, x) from −π.
fn map_cell(b: u32, d: vec3<f32>) -> vec2<u32> {
    let w = scene_words[b + 7u];
    let h = scene_words[b + 8u];
    let c = clamp(d.y, -1.0, 1.0);
    let theta = atan2_f(safe_sqrt((1.0 - c) * (1.0 + c)), c);
    let phi = atan2_f(d.z, d.x);
    let x = min(u32(max((phi + PI) / TAU * f32(w), 0.0)), w - 1u);
    let y = min(u32(max(theta / PI * f32(h), 0.0)), h - 1u);
    return vec2<u32>(x, y);
}

fn map_radiance(b: u32, d: vec3<f32>) -> vec3<f32> {
    let c = map_cell(b, d);
    return word_v3(scene_words[b + 9u] + 3u * (c.y * scene_words[b + 7u] + c.x));
}

/// Density per steradian of `map_sample` returning `d`: the cell's probability over its
/// solid angle (the cell's sinθ at its centre, as the CPU).
fn map_pdf(b: u32, d: vec3<f32>) -> f32 {
    let w = scene_words[b + 7u];
    let h = scene_words[b + 8u];
    let c = map_cell(b, d);
    let p_cell = word_f(scene_words[b + 9u] + 3u * w * h + c.y * w + c.x);
    let sin_theta = sin_cos_f(PI * (f32(c.y) + 0.5) / f32(h)).x;
    if !(p_cell > 0.0) || !(sin_theta > 0.0) {
        return 0.0;
    }
    return p_cell * f32(w * h) / (2.0 * PI * PI * sin_theta);
}

/// The cell i with c[i] ≤ v < c[i + 1] of the n + 1 values at `at` (empty cells skipped).
fn map_find(at: u32, n: u32, v: f32) -> u32 {
    var lo = 0u;
    var hi = n + 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if word_f(at + mid) <= v {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return clamp(lo, 1u, n) - 1u;
}

/// A direction drawn with density proportional to the map's luminance (× sinθ), uniform in
/// (u, v) within its cell; pdf 0 when the map is black.
fn map_sample(b: u32, u: vec2<f32>) -> vec4<f32> {
    let w = scene_words[b + 7u];
    let h = scene_words[b + 8u];
    let rows = scene_words[b + 9u] + 4u * w * h;
    if !(word_f(rows + h) > 0.0) {
        return vec4<f32>(0.0);
    }
    let y = map_find(rows, h, u.x);
    let fy = clamp((u.x - word_f(rows + y)) / (word_f(rows + y + 1u) - word_f(rows + y)), 0.0, 1.0);
    let row = rows + h + 1u + y * (w + 1u);
    let x = map_find(row, w, u.y);
    let fx = clamp((u.y - word_f(row + x)) / (word_f(row + x + 1u) - word_f(row + x)), 0.0, 1.0);
    // Away from the cell's edges so that the direction maps back to the same cell in f32.
    let uu = (f32(x) + clamp(fx, 1e-4, 1.0 - 1e-4)) / f32(w);
    let vv = (f32(y) + clamp(fy, 1e-4, 1.0 - 1e-4)) / f32(h);
    let st = sin_cos_f(PI * vv);
    let sp = sin_cos_f(TAU * uu - PI);
    let wi = vec3<f32>(st.x * sp.y, st.y, st.x * sp.x);
    return vec4<f32>(wi, map_pdf(b, wi));
}

/// Radiance from light `i` at infinity along the escaping direction `d`.
fn light_escaped(i: u32, d: vec3<f32>) -> vec3<f32> {
    let b = params.light_base + 12u * i;
    let kind = scene_words[b];
    let radiance = word_v3(b + 4u);
    if kind == LIGHT_CONSTANT {
        return radiance;
    }
    if kind == LIGHT_SUN && dot(d, word_v3(b + 8u)) >= word_f(b + 7u) {
        return radiance;
    }
    if kind == LIGHT_MAP {
        return map_radiance(b, d);
    }
    return vec3<f32>(0.0);
}

/// Density per steradian with which light `i` is sampled in direction `wi`.
fn light_pdf(i: u32, wi: vec3<f32>) -> f32 {
    let b = params.light_base + 12u * i;
    let kind = scene_words[b];
    if kind == LIGHT_CONSTANT {
        return 1.0 / (4.0 * PI);
    }
    if kind == LIGHT_SUN && dot(wi, word_v3(b + 8u)) >= word_f(b + 7u) {
        return cone_pdf(word_f(b + 11u));
    }
    if kind == LIGHT_MAP {
        return map_pdf(b, wi);
    }
    return 0.0;
}

fn light_sample(i: u32, u: vec2<f32>) -> LightSample {
    let b = params.light_base + 12u * i;
    let kind = scene_words[b];
    var s: LightSample;
    s.distance = INF;
    s.radiance = word_v3(b + 4u);
    s.delta = false;
    s.aim = NONE;
    if kind == LIGHT_CONSTANT {
        let z = 1.0 - 2.0 * u.x;
        let r = safe_sqrt(1.0 - z * z);
        let sc = sin_cos_f(TAU * u.y);
        s.wi = vec3<f32>(r * sc.y, z, r * sc.x);
        s.pdf = 1.0 / (4.0 * PI);
    } else if kind == LIGHT_SUN {
        let omc = word_f(b + 11u);
        s.wi = sample_cone(word_v3(b + 8u), omc, u);
        s.pdf = cone_pdf(omc);
    } else if kind == LIGHT_MAP {
        let m = map_sample(b, u);
        s.wi = m.xyz;
        s.pdf = m.w;
        s.radiance = map_radiance(b, m.xyz);
    } else {
        s.wi = word_v3(b + 8u);
        s.pdf = 1.0;
        s.delta = true;
    }
    return s;
}

fn sphere_emission(i: u32) -> vec3<f32> {
    return word_v3(params.sphere_base + 12u * i + 4u);
}

fn sphere_material(i: u32) -> u32 {
    return scene_words[params.sphere_base + 12u * i + 7u];
}

fn sphere_emits(i: u32) -> bool {
    return scene_words[params.sphere_base + 12u * i + 8u] != 0u;
}

fn sphere_probability(i: u32) -> f32 {
    return word_f(params.sphere_base + 12u * i + 9u);
}

/// 1 − cos of the half-angle of the cone sphere `i` subtends from `p` (≤ 0: `p` is inside).
fn sphere_cone(i: u32, p: vec3<f32>) -> f32 {
    let to = sphere_center(i) - p;
    let d2 = dot(to, to);
    let r = sphere_radius(i);
    if d2 <= r * r {
        return 0.0;
    }
    let s2 = r * r / d2;
    return s2 / (1.0 + safe_sqrt(1.0 - s2));
}

fn sphere_light_pdf(i: u32, p: vec3<f32>, wi: vec3<f32>) -> f32 {
    let omc = sphere_cone(i, p);
    if omc <= 0.0 {
        return 0.0;
    }
    if dot(wi, normalize(sphere_center(i) - p)) >= 1.0 - omc {
        return cone_pdf(omc);
    }
    return 0.0;
}

fn sphere_light_sample(i: u32, p: vec3<f32>, u: vec2<f32>) -> LightSample {
    var s: LightSample;
    s.pdf = 0.0;
    s.delta = false;
    let omc = sphere_cone(i, p);
    if omc <= 0.0 {
        return s;
    }
    let c = sphere_center(i);
    s.wi = sample_cone(normalize(c - p), omc, u);
    let t = hit_sphere(c, sphere_radius(i), p, s.wi, 0.0, INF, false);
    if t < 0.0 {
        return s;
    }
    s.distance = t;
    s.radiance = sphere_emission(i);
    s.pdf = cone_pdf(omc);
    s.aim = prim_id(KIND_SPHERE, i);
    return s;
}

/// The emitter chosen by `u` (index into the emitter list) and its probability; `.y` ≤ 0 when
/// there is none (light/sphere probabilities as the CPU picker computed them).
fn pick_emitter(u: f32) -> vec2<f32> {
    var acc = 0.0;
    var last = -1;
    for (var k = 0u; k < params.emitter_count; k++) {
        let p = emitter_probability(k);
        acc += p;
        if p > 0.0 {
            last = i32(k);
            if u < acc {
                return vec2<f32>(f32(k), p);
            }
        }
    }
    if last >= 0 {
        return vec2<f32>(f32(last), emitter_probability(u32(last)));
    }
    return vec2<f32>(0.0, 0.0);
}

fn emitter_probability(k: u32) -> f32 {
    let b = params.emitter_base + 2u * k;
    let index = scene_words[b + 1u];
    if scene_words[b] == 0u {
        return light_probability(index);
    }
    return sphere_probability(index);
}

fn sample_emitter(k: u32, p: vec3<f32>, u: vec2<f32>) -> LightSample {
    let b = params.emitter_base + 2u * k;
    let index = scene_words[b + 1u];
    if scene_words[b] == 0u {
        return light_sample(index, u);
    }
    return sphere_light_sample(index, p, u);
}
