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
