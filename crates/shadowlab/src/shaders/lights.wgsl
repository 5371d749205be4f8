// Lights on the GPU: the same relevance and attenuation as shadowlab_core::light::Light.

const LIGHT_POINT: u32 = 0u;
const LIGHT_SPOT: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;
const LIGHT_RECT: u32 = 3u;

struct Light {
    // xyz: position (unused for directional lights); w: kind.
    position: vec4<f32>,
    // xyz: emission direction (spot axis, rectangle normal, direction of travel); w: range (0: none).
    direction: vec4<f32>,
    // rgb: colour × intensity; w: emitter radius (point, spot) or angular radius (directional).
    color: vec4<f32>,
    // x: cos of the inner cone half-angle, y: cos outer; z, w: rectangle width and height.
    cone: vec4<f32>,
    // xyz: rectangle tangent (width axis).
    tangent: vec4<f32>,
};

fn light_kind(l: Light) -> u32 {
    return u32(l.position.w + 0.5);
}

// Unit direction from p towards the light's centre (xyz) and the distance to it (w).
fn light_vector(l: Light, p: vec3<f32>) -> vec4<f32> {
    if (light_kind(l) == LIGHT_DIRECTIONAL) {
        return vec4<f32>(-l.direction.xyz, 1.0e30);
    }
    let d = l.position.xyz - p;
    let len = length(d);
    if (len <= 0.0) {
        return vec4<f32>(0.0, 1.0, 0.0, 0.0);
    }
    return vec4<f32>(d / len, len);
}

// The angle the emitter subtends from p, from its centre to its farthest edge, in radians (0: a
// hard light; a rectangle's half-diagonal over its distance).
fn light_angular_radius(l: Light, p: vec3<f32>) -> f32 {
    let kind = light_kind(l);
    if (kind == LIGHT_DIRECTIONAL) {
        return l.color.w;
    }
    var r = l.color.w;
    if (kind == LIGHT_RECT) {
        r = 0.5 * length(l.cone.zw);
    }
    let d = length(l.position.xyz - p);
    return asin(clamp(r / max(d, 1.0e-12), 0.0, 1.0));
}

// DESIGN.md §3: the light's centre is in front of the surface, within range, inside a spot's cone
// and in front of a one-sided rectangle.
fn light_relevant(l: Light, p: vec3<f32>, n: vec3<f32>) -> bool {
    let v = light_vector(l, p);
    if (dot(n, v.xyz) <= 0.0) {
        return false;
    }
    if (l.direction.w > 0.0 && v.w >= l.direction.w) {
        return false;
    }
    let kind = light_kind(l);
    if (kind == LIGHT_SPOT) {
        return dot(-v.xyz, l.direction.xyz) > l.cone.y;
    }
    if (kind == LIGHT_RECT) {
        return dot(-v.xyz, l.direction.xyz) > 0.0;
    }
    return true;
}

fn light_attenuation(l: Light, p: vec3<f32>) -> f32 {
    let kind = light_kind(l);
    if (kind == LIGHT_DIRECTIONAL) {
        return 1.0;
    }
    let v = light_vector(l, p);
    var radius = l.color.w;
    if (kind == LIGHT_RECT) {
        radius = 0.5 * max(l.cone.z, l.cone.w);
    }
    let r = max(radius, 0.01);
    let d2 = max(v.w * v.w, r * r);
    var window = 1.0;
    if (l.direction.w > 0.0) {
        let q = v.w / l.direction.w;
        window = clamp(1.0 - q * q * q * q, 0.0, 1.0);
    }
    var a = window / d2;
    if (kind == LIGHT_SPOT) {
        let cd = dot(-v.xyz, l.direction.xyz);
        let span = l.cone.x - l.cone.y;
        var t = select(0.0, 1.0, cd > l.cone.y);
        if (span > 1.0e-6) {
            t = clamp((cd - l.cone.y) / span, 0.0, 1.0);
        }
        a = a * t * t;
    }
    if (kind == LIGHT_RECT) {
        a = a * max(dot(-v.xyz, l.direction.xyz), 0.0);
    }
    return a;
}
