// The wavefront kernels (Laine, Karras & Aila 2013, "Megakernels considered harmful"): one
// thread per path per stage, with queues between the stages. A pass: `generate` (camera rays,
// all slots in queue half 0), then per bounce `extend` (closest hit of the current queue),
// `shade` (emission, next-event estimation into the shadow queue, the scattering sample into
// the other queue half), `count_shadow_rays`, `shadow` (any hit; adds the unoccluded
// contributions), `next_bounce` (swaps the halves); finally `sum_jobs`. The path logic is the
// CPU's (render/src/integrator.rs, `radiance`), dimension for dimension.

/// The material of a primitive: 32 words at `material_base + 32 m` (`scene_buffers.rs`).
const MATERIAL_LAMBERT: u32 = 0u;
const MATERIAL_MIRROR: u32 = 1u;
const MATERIAL_CHIANG: u32 = 2u;
// MATERIAL_KAJIYA_KAY (3) is in kajiya_kay.wgsl, MATERIAL_MARSCHNER (4) in marschner.wgsl,
// MATERIAL_DEON (5) in deon.wgsl, MATERIAL_YAN_FUR (6) in yan_fur.wgsl, MATERIAL_LEAF (7) in
// leaf.wgsl, MATERIAL_LAMBERTIAN (8) in lambertian.wgsl, MATERIAL_WOOD (9) in wood.wgsl,
// MATERIAL_SADEGHI (10) in sadeghi.wgsl, MATERIAL_IRAWAN (12) in irawan_2012.wgsl,
// MATERIAL_HOLLOW_FIBER (13) in hollow_fiber.wgsl, MATERIAL_HUANG (14) in huang_2022.wgsl, the
// reference fibers (20–23) in reference_fibers.wgsl.

fn is_fiber_material(kind: u32) -> bool {
    return kind == MATERIAL_CHIANG || kind == MATERIAL_KAJIYA_KAY || kind == MATERIAL_MARSCHNER
        || kind == MATERIAL_DEON || kind == MATERIAL_YAN_FUR || kind == MATERIAL_HOLLOW_FIBER
        || kind == MATERIAL_HUANG || is_reference_fiber(kind);
}

/// The surface models shaded in their own frame (`surface_frame`): leaf, lambertian, wood,
/// sadeghi-2013 and irawan-2012.
fn is_surface_model(kind: u32) -> bool {
    return kind == MATERIAL_LEAF || kind == MATERIAL_LAMBERTIAN || kind == MATERIAL_WOOD
        || kind == MATERIAL_SADEGHI || kind == MATERIAL_IRAWAN;
}

fn material_kind(m: u32) -> u32 {
    return scene_words[params.material_base + 32u * m];
}

fn material_rgb(m: u32) -> vec3<f32> {
    return word_v3(params.material_base + 32u * m + 1u);
}

fn load_chiang(m: u32) -> Chiang {
    let b = params.material_base + 32u * m;
    var c: Chiang;
    c.eta = word_f(b + 1u);
    c.sigma_a = word_v3(b + 2u);
    c.s = word_f(b + 5u);
    c.logistic_norm = word_f(b + 6u);
    c.cdf_lo = word_f(b + 7u);
    c.cdf_hi = word_f(b + 8u);
    c.v = vec4<f32>(word_f(b + 9u), word_f(b + 10u), word_f(b + 11u), word_f(b + 12u));
    c.inv_norm = vec4<f32>(word_f(b + 13u), word_f(b + 14u), word_f(b + 15u), word_f(b + 16u));
    c.expm1_neg = vec4<f32>(word_f(b + 17u), word_f(b + 18u), word_f(b + 19u), word_f(b + 20u));
    c.tilt_sin = vec4<f32>(word_f(b + 21u), word_f(b + 22u), word_f(b + 23u), word_f(b + 24u));
    c.tilt_cos = vec4<f32>(word_f(b + 25u), word_f(b + 26u), word_f(b + 27u), word_f(b + 28u));
    return c;
}

fn power_heuristic(a: f32, b: f32) -> f32 {
    let a2 = a * a;
    let b2 = b * b;
    if a2 + b2 > 0.0 {
        return a2 / (a2 + b2);
    }
    return 0.0;
}

fn is_black(c: vec3<f32>) -> bool {
    return c.x == 0.0 && c.y == 0.0 && c.z == 0.0;
}

fn linear_id(gid: vec3<u32>) -> u32 {
    return gid.x;
}

/// Camera ray direction through image position (px, py) (render/src/camera.rs).
fn camera_direction(px: f32, py: f32) -> vec3<f32> {
    let sx = (2.0 * px / params.width - 1.0) * params.tan_half * params.aspect;
    let sy = (1.0 - 2.0 * py / params.height) * params.tan_half;
    return normalize(params.forward + params.right * sx + params.up * sy);
}

@compute @workgroup_size(64)
fn generate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let slot = linear_id(gid);
    if slot >= params.slot_count {
        return;
    }
    // The job holding this slot: the last whose first slot is ≤ slot.
    var lo = 0u;
    var hi = params.job_count;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if jobs[mid].z <= slot {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let job = jobs[lo];
    let x = job.x & 0xffffu;
    let y = job.x >> 16u;
    var s: PathState;
    s.key = pixel_key(params.seed_hash, x, y);
    s.index = job.y + (slot - job.z);
    let jitter = next_2d(s.key, s.index, 0u);
    s.o = params.eye;
    s.d = camera_direction(f32(x) + jitter.x, f32(y) + jitter.y);
    s.t_min = 0.0;
    s.beta = vec3<f32>(1.0);
    s.l = vec3<f32>(0.0);
    s.depth = 0u;
    s.flags = 1u;
    s.prev_pdf = 0.0;
    s.prev_p = params.eye;
    s.pixel = job.x;
    s.skip = NONE;
    s.hit_prim = NONE;
    paths[slot] = s;
    ray_queue[slot] = slot;
}

fn current_half() -> u32 {
    return atomicLoad(&counters[COUNT_CURRENT]);
}

@compute @workgroup_size(64)
fn extend(@builtin(global_invocation_id) gid: vec3<u32>) {
    let cur = current_half();
    let i = linear_id(gid);
    if i >= atomicLoad(&counters[cur]) {
        return;
    }
    let p = ray_queue[cur * params.queue_capacity + i];
    let hit = closest_hit(paths[p].o, paths[p].d, paths[p].t_min, INF, paths[p].skip);
    paths[p].hit_t = hit.t;
    paths[p].hit_prim = hit.prim;
    paths[p].hit_h = hit.h;
}

/// Smallest distance for rays leaving `p` (the primitive left is skipped besides).
fn spawn_epsilon(p: vec3<f32>) -> f32 {
    return 4e-6 * (1.0 + max(max(abs(p.x), abs(p.y)), abs(p.z)));
}

/// The shading frame of a surface model at a surface hit (material words at `b`; a mesh's
/// shading records where `leaf.wgsl` says), as the CPU's `SurfacePoint` and
/// `frame_facing`, with its texture coordinates: the shading normal (a mesh's interpolated corner normals, else the geometric
/// normal `ng`) flipped to the side of ω_o, the tangent along u made orthogonal to it (a mesh's
/// per-triangle tangent, a sphere's ∂P/∂φ), and z × x.
fn surface_frame(b: u32, kind: u32, index: u32, ng: vec3<f32>, o: vec3<f32>, d: vec3<f32>) -> SurfaceShading {
    var sn = ng;
    var tangent: vec3<f32>;
    var uv: vec2<f32>;
    if kind == KIND_SPHERE {
        let phi = atan2_f(ng.z, ng.x);
        let sc = sin_cos_f(phi);
        tangent = vec3<f32>(-sc.x, 0.0, sc.y);
        uv = vec2<f32>(select(phi / TAU, phi / TAU + 1.0, phi < 0.0), 1.0 - acos_f(clamp(ng.y, -1.0, 1.0)) / PI);
    } else {
        let r = word_u(b + 10u) + word_u(b + 11u) + 18u * (index - word_u(b + 12u));
        tangent = word_v3(r);
        // Barycentrics of the hit (Möller–Trumbore, as the CPU's).
        let p0 = triangles[3u * index].xyz;
        let e1 = triangles[3u * index + 1u].xyz - p0;
        let e2 = triangles[3u * index + 2u].xyz - p0;
        let pv = cross(d, e2);
        let inv = 1.0 / dot(e1, pv);
        let tv = o - p0;
        let b1 = dot(tv, pv) * inv;
        let b2 = dot(d, cross(tv, e1)) * inv;
        let n = word_v3(r + 3u) * (1.0 - b1 - b2) + word_v3(r + 6u) * b1 + word_v3(r + 9u) * b2;
        uv = vec2<f32>(word_f(r + 12u), word_f(r + 13u)) * (1.0 - b1 - b2) + vec2<f32>(word_f(r + 14u), word_f(r + 15u)) * b1
            + vec2<f32>(word_f(r + 16u), word_f(r + 17u)) * b2;
        let len = length(n);
        if len > 0.0 && !not_finite(len) {
            sn = n / len;
        }
    }
    let along = tangent - sn * dot(sn, tangent);
    var x: vec3<f32>;
    // A residual at f32's rounding of a tangent along the normal has no direction.
    if length(along) > 1e-6 * length(tangent) {
        x = normalize(along);
    } else {
        x = orthonormal_pair(sn)[0];
    }
    let z = select(sn, -sn, dot(sn, d) > 0.0);
    return SurfaceShading(x, cross(z, x), z, uv);
}

/// A surface model's shading frame (x tangent, y = z × x, z the normal facing ω_o) and the
/// hit's texture coordinates.
struct SurfaceShading {
    x: vec3<f32>,
    y: vec3<f32>,
    z: vec3<f32>,
    uv: vec2<f32>,
}

@compute @workgroup_size(64)
fn shade(@builtin(global_invocation_id) gid: vec3<u32>) {
    let cur = current_half();
    let i = linear_id(gid);
    if i >= atomicLoad(&counters[cur]) {
        return;
    }
    let pi = ray_queue[cur * params.queue_capacity + i];
    var s = paths[pi];
    let prev_delta = (s.flags & 1u) != 0u;
    if s.hit_prim == NONE {
        for (var j = 0u; j < params.light_count; j++) {
            let le = light_escaped(j, s.d);
            if is_black(le) {
                continue;
            }
            var w = 1.0;
            if !prev_delta {
                w = power_heuristic(s.prev_pdf, light_probability(j) * light_pdf(j, s.d));
            }
            s.l += s.beta * le * w;
        }
        paths[pi].l = s.l;
        return;
    }
    let kind = s.hit_prim >> 30u;
    let index = s.hit_prim & 0x3fffffffu;
    let p = s.o + s.d * s.hit_t;
    var material: u32;
    // Fiber frame (u tangent, w toward ω_o), or the facing normal of a surface (and a surface
    // model's shading frame: u tangent, w its normal facing ω_o).
    var fu: vec3<f32>;
    var fv: vec3<f32>;
    var fw: vec3<f32>;
    var n: vec3<f32>;
    var chm: Chiang;
    var chv: ChiangVertex;
    var hfv: HollowVertex;
    var kkm: KajiyaKay;
    var msm: Marschner;
    var dem: Deon;
    var yfm: YanFur;
    var hgm: Huang;
    var hgv: HuangVertex;
    var lfm: Leaf;
    var rfm: ReferenceFiber;
    var irm: Irawan;
    var wdm: Wood;
    var sdm: Sadeghi;
    // A Lambertian surface model's albedo at the hit.
    var k_d: vec3<f32>;
    // ω_o in the fiber (or surface model's) frame.
    var wo_l: vec3<f32>;
    if kind == KIND_SEGMENT {
        let s0 = segments[4u * index];
        let s1 = segments[4u * index + 1u];
        let s2 = segments[4u * index + 2u];
        let s3 = segments[4u * index + 3u];
        let a = vec3<f32>(s0.w, s1.x, s1.y);
        material = bitcast<u32>(s3.w);
        let frac = clamp(dot(p - s0.xyz, a) / s1.z, 0.0, 1.0);
        fu = normalize(s2.xyz * (1.0 - frac) + vec3<f32>(s2.w, s3.x, s3.y) * frac);
        let wo = -s.d;
        let w_raw = wo - fu * dot(fu, wo);
        let len = length(w_raw);
        if len < 1e-6 {
            let b = orthonormal_pair(fu);
            fv = b[0];
            fw = b[1];
        } else {
            fw = w_raw / len;
            fv = cross(fw, fu);
        }
        wo_l = vec3<f32>(dot(wo, fu), dot(wo, fv), dot(wo, fw));
        let fiber_kind = material_kind(material);
        if fiber_kind == MATERIAL_CHIANG {
            chm = load_chiang(material);
            chv = chiang_at_vertex(chm, wo_l, s.hit_h);
        } else if fiber_kind == MATERIAL_MARSCHNER {
            msm = load_marschner(params.material_base + 32u * material);
        } else if fiber_kind == MATERIAL_DEON {
            dem = load_deon(params.material_base + 32u * material);
        } else if fiber_kind == MATERIAL_YAN_FUR {
            yfm = load_yan_fur(params.material_base + 32u * material);
        } else if is_reference_fiber(fiber_kind) {
            rfm = load_reference_fiber(params.material_base + 32u * material);
        } else if fiber_kind == MATERIAL_HOLLOW_FIBER {
            chm = load_chiang(material);
            hfv = hollow_at_vertex(chm, params.material_base + 32u * material, wo_l, s.hit_h);
        } else if fiber_kind == MATERIAL_HUANG {
            hgm = load_huang(params.material_base + 32u * material);
            hgv = huang_at_vertex(hgm, wo_l, s.hit_h);
        } else {
            kkm = load_kajiya_kay(params.material_base + 32u * material);
        }
    } else {
        var ng: vec3<f32>;
        if kind == KIND_SPHERE {
            ng = (p - sphere_center(index)) / sphere_radius(index);
            material = sphere_material(index);
            if sphere_emits(index) && dot(ng, s.d) < 0.0 {
                var w = 1.0;
                if !prev_delta {
                    w = power_heuristic(s.prev_pdf, sphere_probability(index) * sphere_light_pdf(index, s.prev_p, s.d));
                }
                s.l += s.beta * sphere_emission(index) * w;
            }
        } else {
            let a = triangles[3u * index];
            ng = normalize(cross(triangles[3u * index + 1u].xyz - a.xyz, triangles[3u * index + 2u].xyz - a.xyz));
            material = bitcast<u32>(a.w);
        }
        n = select(-ng, ng, dot(ng, s.d) < 0.0);
        let surface_kind = material_kind(material);
        if is_surface_model(surface_kind) {
            let b = params.material_base + 32u * material;
            let frame = surface_frame(b, kind, index, ng, s.o, s.d);
            fu = frame.x;
            fv = frame.y;
            fw = frame.z;
            let wo = -s.d;
            wo_l = vec3<f32>(dot(wo, fu), dot(wo, fv), dot(wo, fw));
            if surface_kind == MATERIAL_LEAF {
                lfm = load_leaf(b);
            } else if surface_kind == MATERIAL_IRAWAN {
                // The tile position: uv times the uv scale, where the surface has uvs.
                var position = vec2<f32>(word_f(b + 15u), word_f(b + 16u));
                if kind == KIND_SPHERE || word_u(b + 19u) != 0u {
                    position = frame.uv * vec2<f32>(word_f(b + 13u), word_f(b + 14u));
                }
                irm = irawan_at(b, position);
            } else if surface_kind == MATERIAL_WOOD {
                wdm = load_wood(b, frame.uv, kind == KIND_SPHERE || word_u(b + 19u) != 0u);
            } else if surface_kind == MATERIAL_SADEGHI {
                sdm = load_sadeghi(b, frame.uv, kind == KIND_SPHERE || word_u(b + 19u) != 0u);
            } else {
                k_d = word_v3(b + 1u);
                // Textured, where the surface has texture coordinates (spheres always do).
                if word_u(b + 13u) != 0u && (kind == KIND_SPHERE || word_u(b + 19u) != 0u) {
                    let scale = vec2<f32>(word_f(b + 17u), word_f(b + 18u));
                    k_d = texture_lookup(word_u(b + 10u), word_u(b + 14u), word_u(b + 15u), word_u(b + 16u), scale, frame.uv);
                }
            }
        }
    }
    let mkind = material_kind(material);
    // The mirror and the specular fiber scatter into a delta lobe: no next-event estimation.
    let delta = mkind == MATERIAL_MIRROR || mkind == MATERIAL_SPECULAR_FIBER;
    if s.depth >= params.max_depth {
        paths[pi].l = s.l;
        return;
    }
    let eps = spawn_epsilon(p);
    let pair = 1u + 5u * s.depth;
    // Next-event estimation (two pairs, always consumed).
    let u_pick = next_2d(s.key, s.index, pair).x;
    let u_light = next_2d(s.key, s.index, pair + 1u);
    if !delta {
        let picked = pick_emitter(u_pick);
        if picked.y > 0.0 {
            let ls = sample_emitter(u32(picked.x), p, u_light);
            if ls.pdf > 0.0 {
                var f = vec3<f32>(0.0);
                var bsdf_pdf = 0.0;
                if is_fiber_material(mkind) {
                    let wi_l = vec3<f32>(dot(ls.wi, fu), dot(ls.wi, fv), dot(ls.wi, fw));
                    var e: vec4<f32>;
                    if mkind == MATERIAL_CHIANG {
                        e = chiang_eval(chm, chv, wi_l);
                    } else if mkind == MATERIAL_MARSCHNER {
                        e = ms_eval(msm, wi_l, wo_l);
                    } else if mkind == MATERIAL_DEON {
                        e = deon_eval(dem, wi_l, wo_l);
                    } else if mkind == MATERIAL_YAN_FUR {
                        e = yan_eval(yfm, wi_l, wo_l, s.hit_h);
                    } else if is_reference_fiber(mkind) {
                        e = reference_fiber_eval(rfm, wi_l, wo_l);
                    } else if mkind == MATERIAL_HOLLOW_FIBER {
                        e = hollow_eval(chm, hfv, wi_l);
                    } else if mkind == MATERIAL_HUANG {
                        e = huang_eval(hgm, hgv, wi_l);
                    } else {
                        e = kk_eval(kkm, wi_l, wo_l);
                    }
                    f = e.xyz * local_cos_theta(wi_l);
                    bsdf_pdf = e.w;
                } else if is_surface_model(mkind) {
                    // Leaves transmit, so light from either side counts; the other surface models
                    // are opaque: light from the geometric normal's side only (as on the CPU).
                    if mkind == MATERIAL_LEAF || dot(n, ls.wi) > 0.0 {
                        let wi_l = vec3<f32>(dot(ls.wi, fu), dot(ls.wi, fv), dot(ls.wi, fw));
                        var e: vec4<f32>;
                        if mkind == MATERIAL_LAMBERTIAN {
                            e = lambertian_eval(k_d, wi_l, wo_l);
                        } else if mkind == MATERIAL_IRAWAN {
                            e = irawan_eval(irm, wi_l, wo_l);
                        } else if mkind == MATERIAL_LEAF {
                            e = leaf_eval(lfm, wi_l, wo_l);
                        } else if mkind == MATERIAL_WOOD {
                            e = wood_eval(wdm, wi_l, wo_l);
                        } else {
                            e = sadeghi_eval(sdm, wi_l, wo_l);
                        }
                        f = e.xyz * abs(wi_l.z);
                        bsdf_pdf = e.w;
                    }
                } else {
                    let c = max(dot(n, ls.wi), 0.0);
                    f = material_rgb(material) * (c / PI);
                    bsdf_pdf = c / PI;
                }
                if !is_black(f) && !is_black(ls.radiance) {
                    let p_light = picked.y * ls.pdf;
                    var w = 1.0;
                    if !ls.delta {
                        w = power_heuristic(p_light, bsdf_pdf);
                    }
                    let k = atomicAdd(&counters[COUNT_SHADOW], 1u);
                    var r: ShadowRay;
                    r.o = p;
                    r.d = ls.wi;
                    r.t_min = eps;
                    r.t_max = ls.distance;
                    r.path = pi;
                    r.contribution = s.beta * f * ls.radiance * (w / p_light);
                    r.skip = s.hit_prim;
                    r.aim = ls.aim;
                    shadow_queue[k] = r;
                }
            }
        }
    }
    // Scattering sample (two pairs) and Russian roulette (one pair).
    let ua = next_2d(s.key, s.index, pair + 2u);
    let ub = next_2d(s.key, s.index, pair + 3u);
    let u_rr = next_2d(s.key, s.index, pair + 4u).x;
    var wi: vec3<f32>;
    var weight: vec3<f32>;
    var pdf = 0.0;
    var sampled_delta = false;
    if is_fiber_material(mkind) {
        var fs: FiberSample;
        if mkind == MATERIAL_CHIANG {
            fs = chiang_sample(chm, chv, vec4<f32>(ua, ub));
        } else if mkind == MATERIAL_MARSCHNER {
            fs = ms_sample(msm, wo_l, vec4<f32>(ua, ub));
        } else if mkind == MATERIAL_DEON {
            fs = deon_sample(dem, wo_l, vec4<f32>(ua, ub));
        } else if mkind == MATERIAL_YAN_FUR {
            fs = yan_sample(yfm, wo_l, s.hit_h, vec4<f32>(ua, ub));
        } else if is_reference_fiber(mkind) {
            fs = reference_fiber_sample(rfm, wo_l, vec4<f32>(ua, ub));
        } else if mkind == MATERIAL_HOLLOW_FIBER {
            fs = hollow_sample(chm, hfv, vec4<f32>(ua, ub));
        } else if mkind == MATERIAL_HUANG {
            fs = huang_sample(hgm, hgv, vec4<f32>(ua, ub));
        } else {
            fs = kk_sample(kkm, wo_l, vec4<f32>(ua, ub));
        }
        if fs.pdf <= 0.0 {
            paths[pi].l = s.l;
            return;
        }
        wi = normalize(fu * fs.wi.x + fv * fs.wi.y + fw * fs.wi.z);
        weight = fs.weight;
        pdf = fs.pdf;
        if mkind == MATERIAL_SPECULAR_FIBER {
            pdf = 0.0;
            sampled_delta = true;
        }
    } else if is_surface_model(mkind) {
        var ls: FiberSample;
        if mkind == MATERIAL_LAMBERTIAN {
            ls = lambertian_sample(k_d, wo_l, vec4<f32>(ua, ub));
        } else if mkind == MATERIAL_IRAWAN {
            ls = irawan_sample(irm, wo_l, vec4<f32>(ua, ub));
        } else if mkind == MATERIAL_LEAF {
            ls = leaf_sample(lfm, wo_l, vec4<f32>(ua, ub));
        } else if mkind == MATERIAL_WOOD {
            ls = wood_sample(wdm, wo_l, vec4<f32>(ua, ub));
        } else {
            ls = sadeghi_sample(sdm, wo_l, vec4<f32>(ua, ub));
        }
        wi = normalize(fu * ls.wi.x + fv * ls.wi.y + fw * ls.wi.z);
        // pdf 0: no sample; pdf −1: a delta lobe (wood's smooth finish). Leaves transmit; the
        // other surface models are opaque, so a direction below the geometric normal ends the path.
        if ls.pdf == 0.0 || (mkind != MATERIAL_LEAF && dot(n, wi) <= 0.0) {
            paths[pi].l = s.l;
            return;
        }
        weight = ls.weight;
        pdf = max(ls.pdf, 0.0);
        sampled_delta = ls.pdf < 0.0;
    } else if mkind == MATERIAL_LAMBERT {
        let t = orthonormal_pair(n)[1];
        let b = cross(n, t);
        let r = sqrt(ua.x);
        let sc = sin_cos_f(TAU * ua.y);
        wi = normalize(t * (r * sc.y) + b * (r * sc.x) + n * safe_sqrt(1.0 - ua.x));
        pdf = dot(n, wi) / PI;
        if !(pdf > 0.0) {
            paths[pi].l = s.l;
            return;
        }
        weight = material_rgb(material);
    } else {
        let wo = -s.d;
        wi = normalize(2.0 * dot(n, wo) * n - wo);
        weight = material_rgb(material);
        sampled_delta = true;
    }
    s.beta *= weight;
    if is_black(s.beta) || not_finite3(s.beta) {
        paths[pi].l = s.l;
        return;
    }
    s.flags = select(0u, 1u, sampled_delta);
    s.prev_pdf = pdf;
    s.prev_p = p;
    s.depth += 1u;
    if s.depth >= params.rr_depth {
        let survive = min(max(max(s.beta.x, s.beta.y), s.beta.z), 1.0);
        if u_rr >= survive {
            paths[pi].l = s.l;
            return;
        }
        s.beta = s.beta / survive;
    }
    s.o = p;
    s.d = wi;
    s.t_min = eps;
    s.skip = s.hit_prim;
    paths[pi] = s;
    let next = 1u - cur;
    let k = atomicAdd(&counters[next], 1u);
    ray_queue[next * params.queue_capacity + k] = pi;
}

fn groups(n: u32) -> u32 {
    return (n + WORKGROUP - 1u) / WORKGROUP;
}

/// counters[8..11]: the extend and shade kernels' dispatch size, [12..15]: the shadow kernel's
/// (copied into the indirect-dispatch buffer between passes).
const ARGS_BOUNCE: u32 = 8u;
const ARGS_SHADOW: u32 = 12u;

fn set_args(at: u32, n: u32) {
    atomicStore(&counters[at], groups(n));
    atomicStore(&counters[at + 1u], 1u);
    atomicStore(&counters[at + 2u], 1u);
}

fn add_rays(n: u32) {
    let lo = atomicLoad(&counters[COUNT_RAYS_LO]);
    atomicStore(&counters[COUNT_RAYS_LO], lo + n);
    if lo + n < lo {
        atomicAdd(&counters[COUNT_RAYS_HI], 1u);
    }
}

@compute @workgroup_size(1)
fn count_shadow_rays() {
    let n = atomicLoad(&counters[COUNT_SHADOW]);
    set_args(ARGS_SHADOW, n);
    add_rays(n);
}

@compute @workgroup_size(64)
fn shadow(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = linear_id(gid);
    if i >= atomicLoad(&counters[COUNT_SHADOW]) {
        return;
    }
    let r = shadow_queue[i];
    if unoccluded(r.o, r.d, r.t_min, r.t_max, r.skip, r.aim) {
        paths[r.path].l += r.contribution;
    }
}

@compute @workgroup_size(1)
fn next_bounce() {
    let cur = atomicLoad(&counters[COUNT_CURRENT]);
    atomicStore(&counters[cur], 0u);
    atomicStore(&counters[COUNT_SHADOW], 0u);
    let next = 1u - cur;
    atomicStore(&counters[COUNT_CURRENT], next);
    let n = atomicLoad(&counters[next]);
    set_args(ARGS_BOUNCE, n);
    add_rays(n);
}

/// Each job's samples summed in sample order; non-finite samples are counted, not added.
@compute @workgroup_size(64)
fn sum_jobs(@builtin(global_invocation_id) gid: vec3<u32>) {
    let j = linear_id(gid);
    if j >= params.job_count {
        return;
    }
    let job = jobs[j];
    var sum = vec3<f32>(0.0);
    var bad = 0u;
    for (var k = 0u; k < job.w; k++) {
        let l = paths[job.z + k].l;
        if not_finite3(l) {
            bad += 1u;
        } else {
            sum += l;
        }
    }
    job_sums[j] = vec4<f32>(sum, bitcast<f32>(bad));
}

/// Ray queries for tests and tools (`ray_queries.rs`): shadow-queue entry i is a ray; its
/// closest hit goes to paths[i] (t, primitive, h) and whether anything blocks it within
/// (t_min, t_max) to paths[i].flags.
@compute @workgroup_size(64)
fn query_rays(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = linear_id(gid);
    if i >= params.slot_count {
        return;
    }
    let r = shadow_queue[i];
    let hit = closest_hit(r.o, r.d, r.t_min, r.t_max, r.skip);
    paths[i].hit_t = hit.t;
    paths[i].hit_prim = hit.prim;
    paths[i].hit_h = hit.h;
    paths[i].flags = select(0u, 1u, !unoccluded(r.o, r.d, r.t_min, r.t_max, r.skip, NONE));
}
