// `hard`: one nearest comparison per pixel against the light's shadow map.

// #include "resolve.wgsl"
// #include "maplookup.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = region_pixel(id);
    if (!in_frame(pixel)) {
        return;
    }
    let s = load_surface(pixel);
    var v = 1.0;
    if (s.relevant) {
        let mp = map_point(s.p, s.n, light_vector(light, s.p).xyz, 0u);
        if (mp.on_map) {
            v = map_tap(mp, vec2<f32>(0.0), mp.layer);
        }
    }
    textureStore(visibility_out, pixel, vec4<f32>(v));
}
