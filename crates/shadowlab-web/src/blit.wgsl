// The engine's tone-mapped image (`Renderer::output_texture`, sRGB: loads return linear values)
// copied onto the page's canvas, pixel for pixel.

@group(0) @binding(0) var image: texture_2d<f32>;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // One triangle covering the viewport.
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

fn load(position: vec4<f32>) -> vec4<f32> {
    let size = vec2<i32>(textureDimensions(image));
    let p = clamp(vec2<i32>(position.xy), vec2<i32>(0), size - 1);
    return vec4<f32>(textureLoad(image, p, 0).rgb, 1.0);
}

// Into an sRGB canvas format: the hardware encodes.
@fragment
fn fs_srgb(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    return load(position);
}

// Into a plain 8-bit canvas format (what browsers offer): encoded here (IEC 61966-2-1).
@fragment
fn fs_encode(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let c = load(position).rgb;
    let low = c * 12.92;
    let high = 1.055 * pow(max(c, vec3<f32>(0.0031308)), vec3<f32>(1.0 / 2.4)) - 0.055;
    return vec4<f32>(select(high, low, c <= vec3<f32>(0.0031308)), 1.0);
}
