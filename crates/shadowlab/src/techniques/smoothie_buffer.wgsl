// `smoothies`: the smoothie buffer (Chan & Durand 2003). Smoothie quads rendered from the light's
// views; the nearest one per texel keeps its distance from the silhouette (world units) and its
// depth.

struct ViewProjection {
    matrix: mat4x4<f32>,
};

@group(0) @binding(0) var<uniform> light_view: ViewProjection;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) offset: f32,
};

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(1) offset: f32) -> VertexOut {
    var out: VertexOut;
    out.clip = light_view.matrix * vec4<f32>(position, 1.0);
    out.offset = offset;
    return out;
}

// x: distance from the silhouette; y: the smoothie's reversed-Z depth (f32 bits: the target is
// Rg32Uint, renderable everywhere).
@fragment
fn fs_main(v: VertexOut) -> @location(0) vec2<u32> {
    return bitcast<vec2<u32>>(vec2<f32>(v.offset, v.clip.z));
}
