// Shared by the shadow-volume shaders: the per-sample stencil uniform, the extraction jobs and
// their counters.

const CASTER_TWO_SIDED: u32 = 1u;
const CASTER_MIRRORED: u32 = 2u;

// One light sample's stencil passes (camera-dependent; the extracted volumes are not).
struct VolumePass {
    // World → clip for volumes: the camera's image with infinite reversed depth
    // (shadowlab_core::volumes::VolumeCamera::volume_matrix).
    volume_matrix: mat4x4<f32>,
    // ZP+: clip = zp_matrix · (x − zp_origin, 1).
    zp_matrix: mat4x4<f32>,
    zp_origin: vec4<f32>,
};

// One (light sample, caster) extraction into the caster's own regions of the volume store
// (geometry.rs: Job).
struct Job {
    model: mat4x4<f32>,
    // xyz: the sample's position (w = 1) or direction of travel (w = 0).
    light: vec4<f32>,
    // x: first face, y: faces, z: first edge, w: edges, in the shared topology buffers.
    ranges: vec4<u32>,
    // x: first face work item (its first sign), y: first edge work item, z: its item (counters
    // and draws), w: CASTER_* flags.
    work: vec4<u32>,
    // First vertex and capacity of its regions (x: sides, y: light caps, z: dark caps).
    base: vec4<u32>,
    capacity: vec4<u32>,
};

// One batch of this frame's extraction.
struct Extraction {
    // x: jobs, y: face work items, z: edge work items, w: items in the store (the stride between
    // the draws of two regions).
    counts: vec4<u32>,
    // x: the batch's first job, y: the first vertex of the window of the vertex buffer it binds.
    first: vec4<u32>,
};
