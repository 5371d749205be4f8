// Depth-only pass of a shadow map: casters transformed by the view of one map layer.

struct ViewProjection {
    matrix: mat4x4<f32>,
};

@group(0) @binding(0) var<uniform> light_view: ViewProjection;

// #include "instance.wgsl"

@vertex
fn vs_main(v: InstancedVertex) -> @builtin(position) vec4<f32> {
    return light_view.matrix * instance_world(v);
}
