// Shared by the shadow-volume shaders: the per-pass uniform, casters and counters.

const CAPS_NONE: u32 = 0u;
// Light caps only, for the ZP+ start pass (of the casters the skip test lists).
const CAPS_ZP_PLUS: u32 = 1u;
// Light and dark caps, for z-fail.
const CAPS_ZFAIL: u32 = 2u;

const CASTER_TWO_SIDED: u32 = 1u;
const CASTER_MIRRORED: u32 = 2u;
const CASTER_ZP_PLUS: u32 = 4u;

struct VolumePass {
    // World → clip for volumes: the camera's image with infinite reversed depth
    // (shadowlab_core::volumes::VolumeCamera::volume_matrix).
    volume_matrix: mat4x4<f32>,
    // ZP+: clip = zp_matrix · (x − zp_origin, 1).
    zp_matrix: mat4x4<f32>,
    zp_origin: vec4<f32>,
    // xyz: light position (w = 1) or direction of travel (w = 0).
    light: vec4<f32>,
    // Frustum planes through the scissor rectangle, and the near plane.
    planes: array<vec4<f32>, 5>,
    // x: casters of this pass, y: the first of them, z: faces, w: edges.
    counts: vec4<u32>,
    // x: caps (CAPS_*), y: cull polygons against `planes`.
    options: vec4<u32>,
    // Vertex regions (sides, light caps, dark caps): capacity and first vertex.
    capacity: vec4<u32>,
    base: vec4<u32>,
};

struct Caster {
    model: mat4x4<f32>,
    // x: first face, y: faces, z: first edge, w: edges, in the shared topology buffers.
    ranges: vec4<u32>,
    // x: first face work item (its first sign), y: first edge work item.
    work: vec2<u32>,
    flags: u32,
    pad: u32,
};

struct Counters {
    // Vertices reserved per region; [3]: reservations refused for lack of room.
    counts: array<atomic<u32>, 4>,
    // Three indirect draws (vertex count, instance count, first vertex, first instance).
    draws: array<u32, 12>,
};
