// A vertex of an instanced mesh (gpu_scene.rs: VERTEX_LAYOUT and INSTANCE_LAYOUT) for passes that
// need no more than where it is: its position and its instance's model matrix.

struct InstancedVertex {
    @location(0) position: vec3<f32>,
    @location(2) model0: vec4<f32>,
    @location(3) model1: vec4<f32>,
    @location(4) model2: vec4<f32>,
    @location(5) model3: vec4<f32>,
};

// The vertex in world space (the scene's local frame).
fn instance_world(v: InstancedVertex) -> vec4<f32> {
    return mat4x4<f32>(v.model0, v.model1, v.model2, v.model3) * vec4<f32>(v.position, 1.0);
}
