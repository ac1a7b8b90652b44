// The reference fibers of the course notes in f32, each as its CPU model (local fiber frame,
// ω = (sinθ, cosθ cosφ, cosθ sinφ), φ = φ_o − φ_i relative):
// * `diffuse` (scatter/src/ideal_diffuse.rs): f_s = ρ/π², ω_i drawn with density cosθ_i/π²;
// * `lambertian-cylinder` (scatter/src/lambertian_cylinder.rs): f_s = ρ g(φ)/(4π),
//   g(φ) = (π − |φ|)cosφ + sin|φ|, drawn exactly (an offset across the visible width, then the
//   cosine about the surface normal it hits), pdf cosθ_i g(φ)/(4π);
// * `specular` (scatter/src/ideal_specular.rs): a delta lobe on the cone θ_i = −θ_o, φ uniform
//   or a mirror cross-section's (φ = 2 asin(2ξ − 1)), optionally Fresnel-weighted;
// * `goldman` (scatter/src/goldman_1997.rs): Kajiya–Kay times the directional factor
//   ρ_r(1 + cosφ)/2 + ρ_t(1 − cosφ)/2; θ_i drawn as Kajiya–Kay's, φ with density
//   (a + b cosφ)/(2πa) (a, b the luminance mean and half-difference of ρ_r and ρ_t), inverted
//   by safeguarded Newton steps.
//
// Words at `b` (32 per material): 0 kind, 1–3 ρ (diffuse, cylinder) or ρ_r (goldman), 4–6 ρ_t,
// 7 a, 8 b, 9 η (specular; 0 when not Fresnel-weighted), 10 1 for the mirror azimuth (specular)
// or the first word of goldman's Kajiya–Kay table; goldman's Kajiya–Kay words from word 16 on
// (`kajiya_kay.wgsl`'s layout shifted by 16, its own table word unread).

const MATERIAL_DIFFUSE_FIBER: u32 = 20u;
const MATERIAL_LAMBERTIAN_CYLINDER: u32 = 21u;
const MATERIAL_SPECULAR_FIBER: u32 = 22u;
const MATERIAL_GOLDMAN: u32 = 23u;

fn is_reference_fiber(kind: u32) -> bool {
    return kind >= MATERIAL_DIFFUSE_FIBER && kind <= MATERIAL_GOLDMAN;
}

struct ReferenceFiber {
    kind: u32,
    rho: vec3<f32>,
    rho_t: vec3<f32>,
    a: f32,
    b: f32,
    eta: f32,
    mirror: bool,
    kk: KajiyaKay,
}

fn load_reference_fiber(b: u32) -> ReferenceFiber {
    var m: ReferenceFiber;
    m.kind = word_u(b);
    m.rho = vec3<f32>(word_f(b + 1u), word_f(b + 2u), word_f(b + 3u));
    m.rho_t = vec3<f32>(word_f(b + 4u), word_f(b + 5u), word_f(b + 6u));
    m.a = word_f(b + 7u);
    m.b = word_f(b + 8u);
    m.eta = word_f(b + 9u);
    m.mirror = word_u(b + 10u) != 0u;
    if m.kind == MATERIAL_GOLDMAN {
        m.kk = load_kajiya_kay(b + 16u);
        m.kk.table = word_u(b + 10u);
    }
    return m;
}

/// φ_o − φ_i wrapped to (−π, π].
fn relative_azimuth(wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    return wrap_few_turns(local_phi(wo) - local_phi(wi));
}

/// The Lambertian cylinder's azimuthal shape g(φ), with ∫g dφ = 8.
fn cylinder_azimuthal(phi: f32) -> f32 {
    let a = min(abs(phi), PI);
    let sc = sin_cos_f(a);
    return max((PI - a) * sc.y + sc.x, 0.0);
}

/// Goldman's directional factor at relative azimuth φ.
fn goldman_directional(m: ReferenceFiber, phi: f32) -> vec3<f32> {
    let k = sin_cos_f(phi).y;
    return m.rho * (0.5 * (1.0 + k)) + m.rho_t * (0.5 * (1.0 - k));
}

/// (f_s rgb, pdf) at ω_i for ω_o, both local (zero for the delta lobe).
fn reference_fiber_eval(m: ReferenceFiber, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    let cos_i = local_cos_theta(wi);
    if m.kind == MATERIAL_DIFFUSE_FIBER {
        return vec4<f32>(m.rho / (PI * PI), cos_i / (PI * PI));
    }
    if m.kind == MATERIAL_LAMBERTIAN_CYLINDER {
        let g = cylinder_azimuthal(relative_azimuth(wi, wo)) / (4.0 * PI);
        return vec4<f32>(m.rho * g, cos_i * g);
    }
    if m.kind == MATERIAL_GOLDMAN {
        if !(m.a > 0.0) {
            return vec4<f32>(0.0);
        }
        let phi = relative_azimuth(wi, wo);
        let kk = kk_eval(m.kk, wi, wo);
        let theta_i = atan2_f(local_sin_theta(wi), cos_i);
        let theta_o = atan2_f(local_sin_theta(wo), local_cos_theta(wo));
        let phi_pdf = (m.a + m.b * sin_cos_f(phi).y) / (TAU * m.a);
        let pdf = kk_theta_pdf(m.kk, theta_i, theta_o) * phi_pdf / max(cos_i, MIN_COS);
        return vec4<f32>(goldman_directional(m, phi) * kk.xyz, pdf);
    }
    return vec4<f32>(0.0);
}

/// Inverts Goldman's φ CDF `(a(φ + π) + b sinφ)/(2πa) = u` on [−π, π] (monotone: a ≥ |b|).
fn goldman_sample_phi(m: ReferenceFiber, u: f32) -> f32 {
    let goal = TAU * m.a * u;
    var lo = -PI;
    var hi = PI;
    var x = TAU * u - PI;
    for (var k = 0; k < 40; k++) {
        let sc = sin_cos_f(x);
        let g = m.a * (x + PI) + m.b * sc.x - goal;
        if abs(g) <= 1e-7 * m.a || hi - lo <= 1e-6 {
            break;
        }
        if g > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let next = x - g / (m.a + m.b * sc.y);
        x = select(0.5 * (lo + hi), next, next > lo && next < hi);
    }
    return x;
}

/// A sample of ω_i (local) with u = (u₀, u₁, u₂, u₃) as the CPU's `sample`. The delta lobe's
/// sample has pdf 1 (a marker: `shade` treats the specular fiber as a delta material).
fn reference_fiber_sample(m: ReferenceFiber, wo: vec3<f32>, u: vec4<f32>) -> FiberSample {
    var out: FiberSample;
    out.pdf = 0.0;
    if m.kind == MATERIAL_DIFFUSE_FIBER {
        // cos_theta_direction(u₀, u₁, 2πu₂).
        let sin_t = sqrt(u.x) * sin_cos_f(TAU * u.y).y;
        let cos_t = safe_sqrt(1.0 - sin_t * sin_t);
        let sp = sin_cos_f(TAU * u.z);
        out.wi = vec3<f32>(sin_t, cos_t * sp.y, cos_t * sp.x);
        out.weight = m.rho;
        out.pdf = cos_t / (PI * PI);
        return out;
    }
    if m.kind == MATERIAL_LAMBERTIAN_CYLINDER {
        // The surface normal at the offset 2u₀ − 1, then the cosine about it.
        let gamma = asin_f(clamp(2.0 * u.x - 1.0, -1.0, 1.0));
        let sn = sin_cos_f(local_phi(wo) + gamma);
        let n = vec3<f32>(0.0, sn.y, sn.x);
        let t = vec3<f32>(1.0, 0.0, 0.0);
        let d = cosine_direction(u.y, u.z);
        let wi = normalize(t * d.x + cross(n, t) * d.y + n * d.z);
        let e = reference_fiber_eval(m, wi, wo);
        if !(e.w > 0.0) {
            return out;
        }
        out.wi = wi;
        out.weight = m.rho;
        out.pdf = e.w;
        return out;
    }
    if m.kind == MATERIAL_SPECULAR_FIBER {
        var phi_rel: f32;
        if m.mirror {
            phi_rel = 2.0 * asin_f(clamp(2.0 * u.x - 1.0, -1.0, 1.0));
        } else {
            phi_rel = PI * (2.0 * u.x - 1.0);
        }
        let cos_o = local_cos_theta(wo);
        let sp = sin_cos_f(local_phi(wo) - phi_rel);
        out.wi = vec3<f32>(-local_sin_theta(wo), cos_o * sp.y, cos_o * sp.x);
        var weight = 1.0;
        if m.eta > 0.0 {
            var cos_iota = cos_o;
            if m.mirror {
                cos_iota = cos_o * max(sin_cos_f(0.5 * phi_rel).y, 0.0);
            }
            weight = fresnel_dielectric(cos_iota, m.eta);
        }
        out.weight = vec3<f32>(weight);
        out.pdf = 1.0;
        return out;
    }
    // Goldman: θ_i as Kajiya–Kay's sampler draws it, φ from the directional factor's density.
    if !(m.a > 0.0) {
        return out;
    }
    let phi_rel = goldman_sample_phi(m, u.w);
    let theta_o = atan2_f(local_sin_theta(wo), local_cos_theta(wo));
    let theta_i = kk_sample_theta(m.kk, theta_o, u.xyz);
    if theta_i < -2.0 {
        return out;
    }
    let wi = fiber_direction(theta_i, local_phi(wo) - phi_rel);
    return fiber_sample_at(wi, reference_fiber_eval(m, wi, wo));
}
