// Percentage-closer filtering over a kernel of taps (group 2), on top of maplookup.wgsl.

// #include "maplookup.wgsl"

struct Kernel {
    // x: taps; y: radius; z: 1 when the radius is in world units (else texels); w: 1 to rotate.
    params: vec4<f32>,
    // xy: tap offset in the unit square (box) or disk (Poisson).
    taps: array<vec4<f32>, 64>,
};

@group(2) @binding(0) var<uniform> kernel: Kernel;

// The kernel radius in texels of the map at mp (world radii are divided by the texel size there).
fn kernel_radius_texels(mp: MapPoint) -> f32 {
    if (kernel.params.z > 0.5) {
        return kernel.params.y / max(mp.texel, 1.0e-12);
    }
    return kernel.params.y;
}

// The average of the kernel's comparison taps around mp in texture layer `layer`, `radius` texels
// wide; rotated per pixel (interleaved gradient noise) when the kernel asks for it. Each tap is
// compared with the receiver's plane there (receiver-plane depth bias, `g` from
// `receiver_plane_gradient`): a wide kernel compared with the centre's depth darkens lit slopes.
fn pcf_filter(mp: MapPoint, layer: u32, radius: f32, pixel: vec2<u32>, g: vec2<f32>) -> f32 {
    var rot = mat2x2<f32>(1.0, 0.0, 0.0, 1.0);
    if (kernel.params.w > 0.5) {
        let a = 6.2831853 * interleaved_gradient_noise(vec2<f32>(pixel));
        rot = mat2x2<f32>(cos(a), sin(a), -sin(a), cos(a));
    }
    let n = max(u32(kernel.params.x), 1u);
    var sum = 0.0;
    for (var i = 0u; i < n; i = i + 1u) {
        let o = rot * kernel.taps[i].xy * radius;
        sum = sum + map_tap_z(mp, o, layer, mp.uvz.z + dot(g, o));
    }
    return sum / f32(n);
}
