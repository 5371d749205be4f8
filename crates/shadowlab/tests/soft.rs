//! Soft shadows from area lights (`pcss`, `blurred`, `smoothies`, `sampled`, `cssm`) against the
//! closed form of the `penumbra` scene and the CPU reference.

mod common;

use shadowlab_core::scenes::penumbra::PenumbraSetup;
use shadowlab_core::{LightId, Scene, load_scene};
use shadowlab_reference::metrics::{ErrorStats, image_rmse};

use common::{gpu, reference, render};

const SOFT: &[&str] = &[
    "pcss",
    "blurred",
    "smoothies",
    "sampled:samples=16",
    "sampled:samples=16,mode=array,pcf=true",
    "cssm",
    "cssm:stabilize=true,sizes=auto,counts=auto",
];

fn penumbra(light_size: f32) -> (Scene, PenumbraSetup) {
    let spec = format!("penumbra:light_size={light_size}");
    let scene = load_scene(&spec).unwrap().scene;
    let setup = PenumbraSetup { light_size, ..PenumbraSetup::default() };
    (scene, setup)
}

#[test]
fn visibility_is_bounded_lit_far_away_and_dark_in_the_umbra() {
    let gpu = gpu();
    let (scene, setup) = penumbra(0.5);
    // The oblique view: the ground under the occluder (the umbra) is in sight.
    let view = scene.view("default").unwrap().clone();
    for spec in SOFT {
        let run = render(&gpu, &scene, &view, 96, spec, &[LightId(0)]);
        let v = run.visibility(LightId(0));
        let (mut far, mut far_lit, mut umbra, mut umbra_dark) = (0, 0, 0, 0);
        let mut umbra_max = 0.0f32;
        for (i, &x) in v.iter().enumerate() {
            if x.is_nan() || !run.surface.covered[i] {
                continue;
            }
            assert!((0.0..=1.0).contains(&x), "{spec}: V = {x}");
            let p = run.surface.positions[i];
            if p.y > 0.01 {
                continue; // the occluder's own top
            }
            // The shadow's outer edge is at |x| or |z| = 0.5 + 0.375 (the penumbra's outer
            // border for a 0.5 m light): "far" is 0.3 m beyond it, "deep umbra" 0.1 m inside the
            // umbra's border at 0.625.
            let reach = p.x.abs().max(p.z.abs());
            if reach > 0.875 + 0.3 {
                far += 1;
                far_lit += usize::from(x == 1.0);
            }
            if reach < 0.625 - 0.1 && setup.visibility(p) == 0.0 {
                umbra += 1;
                umbra_dark += usize::from(x == 0.0);
                umbra_max = umbra_max.max(x);
            }
        }
        println!("{spec}: far {far_lit}/{far} lit, umbra {umbra_dark}/{umbra} dark (max {umbra_max})");
        // Enough pixels on both sides for the checks to mean something (measured 2258 far and 206
        // umbra pixels at 96²; half of those or less means the view changed).
        assert!(far > 1000 && umbra > 100, "{spec}: {far} far and {umbra} umbra pixels");
        // Exactly 1 far away and exactly 0 in the deep umbra, every pixel (measured: all).
        assert_eq!(far_lit, far, "{spec}");
        assert_eq!(umbra_dark, umbra, "{spec}");
    }
}

#[test]
fn penumbra_width_grows_with_the_light_as_the_closed_form_says() {
    let gpu = gpu();
    for spec in ["sampled:samples=256", "pcss", "smoothies"] {
        let mut last = 0.0;
        for size in [0.125f32, 0.25, 0.5] {
            let (scene, setup) = penumbra(size);
            let view = scene.view("top").unwrap().clone();
            let run = render(&gpu, &scene, &view, 256, spec, &[LightId(0)]);
            let v = run.visibility(LightId(0));
            let exact: Vec<f32> = v
                .iter()
                .zip(&run.surface.positions)
                .map(|(x, &p)| if x.is_nan() { f32::NAN } else { setup.visibility(p) })
                .collect();
            let (w, w_exact) = (common::boundary_width(&run, &v), common::boundary_width(&run, &exact));
            // The map's texel on the ground: the hard map's view of the light's centre.
            let light = &scene.lights[0];
            let map = if spec.contains("sampled") { 512 } else { 2048 };
            let frusta = shadowlab_core::lightspace::light_frusta(light, &scene.bounds(), map);
            let texel = frusta.view_for(glam::Vec3::new(0.75, 0.0, 0.0)).texel_size_at(glam::Vec3::new(0.75, 0.0, 0.0));
            println!(
                "{spec} light {size}: width {w:.4} m, closed form {w_exact:.4} m (L/2 = {:.4}), texel {texel:.4} m",
                size / 2.0
            );
            assert!(w > last, "{spec}: the boundary must widen with the light ({w} after {last})");
            last = w;
            if spec == "pcss" {
                // PCSS averages the blocker depth and filters a disk: measured 12-13% narrower
                // than the closed form at every size. Bound 20%.
                assert!((w - w_exact).abs() <= 0.2 * w_exact, "{spec} {size}: {w} vs {w_exact}");
            }
            if spec.starts_with("sampled") {
                // The bound: within one shadow-map texel of the closed form.
                assert!((w - w_exact).abs() <= texel, "{spec} {size}: {w} vs {w_exact} (texel {texel})");
            }
        }
    }
}

#[test]
fn sampled_converges_on_penumbra() {
    let gpu = gpu();
    let (scene, _) = penumbra(0.5);
    let view = scene.view("default").unwrap().clone();
    let mut last = f64::INFINITY;
    let mut rmse = Vec::new();
    for n in [16, 64, 256] {
        let run = render(&gpu, &scene, &view, 128, &format!("sampled:samples={n}"), &[LightId(0)]);
        let r = reference(&scene, &run.surface, LightId(0), 1024);
        let s = ErrorStats::compare(&run.visibility(LightId(0)), &r);
        println!("sampled({n}): RMSE {:.4}, penumbra RMSE {:?}", s.rmse(), s.penumbra_rmse());
        assert!(s.rmse() < last, "RMSE must fall as N grows: {n} samples {} after {last}", s.rmse());
        last = s.rmse();
        rmse.push(s.rmse());
    }
    // The bound for 256 samples: RMSE below 0.02.
    assert!(rmse[2] < 0.02, "{rmse:?}");
}

fn bunny() -> Scene {
    common::scene_file("bunny-plane.toml")
}

#[test]
fn cssm_follows_sampled_on_the_bunny_with_a_fraction_of_the_memory() {
    let gpu = gpu();
    let scene = bunny();
    let light = LightId(0);
    // Azri's framing: the bunny in the first cascade, the plane running into the others. Front
    // faces with a wider normal offset keep acne off the bunny, so that the comparison measures
    // the penumbrae, not the bias.
    let view = scene.view("azri").unwrap().clone();
    let settings = ",faces=front,normal_offset=1.5";
    // Azri places the splits by hand, the bunny in the first cascade (Fig. 3.11; NOTES-003 §1.6):
    // the first split just behind the bunny's box, the second at the geometric mean of that and
    // the scene's far end (a logarithmic split of what is left).
    let forward = (view.target - view.position).normalize();
    let far_depth =
        |b: shadowlab_core::Aabb| b.corners().iter().map(|&c| (c - view.position).dot(forward)).fold(0.0, f32::max);
    let (bunny_far, scene_far) = (far_depth(scene.occluder_bounds()), far_depth(scene.bounds()));
    let split2 = (bunny_far * scene_far).sqrt();
    let splits = format!(",split1={bunny_far},split2={split2}");
    let run = |spec: String| render(&gpu, &scene, &view, 128, &format!("{spec}{settings}"), &[light]);
    let truth = run("sampled:samples=256,pcf=true,map_size=1024".into());
    let t = truth.visibility(light);
    let relevant: Vec<bool> = reference(&scene, &truth.surface, light, 1).iter().map(|r| !r.is_nan()).collect();
    let truth_image = truth.renderer.read_image().unwrap();
    let vis_rmse = |r: &common::Run| ErrorStats::compare_masked(&r.visibility(light), &t, &relevant).rmse();

    let cssm = run(format!("cssm:counts=fixed{splits}"));
    let rmse = vis_rmse(&cssm);
    let image = image_rmse(&cssm.renderer.read_image().unwrap(), &truth_image, Some(&cssm.surface.covered)).unwrap();
    let sixteen = vis_rmse(&run("sampled:samples=16,pcf=true,map_size=1024".into()));
    let lambda_splits = vis_rmse(&run("cssm:counts=fixed".into()));
    let uniform = run(format!("cssm:samples0=36,samples1=36,samples2=36,size1=1024,size2=1024{splits}"));
    let rmse_uniform = vis_rmse(&uniform);
    let (mem, mem_uniform) =
        (cssm.renderer.shadows.stats().memory_bytes, uniform.renderer.shadows.stats().memory_bytes);
    println!(
        "cssm 16/9/4 vs sampled(256), splits at {bunny_far:.2} and {split2:.2} m: visibility RMSE {rmse:.4} \
         (sampled(16) alone {sixteen:.4}; PSSM splits {lambda_splits:.4}; uniform 36 @ 1024 {rmse_uniform:.4}); \
         image RMSE {image:.4}; memory {:.1} vs {:.1} MiB",
        mem as f64 / 1048576.0,
        mem_uniform as f64 / 1048576.0
    );
    // The bound, in Azri's measure (RMSE of the lit images; Azri 0.0075–0.0091): measured
    // 0.0059 at 128².
    assert!(image <= 0.01, "image RMSE {image}");
    // In visibility over relevant pixels, which weighs errors at grazing light fully, cssm is as
    // close as its first cascade's 16 samples allow: measured 0.0123 against 0.0111 for sampled(16)
    // over the whole view (×1.11; 0.0127 and 0.0115 before DESIGN.md §3's relevance by N_g).
    // Bounds: ×1.25 and 0.016.
    assert!(rmse < 1.25 * sixteen && rmse < 0.016, "{rmse} vs sampled(16) {sixteen}");
    // With PSSM's λ = 0.5 the bunny falls in the 9-sample, 512² cascade: measured 0.0255.
    assert!(rmse < lambda_splits, "{rmse} vs {lambda_splits}");
    // Fewer samples cost accuracy: the uniform 36-sample cascades are closer (measured 0.0094).
    assert!(rmse_uniform < rmse, "{rmse_uniform} vs {rmse}");
    // Azri: about 73 MiB against 144 MiB for 36 maps of 1024² (here 73 vs 432 MiB: 36 maps in
    // each of three cascades). At most half.
    assert!(2 * mem < mem_uniform, "{mem} vs {mem_uniform}");
}

/// The texture-array mode looks up the same maps as accumulation over passes: the results agree
/// for layer counts that wgpu would take for cube-map arrays (12 single views; 4 samples × 6 cube
/// faces), which once read as "lit" everywhere.
#[test]
fn array_mode_matches_accumulation() {
    let gpu = gpu();
    let (scene, _) = penumbra(0.5);
    let room = load_scene("room").unwrap().scene;
    let lamp = room.find_light("ceiling lamp").unwrap();
    let cases = [(&scene, "default", LightId(0), 12), (&room, "default", lamp, 4)];
    for (scene, view, light, n) in cases {
        let view = scene.view(view).unwrap().clone();
        let spec = format!("sampled:samples={n},map_size=256");
        let accumulated = render(&gpu, scene, &view, 64, &spec, &[light]).visibility(light);
        let array = render(&gpu, scene, &view, 64, &format!("{spec},mode=array"), &[light]).visibility(light);
        let shadowed = accumulated.iter().filter(|&&v| v < 0.5).count();
        assert!(shadowed > 0, "{n} samples: the view holds a shadow");
        let worst = array.iter().zip(&accumulated).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        // The same comparisons in another order: equal up to float rounding of the sums.
        assert!(worst < 1e-4, "{n} samples: array and accumulation differ by {worst}");
    }
}

/// A lamp inside the view: no sample view can be fitted to the one cascade's slice, so `cssm` falls
/// back to `sampled`'s whole-scene cube faces, its samples taking turns in the same six layers. It
/// then is `sampled` with the same samples, in the values and in the memory.
#[test]
fn cssm_falls_back_to_sampled_for_a_lamp_inside_the_view() {
    let gpu = gpu();
    let room = load_scene("room").unwrap().scene;
    let lamp = room.find_light("ceiling lamp").unwrap();
    let view = room.view("default").unwrap().clone();
    let cssm = render(&gpu, &room, &view, 64, "cssm:cascades=1,samples0=9,size0=256", &[lamp]);
    let sampled = render(&gpu, &room, &view, 64, "sampled:samples=9,map_size=256,pcf=true", &[lamp]);
    let stats = cssm.renderer.shadows.stats();
    assert_eq!(cssm.stat("ceiling lamp", "cascade0_fitted"), 0.0, "the lamp sees the whole view");
    assert_eq!(cssm.stat("ceiling lamp", "cascade0_views_per_sample"), 6.0);
    let (c, s) = (cssm.visibility(lamp), sampled.visibility(lamp));
    assert!(s.iter().any(|&v| v < 0.5), "the view holds a shadow");
    let worst = c.iter().zip(&s).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    // The same maps and comparisons, summed in the same order: equal up to float rounding.
    assert!(worst < 1e-4, "cssm and sampled differ by {worst}");
    // Six layers of 256² (1.5 MiB) for all nine samples, not 54 (14 MiB in array mode). Measured
    // 1.69 MB with the visibility layers and sums beside them; bound: twice the maps.
    let maps = 6 * 256 * 256 * 4;
    println!("cssm fallback: {} bytes for maps of {maps} bytes", stats.memory_bytes);
    assert!(stats.memory_bytes < 2 * maps, "{} bytes", stats.memory_bytes);
}

/// `sizes=auto` sizes each cascade's maps from the pixels they serve: the sun's sharp shadow in the
/// room's far cascade needs more than Azri's 128².
#[test]
fn cssm_automatic_sizes_sharpen_the_sun() {
    let gpu = gpu();
    let room = load_scene("room").unwrap().scene;
    let sun = room.find_light("sun").unwrap();
    let view = room.view("default").unwrap().clone();
    let mut rmse = Vec::new();
    let mut far_size = Vec::new();
    for spec in ["cssm", "cssm:sizes=auto"] {
        let run = render(&gpu, &room, &view, 128, spec, &[sun]);
        let r = reference(&room, &run.surface, sun, 64);
        rmse.push(ErrorStats::compare(&run.visibility(sun), &r).rmse());
        far_size.push(run.stat("sun", "cascade2_map_size"));
    }
    println!("sun: cssm RMSE {:.4} (far maps {}²), sizes=auto {:.4} ({}²)", rmse[0], far_size[0], rmse[1], far_size[1]);
    assert!(far_size[1] > far_size[0], "{far_size:?}");
    // Measured 0.0684 → 0.0345 at 128² (reference 64 samples); bound: at least a quarter less.
    assert!(rmse[1] < 0.75 * rmse[0], "{rmse:?}");
}

/// `pcss`, `smoothies` and `blurred` take the receiver's horizon into account
/// (`shaders/horizon.wgsl`): no pixel is lighter than the part of the emitter above its tangent
/// plane (the CPU's `shadowlab_core::backprojection::fraction_above` on the same surface), and on
/// the bunny, whose curved body hides the panel from itself near every terminator, that brings
/// `pcss` closer to the truth.
#[test]
fn soft_maps_keep_below_the_receivers_horizon() {
    use shadowlab_core::LightKind;
    use shadowlab_core::backprojection::{Emitter, fraction_above};
    let gpu = gpu();
    let scene = bunny();
    let light = LightId(0);
    let view = scene.view("azri").unwrap().clone();
    let LightKind::Rect { position, direction, tangent, width, height } = scene.lights[0].kind else {
        panic!("the bunny's panel is a rectangle");
    };
    let bitangent = direction.cross(tangent).normalize();
    let mut truth = None;
    for spec in ["pcss", "smoothies", "blurred"] {
        let run = render(&gpu, &scene, &view, 96, spec, &[light]);
        let v = run.visibility(light);
        let truth = truth.get_or_insert_with(|| reference(&scene, &run.surface, light, 128));
        let (mut above, mut relevant) = (0, 0);
        for (i, r) in truth.iter().enumerate() {
            if r.is_nan() || v[i].is_nan() {
                continue;
            }
            relevant += 1;
            // The facet's plane, as the truth's (and the shaders') horizon.
            let (p, n) = (run.surface.positions[i], run.surface.geometric_normals[i]);
            let k = glam::Vec3::new(
                (position - p).dot(n),
                0.5 * width * tangent.normalize().dot(n),
                0.5 * height * bitangent.dot(n),
            );
            // 0.01: the G-buffer's normal and position against the read-back ones.
            if v[i] > fraction_above(Emitter::Square, k) + 0.01 {
                above += 1;
            }
        }
        let rmse = ErrorStats::compare(&v, truth).rmse();
        println!("{spec} on the bunny: {above} of {relevant} pixels above their horizon, RMSE {rmse:.4}");
        // Measured 0 of 5283 for each (pcss without the horizon: 212, 4.0%). Bound: 0.2% for the
        // normals' round-off.
        assert!(above * 500 <= relevant, "{spec}: {above} of {relevant} pixels lighter than their horizon allows");
        if spec == "pcss" {
            // Measured 0.0918 at 96² against 128 samples (without the horizon 0.1107). Bound: 0.100.
            assert!(rmse <= 0.100, "pcss RMSE {rmse}");
        }
    }
}
