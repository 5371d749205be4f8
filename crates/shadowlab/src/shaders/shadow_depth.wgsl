// Depth-only pass of a shadow map: casters transformed by the view of one map layer.

struct ViewProjection {
    matrix: mat4x4<f32>,
};

@group(0) @binding(0) var<uniform> light_view: ViewProjection;

// #include "instance.wgsl"
// #include "alpha_mask.wgsl"

@vertex
fn vs_main(v: InstancedVertex) -> @builtin(position) vec4<f32> {
    return light_view.matrix * instance_world(v);
}

// Alpha-masked casters: the texture coordinates carried to a fragment stage that drops the holes.
@vertex
fn vs_masked(v: InstancedVertex, @location(11) uv: vec2<f32>) -> MaskedPosition {
    return MaskedPosition(light_view.matrix * instance_world(v), uv);
}

@fragment
fn fs_masked(in: MaskedPosition) {
    drop_holes(in.uv);
}
