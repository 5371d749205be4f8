// `none`: every pixel sees the whole light.

// #include "resolve.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_frame(id.xy)) {
        return;
    }
    textureStore(visibility_out, id.xy, vec4<f32>(1.0));
}
