// Alpha masks (gpu_scene.rs `AlphaMasks`; shadowlab_core::alpha, whose test this is, step for
// step): a point of an alpha-masked caster blocks light where the factor's alpha times the
// texture's, at the nearest texel with coordinates wrapped, is at least the cutoff. Group 1 of the
// depth passes that draw masked casters; the mask is chosen by the uniform's dynamic offset.

struct MaskUniform {
    // x, y: the mask's texels; z: its layer.
    size: vec4<u32>,
    // x: cutoff; y: the factor's alpha; z: 1 when the mask has a texture.
    test: vec4<f32>,
};

@group(1) @binding(0) var alpha_masks: texture_2d_array<f32>;
@group(1) @binding(1) var<uniform> alpha_mask: MaskUniform;

// The texel of coordinate `c` (wrapped) on an axis of `n` texels.
fn mask_texel(c: f32, n: u32) -> i32 {
    let f = (c - floor(c)) * f32(n);
    return i32(clamp(floor(f), 0.0, f32(n - 1u)));
}

// Whether the point with texture coordinates `uv` blocks light.
fn mask_blocks(uv: vec2<f32>) -> bool {
    var alpha = alpha_mask.test.y;
    if (alpha_mask.test.z > 0.5) {
        let t = vec2<i32>(mask_texel(uv.x, alpha_mask.size.x), mask_texel(uv.y, alpha_mask.size.y));
        alpha = alpha * textureLoad(alpha_masks, t, i32(alpha_mask.size.z), 0).r;
    }
    return alpha >= alpha_mask.test.x;
}

// What a masked caster's vertex stage hands a fragment stage that needs no more than the holes.
struct MaskedPosition {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

// Drops the fragment where the mask is a hole (fragment stages only).
fn drop_holes(uv: vec2<f32>) {
    if (!mask_blocks(uv)) {
        discard;
    }
}
