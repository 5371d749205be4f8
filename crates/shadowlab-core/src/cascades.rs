//! Robust hard shadows for large views (Stingl 2011): z-partitioning split schemes, the warp
//! parameters of PSM / LiSPSM / reparametrised LiSPSM, the focusing fit and the perspective-aliasing
//! error metric. Everything here is CPU maths, shared by the `cascaded` technique, the analysis
//! command and (later) the cascaded soft shadow maps.

use glam::{Mat4, Vec3, Vec4};

/// The split distances `C_0..=C_m` of z-partitioning (Stingl 2011, Eqs. 3.6–3.8 and 4.1).
///
/// `lambda` blends uniform (0) and logarithmic (1) splits (the practical scheme of PSSM, Zhang et
/// al. 2006). `pseudo_near` and `pseudo_far` (distances, `near ≤ pseudo_near < pseudo_far ≤ far`)
/// replace near and far in the inner splits (Eq. 4.1, Lloyd's pseudo-near plane and Stingl's
/// pseudo-far plane); `C_0` and `C_m` stay at the real near and far planes.
pub fn split_distances(near: f32, far: f32, m: usize, lambda: f32, pseudo_near: f32, pseudo_far: f32) -> Vec<f32> {
    let m = m.max(1);
    let (n, f) = (pseudo_near.max(near), pseudo_far.min(far).max(pseudo_near.max(near) * (1.0 + 1e-6)));
    let mut c: Vec<f32> = (0..=m)
        .map(|i| {
            let t = i as f32 / m as f32;
            let uniform = n + (f - n) * t;
            let log = n * (f / n).powf(t);
            (1.0 - lambda) * uniform + lambda * log
        })
        .collect();
    c[0] = near;
    c[m] = far;
    c
}

/// The split scheme's λ: `uniform` 0, `log` 1, `practical` the given λ.
pub fn scheme_lambda(scheme: &str, lambda: f32) -> f32 {
    match scheme {
        "uniform" => 0.0,
        "log" => 1.0,
        _ => lambda,
    }
}

/// LiSPSM's optimal warp distance (Wimmer & Scherzer 2006, as in Stingl 2011 Eq. 3.2):
/// `n_opt = d / (√(z1/z0) − 1)`, where d is the warp frustum's depth in light space and z0, z1 the
/// eye-space depths its near and far planes span. Equal perspective error (m_z) at z0 and z1.
/// Infinite (uniform shadow mapping) when z1 ≤ z0 (light along the view: the duelling frusta).
pub fn n_opt(d: f32, z0: f32, z1: f32) -> f32 {
    let r = (z1 / z0.max(1e-9)).sqrt() - 1.0;
    if r <= 1e-6 { f32::INFINITY } else { d / r }
}

/// The pseudo-plane form of n_opt (Stingl 2011, Eq. 4.2, in its dimensionally consistent form, see
/// NOTES-004 §1.7): equal error at the pseudo-near depth `z0 + pn·(z1 − z0)` and the pseudo-far
/// depth `z1 − pf·(z1 − z0)` (pn, pf ∈ [0, 1)); reduces to [`n_opt`] for pn = pf = 0.
pub fn n_opt_pseudo(d: f32, z0: f32, z1: f32, pn: f32, pf: f32) -> f32 {
    let span = z1 - z0;
    if span <= 1e-9 {
        return f32::INFINITY;
    }
    let a = z0 + pn * span;
    let b = z1 - pf * span;
    d * (z0 + (a * b).max(0.0).sqrt()) / span
}

/// η(γ) of the reparametrised LiSPSM (Lloyd et al., as in Stingl 2011 Eq. 3.3): −1 (uniform) while
/// the light is within Θ/3 of the view direction, rising to 0 (n_opt) by Θ + 0.3·(90° − Θ).
/// `gamma` is the angle between the view and light directions, `theta` half the field of view
/// (radians).
pub fn eta(gamma: f32, theta: f32) -> f32 {
    let right = std::f32::consts::FRAC_PI_2;
    let (ga, gb, gc) = (theta / 3.0, theta, theta + 0.3 * (right - theta));
    let (eb, ec) = (-0.2, 0.0);
    if gamma <= ga {
        -1.0
    } else if gamma <= gb {
        -1.0 + (eb + 1.0) * (gamma - ga) / (gb - ga)
    } else if gamma <= gc {
        eb + (ec - eb) * (right * (gamma - gb) / (gc - gb)).sin()
    } else {
        ec
    }
}

/// The reparametrised warp distance n_repar(η) (Stingl 2011 Eq. 3.4 with the corrected η ≥ 0 branch
/// `(1 + √α)/(η√α + 1)`, NOTES-004 §1.4): η = −1 uniform (∞), 0 LiSPSM's n_opt, 1 PSM.
/// `w` is the warp frustum's depth in light space, α = z1/z0.
pub fn n_repar(w: f32, z0: f32, z1: f32, eta: f32) -> f32 {
    let alpha = z1 / z0.max(1e-9);
    if alpha <= 1.0 + 1e-6 {
        return f32::INFINITY;
    }
    let s = alpha.sqrt();
    let base = w / (alpha - 1.0);
    if eta <= -1.0 {
        f32::INFINITY
    } else if eta < 0.0 {
        base * (1.0 + s - eta * (alpha - 1.0)) / (eta + 1.0)
    } else {
        base * (1.0 + s) / (eta * s + 1.0)
    }
}

/// W_lz of Stingl 2011 Eq. 3.5: the view frustum's extent along the warp axis for an overhead
/// light, from γ, Θ, the near and far distances and the near plane's width `w_e`.
pub fn w_lz(gamma: f32, theta: f32, near: f32, far: f32, w_e: f32) -> f32 {
    let w_s = (far - near) / theta.cos();
    let w_n = w_e * gamma.cos();
    let w_s1 = w_s * (1.0 - (theta - gamma).cos());
    let w_s2 = w_s * (theta + gamma).sin();
    w_n + w_s2 + if gamma <= theta { w_s1 } else { 0.0 }
}

/// The orthographic fit of Stingl 2011 Eq. 3.1, in reversed Z: maps the box `min..max` (in the
/// space the points were transformed to) onto x, y ∈ [−1, 1] and depth ∈ [0, 1] with `max.z` (the
/// side towards the light, in a right-handed light view looking down −z) at depth 1.
pub fn fit_matrix(min: Vec3, max: Vec3) -> Mat4 {
    let e = (max - min).max(Vec3::splat(1e-9));
    Mat4::from_cols(
        Vec4::new(2.0 / e.x, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 2.0 / e.y, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 1.0 / e.z, 0.0),
        Vec4::new(-(max.x + min.x) / e.x, -(max.y + min.y) / e.y, -min.z / e.z, 1.0),
    )
}

/// The light-space perspective warp of LiSPSM, in a light view space whose +y is the warp axis
/// (the view direction projected onto the shadow-map plane): projection centre `c` (behind the
/// body's near face by `n` along +y), with `y_near` the body's near face. It keeps light rays (lines
/// along z) straight and parallel, so a shadow map can still be rendered orthographically after it.
pub fn warp_matrix(c: Vec3, n: f32, d: f32) -> Mat4 {
    // w' = y − c.y; x' = x − c.x; z' = z − c.z; y' = A·w' + B maps w' ∈ [n, n + d] to [0, 1].
    let a = (n + d) / d;
    let b = -n * (n + d) / d;
    Mat4::from_cols(
        Vec4::new(1.0, 0.0, 0.0, 0.0),
        Vec4::new(0.0, a, 0.0, 1.0),
        Vec4::new(0.0, 0.0, 1.0, 0.0),
        Vec4::new(-c.x, -a * c.y + b, -c.z, -c.y),
    )
}

/// Perspective aliasing along the view direction for an overhead directional light (Lloyd et al.
/// 2006, as in Stingl 2011 Eqs. 2.3–2.8), without the resolution ratios: `m_x(z)` and `m_z(z)` for
/// eye depth z in a frustum `near..far`, half field of view `theta`, warp distance `n_warp`
/// (∞: uniform). Multiply by image/shadow-map resolution ratios for texels per pixel.
pub fn perspective_error(z: f32, near: f32, far: f32, theta: f32, n_warp: f32) -> (f32, f32) {
    let k = (far - near) / (2.0 * theta.tan());
    if !n_warp.is_finite() {
        return (far / z, k / z);
    }
    let np = n_warp;
    let mx = far * (np + z - near) / (z * (np + far - near));
    let mz = k * (np + z - near).powi(2) / (z * np * (np + far - near));
    (mx, mz)
}

/// Stingl's sampling-frequency colour map (Listing A.3): shadow-map texels per screen pixel →
/// dark red (heavy undersampling) … green (1) … dark blue (heavy oversampling).
pub fn sampling_colour(area: f32) -> Vec3 {
    const BOUNDS: [f32; 7] = [0.0, 1.0 / 7.75, 1.0 / 3.25, 1.0, 3.25, 7.75, 10.0];
    const COLOURS: [Vec3; 7] = [
        Vec3::new(0.2, 0.0, 0.0),
        Vec3::new(1.0, 0.2, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.3, 0.8, 1.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.0, 0.0, 0.4),
    ];
    for i in 0..6 {
        if area >= BOUNDS[i] && area < BOUNDS[i + 1] {
            let t = (area - BOUNDS[i]) / (BOUNDS[i + 1] - BOUNDS[i]);
            return COLOURS[i].lerp(COLOURS[i + 1], t);
        }
    }
    if area.is_nan() { Vec3::ZERO } else { COLOURS[6] }
}

/// Split colours of the overlay (Stingl 2011 Eq. 5.1): red, yellow, green, blue for i mod 4.
pub fn split_colour(i: usize) -> Vec3 {
    [Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, 1.0)][i % 4]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &[f32], b: &[f32], tol: f32) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol * y.abs().max(1.0))
    }

    #[test]
    fn split_schemes_match_the_documents_values() {
        // NOTES-004 §6.4 (derived from Eqs. 3.6-3.8): n = 1, f = 1000, m = 4.
        let s = |l| split_distances(1.0, 1000.0, 4, l, 1.0, 1000.0);
        assert!(close(&s(0.0), &[1.0, 250.75, 500.5, 750.25, 1000.0], 1e-5), "{:?}", s(0.0));
        assert!(close(&s(1.0), &[1.0, 5.623, 31.623, 177.828, 1000.0], 1e-4), "{:?}", s(1.0));
        assert!(close(&s(0.5), &[1.0, 128.187, 266.061, 464.039, 1000.0], 1e-4), "{:?}", s(0.5));
        let p = split_distances(1.0, 300.0, 4, 0.5, 1.0, 300.0);
        assert!(close(&p, &[1.0, 39.956, 83.910, 148.667, 300.0], 1e-4), "{p:?}");
        // C_0 = n and C_m = f whatever λ and the pseudo planes.
        let q = split_distances(2.0, 500.0, 3, 0.7, 20.0, 300.0);
        assert_eq!((q[0], q[3]), (2.0, 500.0));
        assert_eq!(split_distances(1.0, 10.0, 1, 0.5, 1.0, 10.0), vec![1.0, 10.0]);
    }

    #[test]
    fn n_opt_balances_the_z_error() {
        // n = 1, f = 40, d = f − n: n_opt = 7.32456 and m_z equal at both ends (0.158114 without
        // the resolution factors and the (f − n)/(2 tan Θ) scale).
        let n = n_opt(39.0, 1.0, 40.0);
        assert!((n - 7.32456).abs() < 1e-4, "{n}");
        let theta = 30f32.to_radians();
        let (_, a) = perspective_error(1.0, 1.0, 40.0, theta, n);
        let (_, b) = perspective_error(40.0, 1.0, 40.0, theta, n);
        assert!((a - b).abs() < 1e-4 * a, "{a} vs {b}");
        let k = 39.0 / (2.0 * theta.tan());
        assert!((a / k - 0.158114).abs() < 1e-5, "{}", a / k);
        assert!(n_opt(10.0, 5.0, 5.0).is_infinite(), "duelling frusta → uniform");
        assert!((n_opt_pseudo(39.0, 1.0, 40.0, 0.0, 0.0) - n).abs() < 1e-4);
    }

    #[test]
    fn error_metric_limits() {
        let theta = 30f32.to_radians();
        let (n, f) = (1.0, 40.0);
        for z in [1.0, 5.0, 40.0] {
            // PSM (n' = n): m_x constant 1, m_z ∝ z/(n f).
            let (mx, mz) = perspective_error(z, n, f, theta, n);
            assert!((mx - 1.0).abs() < 1e-5);
            let k = (f - n) / (2.0 * theta.tan());
            assert!((mz - k * z / (n * f)).abs() < 1e-4 * mz);
            // Uniform as the limit of large n'.
            let (ux, uz) = perspective_error(z, n, f, theta, f32::INFINITY);
            let (lx, lz) = perspective_error(z, n, f, theta, 1.0e7);
            assert!((ux - lx).abs() < 1e-3 * ux && (uz - lz).abs() < 1e-3 * uz);
        }
        // At z = f, m_x = 1 for every n'.
        for np in [1.0, 7.3, 100.0] {
            assert!((perspective_error(f, n, f, theta, np).0 - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn n_repar_is_continuous_and_has_its_limits() {
        let (w, z0, z1) = (39.0, 1.0, 40.0);
        assert!(n_repar(w, z0, z1, -1.0).is_infinite(), "η = −1: uniform");
        assert!((n_repar(w, z0, z1, 0.0) - n_opt(w, z0, z1)).abs() < 1e-4, "η = 0: n_opt");
        assert!((n_repar(w, z0, z1, 1.0) - 1.0).abs() < 1e-5, "η = 1: PSM, n' = n");
        // Continuous at η = 0 from both sides.
        assert!((n_repar(w, z0, z1, -1e-4) - n_repar(w, z0, z1, 1e-4)).abs() < 1e-2);
        // η(γ) is continuous at γ_a, γ_b, γ_c: −1 → −0.2 → 0.
        let theta = 30f32.to_radians();
        let right = std::f32::consts::FRAC_PI_2;
        let (ga, gb, gc) = (theta / 3.0, theta, theta + 0.3 * (right - theta));
        let e = 1e-5;
        for (g, want) in [(ga, -1.0), (gb, -0.2), (gc, 0.0)] {
            assert!((eta(g - e, theta) - want).abs() < 1e-3 && (eta(g + e, theta) - want).abs() < 1e-3, "γ = {g}");
        }
        // W_lz at γ = 90° is f − n.
        assert!((w_lz(right, theta, 1.0, 40.0, 1.15) - 39.0).abs() < 1e-3);
    }

    #[test]
    fn fit_maps_the_box_to_the_clip_cube() {
        let (min, max) = (Vec3::new(-3.0, 2.0, -40.0), Vec3::new(5.0, 6.0, -10.0));
        let m = fit_matrix(min, max);
        assert!((m.transform_point3(min) - Vec3::new(-1.0, -1.0, 0.0)).length() < 1e-5);
        assert!((m.transform_point3(max) - Vec3::new(1.0, 1.0, 1.0)).length() < 1e-5);
    }

    #[test]
    fn warp_keeps_light_rays_parallel_and_maps_near_far() {
        let c = Vec3::new(1.0, -5.0, 2.0);
        let (n, d) = (5.0, 20.0);
        let w = warp_matrix(c, n, d);
        // A light ray: fixed x, y, varying z.
        let a = w.project_point3(Vec3::new(3.0, 4.0, -1.0));
        let b = w.project_point3(Vec3::new(3.0, 4.0, -9.0));
        assert!((a.x - b.x).abs() < 1e-6 && (a.y - b.y).abs() < 1e-6 && a.z > b.z);
        // The near face (y = c.y + n) maps to 0, the far face to 1.
        assert!(w.project_point3(Vec3::new(0.0, c.y + n, 0.0)).y.abs() < 1e-6);
        assert!((w.project_point3(Vec3::new(0.0, c.y + n + d, 0.0)).y - 1.0).abs() < 1e-6);
    }

    #[test]
    fn sampling_colours_match_the_listing() {
        assert_eq!(sampling_colour(1.0), Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(sampling_colour(10.0), Vec3::new(0.0, 0.0, 0.4));
        assert!((sampling_colour(1.0 / 7.75) - Vec3::new(1.0, 0.2, 0.0)).length() < 1e-5);
        assert!((sampling_colour(3.25) - Vec3::new(0.3, 0.8, 1.0)).length() < 1e-5);
        assert!((sampling_colour(7.75) - Vec3::new(0.0, 0.0, 1.0)).length() < 1e-5);
        assert_eq!(split_colour(5), Vec3::new(1.0, 1.0, 0.0));
    }
}
