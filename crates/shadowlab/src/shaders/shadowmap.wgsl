// Shadow-map views and lookups shared by the map-based techniques (see shadowlab_core::lightspace).
// Depths are reversed Z: larger is closer to the light.

struct ShadowView {
    view_proj: mat4x4<f32>,
    // xyz: eye; w: 1 for orthographic views.
    eye: vec4<f32>,
    // xyz: unit axis; w: texel scale (world size of a texel, per unit distance for perspective views).
    axis: vec4<f32>,
};

// The cube face of a direction, in the layer order +X, −X, +Y, −Y, +Z, −Z.
fn cube_face(d: vec3<f32>) -> u32 {
    let a = abs(d);
    if (a.x >= a.y && a.x >= a.z) {
        return select(1u, 0u, d.x >= 0.0);
    }
    if (a.y >= a.z) {
        return select(3u, 2u, d.y >= 0.0);
    }
    return select(5u, 4u, d.z >= 0.0);
}

// World size of one shadow-map texel at p.
fn shadow_texel_size(v: ShadowView, p: vec3<f32>) -> f32 {
    if (v.eye.w > 0.5) {
        return v.axis.w;
    }
    return v.axis.w * max(dot(p - v.eye.xyz, v.axis.xyz), 0.0);
}

// Map coordinates (u, v in [0, 1], v down) and reversed-Z depth of p.
fn shadow_project(v: ShadowView, p: vec3<f32>) -> vec3<f32> {
    let c = v.view_proj * vec4<f32>(p, 1.0);
    let ndc = c.xyz / c.w;
    return vec3<f32>(0.5 * ndc.x + 0.5, 0.5 - 0.5 * ndc.y, ndc.z);
}

// True when a projected point lies on the map (outside it nothing is known: treat as lit).
fn shadow_on_map(uvz: vec3<f32>) -> bool {
    return all(uvz.xy >= vec2<f32>(0.0)) && all(uvz.xy <= vec2<f32>(1.0)) && uvz.z >= 0.0 && uvz.z <= 1.0;
}

// Interleaved gradient noise (Jimenez 2014, "Next Generation Post Processing in Call of Duty"):
// a per-pixel value in [0, 1) for rotating filter kernels.
fn interleaved_gradient_noise(pixel: vec2<f32>) -> f32 {
    return fract(52.9829189 * fract(dot(pixel, vec2<f32>(0.06711056, 0.00583715))));
}
