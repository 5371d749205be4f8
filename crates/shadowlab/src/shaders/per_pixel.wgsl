// The entry points of a resolve that computes each pixel's visibility on its own: the including
// shader defines `fn pixel_visibility(pixel: vec2<u32>) -> f32`. A compute shader over the region
// (8 × 8 workgroups), or, with FRAGMENT (devices without compute: WebGL2), a fragment shader
// writing the render target. Both are `main`.

// #include "resolve.wgsl"

// #ifdef FRAGMENT
@fragment
fn main(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(pixel_visibility(vec2<u32>(position.xy)));
}
// #else
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = region_pixel(id);
    if (!in_frame(pixel)) {
        return;
    }
    textureStore(visibility_out, pixel, vec4<f32>(pixel_visibility(pixel)));
}
// #endif
