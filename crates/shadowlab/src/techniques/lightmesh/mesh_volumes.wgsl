// The static casters' shadows on dynamic objects from shadow volumes built on the light mesh
// (Hasselgren 2003 §3.3.2, NOTES-001 §1.9): a side quad on every boundary edge of the lit pieces,
// extruded to infinity, counted by z-pass with depth clamping instead of near clipping, from the
// eye's count (the lit pieces its segment to the light crosses; `mesh_volumes.rs`).

// #include "common.wgsl"

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var depth_texture: texture_2d<f32>;

@vertex
fn quad_vs(@location(0) v: vec4<f32>) -> @builtin(position) vec4<f32> {
    // Homogeneous world positions: w = 0 at infinity, away from the light.
    return camera.view_proj * v;
}

// Z-pass: only the volume fragments in front of the visible surface count. The depth test is made
// here against the G-buffer's depth (in the camera's own convention), so the stencil needs no depth
// copy; clamped depths in front of the near plane stay in front.
@fragment
fn quad_fs(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    let d = textureLoad(depth_texture, vec2<i32>(frag.xy), 0).r;
    if (is_background(camera, d)) {
        discard;
    }
    let reversed = camera.depth.x < 0.5;
    // In front by a margin: a quad that starts on the visible surface itself (the edge of a lit
    // patch lies on its receiver) must not count along that edge (reversed depth: 1e-4 of the
    // distance; standard depth has absolute precision).
    let nearer_standard = frag.z < d - 1e-6;
    let nearer_reversed = frag.z > d * (1.0 + 1e-4);
    let in_front = select(nearer_standard, nearer_reversed, reversed);
    if (!in_front) {
        discard;
    }
    // Not written (the colour mask is empty): only the stencil changes.
    return vec4<f32>(0.0);
}

@vertex
fn mask_vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_position(i);
}

// Drawn where the count is not 0: in the static casters' shadow.
@fragment
fn mask_fs() -> @location(0) vec4<f32> {
    return vec4<f32>(1.0);
}

@group(1) @binding(0) var<storage, read_write> fill: array<atomic<u32>>;

// Counts every rasterised quad fragment, in all and per pixel (as `volumes`' fill pass: the
// `render --overlay fill` view).
@fragment
fn fill_fs(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    atomicAdd(&fill[0], 1u);
    atomicAdd(&fill[4u + u32(frag.y) * u32(camera.size.x) + u32(frag.x)], 1u);
    return vec4<f32>(0.0);
}
