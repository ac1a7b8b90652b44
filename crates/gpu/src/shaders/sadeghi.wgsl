// The Sadeghi et al. 2013 cloth BRDF (scatter/src/sadeghi_2013.rs) in f32, in the local shading
// frame (z the normal, x the tangent along u): two thread families (warp along x, weft along
// y), each with its coverage α_j and tangent offsets ψ_k that tilt the thread's tangent and
// normal about the family's in-plane binormal. With M (masking) and P (projected area) the
// blends of the azimuths about the thread and of the angles in its (t, n) plane,
// f_r = Σ_j α_j ⟨P M f_s cosθ_o⟩_j / (Σ_j α_j ⟨P⟩_j + (1 − Σα_j) ω_o·z), f_s the thread's
// surface and volume lobes (eqs. 3–5). Sampled as on the CPU: half cosine-weighted, half a
// family by α_j, an offset uniformly, then the thread sampler (two Gaussians in θ through the
// pole taper and a cosθ/π² lobe, a third each) in that offset's frame; the pdf is the mixture's
// over the whole sphere.
//
// Words at `b` (32 per material): 0 kind, 10 the table's first word, 11 where a mesh's shading
// records start (relative to the table), 12 the mesh's first triangle, 19 1 when the surface has
// texture coordinates, 20–29 the textures of η, k_d, A, γ_s, γ_v of family 1 then family 2: 1 +
// their offset in the table (`texture_at`), 0 when untextured. The table holds the families, 25
// words each: 0 η, 1 k_d, 2–4 the albedo A, 5 γ_s, 6 γ_v, 7 α_j, 8 the number of offsets,
// 9 + 2k sinψ_k, 10 + 2k cosψ_k; then the textures.

const MATERIAL_SADEGHI: u32 = 10u;
const SADEGHI_FAMILY_WORDS: u32 = 25u;
/// Width of the blend between independent and correlated masking, 20°.
const SADEGHI_MASK_BLEND: f32 = 0.3490658503988659;

struct SadeghiThread {
    eta: f32,
    k_d: f32,
    albedo: vec3<f32>,
    gamma_s: f32,
    gamma_v: f32,
}

/// The first word of family j of the material at `b`.
fn sadeghi_family(b: u32, j: u32) -> u32 {
    return word_u(b + 10u) + SADEGHI_FAMILY_WORDS * j;
}

/// The cloth at one hit: its material's first word and its two threads' parameters there.
struct Sadeghi {
    b: u32,
    thread1: SadeghiThread,
    thread2: SadeghiThread,
}

/// Thread parameter `k` (η, k_d, A, γ_s, γ_v) of family j: word `at` of the family, or its
/// texture's value at uv.
fn sadeghi_param(b: u32, j: u32, k: u32, at: u32, uv: vec2<f32>, has_uv: bool) -> vec3<f32> {
    let t = word_u(b + 20u + 5u * j + k);
    if t != 0u && has_uv {
        return texture_at(word_u(b + 10u) + t - 1u, uv);
    }
    return word_v3(sadeghi_family(b, j) + at);
}

/// The material at `b`, its textured parameters read at uv where the surface has coordinates.
fn load_sadeghi(b: u32, uv: vec2<f32>, has_uv: bool) -> Sadeghi {
    return Sadeghi(b, sadeghi_load_thread(b, 0u, uv, has_uv), sadeghi_load_thread(b, 1u, uv, has_uv));
}

fn sadeghi_load_thread(b: u32, j: u32, uv: vec2<f32>, has_uv: bool) -> SadeghiThread {
    return SadeghiThread(
        sadeghi_param(b, j, 0u, 0u, uv, has_uv).x,
        sadeghi_param(b, j, 1u, 1u, uv, has_uv).x,
        sadeghi_param(b, j, 2u, 2u, uv, has_uv),
        sadeghi_param(b, j, 3u, 5u, uv, has_uv).x,
        sadeghi_param(b, j, 4u, 6u, uv, has_uv).x,
    );
}

/// Thread j's parameters (no array: a dynamically indexed one would live in memory).
fn sadeghi_thread(c: Sadeghi, j: u32) -> SadeghiThread {
    if j == 0u {
        return c.thread1;
    }
    return c.thread2;
}

/// The frame (columns t, n, t × n) of offset k of family j at word f: `v * m` is v in it.
fn sadeghi_frame(f: u32, j: u32, k: u32) -> mat3x3<f32> {
    let t0 = select(vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(1.0, 0.0, 0.0), j == 0u);
    let s = word_f(f + 9u + 2u * k);
    let c = word_f(f + 10u + 2u * k);
    let t = t0 * c + vec3<f32>(0.0, 0.0, s);
    let n = vec3<f32>(0.0, 0.0, c) - t0 * s;
    return mat3x3<f32>(t, n, cross(t, n));
}

/// The masking/shadowing blend of two angles measured from a thread's normal.
fn sadeghi_masking(a: f32, b: f32) -> f32 {
    let d = wrap_few_turns(a - b);
    let u = exp(-d * d / (2.0 * SADEGHI_MASK_BLEND * SADEGHI_MASK_BLEND));
    let ma = max(sin_cos_f(a).y, 0.0);
    let mb = max(sin_cos_f(b).y, 0.0);
    return (1.0 - u) * ma * mb + u * min(ma, mb);
}

/// The thread's f_s from the inclinations θ and their cosines in its fiber frame and the
/// difference of the azimuths (each angle computed once per offset by `sadeghi_eval`: lavapipe
/// compiles every inlined copy).
fn sadeghi_thread_value(th: SadeghiThread, theta_i: f32, ci: f32, theta_o: f32, co: f32, dphi: f32) -> vec3<f32> {
    let theta_h = 0.5 * (theta_i + theta_o);
    let cos_d = sin_cos_f(0.5 * (theta_i - theta_o)).y;
    let cos_half = max(sin_cos_f(0.5 * wrap_few_turns(dphi)).y, 0.0);
    let fr = fresnel_dielectric(cos_d * cos_half, th.eta);
    let surface = fr * cos_half * gaussian_f(th.gamma_s, theta_h);
    let ft = 1.0 - fr;
    let volume = ft * ft * ((1.0 - th.k_d) * gaussian_f(th.gamma_v, theta_h) + th.k_d) / max(ci + co, 1e-12);
    return (vec3<f32>(surface) + th.albedo * volume) / max(cos_d * cos_d, 1e-12);
}

/// The thread sampler's density per sr at θ_i (cosine ci) given θ_o: two Gaussian-in-θ lobes of
/// widths γ_s and γ_v about −θ_o through the pole taper, φ uniform, and cosθ_i/π², a third each.
fn sadeghi_thread_pdf(th: SadeghiThread, theta_i: f32, ci: f32, theta_o: f32) -> f32 {
    var lobes = ci / (PI * PI);
    let slope = taper_derivative(theta_i);
    // A loop, not two calls: one copy of the lobe's code in the kernel (lavapipe compiles it).
    for (var l = 0u; l < 2u; l++) {
        let sigma = select(th.gamma_v, th.gamma_s, l == 0u);
        // The interval [−π/2, π/2] holds the lobe's centre −θ_o: its mass is 1 less both tails.
        let mass = 1.0 - normal_cdf_f((-HALF_PI + theta_o) / sigma) - normal_sf_f((HALF_PI + theta_o) / sigma);
        if mass > 0.0 && slope > 0.0 {
            lobes += gaussian_f(sigma, taper(theta_i) + theta_o) / mass * slope / (TAU * max(ci, MIN_COS));
        }
    }
    return lobes / 3.0;
}

/// (f_r rgb, pdf) at ω_i for ω_o, both local.
fn sadeghi_eval(c: Sadeghi, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    let up = wi.z > 0.0 && wo.z > 0.0;
    let total = word_f(sadeghi_family(c.b, 0u) + 7u) + word_f(sadeghi_family(c.b, 1u) + 7u);
    var num = vec3<f32>(0.0);
    var area = 0.0;
    var thread_pdf = 0.0;
    for (var j = 0u; j < 2u; j++) {
        let f = sadeghi_family(c.b, j);
        let coverage = word_f(f + 7u);
        if coverage <= 0.0 {
            continue;
        }
        let th = sadeghi_thread(c, j);
        let count = word_u(f + 8u);
        var sum = vec3<f32>(0.0);
        var sum_p = 0.0;
        for (var k = 0u; k < count; k++) {
            let m = sadeghi_frame(f, j, k);
            let li = wi * m;
            let lo = wo * m;
            let ci = local_cos_theta(li);
            let co = local_cos_theta(lo);
            let theta_i = atan2_f(local_sin_theta(li), ci);
            let theta_o = atan2_f(local_sin_theta(lo), co);
            thread_pdf += coverage / (total * f32(count)) * sadeghi_thread_pdf(th, theta_i, ci, theta_o);
            if up {
                // P: angles from n in the (t, n) plane; M: azimuths about t from n.
                let phi_i = local_phi(li);
                let phi_o = local_phi(lo);
                let p = sadeghi_masking(atan2_f(li.x, li.y), atan2_f(lo.x, lo.y));
                let mm = sadeghi_masking(phi_i, phi_o);
                sum_p += p;
                if p * mm > 0.0 {
                    sum += sadeghi_thread_value(th, theta_i, ci, theta_o, co, phi_i - phi_o) * (p * mm * co);
                }
            }
        }
        num += sum * (coverage / f32(count));
        area += coverage * sum_p / f32(count);
    }
    var f = vec3<f32>(0.0);
    area += max(1.0 - total, 0.0) * wo.z;
    if up && area > 0.0 {
        f = num / area;
    }
    return vec4<f32>(f, 0.5 * max(wi.z, 0.0) / PI + 0.5 * thread_pdf);
}

/// A sample of ω_i (local) with u as the CPU's `sample` (u₀ picks the cosine or a thread lobe,
/// then the family, the offset and the thread's lobe). Directions below the surface come with
/// weight 0.
fn sadeghi_sample(c: Sadeghi, wo: vec3<f32>, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    if wo.z <= 0.0 {
        return out;
    }
    var wi: vec3<f32>;
    if u.x < 0.5 {
        wi = cosine_direction(u.y, u.z);
    } else {
        var x = (u.x - 0.5) / 0.5;
        let c0 = word_f(sadeghi_family(c.b, 0u) + 7u);
        let c1 = word_f(sadeghi_family(c.b, 1u) + 7u);
        let total = c0 + c1;
        var j = 1u;
        if x * total < c0 || c1 <= 0.0 {
            j = 0u;
            x = min(x * total / c0, 0.99999994);
        } else {
            x = min((x * total - c0) / c1, 0.99999994);
        }
        let f = sadeghi_family(c.b, j);
        let th = sadeghi_thread(c, j);
        let count = word_u(f + 8u);
        let k = min(u32(x * f32(count)), count - 1u);
        x = x * f32(count) - f32(k);
        let m = sadeghi_frame(f, j, k);
        let lo = wo * m;
        let phi_i = local_phi(lo) + PI * (2.0 * u.w - 1.0);
        var sc: vec2<f32>;
        if x < 2.0 / 3.0 {
            let sigma = select(th.gamma_v, th.gamma_s, x < 1.0 / 3.0);
            let mu = -atan2_f(local_sin_theta(lo), local_cos_theta(lo));
            let z = sample_truncated_normal_f(u.y, (-HALF_PI - mu) / sigma, (HALF_PI - mu) / sigma);
            sc = sin_cos_f(untaper(clamp(mu + sigma * z, -HALF_PI, HALF_PI)));
        } else {
            let s = sqrt(u.y) * sin_cos_f(TAU * u.z).y;
            sc = vec2<f32>(s, safe_sqrt(1.0 - s * s));
        }
        let p = sin_cos_f(phi_i);
        wi = normalize(m * vec3<f32>(sc.x, sc.y * p.y, sc.y * p.x));
    }
    let e = sadeghi_eval(c, wi, wo);
    if !(e.w > 0.0) || not_finite(e.w) {
        return out;
    }
    out.wi = wi;
    out.weight = e.xyz * (max(wi.z, 0.0) / e.w);
    out.pdf = e.w;
    return out;
}
