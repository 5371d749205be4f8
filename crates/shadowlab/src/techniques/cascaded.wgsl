// `cascaded`: focused, warped, z-partitioned shadow maps (Stingl 2011). Each split is a layer of the
// map array with its own view; the pixel's split is chosen by depth or best resolution, its kernel
// scaled to keep the world-space softness of split 0 (Eq. 3.9), and optionally blended with the next
// split inside a band at the split's far end.

// #include "per_pixel.wgsl"
// #include "pcfkernel.wgsl"
// #include "selection.wgsl"

fn split_visibility(i: u32, s: Surface, l: vec3<f32>, pixel: vec2<u32>) -> f32 {
    let mp = map_point(s.p, s.n, l, i);
    if (!mp.on_map) {
        return 1.0;
    }
    var radius = kernel_radius_texels(mp);
    if (selection.params.w > 0.5 && i > 0u) {
        // A radius in split-0 texels: the same world size in every split (Eq. 3.9).
        let t0 = shadow_texel_size(shadow_views[0], s.p, map_params.bias.z);
        radius = radius * t0 / max(mp.texel, 1.0e-12);
    }
    return surface_filter(mp, i, radius, pixel, s);
}

fn pixel_visibility(pixel: vec2<u32>) -> f32 {
    let s = load_surface(pixel);
    var v = 1.0;
    if (s.relevant) {
        let l = light_vector(light, s.p).xyz;
        let depth = view_depth(camera, s.p);
        let i = select_split(s.p, s.n, l, depth, kernel.params.y + 2.0);
        v = split_visibility(i, s, l, pixel);
        let band = selection.params.z;
        if (band > 0.0 && i + 1u < split_count()) {
            let lo = split_distance(i);
            let hi = split_distance(i + 1u);
            let start = hi - band * (hi - lo);
            if (depth > start) {
                let t = clamp((depth - start) / max(hi - start, 1.0e-6), 0.0, 1.0);
                v = mix(v, split_visibility(i + 1u, s, l, pixel), t);
            }
        }
    }
    return v;
}
