// Image textures (render/src/texture.rs) in f32: texel (x, y), row 0 at the top, has its centre
// at u = (x + ½)/W, v = 1 − (y + ½)/H; a lookup interpolates bilinearly between the four texel
// centres around (u, v) after the uv scale, indices repeated or clamped.

/// Texel index i of n by the wrapping (0 repeat, 1 clamp), i a whole number.
fn texture_index(i: f32, n: u32, wrap: u32) -> u32 {
    let nf = f32(n);
    if wrap == 0u {
        return min(u32(i - nf * floor(i / nf)), n - 1u);
    }
    return u32(clamp(i, 0.0, nf - 1.0));
}

/// The bilinearly filtered texture (texels rgb from word `at`, w × h) at uv.
fn texture_lookup(at: u32, w: u32, h: u32, wrap: u32, scale: vec2<f32>, uv: vec2<f32>) -> vec3<f32> {
    let s = uv.x * scale.x * f32(w) - 0.5;
    let t = (1.0 - uv.y * scale.y) * f32(h) - 0.5;
    if not_finite(s) || not_finite(t) {
        return word_v3(at);
    }
    let x0 = floor(s);
    let y0 = floor(t);
    let fx = s - x0;
    let fy = t - y0;
    let xa = texture_index(x0, w, wrap);
    let xb = texture_index(x0 + 1.0, w, wrap);
    let ya = texture_index(y0, h, wrap);
    let yb = texture_index(y0 + 1.0, h, wrap);
    return word_v3(at + 3u * (ya * w + xa)) * ((1.0 - fx) * (1.0 - fy)) + word_v3(at + 3u * (ya * w + xb)) * (fx * (1.0 - fy))
        + word_v3(at + 3u * (yb * w + xa)) * ((1.0 - fx) * fy) + word_v3(at + 3u * (yb * w + xb)) * (fx * fy);
}

/// The texture whose header is at word `at` (width, height, wrapping, uv scale x and y; its
/// texels, rgb, follow) at uv.
fn texture_at(at: u32, uv: vec2<f32>) -> vec3<f32> {
    let scale = vec2<f32>(word_f(at + 3u), word_f(at + 4u));
    return texture_lookup(at + 5u, word_u(at), word_u(at + 1u), word_u(at + 2u), scale, uv);
}
