// Huang, Hullin & Hanika 2022 microfacet hair (scatter/src/huang_2022.rs) in f32, near-field:
// an elliptical dielectric fiber whose surface is a GGX distribution about the cuticle-tilted
// mesonormal. R by Walter et al. 2007's microfacet BRDF; TT and TRT along the CPU's lattice of
// entry microfacets (Heitz 2018's visible normals, shifted by a function of h) with one internal
// reflection each, chords across the ellipse and the closed-form rough exit; TRRT+ as the CPU's
// geometric series over the inside interface's albedo table (copied) spread by d'Eon's M.
// Sampled as on the CPU: a lobe by expected power, R by visible normals, TT/TRT by one path
// (∝ its share) and a GGX lobe about its smooth exit, TRRT+ by M mixed with the uniform sphere;
// the pdf is the mixture's. Nothing is stored per path: a walk over the lattice sums what one
// direction needs (eval: one walk; sample: the totals, the chosen path, the eval).
//
// Words at `b` (32 per material): 0 kind, 1 η, 2–4 σ_a, 5 GGX α, 6 aspect b, 7–8 (cos ψ, sin ψ),
// 9 flags (1: orientation `average`), 10 the table's first word, 11–12 (sin, cos) of the tilt,
// 13 mean chord, 14 mean half-width, 15–17 multipliers (R, TT, TRT), 18–20 TRRT+'s M (v,
// 1/(v(1 − e^{−2/v})), e^{−2/v} − 1), 21 entry lattice side, 22–23 R2's step, 24 residual
// floor, 25 uniform share, 26 the offsets Ē_R, Ē_T average (the CPU's 16: read, not a
// constant, so that lavapipe's compiler keeps the loop rolled — unrolled it cost 9 s of CPU per
// kernel compilation). The table: the five h-shifts' rates split as (r₁, r₂, fract(2r)) so
// that fract((h + 2)·rate) keeps f32 precision (r₁ with 11 bits, products exact), then E_R and
// E_T of the inside interface at HUANG_NODES equally spaced μ.

const MATERIAL_HUANG: u32 = 14u;
const HUANG_FLAG_AVERAGE: u32 = 1u;
const HUANG_NODES: u32 = 33u;

struct Huang {
    eta: f32,
    sigma_a: vec3<f32>,
    alpha: f32,
    aspect: f32,
    psi: vec2<f32>,
    flags: u32,
    table: u32,
    tilt: vec2<f32>,
    mean_chord: f32,
    mean_half_width: f32,
    mult: vec3<f32>,
    res_v: f32,
    res_inv_norm: f32,
    res_expm1: f32,
    side: u32,
    /// Offsets averaged across chords (TRRT+).
    chord_offsets: u32,
    r2: vec2<f32>,
    residual_floor: f32,
    uniform_share: f32,
}

fn load_huang(b: u32) -> Huang {
    var m: Huang;
    m.eta = word_f(b + 1u);
    m.sigma_a = vec3<f32>(word_f(b + 2u), word_f(b + 3u), word_f(b + 4u));
    m.alpha = word_f(b + 5u);
    m.aspect = word_f(b + 6u);
    m.psi = vec2<f32>(word_f(b + 7u), word_f(b + 8u));
    m.flags = word_u(b + 9u);
    m.table = word_u(b + 10u);
    m.tilt = vec2<f32>(word_f(b + 11u), word_f(b + 12u));
    m.mean_chord = word_f(b + 13u);
    m.mean_half_width = word_f(b + 14u);
    m.mult = vec3<f32>(word_f(b + 15u), word_f(b + 16u), word_f(b + 17u));
    m.res_v = word_f(b + 18u);
    m.res_inv_norm = word_f(b + 19u);
    m.res_expm1 = word_f(b + 20u);
    m.side = word_u(b + 21u);
    m.chord_offsets = word_u(b + 26u);
    m.r2 = vec2<f32>(word_f(b + 22u), word_f(b + 23u));
    m.residual_floor = word_f(b + 24u);
    m.uniform_share = word_f(b + 25u);
    return m;
}

/// fract((h + 2)·rate_k) for f32 h: h split by its bits into 12 + 12 significant bits, each
/// product with r₁ exact, the rest small.
fn huang_shift(m: Huang, k: u32, h: f32) -> f32 {
    let r1 = word_f(m.table + k);
    let r2 = word_f(m.table + 5u + k);
    let h1 = bitcast<f32>(bitcast<u32>(h) & 0xfffff000u);
    let h2 = h - h1;
    return fract(fract(h1 * r1) + h2 * r1 + h * r2 + word_f(m.table + 10u + k));
}

/// The inside interface's E_R (`which` 0) or E_T (1) at μ, interpolated linearly.
fn huang_albedo(m: Huang, which: u32, mu: f32) -> f32 {
    let x = clamp(mu, 0.0, 1.0) * f32(HUANG_NODES - 1u);
    let k = min(u32(x), HUANG_NODES - 2u);
    let t = x - f32(k);
    let at = m.table + 15u + which * HUANG_NODES + k;
    return word_f(at) * (1.0 - t) + word_f(at + 1u) * t;
}

/// GGX D of the normal `mh` about the axis `n` (0 below the surface), with 1 − cos² as
/// |mh × n|²: no cancellation at the peak of a narrow lobe (α = 0.01 puts it within 10⁻⁴ of
/// cos = 1, where f32's 1 − cos² would be 10⁻³ off).
fn huang_d(alpha: f32, mh: vec3<f32>, n: vec3<f32>) -> f32 {
    let c = dot(mh, n);
    if c <= 0.0 {
        return 0.0;
    }
    let x = cross(mh, n);
    let a2 = alpha * alpha;
    let t = dot(x, x) + c * c * a2;
    return a2 / (PI * t * t);
}

/// A visible normal of GGX about the unit axis `n` for the viewer `v`.
fn huang_visible_normal(alpha: f32, n: vec3<f32>, v: vec3<f32>, u1: f32, u2: f32) -> vec3<f32> {
    let f = orthonormal_pair(n);
    let l = ggx_sample_visible(alpha, vec3<f32>(dot(v, f[0]), dot(v, f[1]), dot(v, n)), u1, u2);
    return f[0] * l.x + f[1] * l.y + n * l.z;
}

/// Refraction of `d` through the normal `n` (relative index `eta`); w < 0 where it is total
/// internal reflection.
fn huang_refract(d: vec3<f32>, n: vec3<f32>, eta: f32) -> vec4<f32> {
    let cos_i = -dot(d, n);
    let sin2_t = eta * eta * max(1.0 - cos_i * cos_i, 0.0);
    if sin2_t >= 1.0 {
        return vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    return vec4<f32>(normalize(d * eta + n * (eta * cos_i - sqrt(1.0 - sin2_t))), 1.0);
}

// The ellipse of semi-axes 1 (along a = (cos ψ, sin ψ)) and b (scatter/src/hair/ellipse.rs).

fn huang_unit(a: vec2<f32>, b: f32, x: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(dot(x, a), (x.y * a.x - x.x * a.y) / b);
}

fn huang_half_width(a: vec2<f32>, b: f32, t: vec2<f32>) -> f32 {
    let e = vec2<f32>(t.y, -t.x);
    let ea = dot(e, a);
    let eb = e.x * a.y - e.y * a.x;
    return sqrt(ea * ea + b * b * eb * eb);
}

fn huang_normal(a: vec2<f32>, b: f32, p: vec2<f32>) -> vec2<f32> {
    return normalize(a * dot(p, a) + vec2<f32>(-a.y, a.x) * ((p.y * a.x - p.x * a.y) / (b * b)));
}

/// Where the chord from the boundary point `p` along `d` (unnormalized) leaves: (q, s) with
/// s the distance in units of d (≤ 0: none).
fn huang_exit(a: vec2<f32>, b: f32, p: vec2<f32>, d: vec2<f32>) -> vec3<f32> {
    let up = huang_unit(a, b, p);
    let ud = huang_unit(a, b, d);
    let qa = dot(ud, ud);
    if qa <= 0.0 {
        return vec3<f32>(0.0);
    }
    let qb = dot(up, ud);
    let s = (safe_sqrt(qb * qb - qa * (dot(up, up) - 1.0)) - qb) / qa;
    return vec3<f32>(p + d * s, s);
}

/// The fiber at one hit (fixed ω_o, h) without its paths.
struct HuangVertex {
    visible: bool,
    wo: vec3<f32>,
    sin_o: f32,
    cos_theta_o: f32,
    n_macro: vec3<f32>,
    n_meso: vec3<f32>,
    /// ω_o·m₁ and Λ(ω_o).
    cos_o: f32,
    lambda_o: f32,
    /// Orientation-average weight.
    scale: f32,
    /// The ellipse's major axis, the entry point, the lattice shifts.
    axis: vec2<f32>,
    entry: vec2<f32>,
    shift: vec4<f32>,
}

/// The mesonormal (y, z part of its 3D form, times cos α) of the outward normal `n`.
fn huang_meso(m: Huang, n: vec2<f32>) -> vec3<f32> {
    return vec3<f32>(-m.tilt.x, m.tilt.y * n.x, m.tilt.y * n.y);
}

fn huang_at_vertex(m: Huang, wo0: vec3<f32>, h0: f32) -> HuangVertex {
    var v: HuangVertex;
    var wo = wo0;
    var t = vec2<f32>(1.0, 0.0);
    let len = length(wo.yz);
    if len > 0.0 {
        t = wo.yz / len;
    }
    // On the axis: the nearest direction with cosθ_o = MIN_COS, as on the CPU.
    if local_cos_theta(wo) < MIN_COS {
        wo = vec3<f32>(select(1.0, -1.0, wo.x < 0.0), MIN_COS * t.x, MIN_COS * t.y);
    }
    v.wo = wo;
    v.sin_o = local_sin_theta(wo);
    v.cos_theta_o = local_cos_theta(wo);
    v.visible = false;
    v.scale = 1.0;
    var h = 0.0;
    if !not_finite(h0) {
        h = clamp(h0, -1.0, 1.0);
    }
    v.shift = vec4<f32>(huang_shift(m, 0u, h), huang_shift(m, 1u, h), huang_shift(m, 2u, h), huang_shift(m, 3u, h));
    v.axis = m.psi;
    if (m.flags & HUANG_FLAG_AVERAGE) != 0u {
        let sc = sin_cos_f(PI * huang_shift(m, 4u, h));
        v.axis = vec2<f32>(sc.y, sc.x);
        v.scale = huang_half_width(v.axis, m.aspect, t) / m.mean_half_width;
    }
    let b = m.aspect;
    // The entry point at offset h across the projected width (Ellipse::entry).
    let e = vec2<f32>(t.y, -t.x);
    let o = e * (h * huang_half_width(v.axis, b, t));
    let uo = huang_unit(v.axis, b, o);
    let ut = huang_unit(v.axis, b, t);
    let qa = dot(ut, ut);
    let qb = dot(uo, ut);
    let s = safe_sqrt(qb * qb - qa * (dot(uo, uo) - 1.0)) / qa - qb / qa;
    v.entry = o + t * s;
    let n1 = huang_normal(v.axis, b, v.entry);
    v.n_macro = vec3<f32>(0.0, n1.x, n1.y);
    v.n_meso = huang_meso(m, n1);
    v.cos_o = dot(wo, v.n_meso);
    if v.cos_o <= 0.0 || dot(wo, v.n_macro) <= 0.0 {
        return v;
    }
    v.visible = true;
    v.lambda_o = ggx_lambda(m.alpha, v.cos_o);
    return v;
}

/// What a walk over the lattice of paths sums for one light direction.
struct HuangSums {
    /// Σ weight × exit density of TT and TRT paths.
    g_tt: vec3<f32>,
    g_trt: vec3<f32>,
    /// TRRT+'s power.
    residual: vec3<f32>,
    /// Σ shares (TT, TRT) and Σ share·D(ω_i·s)(ω_i·s).
    share: vec2<f32>,
    density: vec2<f32>,
    /// The path chosen by the walk's target (its lobe's cumulative share).
    axis: vec3<f32>,
}

/// One internal path arriving at its exit point (reversed travel direction `dv`, outward
/// mesonormal `meso`, macro normal `n_out`, throughput `w`): adds its exit density at `wi` and
/// its sampling share to lobe `lobe` (0 TT, 1 TRT) of `s`; returns its share.
fn huang_exit_path(m: Huang, s: ptr<function, HuangSums>, lobe: u32, dv: vec3<f32>, meso: vec3<f32>, n_out: vec3<f32>, w: vec3<f32>, wi: vec3<f32>) -> vec4<f32> {
    let n_in = -meso;
    let cos_v = dot(dv, n_in);
    let r = huang_refract(-dv, n_in, m.eta);
    var axis = r.xyz;
    if r.w < 0.0 {
        let along = -dv + n_in * cos_v;
        let l = length(along);
        var a = meso * m.alpha;
        if l > 0.0 {
            a += along / l;
        }
        let la = length(a);
        axis = select(meso, a / la, la > 0.0 && !not_finite(la));
    }
    let share = luminance(w) * huang_albedo(m, 1u, cos_v);
    let lambda_v = ggx_lambda(m.alpha, cos_v);
    // The closed-form rough exit: (1 − F(v·m))·D(m)·G₂·(v·m)|ω_i·m|/((v·n)·|ηv + ω_i|²).
    var density = 0.0;
    let cos_out = -dot(wi, n_in);
    let hv = dv * m.eta + wi;
    let len = length(hv);
    if cos_out > 0.0 && dot(wi, n_out) > 0.0 && len > 0.0 {
        let mh = hv / len;
        let vm = dot(dv, mh);
        let im = dot(wi, mh);
        let cos_m = dot(mh, n_in);
        if vm > 0.0 && im < 0.0 && cos_m > 0.0 {
            let g2 = 1.0 / (1.0 + lambda_v + ggx_lambda(m.alpha, cos_out));
            density = (1.0 - fresnel_dielectric(vm, 1.0 / m.eta)) * huang_d(m.alpha, mh, n_in) * g2 * vm * -im / (cos_v * len * len);
        }
    }
    let c = dot(wi, axis);
    if lobe == 0u {
        (*s).g_tt += w * density;
    } else {
        (*s).g_trt += w * density;
    }
    if share > 0.0 {
        (*s).share[lobe] += share;
        (*s).density[lobe] += share * huang_d(m.alpha, wi, axis) * max(c, 0.0);
    }
    return vec4<f32>(axis, share);
}

/// The walk over the entry lattice (scatter's `Huang::prepare`): every TT and TRT path's
/// contribution at `wi`, the TRRT+ power, and the path of lobe `pick` (1 TT, 2 TRT; 0 none)
/// where the cumulative share passes `goal`.
fn huang_walk(m: Huang, v: HuangVertex, wi: vec3<f32>, pick: u32, goal: f32) -> HuangSums {
    var s: HuangSums;
    s.g_tt = vec3<f32>(0.0);
    s.g_trt = vec3<f32>(0.0);
    s.residual = vec3<f32>(0.0);
    s.share = vec2<f32>(0.0);
    s.density = vec2<f32>(0.0);
    s.axis = vec3<f32>(0.0);
    var acc = 0.0;
    var found = false;
    let n = m.side;
    let inv_eta = 1.0 / m.eta;
    let entry_weight = 1.0 / f32(n * n);
    let b = m.aspect;
    for (var k = 0u; k < n * n; k++) {
        let i = k / n;
        let j = k % n;
        let mh = huang_visible_normal(m.alpha, v.n_meso, v.wo, (f32(i) + v.shift.x) / f32(n), (f32(j) + v.shift.y) / f32(n));
        let c1 = dot(v.wo, mh);
        if c1 <= 0.0 {
            continue;
        }
        let r1 = huang_refract(-v.wo, mh, inv_eta);
        let d1 = r1.xyz;
        if r1.w < 0.0 || dot(d1, v.n_meso) >= 0.0 || dot(d1, v.n_macro) >= 0.0 {
            continue;
        }
        let w1 = (1.0 - fresnel_dielectric(c1, m.eta)) * (1.0 + v.lambda_o)
            / (1.0 + v.lambda_o + ggx_lambda(m.alpha, dot(d1, v.n_meso))) * entry_weight;
        let x2 = huang_exit(v.axis, b, v.entry, d1.yz);
        if x2.z <= 0.0 {
            continue;
        }
        let n2 = huang_normal(v.axis, b, x2.xy);
        let n2_3 = vec3<f32>(0.0, n2.x, n2.y);
        let m2 = huang_meso(m, n2);
        if dot(d1, m2) <= 0.0 || dot(d1, n2_3) <= 0.0 {
            continue;
        }
        let w_tt = exp(-m.sigma_a * x2.z) * w1;
        let tt = huang_exit_path(m, &s, 0u, -d1, m2, n2_3, w_tt, wi);
        if pick == 1u && !found && tt.w > 0.0 {
            acc += tt.w;
            s.axis = tt.xyz;
            found = goal < acc;
        }
        // TRT: one rough internal reflection at p₂, its microfacet along the R2 sequence.
        let e = f32(k) + 0.5;
        let mr = huang_visible_normal(m.alpha, -m2, -d1, fract(v.shift.z + e * m.r2.x), fract(v.shift.w + e * m.r2.y));
        let c2 = -dot(d1, mr);
        if c2 <= 0.0 {
            continue;
        }
        let d2 = reflect(d1, mr);
        let c2_out = dot(d2, m2);
        if c2_out >= 0.0 || dot(d2, n2_3) >= 0.0 {
            continue;
        }
        let lambda_v2 = ggx_lambda(m.alpha, dot(d1, m2));
        let w2 = fresnel_dielectric(c2, inv_eta) * (1.0 + lambda_v2) / (1.0 + lambda_v2 + ggx_lambda(m.alpha, c2_out));
        let x3 = huang_exit(v.axis, b, x2.xy, d2.yz);
        if x3.z <= 0.0 {
            continue;
        }
        let n3 = huang_normal(v.axis, b, x3.xy);
        let n3_3 = vec3<f32>(0.0, n3.x, n3.y);
        let m3 = huang_meso(m, n3);
        if dot(d2, m3) <= 0.0 || dot(d2, n3_3) <= 0.0 {
            continue;
        }
        let w_trt = w_tt * exp(-m.sigma_a * x3.z) * w2;
        let trt = huang_exit_path(m, &s, 1u, -d2, m3, n3_3, w_trt, wi);
        if pick == 2u && !found && trt.w > 0.0 {
            acc += trt.w;
            s.axis = trt.xyz;
            found = goal < acc;
        }
        // TRRT+: E_R at p₃, then E_R·A·Ē_T/(1 − A·Ē_R) over the mean chords.
        let cos_d2 = length(d2.yz);
        var next = vec2<f32>(0.0);
        for (var q = 0u; q < m.chord_offsets; q++) {
            let x = (f32(q) + 0.5) / f32(m.chord_offsets);
            let mu = cos_d2 * sqrt(1.0 - x * x);
            next += vec2<f32>(huang_albedo(m, 0u, mu), huang_albedo(m, 1u, mu));
        }
        next /= f32(m.chord_offsets);
        let a = exp(-m.sigma_a * (m.mean_chord / max(cos_d2, MIN_COS)));
        let escapes = a * next.y / max(1.0 - a * next.x, vec3<f32>(1e-12));
        s.residual += w_trt * escapes * huang_albedo(m, 0u, dot(d2, m3));
    }
    return s;
}

/// The sampling components' probabilities (R, TT, TRT, TRRT+/uniform).
fn huang_lobe_prob(m: Huang, v: HuangVertex, s: HuangSums) -> vec4<f32> {
    let e = vec4<f32>(m.mult.x * fresnel_dielectric(v.cos_o, m.eta), m.mult.y * s.share.x, m.mult.z * s.share.y, luminance(s.residual));
    let total = e.x + e.y + e.z + e.w;
    if total > 0.0 {
        return e * ((1.0 - m.residual_floor) / total) + vec4<f32>(0.0, 0.0, 0.0, m.residual_floor);
    }
    return vec4<f32>(0.0, 0.0, 0.0, 1.0);
}

/// (f_s, pdf) at `wi` from the walk's sums at `wi`.
fn huang_finish(m: Huang, v: HuangVertex, s: HuangSums, wi: vec3<f32>) -> vec4<f32> {
    if !v.visible {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0 / (4.0 * PI));
    }
    let q = huang_lobe_prob(m, v, s);
    var g = s.g_tt * m.mult.y + s.g_trt * m.mult.z;
    var pdf = 0.0;
    // R: Walter's BRDF times ω_i·m₁, and its visible-normal density.
    let hv = v.wo + wi;
    let len = length(hv);
    if len > 0.0 {
        let mh = hv / len;
        let d = huang_d(m.alpha, mh, v.n_meso);
        let cos_i = dot(wi, v.n_meso);
        if cos_i > 0.0 && dot(wi, v.n_macro) > 0.0 {
            let g2 = 1.0 / (1.0 + v.lambda_o + ggx_lambda(m.alpha, cos_i));
            g += vec3<f32>(fresnel_dielectric(dot(v.wo, mh), m.eta) * d * g2 / (4.0 * v.cos_o) * m.mult.x);
        }
        pdf += q.x * d / ((1.0 + v.lambda_o) * 4.0 * v.cos_o);
    }
    if s.share.x > 0.0 {
        pdf += q.y * s.density.x / s.share.x;
    }
    if s.share.y > 0.0 {
        pdf += q.z * s.density.y / s.share.y;
    }
    let ci = local_cos_theta(wi);
    let mres = longitudinal(m.res_v, m.res_inv_norm, local_sin_theta(wi), ci, v.sin_o, v.cos_theta_o) / TAU;
    g += s.residual * mres;
    pdf += q.w * ((1.0 - m.uniform_share) * mres + m.uniform_share / (4.0 * PI));
    return vec4<f32>(g * v.scale / max(ci, MIN_COS), pdf);
}

/// (f_s, pdf) for the local light direction `wi`.
fn huang_eval(m: Huang, v: HuangVertex, wi: vec3<f32>) -> vec4<f32> {
    if !v.visible {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0 / (4.0 * PI));
    }
    return huang_finish(m, v, huang_walk(m, v, wi, 0u, 0.0), wi);
}

/// A uniform direction on the sphere.
fn huang_uniform(u1: f32, u2: f32) -> vec3<f32> {
    let z = 2.0 * u1 - 1.0;
    let c = safe_sqrt(1.0 - z * z);
    let sc = sin_cos_f(TAU * u2);
    return vec3<f32>(z, c * sc.y, c * sc.x);
}

/// Three walks at most, one call site: the totals (which lobe), the chosen path (TT, TRT),
/// the value and pdf at the drawn direction.
fn huang_sample(m: Huang, v: HuangVertex, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    if !v.visible {
        out.wi = huang_uniform(u.y, u.z);
        out.weight = vec3<f32>(0.0);
        out.pdf = 1.0 / (4.0 * PI);
        return out;
    }
    var pick = 0u;
    var goal = 0.0;
    var wi = vec3<f32>(0.0);
    for (var stage = 0u; stage < 3u; stage++) {
        let s = huang_walk(m, v, wi, pick, goal);
        if stage == 0u {
            let q = huang_lobe_prob(m, v, s);
            var lobe = 3u;
            var lo = 1.0 - q.w;
            var acc = 0.0;
            for (var k = 0u; k < 4u; k++) {
                if q[k] > 0.0 && u.x < acc + q[k] {
                    lobe = k;
                    lo = acc;
                    break;
                }
                acc += q[k];
            }
            let u0 = clamp((u.x - lo) / q[lobe], 0.0, 1.0 - 6e-8);
            if lobe == 1u || lobe == 2u {
                pick = lobe;
                goal = u0 * s.share[lobe - 1u];
                continue;
            }
            if lobe == 0u {
                wi = reflect(-v.wo, huang_visible_normal(m.alpha, v.n_meso, v.wo, u.y, u.z));
            } else if u0 < m.uniform_share {
                wi = huang_uniform(u.y, u.z);
            } else {
                let si = longitudinal_sample_sin(m.res_v, m.res_expm1, v.sin_o, v.cos_theta_o, u.y, u.z);
                let sc = sin_cos_f(TAU * u.w);
                let ci = safe_sqrt(1.0 - si * si);
                wi = vec3<f32>(si, ci * sc.y, ci * sc.x);
            }
            stage = 1u;
        } else if stage == 1u {
            // A GGX lobe about the chosen path's smooth exit: tan²θ = α²u/(1 − u).
            let a2 = m.alpha * m.alpha;
            let cos2 = (1.0 - u.y) / (1.0 + (a2 - 1.0) * u.y);
            let c = sqrt(cos2);
            let sn = safe_sqrt(1.0 - cos2);
            let f = orthonormal_pair(s.axis);
            let sc = sin_cos_f(TAU * u.z);
            wi = normalize(s.axis * c + f[0] * (sn * sc.y) + f[1] * (sn * sc.x));
        } else {
            let e = huang_finish(m, v, s, wi);
            if not_finite(e.w) || e.w <= 0.0 {
                return out;
            }
            out.wi = wi;
            out.weight = e.xyz * (local_cos_theta(wi) / e.w);
            out.pdf = e.w;
        }
    }
    return out;
}
