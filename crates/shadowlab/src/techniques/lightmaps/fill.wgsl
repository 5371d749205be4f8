// Receiver light maps, filled one emitter sample at a time (Toromanoff 2005 alg. F–H): the casters
// are drawn from the sample through a frustum whose far plane is the receiver's plane and whose
// window is the receiver's rectangle, so each covered pixel IS a light-map texel in shadow; a
// stencil marks them with the sample's number in its render pass. Two full-screen draws then add
// the sample's weight w to every texel's total (G) and to the lit sum (R) where the stencil holds
// another number (no caster of this sample was drawn): V = R / G.

// #include "common.wgsl"
// #include "instance.wgsl"
// #include "alpha_mask.wgsl"

struct Fill {
    // Clip = projection × world: the sample's frustum onto the patch rectangle.
    projection: mat4x4<f32>,
    // xyz: the rectangle's corner; w: its width (world units).
    origin: vec4<f32>,
    // xyz: the width axis; w: the height.
    axis_u: vec4<f32>,
    // xyz: the height axis; w: 1 when the sample is hidden behind the receiver's plane.
    axis_v: vec4<f32>,
    // xyz: sphere normal at the sample; w: 1 when samples are weighted by projected area.
    sphere: vec4<f32>,
    // xyz: the light's centre; w: texels across the rectangle's width.
    centre: vec4<f32>,
    // x: texels across its height; y: the emitter's radius or tan of its angular radius
    // (smoothies); z: 1 for a directional light, whose unit direction towards it is then in
    // `sphere.xyz`.
    texels: vec4<f32>,
};

@group(0) @binding(0) var<uniform> fill: Fill;

@vertex
fn occluder_vs(v: InstancedVertex) -> @builtin(position) vec4<f32> {
    return fill.projection * instance_world(v);
}

@fragment
fn occluder_fs() -> @location(0) vec4<f32> {
    return vec4<f32>(0.0);
}

// Alpha-masked casters: their holes leave the stencil unmarked (`alpha_mask.wgsl`, group 1).
@vertex
fn occluder_masked_vs(v: InstancedVertex, @location(11) uv: vec2<f32>) -> MaskedPosition {
    return MaskedPosition(fill.projection * instance_world(v), uv);
}

@fragment
fn occluder_masked_fs(in: MaskedPosition) -> @location(0) vec4<f32> {
    drop_holes(in.uv);
    return vec4<f32>(0.0);
}

@vertex
fn screen_vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_position(i);
}

// The receiver's point at the texel under `frag`.
fn texel_point(frag: vec4<f32>) -> vec3<f32> {
    let u = frag.x / fill.centre.w * fill.origin.w;
    let v = frag.y / fill.texels.x * fill.axis_u.w;
    return fill.origin.xyz + fill.axis_u.xyz * u + fill.axis_v.xyz * v;
}

// The sample's weight at the texel under `frag`: its projected area seen from there (sphere lights).
fn weight(frag: vec4<f32>) -> f32 {
    if (fill.sphere.w < 0.5) {
        return 1.0;
    }
    return max(dot(fill.sphere.xyz, normalize(texel_point(frag) - fill.centre.xyz)), 0.0);
}

// Texels no caster covered: lit (unless the sample is behind the plane).
@fragment
fn lit_fs(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    let w = weight(frag);
    let lit = select(1.0, 0.0, fill.axis_v.w > 0.5);
    return vec4<f32>(lit * w, w, 0.0, 0.0);
}

// Texels a caster covered: the weight counts, the light does not.
@fragment
fn shadowed_fs(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(0.0, weight(frag), 0.0, 0.0);
}

// Smoothie fill (Chan & Durand 2003; Toromanoff 2005 alg. E in light maps): the casters' smoothies
// drawn through the centre's frustum; each texel keeps the least visibility of the smoothies over
// it (blend min), the smoothie's distance from the silhouette over the outer penumbra's width
// between the smoothie (blocker) and this texel (receiver). The umbra is the hard stencil's.
struct SmoothieOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) offset: f32,
};

@vertex
fn smoothie_vs(@location(0) v: vec4<f32>) -> SmoothieOut {
    var out: SmoothieOut;
    out.clip = fill.projection * vec4<f32>(v.xyz, 1.0);
    out.world = v.xyz;
    out.offset = v.w;
    return out;
}

@fragment
fn smoothie_fs(in: SmoothieOut) -> @location(0) vec4<f32> {
    let p = texel_point(in.clip);
    var width = 0.0;
    if (fill.texels.z > 0.5) {
        // The sun: tan θ times the smoothie's distance from the receiver along the light.
        let n = cross(fill.axis_u.xyz, fill.axis_v.xyz);
        let gap = dot(in.world - p, n) / max(dot(n, fill.sphere.xyz), 1.0e-6);
        width = fill.texels.y * max(gap, 0.0);
    } else {
        // R·(1 − b/r) for a blocker at b and a receiver at r from the light's centre.
        let b = distance(in.world, fill.centre.xyz);
        let r = distance(p, fill.centre.xyz);
        width = fill.texels.y * max(r - b, 0.0) / max(r, 1.0e-9);
    }
    return vec4<f32>(clamp(in.offset / max(width, 1.0e-9), 0.0, 1.0), 1.0, 0.0, 0.0);
}

// The hard umbra (stencil marked by the casters): no light.
@fragment
fn umbra_fs() -> @location(0) vec4<f32> {
    return vec4<f32>(0.0, 1.0, 0.0, 0.0);
}

// The sums' start where a scissor limits a refill (a load op would clear the whole layer).
@fragment
fn zero_fs() -> @location(0) vec4<f32> {
    return vec4<f32>(0.0);
}
