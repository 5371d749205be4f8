// Analysis overlay of a light's shadow maps (Stingl 2011, §5.2): per pixel, the map (split, cube
// face) that shades it, the shadow-map texels per screen pixel (Lloyd's determinant, Listing A.3) and
// whether the pixel lies on a texel-grid line (Listing A.4). Colours are applied on the CPU.

// #include "resolve.wgsl"
// #include "selection.wgsl"

struct OverlayParams {
    // x: texels between grid lines.
    grid: vec4<f32>,
};

@group(2) @binding(0) var<uniform> overlay: OverlayParams;
@group(2) @binding(1) var overlay_out: texture_storage_2d<rgba32float, write>;

// The unbiased map coordinates (in texels) of the surface at `pixel` in view `view`, or a negative w
// for background and pixels outside the frame.
fn texel_coords(pixel: vec2<i32>, view: u32) -> vec3<f32> {
    if (pixel.x < 0 || pixel.y < 0 || f32(pixel.x) >= camera.size.x || f32(pixel.y) >= camera.size.y) {
        return vec3<f32>(0.0, 0.0, -1.0);
    }
    let depth = textureLoad(depth_texture, pixel, 0).r;
    if (is_background(camera, depth)) {
        return vec3<f32>(0.0, 0.0, -1.0);
    }
    let p = world_from_depth(camera, vec2<u32>(pixel), depth);
    return vec3<f32>(shadow_project(shadow_views[view], p).xy * map_params.bias.z, 1.0);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_frame(id.xy)) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let depth = textureLoad(depth_texture, pixel, 0).r;
    if (is_background(camera, depth)) {
        textureStore(overlay_out, id.xy, vec4<f32>(-1.0, 0.0, 0.0, 0.0));
        return;
    }
    let p = world_from_depth(camera, id.xy, depth);
    let l = light_vector(light, p).xyz;
    let i = select_split(p, vec3<f32>(0.0), l, view_depth(camera, p), 0.0);
    let mp = map_point(p, vec3<f32>(0.0), l, i);
    let st = mp.uvz.xy * map_params.bias.z;
    // Screen-space derivatives by finite differences with a neighbour (the one on the same surface).
    var dx = texel_coords(pixel + vec2<i32>(1, 0), mp.layer);
    var sx = 1.0;
    if (dx.z < 0.0) {
        dx = texel_coords(pixel - vec2<i32>(1, 0), mp.layer);
        sx = -1.0;
    }
    var dy = texel_coords(pixel + vec2<i32>(0, 1), mp.layer);
    var sy = 1.0;
    if (dy.z < 0.0) {
        dy = texel_coords(pixel - vec2<i32>(0, 1), mp.layer);
        sy = -1.0;
    }
    let ds_dx = select(vec2<f32>(0.0), (dx.xy - st) * sx, dx.z > 0.0);
    let ds_dy = select(vec2<f32>(0.0), (dy.xy - st) * sy, dy.z > 0.0);
    let area = abs(ds_dx.x * ds_dy.y - ds_dy.x * ds_dx.y);
    let g = max(overlay.grid.x, 1.0);
    let m = fract(st / g);
    let line = m.x < length(vec2<f32>(ds_dx.x, ds_dy.x)) / g || m.y < length(vec2<f32>(ds_dx.y, ds_dy.y)) / g;
    textureStore(overlay_out, id.xy, vec4<f32>(f32(mp.layer), area, select(0.0, 1.0, line), select(0.0, 1.0, mp.on_map)));
}
