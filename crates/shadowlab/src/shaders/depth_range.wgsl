// The visible depth range: min and max view depth over covered pixels, reduced per workgroup and
// then with atomics. Positive floats order like their bit patterns, so atomics on u32 work.

// #include "common.wgsl"

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var depth_texture: texture_2d<f32>;
@group(0) @binding(2) var<storage, read_write> range: array<atomic<u32>, 2>;

var<workgroup> group_min: atomic<u32>;
var<workgroup> group_max: atomic<u32>;

@compute @workgroup_size(16, 16)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    if (local == 0u) {
        atomicStore(&group_min, 0x7f7fffffu);
        atomicStore(&group_max, 0u);
    }
    workgroupBarrier();
    if (f32(id.x) < camera.size.x && f32(id.y) < camera.size.y) {
        let depth = textureLoad(depth_texture, vec2<i32>(id.xy), 0).r;
        if (!is_background(camera, depth)) {
            let d = view_depth(camera, world_from_depth(camera, id.xy, depth));
            if (d > 0.0) {
                atomicMin(&group_min, bitcast<u32>(d));
                atomicMax(&group_max, bitcast<u32>(d));
            }
        }
    }
    workgroupBarrier();
    if (local == 0u) {
        atomicMin(&range[0], atomicLoad(&group_min));
        atomicMax(&range[1], atomicLoad(&group_max));
    }
}
