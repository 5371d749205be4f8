// Which of a light's maps shades a point (group 3): one map (or a cube), or the splits of
// z-partitioning chosen by eye depth or by best resolution (Stingl 2011, §3.3.3).

// #include "maplookup.wgsl"

struct Selection {
    // x: maps (splits); y: 0 by eye depth, 1 best resolution; z: blend band as a fraction of a split's
    // depth range (0: hard switch); w: 1 when kernel radii in texels keep split 0's world size.
    params: vec4<f32>,
    // The split distances C_0 … C_m, four per vec4.
    distances: array<vec4<f32>, 5>,
};

@group(3) @binding(0) var<uniform> selection: Selection;

fn split_count() -> u32 {
    return max(u32(selection.params.x + 0.5), 1u);
}

fn split_distance(i: u32) -> f32 {
    return selection.distances[i / 4u][i % 4u];
}

// The split whose depth range holds eye depth `depth` (the first or last one outside the range).
fn split_by_depth(depth: f32) -> u32 {
    let m = split_count();
    for (var i = 1u; i < m; i = i + 1u) {
        if (depth < split_distance(i)) {
            return i - 1u;
        }
    }
    return m - 1u;
}

// The first (finest) split whose map holds the biased point, at least `margin` texels from its
// border [Zhang et al. 2009].
fn split_best(p: vec3<f32>, n: vec3<f32>, l: vec3<f32>, margin: f32) -> u32 {
    let m = split_count();
    let e = margin / map_params.bias.z;
    for (var i = 0u; i < m; i = i + 1u) {
        let mp = map_point(p, n, l, i);
        if (mp.on_map && all(mp.uvz.xy >= vec2<f32>(e)) && all(mp.uvz.xy <= vec2<f32>(1.0 - e))) {
            return i;
        }
    }
    return m - 1u;
}

fn select_split(p: vec3<f32>, n: vec3<f32>, l: vec3<f32>, depth: f32, margin: f32) -> u32 {
    if (selection.params.y > 0.5) {
        return split_best(p, n, l, margin);
    }
    return split_by_depth(depth);
}
