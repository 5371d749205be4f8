// Temporary (dragged) objects: the light's visibility as its technique wrote it over the permanent
// surface (group 2), times the hard shadow of each temporary object's own map (group 1, one view
// per map, not a cube). Where the eye sees something nearer than the permanent surface (a dragged
// object), the permanent casters' hard shadow from maps of the whole scene (group 1's first
// layers) stands in for the technique's visibility, which is of the surface behind it.

// #include "resolve.wgsl"
// #include "maplookup.wgsl"

struct Temporary {
    // x: the temporary objects' views; y: the permanent views before them (layers 0..y); z: 1 when
    // those are a cube's six faces.
    counts: vec4<u32>,
};

@group(2) @binding(0) var raw_visibility: texture_2d<f32>;
// Storage, not a uniform (`util::branch_buffer`).
@group(2) @binding(1) var<storage, read> temporary: Temporary;
// The depth buffer of the permanent instances alone, from the same camera.
@group(2) @binding(2) var permanent_depth: texture_2d<f32>;

// Whether the pixel shows something the permanent surface does not have there: nearer the eye
// (reversed Z: larger). The same pipeline draws both depth buffers, so wherever they show the same
// surface they agree exactly; the tolerance is for an application's own G-buffer.
fn shows_temporary(pixel: vec2<u32>, depth: f32) -> bool {
    let behind = textureLoad(permanent_depth, vec2<i32>(pixel), 0).r;
    return depth > behind * (1.0 + 1.0e-5);
}

// The permanent casters' hard shadow at a surface point (1 lit), from the view of the whole
// scene's maps that holds it.
fn permanent_visibility(s: Surface) -> f32 {
    let views = temporary.counts.y;
    if (views == 0u) {
        return 1.0;
    }
    var k = 0u;
    if (temporary.counts.z == 1u) {
        k = cube_face(s.p - shadow_views[0].eye.xyz);
    }
    let mp = map_point(s.p, s.n, light_vector(light, s.p).xyz, k);
    if (!mp.on_map) {
        return 1.0;
    }
    return map_tap_z(mp, vec2<f32>(0.0), mp.layer, mp.uvz.z);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = region_pixel(id);
    if (!in_frame(pixel)) {
        return;
    }
    var v = textureLoad(raw_visibility, vec2<i32>(pixel), 0).r;
    let s = load_surface(pixel);
    if (s.relevant && shows_temporary(pixel, s.depth)) {
        v = permanent_visibility(s);
    }
    if (s.relevant && v > 0.0) {
        let l = light_vector(light, s.p).xyz;
        let first = temporary.counts.y;
        for (var k = first; k < first + temporary.counts.x; k = k + 1u) {
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
