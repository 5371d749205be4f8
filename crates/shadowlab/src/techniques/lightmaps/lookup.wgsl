// Receiver light maps looked up: pixels on a patch (in its plane, facing its side, inside its
// rectangle) take V = R / G of the patch's texture, bilinearly; every other pixel keeps what the
// wrapped technique wrote.

// #include "resolve.wgsl"

struct Patch {
    // xyz: the rectangle's corner; w: its width.
    origin: vec4<f32>,
    // xyz: width axis; w: height.
    axis_u: vec4<f32>,
    // xyz: height axis; w: the texture layer.
    axis_v: vec4<f32>,
    // xyz: the receiving side's normal; w: the plane's offset (n · p).
    plane: vec4<f32>,
    // x, y: texels across width and height; z: the plane tolerance (world units); w: 1 if filled.
    texels: vec4<f32>,
};

struct Patches {
    // x: patches; y, z: the texture layers' size in texels.
    count: vec4<f32>,
};

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
        let pa = patches[k];
        if (pa.texels.w < 0.5 || abs(dot(pa.plane.xyz, s.p) - pa.plane.w) > pa.texels.z || dot(s.n, pa.plane.xyz) < 0.5) {
            continue;
        }
        let d = s.p - pa.origin.xyz;
        let u = dot(d, pa.axis_u.xyz);
        let v = dot(d, pa.axis_v.xyz);
        if (u < 0.0 || v < 0.0 || u > pa.origin.w || v > pa.axis_u.w) {
            continue;
        }
        // Texel coordinates, kept half a texel inside the patch so that bilinear taps stay on it.
        let t = clamp(
            vec2<f32>(u / pa.origin.w * pa.texels.x, v / pa.axis_u.w * pa.texels.y),
            vec2<f32>(0.5),
            pa.texels.xy - vec2<f32>(0.5),
        );
        let m = textureSampleLevel(light_maps, light_map_sampler, t / patch_count.count.yz, i32(pa.axis_v.w + 0.5), 0.0);
        let v_out = select(0.0, m.x / m.y, m.y > 0.0);
        textureStore(visibility_out, pixel, vec4<f32>(clamp(v_out, 0.0, 1.0)));
        return;
    }
}
