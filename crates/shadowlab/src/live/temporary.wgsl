// Temporary (dragged) objects, every light in one dispatch: each light's visibility as its
// technique wrote it over the permanent surface (`raw_layers`), times the hard shadow of each
// temporary object's own map (group 3: tiles of an atlas, one view per tile, not a cube). Where the eye sees something
// nearer than the permanent surface (a dragged object), the permanent casters' hard shadow from
// the light's maps of the whole scene (group 1 too) stands in for the technique's visibility,
// which is of the surface behind it. Group 0's light and output are unused: the lights are read
// from `lights`, and the results written to `out_layers`, a light's layer in each.

// #include "resolve.wgsl"
// #include "maplookup.wgsl"

// A light of the lookup.
struct Entry {
    // The bounds of the pixels its lookup covers (unused here).
    rect: vec4<u32>,
    // x: the first temporary view, y: how many; z: the first view of the whole scene, w: how many.
    views: vec4<u32>,
    // x: 1 when the whole scene's views are a cube's six faces; y: the light's layer; w: the
    // light's index in `lights`.
    flags: vec4<u32>,
};

struct Batch {
    // x: the entries.
    count: vec4<u32>,
    entries: array<Entry>,
};

// The workgroups: each an 8 × 8 block and up to 32 lights that look it up (x: a bit per entry,
// from entry z; y: the block's position in blocks, x | y << 16). Each pixel's surface is read once
// for all its lights. Pixels of no workgroup keep the technique's visibility.
struct Work {
    // x: the workgroups.
    count: vec4<u32>,
    blocks: array<vec4<u32>>,
};

// With `DRAGGED` defined, the second lookup of a frame: over the pixels that may show a dragged
// object, which take the permanent casters' shadow instead of the technique's visibility (the
// first wrote the others).

@group(2) @binding(0) var raw_layers: texture_2d_array<f32>;
@group(2) @binding(1) var<storage, read> batch: Batch;
// The depth buffer of the permanent instances alone, from the same camera.
@group(2) @binding(2) var permanent_depth: texture_2d<f32>;
@group(2) @binding(3) var<storage, read> lights: array<Light>;
@group(2) @binding(4) var out_layers: texture_storage_2d_array<r32float, write>;
@group(2) @binding(5) var<storage, read> work: Work;

// The dragged objects' maps (`live::temporary::Atlas`): view k's map is tile k, row by row,
// `atlas_params.bias.w` tiles to a side, then the next layer. bias: x normal offset in texels,
// y constant offset, z a tile's texels a side, w tiles to a side.
// #ifdef HARDWARE_COMPARE
@group(3) @binding(0) var atlas: texture_depth_2d_array;
// #else
@group(3) @binding(0) var atlas: texture_2d_array<f32>;
// #endif
@group(3) @binding(2) var<storage, read> atlas_views: array<ShadowView>;
@group(3) @binding(3) var<uniform> atlas_params: MapParams;

// The stored depth of texel `t` of view k's tile (`t` within the tile).
fn atlas_depth(k: u32, t: vec2<i32>) -> f32 {
    let per_side = u32(atlas_params.bias.w);
    let per_layer = per_side * per_side;
    let i = k % per_layer;
    let origin = vec2<i32>(vec2<u32>(i % per_side, i / per_side)) * i32(atlas_params.bias.z);
// #ifdef HARDWARE_COMPARE
    return textureLoad(atlas, origin + t, i32(k / per_layer), 0);
// #else
    return textureLoad(atlas, origin + t, i32(k / per_layer), 0).r;
// #endif
}

// The dragged object's hard shadow at p (1 lit) in view k: `map_point` and a nearest tap as for
// any map, within the view's tile.
fn atlas_visibility(k: u32, p: vec3<f32>, n: vec3<f32>, l: vec3<f32>) -> f32 {
    let view = atlas_views[k];
    let size = atlas_params.bias.z;
    let texel = shadow_texel_size(view, p, size);
    let q = p + n * (atlas_params.bias.x * texel) + l * atlas_params.bias.y;
    let uvz = shadow_project(view, q);
    if (any(uvz.xy < vec2<f32>(0.0)) || any(uvz.xy > vec2<f32>(1.0))) {
        return 1.0;
    }
    // Beyond the far plane (depth < 0) a receiver is farther than everything stored.
    let z = clamp(uvz.z, 0.0, 1.0);
    let last = i32(size) - 1;
    let t = clamp(vec2<i32>(floor(uvz.xy * size)), vec2<i32>(0), vec2<i32>(last));
    return select(0.0, 1.0, z >= atlas_depth(k, t));
}

// Whether the pixel shows something the permanent surface does not have there: nearer the eye
// (reversed Z: larger). The same pipeline draws both depth buffers, so wherever they show the same
// surface they agree exactly; the tolerance is for an application's own G-buffer.
fn shows_temporary(pixel: vec2<u32>, depth: f32) -> bool {
    let behind = textureLoad(permanent_depth, vec2<i32>(pixel), 0).r;
    return depth > behind * (1.0 + 1.0e-5);
}

// The permanent casters' hard shadow at a surface point (1 lit), from the view of the light's
// whole-scene maps that holds it.
fn permanent_visibility(e: Entry, l: vec3<f32>, p: vec3<f32>, n: vec3<f32>) -> f32 {
    if (e.views.w == 0u) {
        return 1.0;
    }
    var k = e.views.z;
    if (e.flags.x == 1u) {
        k = k + cube_face(p - shadow_views[k].eye.xyz);
    }
    let mp = map_point(p, n, l, k);
    if (!mp.on_map) {
        return 1.0;
    }
    return map_tap_z(mp, vec2<f32>(0.0), mp.layer, mp.uvz.z);
}

@compute @workgroup_size(8, 8)
fn main(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
) {
    let item = group.x + group.y * groups.x;
    if (item >= work.count.x) {
        return;
    }
    let w = work.blocks[item];
    let pixel = vec2<u32>(w.y & 0xffffu, w.y >> 16u) * 8u + local.xy;
    if (f32(pixel.x) >= camera.size.x || f32(pixel.y) >= camera.size.y) {
        return;
    }
    let depth = read_depth(pixel);
    // The background keeps the technique's visibility, already copied into `out_layers`.
    if (is_background(camera, depth)) {
        return;
    }
// #ifdef DRAGGED
    if (!shows_temporary(pixel, depth)) {
        return;
    }
// #endif
    let p = world_from_depth(camera, pixel, depth);
    let n = normalize(textureLoad(normal_texture, vec2<i32>(pixel), 0).xyz);
    var lights_left = w.x;
    while (lights_left != 0u) {
        let e = batch.entries[w.z + countTrailingZeros(lights_left)];
        lights_left = lights_left & (lights_left - 1u);
        let layer = i32(e.flags.y);
        var v = textureLoad(raw_layers, vec2<i32>(pixel), layer, 0).r;
        let light = lights[e.flags.w];
        if (light_relevant(light, p, n)) {
            let l = light_vector(light, p).xyz;
// #ifdef DRAGGED
            v = permanent_visibility(e, l, p, n);
// #endif
            for (var k = e.views.x; k < e.views.x + e.views.y && v > 0.0; k = k + 1u) {
                let view = atlas_views[k];
                // Behind a perspective view's eye the projection flips: nothing of this map is there.
                if (view.eye.w < 0.5 && dot(p - view.eye.xyz, view.axis.xyz) <= 0.0) {
                    continue;
                }
                v = v * atlas_visibility(k, p, n, l);
            }
        }
        textureStore(out_layers, vec2<i32>(pixel), layer, vec4<f32>(v));
    }
}
