// `pcf`: percentage-closer filtering (Reeves, Salesin & Cook 1987) with bilinear comparison taps.

// #include "per_pixel.wgsl"
// #include "pcfkernel.wgsl"

fn pixel_visibility(pixel: vec2<u32>) -> f32 {
    let s = load_surface(pixel);
    var v = 1.0;
    if (s.relevant) {
        let mp = map_point(s.p, s.n, light_vector(light, s.p).xyz, 0u);
        if (mp.on_map) {
            v = surface_filter(mp, mp.layer, kernel_radius_texels(mp), pixel, s);
        }
    }
    return v;
}
