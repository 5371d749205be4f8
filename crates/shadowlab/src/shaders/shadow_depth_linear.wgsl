// Depth pass of a warped shadow map (LiSPSM, PSM): the rasteriser places casters through the warped
// view, but the depth stored is the light-space depth `depth · (p, 1)` (shadowlab_core::lightspace::
// ShadowView::linear_depth). It is affine in the world, so a perspective-correct varying carries it
// exactly, where the warp's own z/w would lose the far half of the view below a float's step.

struct RenderView {
    matrix: mat4x4<f32>,
    depth: vec4<f32>,
};

@group(0) @binding(0) var<uniform> light_view: RenderView;

// Slope-scaled bias in units of the depth's slope per texel, as the raster depth bias of the plain
// pass (which a written depth does not take).
override slope_bias: f32 = 0.0;

// #include "instance.wgsl"
// #include "alpha_mask.wgsl"

struct Out {
    @builtin(position) clip: vec4<f32>,
    @location(0) depth: f32,
};

@vertex
fn vs_main(v: InstancedVertex) -> Out {
    let p = instance_world(v);
    return Out(light_view.matrix * p, dot(light_view.depth, p));
}

@fragment
fn fs_main(in: Out) -> @builtin(frag_depth) f32 {
    // Reversed Z: the bias pushes the stored depth away from the light (smaller).
    let slope = max(abs(dpdx(in.depth)), abs(dpdy(in.depth)));
    return clamp(in.depth - slope_bias * slope, 0.0, 1.0);
}

// Alpha-masked casters: as above, with the texture coordinates and a fragment stage that drops the
// holes.
struct MaskedOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) depth: f32,
    @location(1) uv: vec2<f32>,
};

@vertex
fn vs_masked(v: InstancedVertex, @location(11) uv: vec2<f32>) -> MaskedOut {
    let p = instance_world(v);
    return MaskedOut(light_view.matrix * p, dot(light_view.depth, p), uv);
}

@fragment
fn fs_masked(in: MaskedOut) -> @builtin(frag_depth) f32 {
    drop_holes(in.uv);
    let slope = max(abs(dpdx(in.depth)), abs(dpdy(in.depth)));
    return clamp(in.depth - slope_bias * slope, 0.0, 1.0);
}
