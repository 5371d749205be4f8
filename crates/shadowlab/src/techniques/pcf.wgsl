// `pcf`: percentage-closer filtering (Reeves, Salesin & Cook 1987) with bilinear comparison taps.

// #include "resolve.wgsl"
// #include "maplookup.wgsl"

struct Kernel {
    // x: taps; y: radius; z: 1 when the radius is in world units (else texels); w: 1 to rotate.
    params: vec4<f32>,
    // xy: tap offset in the unit square (box) or disk (Poisson).
    taps: array<vec4<f32>, 64>,
};

@group(2) @binding(0) var<uniform> kernel: Kernel;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_frame(id.xy)) {
        return;
    }
    let s = load_surface(id.xy);
    var v = 1.0;
    if (s.relevant) {
        let mp = map_point(s.p, s.n, light_vector(light, s.p).xyz, 0u);
        if (mp.on_map) {
            var radius = kernel.params.y;
            if (kernel.params.z > 0.5) {
                radius = radius / max(mp.texel, 1.0e-12);
            }
            var rot = mat2x2<f32>(1.0, 0.0, 0.0, 1.0);
            if (kernel.params.w > 0.5) {
                let a = 6.2831853 * interleaved_gradient_noise(vec2<f32>(id.xy));
                rot = mat2x2<f32>(cos(a), sin(a), -sin(a), cos(a));
            }
            let n = u32(kernel.params.x);
            var sum = 0.0;
            for (var i = 0u; i < n; i = i + 1u) {
                sum = sum + map_tap(mp, rot * kernel.taps[i].xy * radius, mp.layer);
            }
            v = sum / f32(n);
        }
    }
    textureStore(visibility_out, id.xy, vec4<f32>(v));
}
