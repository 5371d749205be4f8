// `lightmesh` resolve: the pixels the light mesh lit (`mesh.wgsl`), the shadow masks of the dynamic
// casters' volumes and of the static casters' volumes over dynamic receivers → V (Hasselgren 2003
// §3.1), in one pass.

// #include "resolve.wgsl"

struct Combine {
    // The static volumes' meaningful pixels: x, y, width, height (width 0: none).
    focus: vec4<u32>,
    // x: dynamic casters' volumes are drawn (else they are 1); y: the light has a light mesh (else
    // the static volumes hold everywhere: a dynamic light); z: the static volumes are drawn (else 1).
    flags: vec4<u32>,
};

@group(1) @binding(0) var lit_mask: texture_2d<f32>;
// The volumes' shadow masks (1 in shadow): the dynamic casters', the static casters'.
@group(1) @binding(1) var dynamic_mask: texture_2d<f32>;
@group(1) @binding(2) var static_mask: texture_2d<f32>;
@group(1) @binding(3) var<uniform> combine: Combine;

@compute @workgroup_size(8, 8)
fn resolve(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_frame(id.xy)) {
        return;
    }
    let q = vec2<i32>(id.xy);
    let s = load_surface(id.xy);
    var v = 1.0;
    if (s.relevant) {
        // Static casters: the light mesh on static receivers; on the others (dynamic objects, in
        // the focus rectangle) the static casters' volumes; elsewhere a pixel not in the light mesh
        // is a static receiver in static shadow. A dynamic light has the volumes everywhere.
        var volumes_v = 1.0;
        if (combine.flags.z != 0u) {
            volumes_v = 1.0 - textureLoad(static_mask, q, 0).r;
        }
        let f = combine.focus;
        let in_focus = id.x >= f.x && id.y >= f.y && id.x < f.x + f.z && id.y < f.y + f.w;
        var static_v = 0.0;
        let mark = textureLoad(lit_mask, q, 0);
        if (combine.flags.y == 0u) {
            static_v = volumes_v;
        } else if (mark.g > 0.5) {
            static_v = mark.r;
        } else if (in_focus) {
            static_v = volumes_v;
        }
        var dynamic_v = 1.0;
        if (combine.flags.x != 0u) {
            dynamic_v = 1.0 - textureLoad(dynamic_mask, q, 0).r;
        }
        v = static_v * dynamic_v;
    }
    textureStore(visibility_out, id.xy, vec4<f32>(v));
}
