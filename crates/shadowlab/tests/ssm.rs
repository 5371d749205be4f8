//! `ssm`, soft shadow mapping by back-projection (Guennebaud et al. 2007), against the closed form
//! of the `penumbra` scene and `hard`; its adaptive parts against its exact computation. The rules themselves (edge table, radial integration, kernel bound) are unit-tested
//! on the CPU in `shadowlab_core::backprojection`.

mod common;

use shadowlab::{Edit, LightChange, Renderer, TechniqueSpec};
use shadowlab_core::scenes::penumbra::PenumbraSetup;
use shadowlab_core::{Light, LightId, LightKind, Scene, load_scene};

use common::{gpu, reference, render};
use shadowlab_reference::metrics::ErrorStats;

fn penumbra(light_size: f32) -> (Scene, PenumbraSetup) {
    let scene = load_scene(&format!("penumbra:light_size={light_size}")).unwrap().scene;
    (scene, PenumbraSetup { light_size, ..PenumbraSetup::default() })
}

/// RMSE of `v` against `exact` over the pixels where both are defined.
fn rmse(v: &[f32], exact: &[f32]) -> f32 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (&a, &b) in v.iter().zip(exact) {
        if a.is_nan() || b.is_nan() {
            continue;
        }
        sum += f64::from(a - b).powi(2);
        n += 1;
    }
    (sum / n.max(1) as f64).sqrt() as f32
}

/// Mean of `v − exact` over the pixels where both are defined (a fill's bias).
fn mean_difference(v: &[f32], exact: &[f32]) -> f32 {
    let d: Vec<f64> =
        v.iter().zip(exact).filter(|(a, b)| !(a.is_nan() || b.is_nan())).map(|(a, b)| f64::from(a - b)).collect();
    (d.iter().sum::<f64>() / d.len().max(1) as f64) as f32
}

/// `penumbra`'s closed-form visibility on the ground where `v` is defined (NaN elsewhere).
fn closed_form(run: &common::Run, setup: &PenumbraSetup, v: &[f32]) -> Vec<f32> {
    v.iter()
        .zip(run.surface.positions.iter().zip(&run.surface.covered))
        .map(|(x, (&p, &covered))| if x.is_nan() || !covered || p.y > 0.01 { f32::NAN } else { setup.visibility(p) })
        .collect()
}

#[test]
fn the_penumbra_follows_the_closed_form() {
    let gpu = gpu();
    for size in [0.5f32, 1.0, 0.25] {
        let (scene, setup) = penumbra(size);
        let view = scene.view("top").unwrap().clone();
        let run = render(&gpu, &scene, &view, 256, "ssm", &[LightId(0)]);
        let v = run.visibility(LightId(0));
        let exact = closed_form(&run, &setup, &v);
        let (w, w_exact) = (common::boundary_width(&run, &v), common::boundary_width(&run, &exact));
        let error = rmse(&v, &exact);
        println!(
            "ssm, light {size}: RMSE {error:.4} against the closed form; width {w:.4} m (closed form {w_exact:.4})"
        );
        // Width as the analytic formula: measured within 1 % for all three sizes (+0.4 %, −1.0 %,
        // +0.9 % for 0.5, 1 and 0.25 m; at `t_k=12` the 1 m light's is +6 %: its square's border
        // inside level 3's texels, placed at their centres); bound 5 %.
        assert!((w - w_exact).abs() <= 0.05 * w_exact, "light {size}: width {w} vs {w_exact}");
        // The bound: profile within 0.02 RMSE of the closed form (measured 0.0036, 0.0095
        // and 0.0052 for the 0.5, 1 and 0.25 m lights at 256², the top view; the 0.25 m light was
        // 0.0206 while level 1's border samples were eroded, `coarse_block_edges`).
        assert!(error < 0.02, "light {size}: RMSE {error}");
    }
}

/// The emitter's centre is tested against the contour where the receiver itself projects, and the
/// contour's edges are back-projected from the receiver too: were either taken from the biased
/// lookup point (lifted along the normal by `normal_offset` texels), a contour passing between the
/// two points would count half the emitter twice or not at all, and pixels near V = ½ would read 0
/// or 1. The offset then changes only which samples occlude, not the profile.
#[test]
fn the_normal_offset_leaves_the_penumbra_in_place() {
    let gpu = gpu();
    let (scene, setup) = penumbra(0.5);
    let view = scene.view("default").unwrap().clone();
    for offset in [0.15f32, 3.0] {
        let spec = format!("ssm:normal_offset={offset}");
        let run = render(&gpu, &scene, &view, 128, &spec, &[LightId(0)]);
        let v = run.visibility(LightId(0));
        let exact = closed_form(&run, &setup, &v);
        let error = rmse(&v, &exact);
        let flipped =
            v.iter().zip(&exact).filter(|&(&a, &b)| !b.is_nan() && !a.is_nan() && (a - b).abs() > 0.3).count();
        println!("ssm, normal offset {offset}: RMSE {error:.4} against the closed form; {flipped} pixels off by > 0.3");
        // Measured 0 pixels off by more than 0.3 at both offsets, RMSE 0.0032 and 0.0033 (with
        // the centre tested at the biased point: 1 pixel and RMSE 0.0056 at 0.15; the penumbra
        // RMSE against the truth 0.0204 at 0.15, 0.0742 at 3, against 0.0127–0.0129 now);
        // bounds: none, and RMSE 0.0045 (+35 %).
        assert_eq!(flipped, 0, "offset {offset}: {flipped} pixels off by > 0.3");
        assert!(error < 0.0045, "offset {offset}: RMSE {error}");
    }
}

/// `penumbra`'s square occluder is aligned with the map, its border on a texel border of every level.
/// At `t_k=16` its pixels trace level 1, where the border samples occlude with all their finer texels:
/// eroded by `t_coarse` = 1 like partly occluding ones, the occluder would shrink by half a level-1
/// texel all round and the penumbra come out too light.
#[test]
fn an_occluder_ending_on_a_coarse_border_keeps_it() {
    let gpu = gpu();
    let (scene, setup) = penumbra(0.5);
    let view = scene.view("default").unwrap().clone();
    let run = render(&gpu, &scene, &view, 128, "ssm:t_k=16", &[LightId(0)]);
    let v = run.visibility(LightId(0));
    let exact = closed_form(&run, &setup, &v);
    let error = rmse(&v, &exact);
    println!("ssm:t_k=16: RMSE {error:.4} against the closed form");
    // Measured 0.0033 (with the border eroded: 0.0131, against 0.0032 at the default `t_k`, level 2);
    // bound 0.0045, +35 %.
    assert!(error < 0.0045, "RMSE {error}");
}

/// `ssm`'s pipelines hold one emitter shape (the rectangle's square or the disk): a light replaced by
/// one of the other shape rebuilds them, so the edited renderer draws what a fresh one does.
#[test]
fn a_light_replaced_by_another_shape_is_traced_with_its_own() {
    let gpu = gpu();
    let (scene, _) = penumbra(0.5);
    let view = scene.view("default").unwrap().clone();
    let panel = scene.lights[0].clone();
    let LightKind::Rect { position, .. } = panel.kind else { panic!("penumbra's light is a rectangle") };
    let sphere = Light { kind: LightKind::Point { position, radius: 0.3 }, ..panel.clone() };
    let spec = TechniqueSpec::parse("ssm", &[]).unwrap();
    let visibility = |renderer: &mut Renderer| {
        renderer.render().unwrap();
        renderer.read_visibility(LightId(0)).unwrap().unwrap()
    };
    let mut edited = Renderer::new(&gpu, scene.clone(), &view, 96, 96);
    edited.set_technique(LightId(0), &spec).unwrap();
    let before = visibility(&mut edited);
    let mut sphere_scene = scene.clone();
    sphere_scene.lights[0] = sphere.clone();
    let mut fresh = Renderer::new(&gpu, sphere_scene, &view, 96, 96);
    fresh.set_technique(LightId(0), &spec).unwrap();
    let expected = visibility(&mut fresh);
    for (shape, light) in [("sphere", sphere), ("rectangle", panel)] {
        edited.apply(Edit::Light { light: LightId(0), change: LightChange::Replace(light) }).unwrap();
        let v = visibility(&mut edited);
        let want = if shape == "sphere" { &expected } else { &before };
        let differ = v.iter().zip(want).filter(|(a, b)| !(a.is_nan() && b.is_nan()) && a != b).count();
        // Exactly the fresh engine's image (with the rectangle's pipelines kept for the sphere:
        // 445 of 9 216 pixels differed).
        assert_eq!(differ, 0, "{shape}: {differ} pixels differ from a fresh engine");
    }
}

#[test]
fn adaptive_sampling_with_an_infinite_threshold_is_the_full_computation() {
    let gpu = gpu();
    let (scene, _) = penumbra(0.5);
    let view = scene.view("default").unwrap().clone();
    let full = render(&gpu, &scene, &view, 96, "ssm:adaptive=false", &[LightId(0)]).visibility(LightId(0));
    let endless = render(&gpu, &scene, &view, 96, "ssm:s_min=1e9", &[LightId(0)]).visibility(LightId(0));
    let sparse = render(&gpu, &scene, &view, 96, "ssm:s_min=4", &[LightId(0)]).visibility(LightId(0));
    let differ =
        |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| (x - y).abs()).filter(|d| !d.is_nan()).fold(0.0, f32::max);
    // s_min → ∞ selects every penumbra pixel and pull-push leaves computed pixels alone: equal.
    assert_eq!(differ(&full, &endless), 0.0);
    // A 4-pixel threshold skips most penumbra pixels (15 of 16 where the penumbra is over 16
    // pixels wide) and fills them in: close but not equal (measured max 0.13, RMSE 0.0039 at 96²;
    // bound 0.02, the closed-form bound of the full computation).
    let (worst, error) = (differ(&full, &sparse), rmse(&sparse, &full));
    println!("s_min = 4 against the full computation: max {worst:.4}, RMSE {error:.4}");
    assert!(worst > 0.0, "pixels were skipped");
    assert!(error < 0.02, "pull-push fills the skipped pixels smoothly: RMSE {error}");
    // Under a 1 m light the penumbra is wider and more of it filled. Pulled through 2 × 2 boxes,
    // a coarse texel holding one computed pixel took its value whole, half a texel off: the ramp
    // moved outwards level by level (RMSE 0.0152 against the full computation, mean −0.0015);
    // Gortler's tent pull weighs each pixel by its distance (0.0113, mean −0.0003). Bounds: the
    // tent's figures plus 15 % and × 2.7, both below the box's.
    let (wide, _) = penumbra(1.0);
    let wide_full = render(&gpu, &wide, &view, 96, "ssm:adaptive=false", &[LightId(0)]).visibility(LightId(0));
    let wide_sparse = render(&gpu, &wide, &view, 96, "ssm:s_min=4", &[LightId(0)]).visibility(LightId(0));
    let (error, bias) = (rmse(&wide_sparse, &wide_full), mean_difference(&wide_sparse, &wide_full));
    println!("1 m light, s_min = 4 against the full computation: RMSE {error:.4}, mean {bias:.4}");
    assert!(error < 0.013 && bias.abs() < 0.0008, "the fill is off: RMSE {error}, mean {bias}");
    // GPUs take the indirect dispatch of the list, CPU adapters (this machine) a direct one looping
    // over it: the same pixels, the same values.
    for dispatch in ["indirect", "direct"] {
        let spec = format!("ssm:adaptive=false,dispatch={dispatch}");
        let v = render(&gpu, &scene, &view, 96, &spec, &[LightId(0)]).visibility(LightId(0));
        assert_eq!(differ(&v, &full), 0.0, "{dispatch}");
    }
}

/// CPU adapters end an invocation's loops past a budget (llvmpipe: 65 535 iterations, shared by
/// every loop; `ssm.wgsl`, `loop_budget`) without a word. The direct pass that loops over the
/// list ran into it where kernels are wide (no LOD on the bunny): listed pixels came out cut short,
/// differently from run to run (the list's order is the atomics'), 397 of them against the
/// indirect dispatch at 128² (2 at 96²). Bounded now: both dispatches give the same values, run
/// after run.
#[test]
fn wide_kernels_stay_within_the_loop_budget() {
    let gpu = gpu();
    let scene = common::scene_file("bunny-plane.toml");
    let view = scene.view("azri").unwrap().clone();
    let run = |dispatch: &str| {
        let spec = format!("ssm:lod=false,adaptive=false,dispatch={dispatch}");
        render(&gpu, &scene, &view, 128, &spec, &[LightId(0)]).visibility(LightId(0))
    };
    let indirect = run("indirect");
    let penumbra = indirect.iter().filter(|v| **v > 0.02 && **v < 0.98).count();
    println!("{penumbra} penumbra pixels");
    // The case must be there: wide penumbrae over the ground and the body (measured 1 301 pixels
    // strictly between 0.02 and 0.98 at 128²; at least 400).
    assert!(penumbra >= 400, "{penumbra} penumbra pixels");
    for attempt in 0..2 {
        let direct = run("direct");
        let differ = direct.iter().zip(&indirect).filter(|(a, b)| !(a.is_nan() && b.is_nan()) && a != b).count();
        assert_eq!(differ, 0, "run {attempt}: {differ} pixels differ between the direct and indirect dispatches");
    }
}

/// The continuous level λ grows with the light; where it crosses an integer the level used
/// changes, and without blending V jumps there. With the band β the change is spread out.
#[test]
fn lod_blending_leaves_no_step_as_the_light_grows() {
    let gpu = gpu();
    let (scene, _) = penumbra(0.3);
    let view = scene.view("top").unwrap().clone();
    let steps = |spec: &str| {
        let spec = TechniqueSpec::parse(spec, &[]).unwrap();
        let mut renderer = Renderer::new(&gpu, scene.clone(), &view, 96, 96);
        renderer.set_technique(LightId(0), &spec).unwrap();
        let mut last: Option<Vec<f32>> = None;
        let mut worst = 0.0f32;
        // 0.30 → 0.60 m in 1 % steps: the kernel doubles, so λ crosses one integer everywhere.
        for k in 0..=30 {
            let size = 0.3 * 1.0233f32.powi(k);
            renderer.apply(Edit::Light { light: LightId(0), change: LightChange::Size(size, size) }).unwrap();
            renderer.render().unwrap();
            let v = renderer.read_visibility(LightId(0)).unwrap().unwrap();
            if let Some(prev) = &last {
                let step = v.iter().zip(prev).map(|(a, b)| (a - b).abs()).filter(|d| !d.is_nan()).fold(0.0, f32::max);
                worst = worst.max(step);
            }
            last = Some(v);
        }
        worst
    };
    let (blended, switched) = (steps("ssm:adaptive=false"), steps("ssm:adaptive=false,beta=0"));
    println!("largest change of V between 2.3 % light steps: blended {blended:.4}, switched {switched:.4}");
    // Measured at 96²: blended 0.033, switched 0.089 (the level change shows as a step).
    assert!(blended < 0.5 * switched, "blending must smooth the level change: {blended} vs {switched}");
}

/// Every kind of light the technique takes, including a cube map's point light and the sun: V in
/// [0, 1], never NaN on relevant pixels, and the hard limit (emitter size 0) is the contour's hard
/// shadow, which differs from `hard`'s only along the shadow's boundary.
#[test]
fn every_light_type_gives_bounded_visibility_and_a_hard_limit() {
    let gpu = gpu();
    let room = load_scene("room").unwrap().scene;
    let view = room.view("default").unwrap().clone();
    for (i, light) in room.lights.iter().enumerate() {
        let id = LightId(i as u32);
        let run = render(&gpu, &room, &view, 64, "ssm:map_size=512", &[id]);
        let truth = reference(&room, &run.surface, id, 1);
        let v = run.visibility(id);
        let mut shadowed = 0;
        for (x, r) in v.iter().zip(&truth) {
            if r.is_nan() {
                continue;
            }
            assert!((0.0..=1.0).contains(x), "{}: V = {x}", light.name);
            shadowed += usize::from(*x < 0.5);
        }
        println!("{} ({}): {shadowed} pixels in shadow", light.name, light.type_name());
    }
    let mut hard_room = room.clone();
    hard_room.scale_emitters(0.0);
    let lamp = room.find_light("ceiling lamp").unwrap();
    let ssm = render(&gpu, &hard_room, &view, 64, "ssm:map_size=512", &[lamp]).visibility(lamp);
    let hard = render(&gpu, &hard_room, &view, 64, "hard:map_size=512", &[lamp]).visibility(lamp);
    assert!(ssm.iter().all(|v| v.is_nan() || *v == 0.0 || *v == 1.0), "a point light's shadow is hard");
    let differ = ssm.iter().zip(&hard).filter(|(a, b)| !a.is_nan() && a != b).count();
    let shadowed = hard.iter().filter(|v| **v == 0.0).count();
    println!("hard limit: {differ} pixels differ from `hard` of {shadowed} in shadow");
    // The contour test and the map comparison differ only within a texel of the boundary:
    // measured 5 pixels of 620 at 64² (3 on the back faces); bound a tenth.
    assert!(shadowed > 100 && differ * 10 < shadowed, "{differ} of {shadowed}");
}

/// A point light's map is a cube, and a kernel near a face's edge reaches past it. Read as
/// "nothing occludes" there, the umbra behind an occluder that spans the seam came out partly lit
/// along the seam's line (the room's accent lamp on the far wall); the edge texels are extended
/// instead, as the comparison sampler's clamp does for the other map techniques.
#[test]
fn umbra_stays_dark_across_a_cube_maps_seams() {
    let gpu = gpu();
    let room = load_scene("room").unwrap().scene;
    let view = room.view("default").unwrap().clone();
    let accent = room.find_light("accent").unwrap();
    let centre = room.lights[accent.index()].position().expect("a point light");
    let run = render(&gpu, &room, &view, 128, "ssm:lod=false,adaptive=false", &[accent]);
    let v = run.visibility(accent);
    let truth = reference(&room, &run.surface, accent, 64);
    let (mut umbra, mut lit) = (0, 0);
    for (i, (&x, &r)) in v.iter().zip(&truth).enumerate() {
        // Near a seam: the direction's two largest components within 10 % of each other.
        let mut d = (run.surface.positions[i] - centre).abs().to_array();
        d.sort_by(|a, b| b.total_cmp(a));
        if r != 0.0 || x.is_nan() || d[1] < 0.9 * d[0] {
            continue;
        }
        umbra += 1;
        lit += usize::from(x > 0.2);
    }
    println!("umbra near the accent's cube seams: {lit} of {umbra} pixels lit over 0.2");
    // The case must be there (measured 360 umbra pixels near a seam at 128²; at least 200).
    // Measured: 1 lit with the edge texels extended, 62 when past the edge read as empty (the
    // seam's line; 9 with the kernel's bounds extended but not the contour); bound 10.
    assert!(umbra >= 200, "{umbra} umbra pixels near a seam");
    assert!(lit <= 10, "{lit} of {umbra} umbra pixels lit");
}

/// The room's accent lamp stands on a shelf under a board. Eq. 1 on the nearest depth of the
/// kernel's square let the board, near the light, give every floor pixel a kernel of hundreds of
/// texels, and the paper's one level per pixel (§5.1) was level 4–5, where the chair slats' small
/// shadows, cast near the floor, are lost. Read per texel (`occluder_bounds`), the board lies
/// beyond its own kernel of most floor pixels and the levels are finer; where a nearer occluder
/// still widens a pixel's kernel, occluder layers trace the ones near the floor finer (`layers`,
/// shadowlab_core::backprojection::occluder_layers): against the truth the error stays below one
/// layer's; where all occluders lie at one depth the layers change nothing (no occluder counted
/// twice); and the loop budget holds (several pixels to an invocation and one give the same
/// visibility).
#[test]
fn occluder_layers_keep_small_shadows_beside_a_wide_penumbra() {
    let gpu = gpu();
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let accent = LightId(scene.lights.iter().position(|l| l.name == "accent").unwrap() as u32);
    let layered = render(&gpu, &scene, &view, 128, "ssm:adaptive=false", &[accent]);
    let truth = reference(&scene, &layered.surface, accent, 128);
    let v = layered.visibility(accent);
    let one = render(&gpu, &scene, &view, 128, "ssm:adaptive=false,layers=1", &[accent]).visibility(accent);
    let (e_layered, e_one) = (rmse(&v, &truth), rmse(&one, &truth));
    println!("accent lamp, RMSE against the truth: three layers {e_layered:.4}, one {e_one:.4}");
    // Measured at 128² (128 reference samples): 0.0305 against 0.0347 (0.88 ×; at `t_k=8` 0.0315
    // against 0.0394; with Eq. 1 on the square's nearest depth 0.0329 against 0.2238); bound 0.9 ×.
    assert!(e_layered < 0.9 * e_one, "layers {e_layered} vs one {e_one}");
    // One layer alone, from the per-texel kernel: measured 0.0347 (0.2238 with Eq. 1 on the
    // square's nearest depth, which set the floor's levels from the board); bound 2 ×.
    assert!(e_one < 0.075, "one layer {e_one}");
    // Where every occluder lies at one depth (`penumbra`'s square, with the 1 m light: levels 3–5)
    // the finer layers hold nothing, and the layers change nothing.
    let (square, _) = penumbra(1.0);
    let top = square.view("top").unwrap().clone();
    let layered = render(&gpu, &square, &top, 96, "ssm:adaptive=false", &[LightId(0)]).visibility(LightId(0));
    let one = render(&gpu, &square, &top, 96, "ssm:adaptive=false,layers=1", &[LightId(0)]).visibility(LightId(0));
    let worst = layered.iter().zip(&one).map(|(a, b)| (a - b).abs()).filter(|d| !d.is_nan()).fold(0.0, f32::max);
    println!("penumbra, one occluder depth: layers change V by at most {worst}");
    assert!(worst < 1e-6, "layers changed a one-depth penumbra by {worst}");
    // The loop budget with the most loops a layered pixel can take here (the widest kernel at each
    // level, two levels blended everywhere, four layers one level apart): counting one layer's
    // loops where four run left 2 pixels differing.
    let heavy = "ssm:adaptive=false,t_k=64,beta=0.5,finer=1,layers=4";
    let direct = render(&gpu, &scene, &view, 128, &format!("{heavy},dispatch=direct"), &[accent]).visibility(accent);
    let indirect =
        render(&gpu, &scene, &view, 128, &format!("{heavy},dispatch=indirect"), &[accent]).visibility(accent);
    let differ = direct.iter().zip(&indirect).filter(|(a, b)| !(a.is_nan() && b.is_nan()) && a != b).count();
    assert_eq!(differ, 0, "{differ} pixels differ between the direct and indirect dispatches");
}

/// The check on the bunny (`scenes/bunny-plane.toml`, Azri's view and the default one):
/// `ssm`'s penumbra RMSE against the truth is lower than `pcss`'s. Its defaults map the front
/// faces, the surfaces the truth sees: with the back faces (as `pcss` maps them) the bunny's own
/// curved body, half of the penumbra, was too light for every map technique.
#[test]
fn penumbra_error_on_the_bunny_is_below_pcss() {
    let gpu = gpu();
    let scene = common::scene_file("bunny-plane.toml");
    for name in ["azri", "default"] {
        let view = scene.view(name).unwrap().clone();
        let ssm = render(&gpu, &scene, &view, 128, "ssm", &[LightId(0)]);
        let truth = reference(&scene, &ssm.surface, LightId(0), 256);
        let pcss = render(&gpu, &scene, &view, 128, "pcss", &[LightId(0)]);
        let back = render(&gpu, &scene, &view, 128, "ssm:faces=back,slope_bias=1.5,normal_offset=0.3", &[LightId(0)]);
        let penumbra = |run: &common::Run| {
            ErrorStats::compare(&run.visibility(LightId(0)), &truth).penumbra_rmse().expect("a penumbra")
        };
        let (e_ssm, e_pcss, e_back) = (penumbra(&ssm), penumbra(&pcss), penumbra(&back));
        println!("bunny, {name}: penumbra RMSE ssm {e_ssm:.4}, pcss {e_pcss:.4}, ssm on back faces {e_back:.4}");
        // Measured at 128² (256 reference samples): azri 0.103 against 0.194 (0.53 ×), default
        // 0.097 against 0.156 (0.62 ×); with the back faces and the other map techniques' bias,
        // 0.197 and 0.165 (1.02 ×, 1.06 ×). Bound: below `pcss`, the issue's.
        assert!(e_ssm < e_pcss, "{name}: ssm {e_ssm} vs pcss {e_pcss}");
    }
}

/// The check in the room: with all four lights (two lamps, the accent lamp under its
/// board, the sun through the window), `ssm`'s penumbra error pooled over the lights, as `compare`
/// reports it, is below `pcss`'s.
#[test]
fn penumbra_error_in_the_room_is_below_pcss() {
    let gpu = gpu();
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let lights: Vec<LightId> = (0..scene.lights.len() as u32).map(LightId).collect();
    let ssm = render(&gpu, &scene, &view, 128, "ssm", &lights);
    let pcss = render(&gpu, &scene, &view, 128, "pcss", &lights);
    let (mut e_ssm, mut e_pcss) = (ErrorStats::default(), ErrorStats::default());
    for &light in &lights {
        let truth = reference(&scene, &ssm.surface, light, 256);
        e_ssm.merge(&ErrorStats::compare(&ssm.visibility(light), &truth));
        e_pcss.merge(&ErrorStats::compare(&pcss.visibility(light), &truth));
    }
    let (e_ssm, e_pcss) = (e_ssm.penumbra_rmse().unwrap(), e_pcss.penumbra_rmse().unwrap());
    println!("room: penumbra RMSE ssm {e_ssm:.4}, pcss {e_pcss:.4}");
    // Measured at 128² (256 reference samples): 0.0643 against 0.0675 (0.95 ×; 0.0678 at `t_k=8`;
    // 0.0723 with the emitter's centre tested at the biased point, 0.0803 before both fixes of
    // `the_normal_offset_leaves_the_penumbra_in_place` and `an_occluder_ending_on_a_coarse_border_keeps_it`).
    // Bound: below `pcss`, the issue's.
    assert!(e_ssm < e_pcss, "ssm {e_ssm} vs pcss {e_pcss}");
}

/// A receiver in the map (front faces, `ssm`'s default) at a crease: where `columns`' ceiling
/// meets the end wall, the wall faces lamp 0 squarely, so beside the ceiling's pixels the map
/// holds the wall at the ceiling's own depth, nearer the light than the ceiling's plane extended
/// past the wall. Counted as an occluder at the receiver's depth, its back-projection covered the
/// whole emitter and the lit crease went black (13 lit pixels below ½ at 128²). Nothing farther
/// from the light than the receiver occludes it (`threshold` in ssm.wgsl).
#[test]
fn a_lit_crease_stays_lit_with_the_receiver_in_the_map() {
    let gpu = gpu();
    let scene = load_scene("columns").unwrap().scene;
    let view = scene.view("hall").unwrap().clone();
    let lamp = LightId(0);
    let run = render(&gpu, &scene, &view, 128, "ssm", &[lamp]);
    let truth = reference(&scene, &run.surface, lamp, 64);
    let v = run.visibility(lamp);
    let lit = truth.iter().filter(|t| **t >= 1.0).count();
    let dark = v.iter().zip(&truth).filter(|(v, t)| **t >= 1.0 && **v < 0.5).count();
    println!("columns, lamp 0: {dark} of {lit} fully lit pixels below ½");
    // The case must be there (measured 10 364 lit pixels; at least 5 000).
    assert!(lit >= 5000, "{lit} lit pixels");
    // Measured 0 (13 before, on the crease); bound 3, for stray pixels elsewhere.
    assert!(dark <= 3, "{dark} lit pixels darkened below ½");
}

/// A rectangle light inside a room: the Cornell box's ceiling panel, 1 cm below the ceiling. Its
/// map is a cube, and its side faces see the ceiling beside the light 1 cm from it, the nearest
/// depth of the map: by Eq. 1 alone that ceiling could hide the emitter from every wall, so the
/// kernels spanned the whole map, the level was the top one and the walls went dark (RMSE 0.64).
/// Nothing on or behind a one-sided emitter's plane can hide it from a receiver it lights
/// (`behind_emitter` in ssm.wgsl), and the walls come out as `pcss` draws them or closer.
#[test]
fn a_ceiling_panel_is_not_hidden_by_its_ceiling() {
    let gpu = gpu();
    let obj = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/assets/cornell-box/CornellBox-Original.obj");
    let options = shadowlab_core::LoadOptions { emissive_lights: true };
    let scene = shadowlab_core::load_scene_with(obj.to_str().unwrap(), options).unwrap().scene;
    let view = scene.views[0].clone();
    let panel = LightId(0);
    let ssm = render(&gpu, &scene, &view, 128, "ssm", &[panel]);
    let truth = reference(&scene, &ssm.surface, panel, 128);
    let pcss = render(&gpu, &scene, &view, 128, "pcss", &[panel]);
    let (e_ssm, e_pcss) = (rmse(&ssm.visibility(panel), &truth), rmse(&pcss.visibility(panel), &truth));
    println!("Cornell box: RMSE ssm {e_ssm:.4}, pcss {e_pcss:.4}");
    // Measured at 128² (128 reference samples): 0.054 against `pcss`'s 0.068 (0.64 before; 0.040
    // at `t_k=8`). Bound: no worse than `pcss`.
    assert!(e_ssm <= e_pcss, "ssm {e_ssm} vs pcss {e_pcss}");
}

/// Past about 6.7 million output pixels (4K) the list with every listed pixel's setup would outgrow
/// a storage binding on CPU adapters and in browsers (128 MiB), and `visibility` sets each pixel up
/// again instead (`records=off` forces it at any size): the same code, so the same image, bit for
/// bit. (Returning the setup of the next pixel instead changed 1 428 of the room's pixel-lights.)
#[test]
fn pixels_set_up_again_give_the_same_image() {
    let gpu = gpu();
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let lights: Vec<LightId> = (0..scene.lights.len() as u32).map(LightId).collect();
    let kept = render(&gpu, &scene, &view, 96, "ssm", &lights);
    let again = render(&gpu, &scene, &view, 96, "ssm:records=off", &lights);
    let differ: usize = lights
        .iter()
        .map(|&l| {
            let (a, b) = (kept.visibility(l), again.visibility(l));
            a.iter().zip(&b).filter(|(x, y)| !(x.is_nan() && y.is_nan()) && x != y).count()
        })
        .sum();
    assert_eq!(differ, 0, "{differ} pixel-lights differ with the setups made again");
}

/// A depth pyramid larger than a storage binding may hold is a clear error that names the largest
/// map size that fits, not a failed binding: one 8192² view needs 171 MiB of levels, past the
/// 128 MiB of CPU adapters and browsers (an adapter that binds more renders it).
#[test]
fn a_pyramid_past_the_binding_limit_is_a_clear_error() {
    let gpu = gpu();
    let (scene, _) = penumbra(0.5);
    let view = scene.view("default").unwrap().clone();
    let mut renderer = Renderer::new(&gpu, scene, &view, 32, 32);
    renderer.set_technique(LightId(0), &TechniqueSpec::parse("ssm:map_size=8192", &[]).unwrap()).unwrap();
    let limits = gpu.device.limits();
    let limit = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
    // Levels 1… of one 8192² view: 4096² + 2048² + … + 1 texels of 8 bytes.
    let needed: u64 = (0..13).map(|k| 1u64 << (2 * k)).sum::<u64>() * 8;
    match renderer.render() {
        Err(e) if needed > limit => {
            let message = e.to_string();
            assert!(message.contains("map_size=4096 or less"), "unclear: {message}");
        }
        Ok(_) if needed <= limit => {}
        other => panic!("needed {needed} bytes against a limit of {limit}: {other:?}"),
    }
}

/// A device like `common::gpu`'s (lavapipe), whose storage bindings hold at most `bytes`.
fn gpu_with_binding_limit(bytes: u64) -> shadowlab::Gpu {
    pollster::block_on(async {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN;
        let instance = wgpu::Instance::new(desc);
        let adapter =
            instance.request_adapter(&wgpu::RequestAdapterOptions::default()).await.expect("a Vulkan adapter");
        let mut limits = adapter.limits();
        limits.max_storage_buffer_binding_size = bytes;
        let wanted = wgpu::Features::TIMESTAMP_QUERY
            | wgpu::Features::DEPTH_CLIP_CONTROL
            | wgpu::Features::DEPTH32FLOAT_STENCIL8;
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("small bindings"),
                required_features: adapter.features() & wanted,
                required_limits: limits,
                ..Default::default()
            })
            .await
            .expect("a device with smaller bindings");
        shadowlab::Gpu::from_device(device, queue, &adapter.get_info())
    })
}

/// Resized across the size past which the list cannot hold every listed pixel's setup (a storage
/// binding's limit: about 4K on CPU adapters and in browsers), `ssm` makes its list again without
/// them and its pipelines follow, and back again: at each size every light equals, bit for bit, a
/// fresh engine's on a device that binds enough (the same code either way). The limit is lowered
/// to 1 MiB on a device of the test's own: 128² records (320 KiB of list), 256² does not (1.25
/// MiB), as `ssm_setups_recorded` says. Fails if the pipelines keep the recording variant over
/// the smaller list (7 977 pixels of a light differ at 256²); and failed while a resize rebuilt
/// the view from the camera's matrices (1 242 pixels of a light at 128²).
#[test]
fn a_resize_across_the_record_limit_keeps_the_image() {
    let small = gpu_with_binding_limit(1 << 20);
    let gpu = gpu();
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let lights: Vec<LightId> = (0..scene.lights.len() as u32).map(LightId).collect();
    let spec = "ssm:map_size=256";
    let technique = TechniqueSpec::parse(spec, &[]).unwrap();
    let mut live = Renderer::new(&small, scene.clone(), &view, 128, 128);
    for &l in &lights {
        live.set_technique(l, &technique).unwrap();
    }
    for size in [128, 256, 128] {
        live.resize(size, size).unwrap();
        live.render().unwrap();
        let error = small.take_error();
        assert!(error.is_none(), "{size}²: {error:?}");
        let recorded: Vec<f64> = live
            .shadows
            .stats()
            .extra
            .iter()
            .filter(|(k, _)| k.ends_with("ssm_setups_recorded"))
            .map(|(_, v)| *v)
            .collect();
        let expected = if size == 128 { 1.0 } else { 0.0 };
        assert!(
            recorded.len() == lights.len() && recorded.iter().all(|&r| r == expected),
            "{size}²: setups recorded {recorded:?}, expected {expected} for each light"
        );
        let fresh = render(&gpu, &scene, &view, size, spec, &lights);
        for &l in &lights {
            let mine = live.read_visibility(l).unwrap().expect("shadowed");
            let theirs = fresh.visibility(l);
            let differ = mine.iter().zip(&theirs).filter(|(a, b)| !(a.is_nan() && b.is_nan()) && a != b).count();
            assert_eq!(differ, 0, "{size}²: light {}: {differ} pixels differ from a fresh engine", l.index());
        }
    }
}
