// Shadow-volume extraction on the GPU (no geometry shaders in wgpu), one job per (light sample,
// caster) whose cached volume is stale: one thread per face decides whether it occludes and emits
// its light and dark caps; one thread per edge counts the signs of the faces around it and emits
// its side quads. Everything any counting method needs is extracted, and nothing depends on the
// camera: the stencil passes choose which regions to draw. The rules are those of the CPU
// reference, shadowlab_core::volumes (silhouettes by net edge counting, Hasselgren 2003 §2.3; caps
// for z-fail, NOTES-001 §1.4), which the tests compare against.

// #include "volumes_common.wgsl"

// Welded object-space positions of every mesh (w unused).
@group(0) @binding(0) var<storage, read> positions: array<vec4<f32>>;
// Faces: welded vertex indices (absolute) and w = 1 for degenerate faces.
@group(0) @binding(1) var<storage, read> triangles: array<vec4<u32>>;
// Edges: welded vertices a < b (absolute), the first of their uses, the number of uses.
@group(0) @binding(2) var<storage, read> edges: array<vec4<u32>>;
// Uses: the face (relative to its mesh) in the low 31 bits; the top bit when it runs a → b.
@group(0) @binding(3) var<storage, read> uses: array<u32>;

@group(1) @binding(0) var<storage, read> jobs: array<Job>;
// One sign per face of this frame's jobs: 1 occludes as wound, −1 turned over, 0 not at all.
@group(1) @binding(1) var<storage, read_write> signs: array<i32>;
// The window of the vertex buffer that holds this batch's regions (from vertex extraction.first.y).
@group(1) @binding(2) var<storage, read_write> out_vertices: array<vec4<f32>>;
// First the indirect draws (vertex count, instance count, first vertex, first instance): every
// item's sides, then every item's light caps, then every item's dark caps, so that neighbouring
// items draw with one call. Then per item four counters: vertices reserved in its sides, light
// caps and dark caps, and reservations refused for lack of room. (One buffer: a shader stage
// binds at most eight storage buffers.)
@group(1) @binding(3) var<storage, read_write> counters: array<atomic<u32>>;
@group(1) @binding(4) var<uniform> extraction: Extraction;

// Counter `r` of `item`.
fn count_index(item: u32, r: u32) -> u32 {
    return 12u * extraction.counts.w + 4u * item + r;
}

fn work_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

// The job whose work range holds `g`: the last one whose first item (faces or edges) ≤ g.
fn find_job(g: u32, edge_items: bool) -> u32 {
    var lo = 0u;
    var hi = extraction.counts.x;
    loop {
        if (hi - lo <= 1u) {
            break;
        }
        let mid = (lo + hi) / 2u;
        let w = jobs[extraction.first.x + mid].work;
        let first = select(w.x, w.y, edge_items);
        if (first <= g) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return extraction.first.x + lo;
}

fn world_position(j: Job, v: u32) -> vec3<f32> {
    return (j.model * vec4<f32>(positions[v].xyz, 1.0)).xyz;
}

// The homogeneous point at infinity that p extrudes to, away from the light.
fn extrude(j: Job, p: vec3<f32>) -> vec4<f32> {
    if (j.light.w > 0.5) {
        return vec4<f32>(p - j.light.xyz, 0.0);
    }
    return vec4<f32>(j.light.xyz, 0.0);
}

fn towards_light(j: Job, p: vec3<f32>) -> vec3<f32> {
    if (j.light.w > 0.5) {
        return j.light.xyz - p;
    }
    return -j.light.xyz;
}

// Reserves `n` vertices of region `r` (0 sides, 1 light caps, 2 dark caps) of job `j`; returns the
// first one (in the window) or 0xffffffff when the region is full (counted, and reported by the
// technique's stats).
fn reserve(j: Job, r: u32, n: u32) -> u32 {
    let first = atomicAdd(&counters[count_index(j.work.z, r)], n);
    if (first + n > j.capacity[r]) {
        atomicAdd(&counters[count_index(j.work.z, 3u)], 1u);
        return 0xffffffffu;
    }
    return j.base[r] - extraction.first.y + first;
}

// Zeroes the counters of every job's item.
@compute @workgroup_size(64)
fn reset(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let g = work_index(gid, groups);
    if (g >= extraction.counts.x) {
        return;
    }
    let item = jobs[extraction.first.x + g].work.z;
    for (var r = 0u; r < 4u; r = r + 1u) {
        atomicStore(&counters[count_index(item, r)], 0u);
    }
}

@compute @workgroup_size(64)
fn faces(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let g = work_index(gid, groups);
    if (g >= extraction.counts.y) {
        return;
    }
    let j = jobs[find_job(g, false)];
    let t = triangles[j.ranges.x + g - j.work.x];
    var s = 0;
    if (t.w == 0u) {
        let a = world_position(j, t.x);
        let b = world_position(j, t.y);
        let d = world_position(j, t.z);
        var facing = dot(cross(b - a, d - a), towards_light(j, (a + b + d) / 3.0));
        if ((j.work.w & CASTER_MIRRORED) != 0u) {
            facing = -facing;
        }
        if (facing > 0.0) {
            s = 1;
        } else if ((j.work.w & CASTER_TWO_SIDED) != 0u && facing < 0.0) {
            s = -1;
        }
        if (s != 0) {
            // Light caps: the occluding faces, wound to face the light (a mirror turns the winding
            // over once more). Z-fail draws them all, ZP+ those of the casters it lists.
            var o = s;
            if ((j.work.w & CASTER_MIRRORED) != 0u) {
                o = -o;
            }
            var q1 = b;
            var q2 = d;
            if (o < 0) {
                q1 = d;
                q2 = b;
            }
            let at = reserve(j, 1u, 3u);
            if (at != 0xffffffffu) {
                out_vertices[at] = vec4<f32>(a, 1.0);
                out_vertices[at + 1u] = vec4<f32>(q1, 1.0);
                out_vertices[at + 2u] = vec4<f32>(q2, 1.0);
            }
            // Dark caps (z-fail): the faces at infinity, reversed. A directional light extrudes
            // every vertex to the same point, so its dark cap vanishes.
            if (j.light.w > 0.5) {
                let at = reserve(j, 2u, 3u);
                if (at != 0xffffffffu) {
                    out_vertices[at] = extrude(j, a);
                    out_vertices[at + 1u] = extrude(j, q2);
                    out_vertices[at + 2u] = extrude(j, q1);
                }
            }
        }
    }
    signs[g] = s;
}

@compute @workgroup_size(64)
fn sides(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let g = work_index(gid, groups);
    if (g >= extraction.counts.z) {
        return;
    }
    let j = jobs[find_job(g, true)];
    let e = edges[j.ranges.z + g - j.work.y];
    var net = 0;
    for (var u = e.z; u < e.z + e.w; u = u + 1u) {
        let use_ = uses[u];
        let s = signs[j.work.x + (use_ & 0x7fffffffu)];
        if ((use_ & 0x80000000u) != 0u) {
            net = net + s;
        } else {
            net = net - s;
        }
    }
    if (net == 0) {
        return;
    }
    // Oriented so that the occluding faces lie to the left of a → b seen from the light.
    var va = e.x;
    var vb = e.y;
    if ((net < 0) != ((j.work.w & CASTER_MIRRORED) != 0u)) {
        va = e.y;
        vb = e.x;
    }
    let a = world_position(j, va);
    let b = world_position(j, vb);
    let fa = vec4<f32>(a, 1.0);
    let fb = vec4<f32>(b, 1.0);
    let ia = extrude(j, a);
    let ib = extrude(j, b);
    // A directional light's quad is one infinite triangle (a∞ = b∞).
    let point_light = j.light.w > 0.5;
    let per_quad = select(3u, 6u, point_light);
    let n = u32(abs(net));
    let at = reserve(j, 0u, per_quad * n);
    if (at == 0xffffffffu) {
        return;
    }
    for (var k = 0u; k < n; k = k + 1u) {
        let o = at + k * per_quad;
        out_vertices[o] = fb;
        out_vertices[o + 1u] = fa;
        out_vertices[o + 2u] = ia;
        if (point_light) {
            out_vertices[o + 3u] = fb;
            out_vertices[o + 4u] = ia;
            out_vertices[o + 5u] = ib;
        }
    }
}

// Turns every job's counters into its three indirect draws (sides, light caps, dark caps).
@compute @workgroup_size(64)
fn finish(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let g = work_index(gid, groups);
    if (g >= extraction.counts.x) {
        return;
    }
    let j = jobs[extraction.first.x + g];
    let item = j.work.z;
    for (var r = 0u; r < 3u; r = r + 1u) {
        let n = min(atomicLoad(&counters[count_index(item, r)]), j.capacity[r]);
        let d = 4u * (r * extraction.counts.w + item);
        atomicStore(&counters[d], n - n % 3u);
        atomicStore(&counters[d + 1u], 1u);
        atomicStore(&counters[d + 2u], j.base[r]);
        atomicStore(&counters[d + 3u], 0u);
    }
}
