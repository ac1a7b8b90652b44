// The hollow fiber (scatter/src/hollow_fiber.rs, near field) in f32: Chiang's lobes (chiang.wgsl's
// longitudinal M_p, tilts and trimmed logistic, from the same constants) split into sub-lobes
// by the kinds of wall pass of a tube (scatter/src/hair/tube.rs): a pass misses the lumen,
// reflects off it, or crosses it along j = 1…3 chords, each kind with its Fresnel probability
// and turn; TT has one sub-lobe per kind, TRT one per unordered pair, the residual takes the
// rest with N = 1/(2π). Sampled as on the CPU: a sub-lobe by the luminance of its A, θ_i from
// M_p, φ from the logistic about its exit (uniform for the residual), evaluated at the angles
// of the direction returned.
//
// Words at `b` (32 per material): 0 kind, 1–28 as a Chiang material's (`load_chiang`), 29 the
// lumen's relative radius κ, 30 its index η_l, 31 the enabled lobes (bit p).

const MATERIAL_HOLLOW_FIBER: u32 = 13u;
/// Sub-lobes: R, TT per pass kind (4), TRT per unordered pair of kinds (10), the residual.
const HOLLOW_SUBLOBES: u32 = 16u;

/// The fiber at one path vertex (fixed ω_o and h): its wall-pass kinds and the A of the
/// sub-lobes per unit of their kinds' weights.
struct HollowVertex {
    /// Pass kinds listed (1 or 4), their probabilities and turns.
    kinds: u32,
    weight: vec4<f32>,
    turn: vec4<f32>,
    /// R's A (gray), TT's per unit weight, TRT's per unit weight product, the residual's.
    a0: f32,
    a1: vec3<f32>,
    a2: vec3<f32>,
    a3: vec3<f32>,
    /// Exit azimuths Φ(p, h) of the solid wall, p = 0, 1, 2.
    exit: vec3<f32>,
    /// Enabled lobes (bit p) and the sum of the enabled sub-lobes' luminances.
    lobes: u32,
    total: f32,
    tilted_sin: vec4<f32>,
    tilted_cos: vec4<f32>,
    phi_o: f32,
}

/// One sub-lobe: its lobe p (3: the residual), A and exit azimuth.
struct HollowSubLobe {
    p: u32,
    a: vec3<f32>,
    exit: f32,
}

fn hollow_at_vertex(m: Chiang, b: u32, wo: vec3<f32>, h0: f32) -> HollowVertex {
    var v: HollowVertex;
    let kappa = word_f(b + 29u);
    let lumen_eta = word_f(b + 30u);
    v.lobes = word_u(b + 31u);
    let sin_o = local_sin_theta(wo);
    let cos_o = local_cos_theta(wo);
    let h = clamp(h0, -1.0, 1.0);
    let f = fresnel_dielectric(cos_o * safe_sqrt(1.0 - h * h), m.eta);
    let inv_eta_prime = cos_o / sqrt(m.eta * m.eta - sin_o * sin_o);
    let st = sin_o / m.eta;
    let cos_theta_t = safe_sqrt(1.0 - st * st);
    // The wall passes (`Tube::passes`).
    let bb = h * inv_eta_prime;
    let inner = select(0.0, safe_sqrt(kappa * kappa - bb * bb), abs(bb) < kappa);
    let wall_length = 2.0 * (safe_sqrt(1.0 - bb * bb) - inner) / cos_theta_t;
    v.kinds = 1u;
    v.weight = vec4<f32>(1.0, 0.0, 0.0, 0.0);
    v.turn = vec4<f32>(0.0);
    var beyond = 0.0;
    let core_ratio = lumen_eta / m.eta;
    if abs(bb) < kappa && core_ratio != 1.0 {
        let sin_k = bb / kappa;
        let gamma_k = asin_f(sin_k);
        v.turn.x = PI - 2.0 * gamma_k;
        let d = (lumen_eta * lumen_eta - 1.0) + cos_o * cos_o;
        let inv_core = select(1.0, min(cos_o / sqrt(d), 1.0), d > 0.0);
        let sin_c = h * inv_core / kappa;
        let fc = fresnel_dielectric(cos_theta_t * safe_sqrt(1.0 - sin_k * sin_k), core_ratio);
        if abs(sin_c) < 1.0 && fc < 1.0 {
            let gamma_c = asin_f(sin_c);
            let cross = 2.0 * (gamma_c - gamma_k);
            let inside = 2.0 * gamma_c - PI;
            let w = (1.0 - fc) * (1.0 - fc);
            v.kinds = 4u;
            v.weight = vec4<f32>(fc, w, w * fc, w * fc * fc);
            v.turn = vec4<f32>(v.turn.x, cross, cross + inside, cross + 2.0 * inside);
            beyond = (1.0 - fc) * fc * fc * fc;
        }
    }
    let t = exp(-m.sigma_a * wall_length);
    let one_minus_f2 = (1.0 - f) * (1.0 - f);
    v.a0 = f;
    v.a1 = t * one_minus_f2;
    v.a2 = v.a1 * t * f;
    let ft = t * f;
    let tail = select(vec3<f32>(0.0), f * f * t * t * t / (1.0 - ft), ft < vec3<f32>(1.0));
    let pe = t * (1.0 - beyond);
    let bt = t * beyond;
    v.a3 = (bt + bt * (t + pe) * f + tail) * one_minus_f2;
    let gamma_o = asin_f(h);
    let gamma_t = asin_f(h * inv_eta_prime);
    v.exit = vec3<f32>(-2.0 * gamma_o, 2.0 * gamma_t - 2.0 * gamma_o + PI, 4.0 * gamma_t - 2.0 * gamma_o + 2.0 * PI);
    v.tilted_sin = sin_o * m.tilt_cos + cos_o * m.tilt_sin;
    v.tilted_cos = abs(cos_o * m.tilt_cos - sin_o * m.tilt_sin);
    v.phi_o = local_phi(wo);
    v.total = 0.0;
    for (var q = 0u; q < HOLLOW_SUBLOBES; q++) {
        v.total += luminance(hollow_sub_lobe(v, q).a);
    }
    return v;
}

/// Sub-lobe q: 0 R, 1–4 TT of pass kind q − 1, 5–14 TRT of the pairs k ≤ k′ in order, 15 the
/// residual; A = 0 where the kind is not listed or the lobe is off.
fn hollow_sub_lobe(v: HollowVertex, q: u32) -> HollowSubLobe {
    var s: HollowSubLobe;
    s.a = vec3<f32>(0.0);
    if q == 0u {
        s.p = 0u;
        s.a = vec3<f32>(v.a0);
        s.exit = v.exit.x;
    } else if q < 5u {
        let k = q - 1u;
        s.p = 1u;
        if k < v.kinds {
            s.a = v.a1 * v.weight[k];
        }
        s.exit = v.exit.y + v.turn[k];
    } else if q < 15u {
        // The pair (k, k′) of index q − 5 among k ≤ k′ < 4.
        var k = 0u;
        var r = q - 5u;
        while r >= 4u - k {
            r -= 4u - k;
            k += 1u;
        }
        let k2 = k + r;
        s.p = 2u;
        if k2 < v.kinds {
            s.a = v.a2 * (v.weight[k] * v.weight[k2] * select(2.0, 1.0, k == k2));
        }
        s.exit = v.exit.z + v.turn[k] + v.turn[k2];
    } else {
        s.p = 3u;
        s.a = v.a3;
        s.exit = 0.0;
    }
    if (v.lobes & (1u << s.p)) == 0u {
        s.a = vec3<f32>(0.0);
    }
    return s;
}

/// (Σ A_q M N rgb, Σ w_q M N): the per-h integrand and the pdf at (sinθ_i, cosθ_i, φ_i − φ_o).
fn hollow_integrand_and_pdf(m: Chiang, v: HollowVertex, sin_i: f32, cos_i: f32, dphi: f32) -> vec4<f32> {
    if v.total <= 0.0 {
        return vec4<f32>(0.0);
    }
    var mp: vec4<f32>;
    for (var p = 0u; p < 4u; p++) {
        mp[p] = longitudinal(m.v[p], m.inv_norm[p], sin_i, cos_i, v.tilted_sin[p], v.tilted_cos[p]);
    }
    var out = vec4<f32>(0.0);
    for (var q = 0u; q < HOLLOW_SUBLOBES; q++) {
        let s = hollow_sub_lobe(v, q);
        if max(s.a.x, max(s.a.y, s.a.z)) <= 0.0 {
            continue;
        }
        var n = 1.0 / TAU;
        if s.p < 3u {
            n = logistic(wrap_few_turns(dphi - s.exit), m.s) * m.logistic_norm;
        }
        let mn = mp[s.p] * n;
        out += vec4<f32>(s.a, luminance(s.a) / v.total) * mn;
    }
    return out;
}

/// (f_s, pdf) for the local light direction `wi`.
fn hollow_eval(m: Chiang, v: HollowVertex, wi: vec3<f32>) -> vec4<f32> {
    let cos_i = local_cos_theta(wi);
    let r = hollow_integrand_and_pdf(m, v, local_sin_theta(wi), cos_i, local_phi(wi) - v.phi_o);
    return vec4<f32>(r.xyz / max(cos_i, MIN_COS), r.w);
}

fn hollow_sample(m: Chiang, v: HollowVertex, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    if v.total <= 0.0 {
        return out;
    }
    // The sub-lobe: the first whose cumulative weight passes u₀ (the last one drawable).
    var chosen = HOLLOW_SUBLOBES;
    var acc = 0.0;
    for (var q = 0u; q < HOLLOW_SUBLOBES; q++) {
        let w = luminance(hollow_sub_lobe(v, q).a) / v.total;
        if w > 0.0 {
            chosen = q;
            acc += w;
            if u.x < acc {
                break;
            }
        }
    }
    let s = hollow_sub_lobe(v, chosen);
    let sin_d = sample_longitudinal(m, s.p, v.tilted_sin[s.p], v.tilted_cos[s.p], u.y, u.z);
    let cos_d = safe_sqrt(1.0 - sin_d * sin_d);
    var dphi = TAU * u.w;
    if s.p < 3u {
        dphi = s.exit + sample_trimmed_logistic(m, u.w);
    }
    let sc = sin_cos_f(v.phi_o + dphi);
    let wi = vec3<f32>(sin_d, cos_d * sc.y, cos_d * sc.x);
    // Evaluated at the angles of the direction returned, as the CPU's.
    let r = hollow_integrand_and_pdf(m, v, local_sin_theta(wi), local_cos_theta(wi), local_phi(wi) - v.phi_o);
    if not_finite(r.w) || r.w <= 0.0 {
        return out;
    }
    out.wi = wi;
    out.weight = r.xyz / r.w;
    out.pdf = r.w;
    return out;
}
