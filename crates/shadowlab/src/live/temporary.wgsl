// Temporary (dragged) objects: the light's visibility as its technique wrote it (group 2), times
// the hard shadow of each temporary object's own map (group 1, one view per map, not a cube).

// #include "resolve.wgsl"
// #include "maplookup.wgsl"

struct Temporary {
    // x: views.
    counts: vec4<u32>,
};

@group(2) @binding(0) var raw_visibility: texture_2d<f32>;
@group(2) @binding(1) var<uniform> temporary: Temporary;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = region_pixel(id);
    if (!in_frame(pixel)) {
        return;
    }
    var v = textureLoad(raw_visibility, vec2<i32>(pixel), 0).r;
    let s = load_surface(pixel);
    if (s.relevant && v > 0.0) {
        let l = light_vector(light, s.p).xyz;
        for (var k = 0u; k < temporary.counts.x; k = k + 1u) {
            let view = shadow_views[k];
            // Behind a perspective view's eye the projection flips: nothing of this map is there.
            if (view.eye.w < 0.5 && dot(s.p - view.eye.xyz, view.axis.xyz) <= 0.0) {
                continue;
            }
            let mp = map_point(s.p, s.n, l, k);
            if (all(mp.uvz.xy >= vec2<f32>(0.0)) && all(mp.uvz.xy <= vec2<f32>(1.0))) {
                // Beyond the far plane (depth < 0) a receiver is farther than everything stored.
                v = v * map_tap_z(mp, vec2<f32>(0.0), mp.layer, clamp(mp.uvz.z, 0.0, 1.0));
            }
        }
    }
    textureStore(visibility_out, pixel, vec4<f32>(v));
}
