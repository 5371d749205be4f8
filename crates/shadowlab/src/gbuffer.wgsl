// G-buffer pass: world normal (+ shininess), albedo (+ specular strength), emission, geometric
// normal; reversed-Z depth.

// #include "common.wgsl"

@group(0) @binding(0) var<uniform> camera: Camera;
// The material's base colour texture (sRGB, so sampled linear), white where it has none.
@group(1) @binding(0) var base_colour: texture_2d<f32>;
@group(1) @binding(1) var base_colour_sampler: sampler;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) model0: vec4<f32>,
    @location(3) model1: vec4<f32>,
    @location(4) model2: vec4<f32>,
    @location(5) model3: vec4<f32>,
    @location(6) normal0: vec4<f32>,
    @location(7) normal1: vec4<f32>,
    @location(8) normal2: vec4<f32>,
    @location(9) albedo_specular: vec4<f32>,
    @location(10) material: vec4<f32>,
    @location(11) uv: vec2<f32>,
};

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) albedo_specular: vec4<f32>,
    @location(2) material: vec4<f32>,
    // Position relative to the eye: small, so its screen derivatives keep their precision.
    @location(3) eye_relative: vec3<f32>,
    @location(4) uv: vec2<f32>,
};

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    let model = mat4x4<f32>(v.model0, v.model1, v.model2, v.model3);
    let normal_matrix = mat3x3<f32>(v.normal0.xyz, v.normal1.xyz, v.normal2.xyz);
    var out: VertexOut;
    let world = model * vec4<f32>(v.position, 1.0);
    out.clip = camera.view_proj * world;
    out.eye_relative = world.xyz - camera.position.xyz;
    out.normal = normal_matrix * v.normal;
    out.albedo_specular = v.albedo_specular;
    out.material = v.material;
    out.uv = v.uv;
    return out;
}

struct GBufferOut {
    @location(0) normal: vec4<f32>,
    @location(1) albedo: vec4<f32>,
    @location(2) emissive: vec4<f32>,
    @location(3) geometric_normal: vec4<f32>,
};

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> GBufferOut {
    // The facet's normal: screen derivatives of a triangle's interpolated position lie in its
    // plane (helper pixels of a 2×2 quad extrapolate the same triangle). Turned towards the eye,
    // it is N_g as DESIGN.md §3 defines it for either side of a surface.
    var ng = normalize(cross(dpdx(in.eye_relative), dpdy(in.eye_relative)));
    if (dot(ng, in.eye_relative) > 0.0) {
        ng = -ng;
    }
    var n = normalize(in.normal);
    // Only double-sided surfaces show their back (single-sided backs are culled): face the viewer.
    if (!front) {
        n = -n;
    }
    var out: GBufferOut;
    out.normal = vec4<f32>(n, in.material.x);
    let texel = textureSample(base_colour, base_colour_sampler, in.uv);
    out.albedo = vec4<f32>(in.albedo_specular.rgb * texel.rgb, in.albedo_specular.a);
    out.emissive = vec4<f32>(in.material.yzw, 1.0);
    out.geometric_normal = vec4<f32>(ng, 0.0);
    return out;
}
