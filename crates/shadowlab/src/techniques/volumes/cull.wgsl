// A drag step's region (FrameContext::region): which casters' volumes can change its count.
//
// A closed volume that holds no surface point of the region adds nothing to any of its pixels'
// counts as long as it is left out of every draw: z-fail counts the volumes behind the surface;
// ZP+ starts at the count of the near plane (its light caps from the light) and counts in front
// of the surface, so a volume entered and left before the surface adds 0 to both or to neither.
// Plain z-pass starts at 0, so the casters its plan lists as reaching the near pyramid are kept
// whatever the surface (flag KEEP, `plan::CullInputs::push_sample`; none when `auto` chose
// z-pass), and a robust z-pass, whose start was counted at the eye, is not culled here at all.
// `region_bounds` (one invocation per pixel) bounds the region's relevant surface points (the only
// pixels whose resolve reads the mask); then one workgroup per light sample (`cull`) tests that box
// against each caster's shadow hulls
// (shadowlab_core::volumes::shadow_hull of its box and of its triangles' parts), writing the
// sample's indirect draws with the casters that miss it set to no instance. The CPU's own test
// (`plan::region_casters`) can only use the region's frustum; this one sees the surface that is
// actually there.

// #include "resolve.wgsl"

// Under a wrapper that overwrites some pixels after this resolve (`lightmaps`' filled receivers:
// `technique::Covered`), those pixels' counts do not matter and their surface is left out.
// #ifdef COVERED
// #include "patches.wgsl"
@group(2) @binding(0) var<uniform> covered_count: Patches;
@group(2) @binding(1) var<storage, read> covered_patches: array<Patch>;

fn covered(s: Surface) -> bool {
    let n = u32(covered_count.count.x + 0.5);
    for (var k = 0u; k < n; k = k + 1u) {
        if (patch_texel(covered_patches[k], s.p, s.n).x >= 0.0) {
            return true;
        }
    }
    return false;
}
// #else
fn covered(s: Surface) -> bool {
    return false;
}
// #endif

// The half-spaces n·p + w ≥ 0 bounding a caster's volumes; `count` 0: unbounded (the light is
// in its box).
struct Hull {
    planes: array<vec4<f32>, 10>,
    count: vec4<u32>,
};

// One (sample, caster) to test: x its item in the store, y its first hull (its box's), z the
// hulls of its parts that follow, w flags.
struct CullCaster {
    data: vec4<u32>,
};

const KEEP: u32 = 1u;

// `firsts[0]`: items in the store (the stride between the draws of two regions); light sample s
// (workgroup s) tests `casters[firsts[s + 1] .. firsts[s + 2]]`.
@group(1) @binding(0) var<storage, read> firsts: array<u32>;
@group(1) @binding(1) var<storage, read> hulls: array<Hull>;
@group(1) @binding(2) var<storage, read> casters: array<CullCaster>;
@group(1) @binding(3) var<storage, read> draws_in: array<u32>;
@group(1) @binding(4) var<storage, read_write> draws_out: array<u32>;
// The region's surface points: 0–2 the complement of the smallest coordinate's `ordered`, 3–5 the
// largest's, 6 the farthest distance from the eye; zero (cleared) when there is none. Every
// `ordered` of a number is above zero, so the maxima start from the cleared buffer.
@group(1) @binding(5) var<storage, read_write> bounds: array<atomic<u32>, 8>;

const GROUP: u32 = 64u;

// An order-preserving map of f32 onto u32 (negative values reversed below the positive ones).
fn ordered(x: f32) -> u32 {
    let b = bitcast<u32>(x);
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

fn unordered(u: u32) -> f32 {
    return bitcast<f32>(select(~u, u & 0x7fffffffu, (u & 0x80000000u) != 0u));
}

// Whether some point of the box (centre c, half extent h) may lie inside the hull.
fn meets(hull: u32, c: vec3<f32>, h: vec3<f32>) -> bool {
    let n = hulls[hull].count.x;
    for (var i = 0u; i < n; i = i + 1u) {
        let pl = hulls[hull].planes[i];
        if (dot(pl.xyz, c) + dot(abs(pl.xyz), h) + pl.w < 0.0) {
            return false;
        }
    }
    return true;
}

// One invocation per pixel of the region: a pass over the pixels of its own, rather than loops in
// `cull`'s workgroups, since CPU adapters end an invocation's loops past a budget (llvmpipe:
// 65 535 iterations; ssm.wgsl, `loop_budget`), which a large region with light-map receivers to
// test per pixel would pass, leaving the box too small and culling casters that count.
@compute @workgroup_size(8, 8)
fn region_bounds(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = region.rect.zw;
    if (id.x >= size.x || id.y >= size.y) {
        return;
    }
    let pixel = region.rect.xy + id.xy;
    if (!in_frame(pixel)) {
        return;
    }
    let s = load_surface(pixel);
    if (!s.relevant || covered(s)) {
        return;
    }
    for (var a = 0u; a < 3u; a = a + 1u) {
        atomicMax(&bounds[a], ~ordered(s.p[a]));
        atomicMax(&bounds[3u + a], ordered(s.p[a]));
    }
    atomicMax(&bounds[6], ordered(distance(s.p, camera.position.xyz)));
}

@compute @workgroup_size(64)
fn cull(@builtin(local_invocation_index) t: u32, @builtin(workgroup_id) wg: vec3<u32>) {
    var lo = vec3<f32>(0.0);
    var hi = vec3<f32>(0.0);
    for (var a = 0u; a < 3u; a = a + 1u) {
        lo[a] = unordered(~atomicLoad(&bounds[a]));
        hi[a] = unordered(atomicLoad(&bounds[3u + a]));
    }
    let empty = atomicLoad(&bounds[3]) == 0u;
    // The depth buffer's round-off and the reconstruction's: 1e-4 of the distance to the eye on
    // every axis (reversed-Z f32 depth holds about 1e-6 of it).
    let pad = vec3<f32>(1.0e-4 * unordered(atomicLoad(&bounds[6])) + 1.0e-6);
    let c = 0.5 * (lo + hi);
    let h = 0.5 * (hi - lo) + pad;
    let which = wg.x;
    let items = firsts[0];
    for (var k = firsts[which + 1u] + t; k < firsts[which + 2u]; k = k + GROUP) {
        let d = casters[k].data;
        var keep = (d.w & KEEP) != 0u;
        if (!keep && !empty) {
            keep = meets(d.y, c, h);
            if (keep && d.z > 0u) {
                keep = false;
                for (var p = 0u; p < d.z; p = p + 1u) {
                    if (meets(d.y + 1u + p, c, h)) {
                        keep = true;
                        break;
                    }
                }
            }
        }
        // Sides, light caps and dark caps: draws of 4 words (vertex count, instances, first
        // vertex, first instance), one region after the other.
        for (var r = 0u; r < 3u; r = r + 1u) {
            let at = 4u * (r * items + d.x);
            draws_out[at] = draws_in[at];
            draws_out[at + 1u] = select(0u, draws_in[at + 1u], keep);
            draws_out[at + 2u] = draws_in[at + 2u];
            draws_out[at + 3u] = draws_in[at + 3u];
        }
    }
}
