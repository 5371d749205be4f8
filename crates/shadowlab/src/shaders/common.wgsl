// Camera and surface reconstruction shared by every pass (see frame.rs: CameraUniform).

struct Camera {
    view_proj: mat4x4<f32>,
    // Inverse of projection × (view without translation): maps NDC to positions relative to the
    // eye, which keeps precision far from the origin.
    inv_view_proj_rel: mat4x4<f32>,
    // xyz: eye position.
    position: vec4<f32>,
    // width, height, 1/width, 1/height.
    size: vec4<f32>,
    // x: depth of the background (0 with reversed Z, 1 with standard Z).
    depth: vec4<f32>,
    // xyz: unit viewing direction.
    forward: vec4<f32>,
};

// Distance of p from the eye along the viewing direction.
fn view_depth(cam: Camera, p: vec3<f32>) -> f32 {
    return dot(p - cam.position.xyz, cam.forward.xyz);
}

// NDC of the centre of `pixel` (top-left origin, y up in NDC).
fn ndc_of_pixel(pixel: vec2<u32>, size: vec4<f32>) -> vec2<f32> {
    return ndc_of_point(vec2<f32>(pixel) + vec2<f32>(0.5), size);
}

// NDC of a point given in pixels (top-left origin).
fn ndc_of_point(xy: vec2<f32>, size: vec4<f32>) -> vec2<f32> {
    let uv = xy * size.zw;
    return vec2<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
}

// World position of the surface seen at `pixel` with depth-buffer value `depth`.
fn world_from_depth(cam: Camera, pixel: vec2<u32>, depth: f32) -> vec3<f32> {
    let h = cam.inv_view_proj_rel * vec4<f32>(ndc_of_pixel(pixel, cam.size), depth, 1.0);
    return cam.position.xyz + h.xyz / h.w;
}

// The point, relative to the eye, on the ray through NDC `ndc` at depth-buffer value `depth`.
fn eye_relative(cam: Camera, ndc: vec2<f32>, depth: f32) -> vec3<f32> {
    let h = cam.inv_view_proj_rel * vec4<f32>(ndc, depth, 1.0);
    return h.xyz / h.w;
}

// Where the ray through the centre of `pixel` moved by `d` pixels meets the plane through p with
// normal n; the point on that ray at depth-buffer value `depth` where ray and plane are parallel.
// (The neighbour's surface point on the pixel's plane: how far apart a pixel's samples lie there.)
fn pixel_on_plane(cam: Camera, pixel: vec2<u32>, d: vec2<f32>, depth: f32, p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let ndc = ndc_of_point(vec2<f32>(pixel) + vec2<f32>(0.5) + d, cam.size);
    let a = eye_relative(cam, ndc, depth);
    // A second point of the ray, halfway to the background's depth (finite for either Z).
    let dir = eye_relative(cam, ndc, mix(depth, cam.depth.x, 0.5)) - a;
    let den = dot(dir, n);
    let rel = p - cam.position.xyz;
    if (abs(den) < 1.0e-6 * length(dir)) {
        return cam.position.xyz + a;
    }
    return cam.position.xyz + a + dir * (dot(rel - a, n) / den);
}

fn is_background(cam: Camera, depth: f32) -> bool {
    return depth == cam.depth.x;
}

// A triangle that covers the screen: vertices 0, 1, 2.
fn fullscreen_position(vertex: u32) -> vec4<f32> {
    let x = f32((vertex << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(vertex & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}
