// The hierarchical shadow map of `ssm` (Guennebaud et al. 2006, 2007 §3): a pyramid over each
// view's map whose texels hold the nearest and the farthest stored depth they cover (reversed Z:
// the largest and the smallest). Level 1 is reduced from the map, each further level from the last.

// #include "resolve.wgsl"
// #include "maplookup.wgsl"

struct Reduce {
    // x: level written (≥ 1); y: its offset in a view's block; z: its side; w: texels per view.
    dst: vec4<u32>,
    // x: level read; y: its offset (levels ≥ 1); z: its side.
    src: vec4<u32>,
};

@group(2) @binding(0) var<uniform> reduce: Reduce;
@group(2) @binding(1) var<storage, read_write> hsm: array<vec2<f32>>;

fn source(view: u32, t: vec2<u32>) -> vec2<f32> {
    if (reduce.src.x == 0u) {
        let d = stored_depth(vec2<i32>(t), view);
        return vec2<f32>(d, d);
    }
    return hsm[view * reduce.dst.w + reduce.src.y + t.y * reduce.src.z + t.x];
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let side = reduce.dst.z;
    if (id.x >= side || id.y >= side) {
        return;
    }
    let view = id.z;
    var out = vec2<f32>(0.0, 1.0);
    for (var dy = 0u; dy < 2u; dy = dy + 1u) {
        for (var dx = 0u; dx < 2u; dx = dx + 1u) {
            let t = 2u * id.xy + vec2<u32>(dx, dy);
            if (t.x < reduce.src.z && t.y < reduce.src.z) {
                let d = source(view, t);
                out = vec2<f32>(max(out.x, d.x), min(out.y, d.y));
            }
        }
    }
    hsm[view * reduce.dst.w + reduce.dst.y + id.y * side + id.x] = out;
}
