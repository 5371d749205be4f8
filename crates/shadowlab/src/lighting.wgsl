// Deferred lighting, DESIGN.md §3: colour = albedo·ambient + Σ_l V_l·colour_l·intensity_l·
// attenuation_l·(albedo/π·max(N·L, 0) + specular_l), one additive pass per light, then tone mapping.

// #include "common.wgsl"
// #include "lights.wgsl"

struct Environment {
    // rgb: ambient light; w: exposure.
    ambient: vec4<f32>,
    // rgb: background colour.
    background: vec4<f32>,
};

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var depth_texture: texture_2d<f32>;
@group(0) @binding(2) var normal_texture: texture_2d<f32>;
@group(0) @binding(3) var albedo_texture: texture_2d<f32>;
@group(0) @binding(4) var emissive_texture: texture_2d<f32>;
@group(0) @binding(5) var<uniform> environment: Environment;

// #ifdef SAMPLED_DEPTH
// Without compute (WebGL2) depths are read through a nearest sampler: GLES reads 0 from a depth
// texture without one (context.rs: `Shared::nearest`).
@group(0) @binding(6) var depth_sampler: sampler;

fn read_depth(pixel: vec2<i32>) -> f32 {
    let size = vec2<f32>(textureDimensions(depth_texture));
    return textureSampleLevel(depth_texture, depth_sampler, (vec2<f32>(pixel) + 0.5) / size, 0.0).r;
}
// #else
fn read_depth(pixel: vec2<i32>) -> f32 {
    return textureLoad(depth_texture, pixel, 0).r;
}
// #endif

// #ifdef SAMPLED_DEPTH
@group(1) @binding(0) var<uniform> light: Light;
// #else
// Storage where compute runs (`util::branch_buffer`).
@group(1) @binding(0) var<storage, read> light: Light;
// #endif
@group(1) @binding(1) var visibility: texture_2d<f32>;

@group(2) @binding(0) var hdr_texture: texture_2d<f32>;

const PI: f32 = 3.14159265358979;

@vertex
fn vs_fullscreen(@builtin(vertex_index) vertex: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_position(vertex);
}

// Ambient and emission (and the background), before the lights add up.
@fragment
fn fs_base(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(frag.xy);
    let depth = read_depth(pixel);
    if (is_background(camera, depth)) {
        return vec4<f32>(environment.background.rgb, 1.0);
    }
    let albedo = textureLoad(albedo_texture, pixel, 0).rgb;
    let emissive = textureLoad(emissive_texture, pixel, 0).rgb;
    return vec4<f32>(albedo * environment.ambient.rgb + emissive, 1.0);
}

// One light's contribution, scaled by its visibility layer.
@fragment
fn fs_light(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<u32>(frag.xy);
    let depth = read_depth(vec2<i32>(pixel));
    if (is_background(camera, depth)) {
        return vec4<f32>(0.0);
    }
    let p = world_from_depth(camera, pixel, depth);
    let normal = textureLoad(normal_texture, vec2<i32>(pixel), 0);
    let n = normalize(normal.xyz);
    let material = textureLoad(albedo_texture, vec2<i32>(pixel), 0);
    let l = light_vector(light, p).xyz;
    let n_dot_l = dot(n, l);
    if (n_dot_l <= 0.0) {
        return vec4<f32>(0.0);
    }
    let v = clamp(textureLoad(visibility, vec2<i32>(pixel), 0).r, 0.0, 1.0);
    // Energy-normalised Blinn-Phong (Akenine-Möller et al., Real-Time Rendering, §9.8).
    let view_dir = normalize(camera.position.xyz - p);
    let h = normalize(l + view_dir);
    let shininess = max(normal.w, 1.0);
    let specular = material.a * (shininess + 8.0) / (8.0 * PI) * pow(max(dot(n, h), 0.0), shininess);
    let radiance = light.color.rgb * light_attenuation(light, p);
    return vec4<f32>(v * radiance * (material.rgb / PI + specular) * n_dot_l, 0.0);
}

// ACES filmic curve fitted by Narkowicz (2015); the sRGB target does the encoding.
@fragment
fn fs_tonemap(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    let hdr = textureLoad(hdr_texture, vec2<i32>(frag.xy), 0).rgb * environment.ambient.w;
    let mapped = clamp((hdr * (2.51 * hdr + 0.03)) / (hdr * (2.43 * hdr + 0.59) + 0.14), vec3<f32>(0.0), vec3<f32>(1.0));
    return vec4<f32>(mapped, 1.0);
}
