// Shadow-volume extraction on the GPU (no geometry shaders in wgpu): one thread per caster face
// decides whether it occludes and emits its caps; one thread per caster edge counts the signs of
// the faces around it and emits its side quads. The rules are those of the CPU reference,
// shadowlab_core::volumes (silhouettes by net edge counting, Hasselgren 2003 §2.3; caps for z-fail,
// NOTES-001 §1.4), which the tests compare against.

// #include "volumes_common.wgsl"

// Welded object-space positions of every mesh (w unused).
@group(0) @binding(0) var<storage, read> positions: array<vec4<f32>>;
// Faces: welded vertex indices (absolute) and w = 1 for degenerate faces.
@group(0) @binding(1) var<storage, read> triangles: array<vec4<u32>>;
// Edges: welded vertices a < b (absolute), the first of their uses, the number of uses.
@group(0) @binding(2) var<storage, read> edges: array<vec4<u32>>;
// Uses: the face (relative to its mesh) in the low 31 bits; the top bit when it runs a → b.
@group(0) @binding(3) var<storage, read> uses: array<u32>;

@group(1) @binding(0) var<storage, read> casters: array<Caster>;
// One sign per face of this pass's casters: 1 occludes as wound, −1 turned over, 0 not at all.
@group(1) @binding(1) var<storage, read_write> signs: array<i32>;
@group(1) @binding(2) var<storage, read_write> out_vertices: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read_write> counters: Counters;
@group(1) @binding(4) var<uniform> pass_info: VolumePass;

fn work_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

// The caster whose work range holds `g`: the last one whose first item (x: faces, y: edges) ≤ g.
fn find_caster(g: u32, edge_items: bool) -> u32 {
    var lo = 0u;
    var hi = pass_info.counts.x;
    loop {
        if (hi - lo <= 1u) {
            break;
        }
        let mid = (lo + hi) / 2u;
        let c = casters[pass_info.counts.y + mid];
        let first = select(c.work.x, c.work.y, edge_items);
        if (first <= g) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return pass_info.counts.y + lo;
}

fn world_position(c: Caster, v: u32) -> vec3<f32> {
    return (c.model * vec4<f32>(positions[v].xyz, 1.0)).xyz;
}

// The homogeneous point at infinity that p extrudes to, away from the light.
fn extrude(p: vec3<f32>) -> vec4<f32> {
    if (pass_info.light.w > 0.5) {
        return vec4<f32>(p - pass_info.light.xyz, 0.0);
    }
    return vec4<f32>(pass_info.light.xyz, 0.0);
}

fn towards_light(p: vec3<f32>) -> vec3<f32> {
    if (pass_info.light.w > 0.5) {
        return pass_info.light.xyz - p;
    }
    return -pass_info.light.xyz;
}

// A polygon is culled when all its vertices lie outside one frustum plane (Hasselgren 2003
// §3.3.1.2); homogeneous plane tests are exact for vertices at infinity too.
fn outside(v0: vec4<f32>, v1: vec4<f32>, v2: vec4<f32>, v3: vec4<f32>) -> bool {
    if (pass_info.options.y == 0u) {
        return false;
    }
    for (var i = 0u; i < 5u; i = i + 1u) {
        let p = pass_info.planes[i];
        if (dot(p, v0) < 0.0 && dot(p, v1) < 0.0 && dot(p, v2) < 0.0 && dot(p, v3) < 0.0) {
            return true;
        }
    }
    return false;
}

// Reserves `n` vertices of region `r` (0 sides, 1 light caps, 2 dark caps); returns the first one
// or 0xffffffff when the region is full (counted, and reported by the technique's stats).
fn reserve(r: u32, n: u32) -> u32 {
    let first = atomicAdd(&counters.counts[r], n);
    if (first + n > pass_info.capacity[r]) {
        atomicAdd(&counters.counts[3], 1u);
        return 0xffffffffu;
    }
    return pass_info.base[r] + first;
}

@compute @workgroup_size(64)
fn faces(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let g = work_index(gid, groups);
    if (g >= pass_info.counts.z) {
        return;
    }
    let c = casters[find_caster(g, false)];
    let t = triangles[c.ranges.x + g - c.work.x];
    var s = 0;
    if (t.w == 0u) {
        let a = world_position(c, t.x);
        let b = world_position(c, t.y);
        let d = world_position(c, t.z);
        var facing = dot(cross(b - a, d - a), towards_light((a + b + d) / 3.0));
        if ((c.flags & CASTER_MIRRORED) != 0u) {
            facing = -facing;
        }
        if (facing > 0.0) {
            s = 1;
        } else if ((c.flags & CASTER_TWO_SIDED) != 0u && facing < 0.0) {
            s = -1;
        }
        let caps = pass_info.options.x;
        let zp_listed = (c.flags & CASTER_ZP_PLUS) != 0u;
        if (s != 0 && (caps == CAPS_ZFAIL || (caps == CAPS_ZP_PLUS && zp_listed))) {
            // Wound to face the light (a mirror turns the winding over once more).
            var o = s;
            if ((c.flags & CASTER_MIRRORED) != 0u) {
                o = -o;
            }
            var q1 = b;
            var q2 = d;
            if (o < 0) {
                q1 = d;
                q2 = b;
            }
            let f0 = vec4<f32>(a, 1.0);
            let f1 = vec4<f32>(q1, 1.0);
            let f2 = vec4<f32>(q2, 1.0);
            // ZP+ draws the light caps from the light: camera culling does not apply.
            if (caps == CAPS_ZP_PLUS || !outside(f0, f1, f2, f2)) {
                let at = reserve(1u, 3u);
                if (at != 0xffffffffu) {
                    out_vertices[at] = f0;
                    out_vertices[at + 1u] = f1;
                    out_vertices[at + 2u] = f2;
                }
            }
            // Dark caps: the faces at infinity, reversed. A directional light extrudes every
            // vertex to the same point, so its dark cap vanishes.
            if (caps == CAPS_ZFAIL && pass_info.light.w > 0.5) {
                let i0 = extrude(a);
                let i1 = extrude(q1);
                let i2 = extrude(q2);
                if (!outside(i0, i1, i2, i2)) {
                    let at = reserve(2u, 3u);
                    if (at != 0xffffffffu) {
                        out_vertices[at] = i0;
                        out_vertices[at + 1u] = i2;
                        out_vertices[at + 2u] = i1;
                    }
                }
            }
        }
    }
    signs[g] = s;
}

@compute @workgroup_size(64)
fn sides(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let g = work_index(gid, groups);
    if (g >= pass_info.counts.w) {
        return;
    }
    let c = casters[find_caster(g, true)];
    let e = edges[c.ranges.z + g - c.work.y];
    var net = 0;
    for (var u = e.z; u < e.z + e.w; u = u + 1u) {
        let use_ = uses[u];
        let s = signs[c.work.x + (use_ & 0x7fffffffu)];
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
    if ((net < 0) != ((c.flags & CASTER_MIRRORED) != 0u)) {
        va = e.y;
        vb = e.x;
    }
    let a = world_position(c, va);
    let b = world_position(c, vb);
    let fa = vec4<f32>(a, 1.0);
    let fb = vec4<f32>(b, 1.0);
    let ia = extrude(a);
    let ib = extrude(b);
    if (outside(fa, fb, ia, ib)) {
        return;
    }
    // A directional light's quad is one infinite triangle (a∞ = b∞).
    let point_light = pass_info.light.w > 0.5;
    let per_quad = select(3u, 6u, point_light);
    let n = u32(abs(net));
    let at = reserve(0u, per_quad * n);
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

// Turns the counters into the three indirect draws (sides, light caps, dark caps).
@compute @workgroup_size(1)
fn finish() {
    for (var r = 0u; r < 3u; r = r + 1u) {
        let n = min(atomicLoad(&counters.counts[r]), pass_info.capacity[r]);
        counters.draws[r * 4u] = n - n % 3u;
        counters.draws[r * 4u + 1u] = 1u;
        counters.draws[r * 4u + 2u] = pass_info.base[r];
        counters.draws[r * 4u + 3u] = 0u;
    }
}
