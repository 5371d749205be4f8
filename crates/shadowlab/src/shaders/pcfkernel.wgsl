// Percentage-closer filtering over a kernel of taps (group 2), on top of maplookup.wgsl.

// #include "footprint.wgsl"

struct Kernel {
    // x: taps; y: radius; z: 1 when the radius is in world units (else texels); w: 1 to rotate.
    params: vec4<f32>,
    // xy: tap offset in the unit square (box) or disk (Poisson).
    taps: array<vec4<f32>, 64>,
    // x: the largest blur in screen pixels (`max_blur`; 0: unbounded).
    limits: vec4<f32>,
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
// compared with the receiver's plane there (receiver-plane depth bias, `rp.xy` from
// `receiver_plane`): a wide kernel compared with the centre's depth darkens lit slopes; and
// closer by the crease bias `rp.z` × its reach (its offset, and the texels a bilinear tap reads up
// to 1/√2 texel from its point), so that it does not darken the foot of a wall.
//
// With `max_blur` set and `footprint` (`pixel_texels`; 0: none) given, the blur stays within
// `max_blur` pixels of the screen (so that a map whose texels cover many pixels, near the eye or on
// a surface the light grazes, does not spread an edge over metres of a lit street): the radius
// is at most that many pixels' footprint, and where that is under a texel each bilinear tap's
// ramp between texels is narrowed to it (`map_tap_sharp`).
fn pcf_filter(mp: MapPoint, layer: u32, radius: f32, pixel: vec2<u32>, rp: vec3<f32>, footprint: f32) -> f32 {
    var rot = mat2x2<f32>(1.0, 0.0, 0.0, 1.0);
    if (kernel.params.w > 0.5) {
        let a = 6.2831853 * interleaved_gradient_noise(vec2<f32>(pixel));
        rot = mat2x2<f32>(cos(a), sin(a), -sin(a), cos(a));
    }
    let n = max(u32(kernel.params.x), 1u);
    var r = radius;
    // The width of a tap's ramp between texels, in texels (1: plain bilinear).
    var ramp = 1.0;
    if (kernel.limits.x > 0.0 && footprint > 0.0) {
        let blur = kernel.limits.x * footprint;
        r = min(r, blur);
        ramp = clamp(blur, 1.0e-3, 1.0);
    }
    let reach = select(0.0, 0.7071 * ramp, map_params.mode.x > 0.5);
    var sum = 0.0;
    for (var i = 0u; i < n; i = i + 1u) {
        let o = rot * kernel.taps[i].xy * r;
        sum = sum + map_tap_sharp(mp, o, layer, mp.uvz.z + dot(rp.xy, o) + rp.z * (length(o) + reach), ramp);
    }
    return sum / f32(n);
}

// `pcf_filter` at surface `s` (its receiver plane and footprint), giving way to the point's own
// texel on a facet that the light grazes (`filter_weight`).
fn surface_filter(mp: MapPoint, layer: u32, radius: f32, pixel: vec2<u32>, s: Surface) -> f32 {
    let w = filter_weight(pixel, s);
    var v = 0.0;
    if (w > 0.0) {
        v = pcf_filter(mp, layer, radius, pixel, receiver_plane(mp, s.p, s.n), pixel_texels(mp, s, pixel));
    }
    if (w < 1.0) {
        v = mix(centre_tap(mp, layer), v, w);
    }
    return v;
}
