// A pixel's footprint in a shadow map, for filters that must not blur beyond a pixel of the screen
// (`pcf`, `cascaded`'s kernels, `pcss`'s smallest filter).

// #include "resolve.wgsl"
// #include "maplookup.wgsl"

// How far, in texels of the map at mp, a disk may reach and stay within one pixel of the screen
// in every direction: the map-space steps to where the next pixel's ray, across and down, meets the
// receiver's plane are the columns of the Jacobian J (texels per pixel); a map offset r maps back
// to at most r / σ_min(J) pixels. So the answer is J's smaller singular value, small where the
// pixel's footprint in the map is thin (a facade seen along the street, ground the light grazes).
// Never NaN.
fn pixel_texels(mp: MapPoint, s: Surface, pixel: vec2<u32>) -> f32 {
    let view = shadow_views[mp.layer];
    let o = shadow_project(view, s.p).xy;
    let x = (shadow_project(view, pixel_on_plane(camera, pixel, vec2<f32>(1.0, 0.0), s.depth, s.p, s.n)).xy - o)
        * map_params.bias.z;
    let y = (shadow_project(view, pixel_on_plane(camera, pixel, vec2<f32>(0.0, 1.0), s.depth, s.p, s.n)).xy - o)
        * map_params.bias.z;
    let a = dot(x, x);
    let b = dot(y, y);
    let c = dot(x, y);
    // The smaller eigenvalue of JᵀJ, written so that it does not cancel to below zero.
    let big = 0.5 * (a + b + sqrt((a - b) * (a - b) + 4.0 * c * c));
    let det = abs(x.x * y.y - x.y * y.x);
    let t = det / max(sqrt(big), 1.0e-20);
    // A neighbour's ray that misses the map's projection (behind a spot light, say) gives no
    // footprint: taken as unbounded, so the filter keeps its own radius.
    if (!(t >= 0.0 && t < 1.0e30)) {
        return 1.0e30;
    }
    return t;
}

// Where a filter is trusted, by the facet's own angle to the light (|N·L| of `geometric_normal`):
// not at all below GRAZING_LO (1.1° from edge-on), fully above GRAZING_HI (2.9°).
const GRAZING_LO: f32 = 0.02;
const GRAZING_HI: f32 = 0.05;

// How much of a filter to keep at a pixel: 0 on a facet that the light grazes, 1 from about 3°
// up. Such a facet projects to a sliver thinner than a texel in the map, so every texel around
// its point holds some other surface (the ledge over a chamfer the sun grazes, the wall it meets),
// nearer the light than the facet's own plane predicts; a filter's taps read them as occluders
// (Sibenik: a line of 12 lit pixels darkened to 0.61–0.75 at 128 × 96, its facets' N·L 0.0094),
// while the point's own texel, `hard`'s single test, is right. The facet's Lambert term is under
// 0.05 there, so the filter's softening is hardly missed.
fn filter_weight(pixel: vec2<u32>, s: Surface) -> f32 {
    let c = abs(dot(geometric_normal(pixel, s.n), light_vector(light, s.p).xyz));
    return smoothstep(GRAZING_LO, GRAZING_HI, c);
}

// The point's own texel in view `layer`, compared as `hard` compares it (a bilinear sampler's
// ramp narrowed to nothing).
fn centre_tap(mp: MapPoint, layer: u32) -> f32 {
    return map_tap_sharp(mp, vec2<f32>(0.0), layer, mp.uvz.z, 1.0e-3);
}
