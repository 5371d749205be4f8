// Receiver light maps' patches (`lightmaps`): planar rectangles whose pixels take their visibility
// from a texture in the patch's plane.

struct Patch {
    // xyz: the rectangle's corner; w: its width.
    origin: vec4<f32>,
    // xyz: width axis; w: height.
    axis_u: vec4<f32>,
    // xyz: height axis; w: the texture layer.
    axis_v: vec4<f32>,
    // xyz: the receiving side's normal; w: the plane's offset (n · p).
    plane: vec4<f32>,
    // x, y: texels across width and height; z: the plane tolerance (world units); w: 1 if filled.
    texels: vec4<f32>,
};

struct Patches {
    // x: patches; y, z: the texture layers' size in texels.
    count: vec4<f32>,
};

// The texel coordinates of the surface point p (normal n) on a filled patch, kept half a texel
// inside so that bilinear taps stay on it; negative when the patch does not take the point (not
// filled, off its plane or its rectangle, facing away).
fn patch_texel(pa: Patch, p: vec3<f32>, n: vec3<f32>) -> vec2<f32> {
    if (pa.texels.w < 0.5 || abs(dot(pa.plane.xyz, p) - pa.plane.w) > pa.texels.z || dot(n, pa.plane.xyz) < 0.5) {
        return vec2<f32>(-1.0);
    }
    let d = p - pa.origin.xyz;
    let u = dot(d, pa.axis_u.xyz);
    let v = dot(d, pa.axis_v.xyz);
    if (u < 0.0 || v < 0.0 || u > pa.origin.w || v > pa.axis_u.w) {
        return vec2<f32>(-1.0);
    }
    return clamp(
        vec2<f32>(u / pa.origin.w * pa.texels.x, v / pa.axis_u.w * pa.texels.y),
        vec2<f32>(0.5),
        pa.texels.xy - vec2<f32>(0.5),
    );
}
