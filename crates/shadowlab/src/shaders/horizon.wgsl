// The receiver's own horizon: the part of an area light's emitter above the receiver's tangent
// plane. The part below is hidden by the receiver itself (the attached shadow near a terminator),
// which the truth's rays see (DESIGN.md §3: a ray below the tangent plane enters the surface) and
// a depth map cannot. Since the truth's visible part of the emitter lies inside this one, the
// minimum of a technique's visibility and this fraction is never farther from the truth than the
// technique alone, given the facet's own normal (`geometric_normal` of resolve.wgsl; with the
// shading normal in its place, 0.1% of the bunny's lit pixels darken near its terminators).
// Taken by `ssm`, `pcss`, `blurred` and `smoothies`; the CPU reference is
// shadowlab_core::backprojection::fraction_above.

// #include "lights.wgsl"

fn cross2(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return a.x * b.y - a.y * b.x;
}

// Corner i of the square [−1, 1]², counter-clockwise from (1, 1).
fn square_corner(i: i32) -> vec2<f32> {
    let k = i & 3;
    return vec2<f32>(select(-1.0, 1.0, k == 0 || k == 3), select(-1.0, 1.0, k < 2));
}

// The fraction of the normalised emitter domain (the square [−1, 1]², or the unit disk) where
// k.x + k.y u + k.z v > 0.
fn emitter_above(disk: bool, k: vec3<f32>) -> f32 {
    if (any(k != k)) {
        return 1.0;
    }
    let l = length(k.yz);
    if (l < 1.0e-12) {
        return select(0.0, 1.0, k.x > 0.0);
    }
    if (disk) {
        // The centre's signed distance to the line; the circular segment beyond it is hidden.
        let d = clamp(k.x / l, -1.0, 1.0);
        return (3.14159265 - (acos(d) - d * sqrt(max(1.0 - d * d, 0.0)))) / 3.14159265;
    }
    // Twice the area of the square clipped by the half-plane, by the shoelace formula (Green's
    // theorem) over its boundary: each side's part inside, then the chord along the cut line from
    // where the boundary leaves the half-plane to where it enters again (a convex square is cut
    // at most twice).
    var twice = 0.0;
    var leave = vec2<f32>(0.0);
    var enter = vec2<f32>(0.0);
    var cut = false;
    for (var i = 0; i < 4; i = i + 1) {
        let a = square_corner(i + 2);
        let b = square_corner(i + 3);
        let fa = k.x + dot(k.yz, a);
        let fb = k.x + dot(k.yz, b);
        if ((fa >= 0.0) != (fb >= 0.0)) {
            let x = a + (fa / (fa - fb)) * (b - a);
            cut = true;
            if (fa >= 0.0) {
                twice = twice + cross2(a, x);
                leave = x;
            } else {
                twice = twice + cross2(x, b);
                enter = x;
            }
        } else if (fa >= 0.0) {
            twice = twice + cross2(a, b);
        }
    }
    if (cut) {
        twice = twice + cross2(leave, enter);
    }
    return clamp(0.5 * twice / 4.0, 0.0, 1.0);
}

// The fraction of light l's emitter above the tangent plane (unit normal n) at p: a rectangle in
// its own plane; a sphere light as its disk facing p (radius r at distance |c − p|); the sun as
// its cone of directions in gnomonic projection (a disk of radius tan θ at distance 1). A zero-size
// emitter gives 1 in front of the plane and 0 behind it.
fn light_horizon(l: Light, p: vec3<f32>, n: vec3<f32>) -> f32 {
    let kind = light_kind(l);
    if (kind == LIGHT_RECT) {
        let half = 0.5 * l.cone.zw;
        let tangent = normalize(l.tangent.xyz);
        let bitangent = normalize(cross(l.direction.xyz, tangent));
        return emitter_above(false, vec3<f32>(dot(l.position.xyz - p, n), half.x * dot(tangent, n), half.y * dot(bitangent, n)));
    }
    var m = -l.direction.xyz;
    var along = 1.0;
    var r = tan(l.color.w);
    if (kind != LIGHT_DIRECTIONAL) {
        let d = l.position.xyz - p;
        along = length(d);
        m = d / max(along, 1.0e-30);
        r = l.color.w;
    }
    // The disk is symmetric about its centre: only the tilt of n out of m matters, not the basis.
    let c = dot(m, n);
    return emitter_above(true, vec3<f32>(along * c, r * sqrt(max(dot(n, n) - c * c, 0.0)), 0.0));
}
