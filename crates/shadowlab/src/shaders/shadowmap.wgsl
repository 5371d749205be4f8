// Shadow-map views and lookups shared by the map-based techniques (see shadowlab_core::lightspace).
// Depths are reversed Z: larger is closer to the light.

struct ShadowView {
    view_proj: mat4x4<f32>,
    // xyz: eye; w: 1 for orthographic views.
    eye: vec4<f32>,
    // xyz: unit axis; w: texel scale (world size of a texel, per unit distance for perspective views).
    axis: vec4<f32>,
    // x, y: near and far distances along the axis; z: the texture layer that holds the view's map
    // (views may share layers, or switch between a cached static map and its composite copy);
    // w: 1 when the map stores the linear depth dot(depth, (p, 1)) (a warped map).
    range: vec4<f32>,
    depth: vec4<f32>,
};

// The cube face of a direction, in the layer order +X, −X, +Y, −Y, +Z, −Z.
fn cube_face(d: vec3<f32>) -> u32 {
    let a = abs(d);
    if (a.x >= a.y && a.x >= a.z) {
        return select(1u, 0u, d.x >= 0.0);
    }
    if (a.y >= a.z) {
        return select(3u, 2u, d.y >= 0.0);
    }
    return select(5u, 4u, d.z >= 0.0);
}

// Map coordinates (u, v in [0, 1], v down) and reversed-Z depth of p.
fn shadow_project(v: ShadowView, p: vec3<f32>) -> vec3<f32> {
    let c = v.view_proj * vec4<f32>(p, 1.0);
    let ndc = c.xyz / c.w;
    let z = select(ndc.z, dot(v.depth, vec4<f32>(p, 1.0)), v.range.w > 0.5);
    return vec3<f32>(0.5 * ndc.x + 0.5, 0.5 - 0.5 * ndc.y, z);
}

// The distance along the view's axis of a point stored at reversed-Z depth z (inverting
// lightspace::perspective_reversed and orthographic_reversed).
fn shadow_distance(v: ShadowView, z: f32) -> f32 {
    let n = v.range.x;
    let f = v.range.y;
    if (v.eye.w > 0.5) {
        return f - z * (f - n);
    }
    return n * f / max(z * (f - n) + n, 1.0e-20);
}

// World size of one shadow-map texel at p (the larger side of its footprint across the light
// ray), measured through the view's own projection so that it holds for warped maps too.
fn shadow_texel_size(v: ShadowView, p: vec3<f32>, map_size: f32) -> f32 {
    var ray = v.axis.xyz;
    var nominal = v.axis.w;
    if (v.eye.w < 0.5) {
        ray = normalize(p - v.eye.xyz);
        nominal = v.axis.w * max(dot(p - v.eye.xyz, v.axis.xyz), 1.0e-6);
    }
    var t = cross(ray, vec3<f32>(0.0, 1.0, 0.0));
    if (dot(t, t) < 1.0e-6) {
        t = cross(ray, vec3<f32>(1.0, 0.0, 0.0));
    }
    t = normalize(t);
    let b = cross(ray, t);
    let o = shadow_project(v, p).xy;
    let du = length(shadow_project(v, p + t * nominal).xy - o) * map_size;
    let dv = length(shadow_project(v, p + b * nominal).xy - o) * map_size;
    return nominal / max(min(du, dv), 1.0e-9);
}


// True when a projected point lies on the map (outside it nothing is known: treat as lit).
fn shadow_on_map(uvz: vec3<f32>) -> bool {
    return all(uvz.xy >= vec2<f32>(0.0)) && all(uvz.xy <= vec2<f32>(1.0)) && uvz.z >= 0.0 && uvz.z <= 1.0;
}

// Interleaved gradient noise (Jimenez 2014, "Next Generation Post Processing in Call of Duty"):
// a per-pixel value in [0, 1) for rotating filter kernels.
fn interleaved_gradient_noise(pixel: vec2<f32>) -> f32 {
    return fract(52.9829189 * fract(dot(pixel, vec2<f32>(0.06711056, 0.00583715))));
}
