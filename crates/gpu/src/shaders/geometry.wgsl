// Ray queries against the scene: the CPU's BVH walked as it is stored (geometry/src/bvh/flat.rs:
// 8-wide axis-aligned nodes with 8-bit quantized child boxes and 8-wide oriented nodes whose
// children each carry their own integer frame), tube segments (geometry/src/curves.rs), spheres
// and triangles. The box tests widen every box by twice the CPU walk's bound on its rounding
// (a fused multiply-add is exact where the CPU rounds twice), so no box that the ray enters is
// missed.

const EPS: f32 = 1.1920929e-7;
const NONE: u32 = 0xffffffffu;
/// Primitive kinds in the top two bits of a primitive id.
const KIND_SEGMENT: u32 = 1u;
const KIND_SPHERE: u32 = 2u;
const KIND_TRIANGLE: u32 = 3u;
const STACK_SIZE: u32 = 64u;

fn prim_id(kind: u32, index: u32) -> u32 {
    return (kind << 30u) | index;
}

struct Hit {
    t: f32,
    /// Primitive id (`prim_id`), NONE for a miss.
    prim: u32,
    /// Offset across a fiber (segments only).
    h: f32,
}

var<private> stack_ref: array<u32, 64>;
var<private> stack_t: array<f32, 64>;

/// Entry of the ray into tube segment `i` within (t_min, t_max): (t, h), t < 0 when none
/// (geometry/src/curves.rs, `intersect_segment`).
fn hit_segment(i: u32, o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> vec2<f32> {
    let s0 = segments[4u * i];
    let s1 = segments[4u * i + 1u];
    let s2 = segments[4u * i + 2u];
    let s3 = segments[4u * i + 3u];
    let p0 = s0.xyz;
    let a = vec3<f32>(s0.w, s1.x, s1.y);
    let len = s1.z;
    let r = s1.w;
    let d_perp = d - a * dot(d, a);
    let aa = dot(d_perp, d_perp);
    if aa < 1e-12 {
        return vec2<f32>(-1.0, 0.0);
    }
    let oc = o - p0;
    let oc_perp = oc - a * dot(oc, a);
    let t_c = -dot(oc_perp, d_perp) / aa;
    let q = oc_perp + d_perp * t_c;
    let q2 = dot(q, q);
    if q2 >= r * r {
        return vec2<f32>(-1.0, 0.0);
    }
    let t = t_c - sqrt((r * r - q2) / aa);
    if !(t > t_min && t < t_max) {
        return vec2<f32>(-1.0, 0.0);
    }
    let pr = oc + d * t;
    let n0 = s2.xyz;
    let n1 = vec3<f32>(s2.w, s3.x, s3.y);
    if dot(pr, n0) < 0.0 || dot(pr - a * len, n1) > 0.0 {
        return vec2<f32>(-1.0, 0.0);
    }
    let w = -d_perp / sqrt(aa);
    let v = cross(w, a);
    return vec2<f32>(t, clamp(dot(q, v) / r, -1.0, 1.0));
}

/// Nearest root of the sphere beyond t_min and before t_max (< 0: none). `leaving`: the ray
/// starts on this sphere, so only the far root of a ray heading inward counts.
fn hit_sphere(c: vec3<f32>, r: f32, o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, leaving: bool) -> f32 {
    let oc = o - c;
    let b = dot(oc, d);
    let q = oc - d * b;
    let disc = r * r - dot(q, q);
    if disc < 0.0 {
        return -1.0;
    }
    let s = sqrt(disc);
    let t0 = -b - s;
    let t1 = -b + s;
    if leaving {
        if b < 0.0 && t1 > t_min && t1 < t_max {
            return t1;
        }
        return -1.0;
    }
    if t0 > t_min && t0 < t_max {
        return t0;
    }
    if t1 > t_min && t1 < t_max {
        return t1;
    }
    return -1.0;
}

/// Möller–Trumbore: the distance to triangle `i` within (t_min, t_max), < 0 when none.
fn hit_triangle(i: u32, o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> f32 {
    let a = triangles[3u * i].xyz;
    let e1 = triangles[3u * i + 1u].xyz - a;
    let e2 = triangles[3u * i + 2u].xyz - a;
    let pv = cross(d, e2);
    let det = dot(e1, pv);
    if abs(det) < 1e-20 {
        return -1.0;
    }
    let inv = 1.0 / det;
    let tv = o - a;
    let u = dot(tv, pv) * inv;
    if u < 0.0 || u > 1.0 {
        return -1.0;
    }
    let qv = cross(tv, e1);
    let v = dot(d, qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return -1.0;
    }
    let t = dot(e2, qv) * inv;
    if t > t_min && t < t_max {
        return t;
    }
    return -1.0;
}

/// A ray prepared for the node tests.
struct NodeRay {
    o: vec3<f32>,
    d: vec3<f32>,
    inv: vec3<f32>,
    /// Widening for the f32 origin's rounding.
    slack: f32,
    t_min: f32,
}

fn node_ray(o: vec3<f32>, d: vec3<f32>, t_min: f32) -> NodeRay {
    var r: NodeRay;
    r.o = o;
    r.d = d;
    let dd = select(d, select(vec3<f32>(-1e-30), vec3<f32>(1e-30), d >= vec3<f32>(0.0)), abs(d) < vec3<f32>(1e-30));
    r.inv = 1.0 / dd;
    r.slack = max(max(abs(o.x), abs(o.y)), abs(o.z)) * EPS * 8.0;
    r.t_min = t_min - 1e-6;
    return r;
}

/// Byte `k` of 8-byte row `row` packed in words starting at `w0` of the node at `base`.
fn node_byte(base: u32, w0: u32, row: u32, k: u32) -> u32 {
    return (nodes[base + w0 + 2u * row + (k >> 2u)] >> (8u * (k & 3u))) & 0xffu;
}

/// Pushes the children of an axis-aligned node that the ray enters within (t_min, t_max),
/// farthest first, onto the stack from `sp`; returns the new stack size.
fn push_aabb_children(index: u32, r: NodeRay, t_max: f32, sp0: u32, sorted: bool) -> u32 {
    let base = index * 32u;
    let origin = vec3<f32>(bitcast<f32>(nodes[base]), bitcast<f32>(nodes[base + 1u]), bitcast<f32>(nodes[base + 2u]));
    let scale = vec3<f32>(bitcast<f32>(nodes[base + 4u]), bitcast<f32>(nodes[base + 5u]), bitcast<f32>(nodes[base + 6u]));
    let used = nodes[base + 28u];
    let offset = origin - r.o;
    let step = scale * r.inv;
    let centre = offset * r.inv;
    let widen = 2.0 * (r.slack + (abs(offset) + scale * 256.0) * (4.0 * EPS)) * abs(r.inv);
    let lo = centre - widen;
    let hi = centre + widen;
    let positive = r.inv >= vec3<f32>(0.0);
    var sp = sp0;
    for (var k = 0u; k < 8u; k++) {
        if (used & (1u << k)) == 0u {
            continue;
        }
        var t0 = r.t_min;
        var t1 = t_max;
        for (var axis = 0u; axis < 3u; axis++) {
            let q_lo = f32(node_byte(base, 8u, axis, k));
            let q_hi = f32(node_byte(base, 8u, 3u + axis, k));
            let near = select(q_hi, q_lo, positive[axis]);
            let far = select(q_lo, q_hi, positive[axis]);
            t0 = max(t0, near * step[axis] + lo[axis]);
            t1 = min(t1, far * step[axis] + hi[axis]);
        }
        if t0 <= t1 * (1.0 + 4.0 * EPS) {
            sp = push_sorted(sp, sp0, nodes[base + 20u + k], max(t0, 0.0), sorted);
        }
    }
    return sp;
}

/// The oriented node's test (geometry/src/bvh/oriented.rs): the ray rotated into each child's
/// integer frame, slabs against its box widened by the CPU's bound, doubled.
fn push_oriented_children(index: u32, r: NodeRay, t_max: f32, sp0: u32, sorted: bool) -> u32 {
    let base = params.oriented_base + index * 80u;
    let center = vec3<f32>(bitcast<f32>(nodes[base + 66u]), bitcast<f32>(nodes[base + 67u]), bitcast<f32>(nodes[base + 68u]));
    let radius = bitcast<f32>(nodes[base + 69u]);
    let used = nodes[base + 78u];
    let rel = r.o - center;
    let l1 = abs(rel.x) + abs(rel.y) + abs(rel.z);
    let widen = 2.0 * (r.slack + (l1 + radius) * (32.0 * EPS)) * 221.0;
    var sp = sp0;
    for (var k = 0u; k < 8u; k++) {
        if (used & (1u << k)) == 0u {
            continue;
        }
        var t0 = r.t_min;
        var t1 = t_max;
        for (var row = 0u; row < 3u; row++) {
            var rot: vec3<f32>;
            for (var col = 0u; col < 3u; col++) {
                let word = nodes[base + 2u * (3u * row + col) + (k >> 2u)];
                rot[col] = f32(extractBits(bitcast<i32>(word), 8u * (k & 3u), 8u));
            }
            let dr = dot(rot, r.d);
            let orr = dot(rot, rel);
            let inv = 1.0 / select(max(abs(dr), 1e-30), -max(abs(dr), 1e-30), dr < 0.0);
            let box_lo = bitcast<f32>(nodes[base + 18u + 8u * row + k]);
            let box_hi = bitcast<f32>(nodes[base + 42u + 8u * row + k]);
            let t_lo = (box_lo - widen - orr) * inv;
            let t_hi = (box_hi + widen - orr) * inv;
            t0 = max(t0, min(t_lo, t_hi));
            t1 = min(t1, max(t_lo, t_hi));
        }
        if t0 <= t1 * (1.0 + 4.0 * EPS) {
            sp = push_sorted(sp, sp0, nodes[base + 70u + k], max(t0, 0.0), sorted);
        }
    }
    return sp;
}

/// Pushes (child, t) at `sp`; when `sorted`, keeps the entries from `sp0` farthest first (an
/// insertion into the node's few children), so the nearest child is popped first.
fn push_sorted(sp: u32, sp0: u32, child: u32, t: f32, sorted: bool) -> u32 {
    if sp >= STACK_SIZE {
        return sp;
    }
    var j = sp;
    if sorted {
        while j > sp0 && stack_t[j - 1u] < t {
            stack_ref[j] = stack_ref[j - 1u];
            stack_t[j] = stack_t[j - 1u];
            j -= 1u;
        }
    }
    stack_ref[j] = child;
    stack_t[j] = t;
    return sp + 1u;
}

fn push_children(node: u32, r: NodeRay, t_max: f32, sp: u32, sorted: bool) -> u32 {
    let index = node & 0x0fffffffu;
    if (node >> 28u) == 0u {
        return push_aabb_children(index, r, t_max, sp, sorted);
    }
    return push_oriented_children(index, r, t_max, sp, sorted);
}

fn is_node(child: u32) -> bool {
    let c = child >> 28u;
    return c == 0u || c == 14u;
}

/// Closest hit in one tree (`kind`: its primitives' kind), improving `best`.
fn closest_in_tree(root: u32, kind: u32, o: vec3<f32>, d: vec3<f32>, t_min: f32, best0: Hit, skip: u32) -> Hit {
    var best = best0;
    if (root >> 28u) == 15u {
        return best;
    }
    let r = node_ray(o, d, t_min);
    var sp = 0u;
    stack_ref[0] = root;
    stack_t[0] = 0.0;
    sp = 1u;
    loop {
        if sp == 0u {
            break;
        }
        sp -= 1u;
        let child = stack_ref[sp];
        if stack_t[sp] > best.t * (1.0 + 4.0 * EPS) {
            continue;
        }
        if is_node(child) {
            sp = push_children(child, r, best.t, sp, true);
            continue;
        }
        let count = child >> 28u;
        let first = child & 0x0fffffffu;
        for (var k = 0u; k < count; k++) {
            let prim = prims[first + k];
            let id = prim_id(kind, prim);
            if id == skip {
                continue;
            }
            if kind == KIND_SEGMENT {
                let h = hit_segment(prim, o, d, t_min, best.t);
                if h.x >= 0.0 {
                    best = Hit(h.x, id, h.y);
                }
            } else {
                let t = hit_triangle(prim, o, d, t_min, best.t);
                if t >= 0.0 {
                    best = Hit(t, id, 0.0);
                }
            }
        }
    }
    return best;
}

/// True when the ray meets a primitive of the tree within (t_min, t_max).
fn any_in_tree(root: u32, kind: u32, o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, skip: u32) -> bool {
    if (root >> 28u) == 15u {
        return false;
    }
    let r = node_ray(o, d, t_min);
    stack_ref[0] = root;
    var sp = 1u;
    loop {
        if sp == 0u {
            break;
        }
        sp -= 1u;
        let child = stack_ref[sp];
        if is_node(child) {
            sp = push_children(child, r, t_max, sp, false);
            continue;
        }
        let count = child >> 28u;
        let first = child & 0x0fffffffu;
        for (var k = 0u; k < count; k++) {
            let prim = prims[first + k];
            if prim_id(kind, prim) == skip {
                continue;
            }
            if kind == KIND_SEGMENT {
                if hit_segment(prim, o, d, t_min, t_max).x >= 0.0 {
                    return true;
                }
            } else if hit_triangle(prim, o, d, t_min, t_max) >= 0.0 {
                return true;
            }
        }
    }
    return false;
}

// The scene's word table (`scene_words`): spheres (12 words each), objects (2 words: kind and
// root), from the offsets in `params`.
fn sphere_center(i: u32) -> vec3<f32> {
    let b = params.sphere_base + 12u * i;
    return vec3<f32>(bitcast<f32>(scene_words[b]), bitcast<f32>(scene_words[b + 1u]), bitcast<f32>(scene_words[b + 2u]));
}

fn sphere_radius(i: u32) -> f32 {
    return bitcast<f32>(scene_words[params.sphere_base + 12u * i + 3u]);
}

/// Nearest hit along the ray within (t_min, t_max), skipping the primitive `skip` it leaves.
fn closest_hit(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, skip: u32) -> Hit {
    var best = Hit(t_max, NONE, 0.0);
    for (var i = 0u; i < params.sphere_count; i++) {
        let id = prim_id(KIND_SPHERE, i);
        let t = hit_sphere(sphere_center(i), sphere_radius(i), o, d, t_min, best.t, id == skip);
        if t >= 0.0 {
            best = Hit(t, id, 0.0);
        }
    }
    for (var j = 0u; j < params.object_count; j++) {
        let b = params.object_base + 2u * j;
        best = closest_in_tree(scene_words[b + 1u], scene_words[b], o, d, t_min, best, skip);
    }
    return best;
}

/// True when nothing blocks the ray within (t_min, t_max); `skip` is the primitive it leaves,
/// `aim` a sphere it is aimed at (never a blocker: the ray ends on it).
fn unoccluded(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, skip: u32, aim: u32) -> bool {
    for (var i = 0u; i < params.sphere_count; i++) {
        let id = prim_id(KIND_SPHERE, i);
        if id == aim {
            continue;
        }
        if hit_sphere(sphere_center(i), sphere_radius(i), o, d, t_min, t_max, id == skip) >= 0.0 {
            return false;
        }
    }
    for (var j = 0u; j < params.object_count; j++) {
        let b = params.object_base + 2u * j;
        if any_in_tree(scene_words[b + 1u], scene_words[b], o, d, t_min, t_max, skip) {
            return false;
        }
    }
    return true;
}
