// Depth-only pass of a shadow map: casters transformed by the view of one map layer.

struct ViewProjection {
    matrix: mat4x4<f32>,
};

@group(0) @binding(0) var<uniform> light_view: ViewProjection;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(2) model0: vec4<f32>,
    @location(3) model1: vec4<f32>,
    @location(4) model2: vec4<f32>,
    @location(5) model3: vec4<f32>,
};

@vertex
fn vs_main(v: VertexIn) -> @builtin(position) vec4<f32> {
    let model = mat4x4<f32>(v.model0, v.model1, v.model2, v.model3);
    return light_view.matrix * (model * vec4<f32>(v.position, 1.0));
}
