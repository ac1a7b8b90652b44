// The CPU renderer's sampler (render/src/sampler.rs) in 32-bit integers: per pixel, each pair
// of dimensions is the 2D Sobol (0,2)-sequence, Owen-scrambled by hashing (Burley 2020), its
// index shuffled by another Owen scramble, keyed by (pixel, seed, pair). 64-bit words are
// vec2<u32> (x: low half, y: high half); the values are the CPU's to 24 bits.

fn mul32_wide(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>((p00 & 0xffffu) | (mid << 16u), p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}

fn mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = mul32_wide(a.x, b.x);
    return vec2<u32>(lo.x, lo.y + a.x * b.y + a.y * b.x);
}

fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

/// `a >> s` for 0 < s < 32.
fn shr64(a: vec2<u32>, s: u32) -> vec2<u32> {
    return vec2<u32>((a.x >> s) | (a.y << (32u - s)), a.y >> s);
}

/// SplitMix64's finalizer (math/src/split_mix.rs, `mix64`).
fn mix64(z0: vec2<u32>) -> vec2<u32> {
    var z = z0 ^ shr64(z0, 30u);
    z = mul64(z, vec2<u32>(0x1CE4E5B9u, 0xBF58476Du));
    z = z ^ shr64(z, 27u);
    z = mul64(z, vec2<u32>(0x133111EBu, 0x94D049BBu));
    return z ^ shr64(z, 31u);
}

/// The key of pixel (x, y): `mix64(mix64(seed ^ C) ^ (y << 32 | x))`, the inner hash given.
fn pixel_key(seed_hash: vec2<u32>, x: u32, y: u32) -> vec2<u32> {
    return mix64(seed_hash ^ vec2<u32>(x, y));
}

fn owen_scramble_reversed(v0: u32, seed: u32) -> u32 {
    var v = v0 + seed;
    v ^= v * 0x6c50b47cu;
    v ^= v * 0xb82f1e52u;
    v ^= v * 0xc7afe638u;
    v ^= v * 0x8d22f6e6u;
    return v;
}

/// A 32-bit fraction as f32 in [0, 1): its top 24 bits (exact).
fn unit_f32(bits: u32) -> f32 {
    return f32(bits >> 8u) * (1.0 / 16777216.0);
}

/// Dimension pair `pair` of sample `index` of the pixel keyed `key`.
fn next_2d(key: vec2<u32>, index: u32, pair: u32) -> vec2<f32> {
    let h = mix64(key ^ mix64(add64(vec2<u32>(pair, 0u), vec2<u32>(0x7F4A7C15u, 0x9E3779B9u))));
    let i = reverseBits(owen_scramble_reversed(reverseBits(index), h.x));
    let y = sobol_bytes[i & 0xffu] ^ sobol_bytes[256u + ((i >> 8u) & 0xffu)]
        ^ sobol_bytes[512u + ((i >> 16u) & 0xffu)] ^ sobol_bytes[768u + (i >> 24u)];
    let sx = reverseBits(owen_scramble_reversed(i, h.y));
    let sy = reverseBits(owen_scramble_reversed(y, mix64(h).x));
    return vec2<f32>(unit_f32(sx), unit_f32(sy));
}
