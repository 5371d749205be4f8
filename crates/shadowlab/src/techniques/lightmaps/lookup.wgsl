// Receiver light maps looked up: pixels on a patch (in its plane, facing its side, inside its
// rectangle) take V = R / G of the patch's texture, bilinearly; every other pixel keeps what the
// wrapped technique wrote.

// #include "resolve.wgsl"
// #include "patches.wgsl"

@group(1) @binding(0) var<uniform> patch_count: Patches;
@group(1) @binding(1) var<storage, read> patches: array<Patch>;
@group(1) @binding(2) var light_maps: texture_2d_array<f32>;
@group(1) @binding(3) var light_map_sampler: sampler;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = region_pixel(id);
    if (!in_frame(pixel)) {
        return;
    }
    let s = load_surface(pixel);
    if (!s.relevant) {
        return;
    }
    let n = u32(patch_count.count.x + 0.5);
    for (var k = 0u; k < n; k = k + 1u) {
        let t = patch_texel(patches[k], s.p, s.n);
        if (t.x < 0.0) {
            continue;
        }
        let m = textureSampleLevel(light_maps, light_map_sampler, t / patch_count.count.yz, i32(patches[k].axis_v.w + 0.5), 0.0);
        let v_out = select(0.0, m.x / m.y, m.y > 0.0);
        textureStore(visibility_out, pixel, vec4<f32>(clamp(v_out, 0.0, 1.0)));
        return;
    }
}
