// The stencil passes of shadow volumes: the surface depth converted to the volumes' depth mapping,
// the volumes themselves, the ZP+ start pass from the light, and a fragment counter for the fill
// statistics.

// #include "common.wgsl"
// #include "volumes_common.wgsl"

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var depth_texture: texture_2d<f32>;
@group(0) @binding(2) var<uniform> pass_info: VolumePass;

// Light caps lie on the occluders' own lit faces. Pushed back by this factor on depth (relative
// 1e-5 of the distance, well above f32 round-off of 1e-7), z-fail sees them behind those faces,
// where they belong: the face is on the boundary of its own volume, and lit.
const CAP_PUSH: f32 = 0.99999;
// ... and by at least this much depth: where depth has a fixed absolute precision rather than
// float precision near 0 (wgpu's GL backend maps it through [-1, 1]: about 2^-24 everywhere), a
// relative push of far caps is lost in round-off. 2^-21 is 8 such steps and half the volumes'
// infinity depth (INFINITY_DEPTH = 2^-20), so a pushed cap stays in front of infinity.
const DEPTH_NUDGE: f32 = 4.76837158203125e-7;

@vertex
fn copy_vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_position(i);
}

struct DepthOut {
    @builtin(frag_depth) depth: f32,
};

// The surface's depth (in whatever convention the application's camera has) in the volumes'
// infinite reversed mapping; the background goes behind infinity.
@fragment
fn copy_fs(@builtin(position) frag: vec4<f32>) -> DepthOut {
    let pixel = vec2<u32>(frag.xy);
    let d = textureLoad(depth_texture, vec2<i32>(pixel), 0).r;
    var out: DepthOut;
    out.depth = 0.0;
    if (!is_background(camera, d)) {
        let c = pass_info.volume_matrix * vec4<f32>(world_from_depth(camera, pixel, d), 1.0);
        out.depth = clamp(c.z / c.w, 0.0, 1.0);
    }
    return out;
}

@vertex
fn side_vs(@location(0) v: vec4<f32>) -> @builtin(position) vec4<f32> {
    return pass_info.volume_matrix * v;
}

@vertex
fn cap_vs(@location(0) v: vec4<f32>) -> @builtin(position) vec4<f32> {
    let c = pass_info.volume_matrix * v;
    return vec4<f32>(c.xy, c.z * CAP_PUSH - DEPTH_NUDGE * c.w, c.w);
}

@vertex
fn zp_vs(@location(0) v: vec4<f32>) -> @builtin(position) vec4<f32> {
    return pass_info.zp_matrix * vec4<f32>(v.xyz - pass_info.zp_origin.xyz, 1.0);
}

// Receiver cropping (Toromanoff 2005 alg. 12): receivers seen in front mark the stencil's top
// bit, pulled towards the camera by this factor (relative 1e-5 of the distance, and at least
// DEPTH_NUDGE) so that they pass the depth test against their own copied depth.
const RECEIVER_PULL: f32 = 1.00001;

struct ReceiverIn {
    @location(0) position: vec3<f32>,
    @location(2) m0: vec4<f32>,
    @location(3) m1: vec4<f32>,
    @location(4) m2: vec4<f32>,
    @location(5) m3: vec4<f32>,
};

@vertex
fn receiver_vs(v: ReceiverIn) -> @builtin(position) vec4<f32> {
    let world = mat4x4<f32>(v.m0, v.m1, v.m2, v.m3) * vec4<f32>(v.position, 1.0);
    let c = pass_info.volume_matrix * world;
    return vec4<f32>(c.xy, min(c.z * RECEIVER_PULL + DEPTH_NUDGE * c.w, c.w), c.w);
}

@group(1) @binding(0) var<storage, read_write> fill: array<atomic<u32>>;

// Counts every rasterised volume fragment: the fill rate shadow volumes are known for, in all
// (fill[0]) and per pixel (from fill[4], row by row: the `render --overlay fill` heat image,
// Hasselgren 2003 Fig. 8). (Cropped receivers' fragments are counted too: there the stencil test
// rejects the update, not the rasterisation.)
@fragment
fn fill_fs(@builtin(position) frag: vec4<f32>) {
    atomicAdd(&fill[0], 1u);
    atomicAdd(&fill[4u + u32(frag.y) * u32(camera.size.x) + u32(frag.x)], 1u);
}

// The value a mask draw writes where its stencil test passes (see `MaskDraw` in mod.rs): a pixel
// is in shadow when its stencil count is positive (Haines 1994's signed crossings), or odd with
// the invert stencil (Kilgard 2001); the top bit marks cropped receivers.
override mask_value: f32 = 1.0;

@fragment
fn mask_fs() -> @location(0) vec4<f32> {
    return vec4<f32>(mask_value);
}
