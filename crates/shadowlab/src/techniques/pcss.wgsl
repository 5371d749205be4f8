// `pcss`: percentage-closer soft shadows (Fernando 2005). Blocker search, penumbra estimate from
// the average blocker distance by similar triangles, then PCF over a kernel of that size.

// #include "per_pixel.wgsl"
// #include "footprint.wgsl"
// #include "horizon.wgsl"

struct Pcss {
    // x: search taps; y: filter taps; z: 1 to rotate the disk per pixel; w: the emitter's radius
    // (perspective views) or the tangent of its angular radius (orthographic views).
    params: vec4<f32>,
    // x, y: largest search and filter radii (texels); z: smallest filter radius (texels); w: the
    // nearest distance from the light a blocker can have (the emitter's radius).
    limits: vec4<f32>,
    // xy: a progressive Poisson disk in the unit disk (every prefix well spread).
    taps: array<vec4<f32>, 64>,
};

@group(2) @binding(0) var<uniform> pcss: Pcss;

// Half the penumbra width at a receiver at distance zr for blockers at zb (Fernando 2005, Eq. 1).
fn penumbra_half_width(view: ShadowView, zr: f32, zb: f32) -> f32 {
    if (view.eye.w > 0.5) {
        return pcss.params.w * max(zr - zb, 0.0);
    }
    return pcss.params.w * max(zr - zb, 0.0) / max(zb, 1.0e-6);
}

fn pcss_visibility(mp: MapPoint, s: Surface, pixel: vec2<u32>) -> f32 {
    let p = s.p;
    let n = s.n;
    let view = shadow_views[mp.layer];
    // Each tap is compared with the receiver plane's depth there (receiver-plane depth bias). (The
    // crease bias of `pcf` is left out: over a soft penumbra's radius it hides contact shadows;
    // on the dragon under a grazing sun it took the RMSE from 0.031 to 0.042.)
    let g = receiver_plane_gradient(mp, p, n);
    let zr = shadow_distance(view, mp.uvz.z);
    var rot = mat2x2<f32>(1.0, 0.0, 0.0, 1.0);
    if (pcss.params.z > 0.5) {
        let a = 6.2831853 * interleaved_gradient_noise(vec2<f32>(pixel));
        rot = mat2x2<f32>(cos(a), sin(a), -sin(a), cos(a));
    }
    // 1. Blocker search: the blockers that can hide part of the light lie in the cone from the
    // receiver to the emitter; through the light's centre that cone covers, at the receiver's
    // distance, the penumbra of the nearest possible blocker.
    let zn = max(view.range.x, pcss.limits.w);
    let search = clamp(penumbra_half_width(view, zr, min(zn, zr)) / max(mp.texel, 1.0e-12), 1.0, pcss.limits.x);
    var sum = 0.0;
    var count = 0.0;
    let ns = max(u32(pcss.params.x), 1u);
    for (var i = 0u; i < ns; i = i + 1u) {
        let o = rot * pcss.taps[i].xy * search;
        let d = map_depth(mp, o, mp.layer);
        // Reversed Z: a larger stored depth is closer to the light.
        if (d > mp.uvz.z + dot(g, o)) {
            sum = sum + shadow_distance(view, d);
            count = count + 1.0;
        }
    }
    if (count == 0.0) {
        return 1.0;
    }
    // 2. Penumbra estimate from the average blocker distance; 3. PCF over it.
    let zb = sum / count;
    // The smallest filter only smooths the map's texels away: no wider than a pixel's footprint
    // (`pixel_texels`), and below a texel the bilinear taps' ramps narrowed to that (as `pcf`'s
    // `max_blur=1`), so that a hard light's map of metre texels does not blur every edge by metres.
    let fp = pixel_texels(mp, s, pixel);
    let floor_radius = min(pcss.limits.z, fp);
    let radius = clamp(penumbra_half_width(view, zr, zb) / max(mp.texel, 1.0e-12), floor_radius, pcss.limits.y);
    let ramp = clamp(max(radius, fp), 1.0e-3, 1.0);
    let nf = max(u32(pcss.params.y), 1u);
    var v = 0.0;
    for (var i = 0u; i < nf; i = i + 1u) {
        let o = rot * pcss.taps[i].xy * radius;
        v = v + map_tap_sharp(mp, o, mp.layer, mp.uvz.z + dot(g, o), ramp);
    }
    return v / f32(nf);
}

// The sun's angular radius, 0.27° in radians, and a little more for rounding.
const SUN_DISK: f32 = 0.0048;

fn pixel_visibility(pixel: vec2<u32>) -> f32 {
    let s = load_surface(pixel);
    var v = 1.0;
    if (s.relevant) {
        let mp = map_point(s.p, s.n, light_vector(light, s.p).xyz, 0u);
        if (mp.on_map) {
            // On a facet that the light grazes the point's own texel is the answer for an emitter
            // no larger than the sun's disk (0.27°: `SUN_DISK`); under a larger one such a facet
            // lies in real penumbrae that the filter finds (`room`'s accent lamp, 0.4–1.1° from
            // the floor: penumbra RMSE 0.105 → 0.115 with the point's texel).
            var w = 1.0;
            if (light_angular_radius(light, s.p) <= SUN_DISK) {
                w = filter_weight(pixel, s);
            }
            if (w > 0.0) {
                v = pcss_visibility(mp, s, pixel);
            }
            if (w < 1.0) {
                v = mix(centre_tap(mp, mp.layer), v, w);
            }
        }
        // The map cannot see the receiver hide part of the emitter from itself (horizon.wgsl).
        v = min(v, light_horizon(light, s.p, geometric_normal(pixel, s.n)));
    }
    return v;
}
