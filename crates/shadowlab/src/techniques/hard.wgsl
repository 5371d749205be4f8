// `hard`: one nearest comparison per pixel against the light's shadow map.

// #include "per_pixel.wgsl"
// #include "maplookup.wgsl"

fn pixel_visibility(pixel: vec2<u32>) -> f32 {
    let s = load_surface(pixel);
    var v = 1.0;
    if (s.relevant) {
        let mp = map_point(s.p, s.n, light_vector(light, s.p).xyz, 0u);
        if (mp.on_map) {
            v = map_tap(mp, vec2<f32>(0.0), mp.layer);
        }
    }
    return v;
}
