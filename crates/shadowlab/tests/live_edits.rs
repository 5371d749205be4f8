//! The live engine under many edits: what a chair in a corner costs a lamp that does not reach it,
//! memory after thousands of random edits, a dragged object's shadow against the truth, and bad
//! edits at the engine's level.

mod common;

use glam::{Affine3A, Vec3};
use shadowlab::{Edit, EditError, LightChange, Renderer, TechniqueSpec};
use shadowlab_core::{Aabb, LightId, Mobility, SurfaceBuffer, load_scene};
use shadowlab_reference::metrics::ErrorStats;

use common::{gpu, reference};

fn renderer(scene: &str, spec: &str, lights: &[LightId], size: (u32, u32)) -> Renderer {
    let scene = load_scene(scene).unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let mut r = Renderer::new(&gpu(), scene, &view, size.0, size.1);
    let spec = TechniqueSpec::parse(spec, &[]).unwrap();
    for &l in lights {
        r.set_technique(l, &spec).unwrap();
    }
    r
}

/// `room:lamps=8`: a chair pushed into a corner that lamp 4's range (4 m from (1.9, 1.9, 1.35))
/// does not reach re-renders nothing for it, while a lamp that does reach it re-renders.
#[test]
fn a_chair_in_a_corner_costs_nothing_to_a_lamp_that_does_not_reach_it() {
    let scene = load_scene("room:lamps=8").unwrap().scene;
    let far_lamp = scene.find_light("lamp 4").unwrap();
    let near_lamp = scene.find_light("lamp 6").unwrap();
    let corner = Vec3::new(-2.1, 0.0, -1.6); // the north-west corner of the floor
    let light = |l: LightId| scene.lights[l.index()].clone();
    let reach = |l: LightId| light(l).position().unwrap().distance(corner) - light(l).range.unwrap();
    assert!(reach(far_lamp) > 0.8, "lamp 4 must not reach the corner: {}", reach(far_lamp));
    assert!(reach(near_lamp) < -0.5, "lamp 6 must reach it: {}", reach(near_lamp));
    for (lamp, expect_work) in [(far_lamp, false), (near_lamp, true)] {
        let mut r = renderer("room:lamps=8", "hard:map_size=256", &[lamp], (48, 36));
        let chair = r.shadows.live().find_instance("chair north-west").unwrap();
        let t = r.shadows.live().instance(chair).unwrap().transform;
        let to = Affine3A::from_translation(corner + Vec3::new(0.4, 0.0, 0.4) - Vec3::from(t.translation)) * t;
        // Pushed into the corner first (leaving the table, which both lamps reach) ...
        r.apply(Edit::Transform { instance: chair, transform: to }).unwrap();
        r.render().unwrap();
        // ... then moved about within it.
        let nudged = Affine3A::from_translation(Vec3::new(0.1, 0.0, -0.05)) * to;
        r.apply(Edit::Transform { instance: chair, transform: nudged }).unwrap();
        let w = r.render().unwrap().work;
        assert_eq!(w.map_views > 0, expect_work, "lamp {}: {w:?}", lamp.0);
    }
}

/// The memory and cached items of `r` with every object of `movable` (and the copies added) at
/// rest (static): what a drag
/// holds (the dragged objects' maps and layers) is freed on release, so memory is compared between
/// like states.
fn settled(r: &mut Renderer, movable: &[shadowlab::InstanceId]) -> (u64, usize) {
    for &id in movable {
        r.apply(Edit::Mobility { instance: id, mobility: Mobility::Static }).unwrap();
    }
    r.render().unwrap();
    (r.shadows.memory_bytes(), r.shadows.cached_items())
}

/// 10,000 random edits (moves, mobility changes, drags, additions and removals, light changes):
/// the GPU memory shadows hold is the same as after the first 100, and so is the cache's size.
#[test]
fn memory_does_not_grow_under_ten_thousand_edits() {
    let mut r = renderer("room", "hard:map_size=64", &[LightId(0), LightId(3)], (32, 24));
    r.render().unwrap();
    let mut rng = shadowlab_core::sampling::Rng::for_stream(7, 1);
    let movable: Vec<_> = ["chair east", "chair south", "cup", "bowl", "chair north-east"]
        .map(|n| r.shadows.live().find_instance(n).unwrap())
        .into();
    let home: Vec<Affine3A> = movable.iter().map(|&id| r.shadows.live().instance(id).unwrap().transform).collect();
    let mut added = Vec::new();
    let mut after_100 = (0, 0);
    for k in 0..10_000u32 {
        let id = movable[(rng.next_f32() * movable.len() as f32) as usize % movable.len()];
        let edit = match (rng.next_f32() * 6.0) as u32 {
            0 | 1 => {
                // Anywhere within 15 cm of where it started: the objects stay in the same views, so
                // the composite layers they need are made in the first edits.
                let t = home[movable.iter().position(|m| *m == id).unwrap()];
                let d = Vec3::new(rng.next_f32() - 0.5, 0.0, rng.next_f32() - 0.5) * 0.3;
                Edit::Transform { instance: id, transform: Affine3A::from_translation(d) * t }
            }
            2 => Edit::Mobility {
                instance: id,
                mobility: [Mobility::Static, Mobility::Dynamic, Mobility::Temporary]
                    [(rng.next_f32() * 3.0) as usize % 3],
            },
            3 if added.len() < 3 => {
                let mut copy = r.shadows.live().instance(id).unwrap().clone();
                copy.name = format!("copy {k}");
                Edit::AddInstance(Box::new(copy))
            }
            3 | 4 if !added.is_empty() => Edit::RemoveInstance(added.swap_remove(0)),
            _ => Edit::Light { light: LightId(0), change: LightChange::Radius(0.05 + 0.05 * rng.next_f32()) },
        };
        if let Ok(a) = r.apply(edit)
            && matches!(a.kind, shadowlab::live::EditKind::AddInstance(_))
        {
            added.extend(a.instance);
        }
        if k % 25 == 0 {
            r.render().unwrap();
        }
        if k == 100 {
            after_100 = settled(&mut r, &[&movable[..], &added[..]].concat());
        }
    }
    let last = settled(&mut r, &[&movable[..], &added[..]].concat());
    println!("after 100 edits {after_100:?}, after 10,000 {last:?}");
    assert_eq!(last.0, after_100.0, "GPU memory grew");
    // The cache holds one record per live item, whatever the number of edits: at most a static and
    // a composite record for each of the ceiling lamp's six cube faces and the sun's one view
    // (measured 7 after 100 edits and after 10,000, all objects at rest).
    assert!(last.1 <= 2 * (6 + 1), "the cache holds {} records after {} at edit 100", last.1, after_100.1);
}

/// The dragged chair casts through its own pass: its shadow against the ray-traced truth is no
/// worse than `hard`'s with the chair at rest in the same place, and the shadows on it are
/// nearly as right.
#[test]
fn a_dragged_chair_casts_a_shadow_as_right_as_a_resting_one() {
    let lights: Vec<LightId> = (0..4).map(LightId).collect();
    let mut scene = load_scene("room").unwrap().scene;
    scene.scale_emitters(0.0);
    // Over every pixel, and over those that show the chair (within its bounds).
    let wrong = |r: &mut Renderer, surface: &SurfaceBuffer, chair: &Aabb| {
        let (mut s, mut on_chair, mut shadowed) = (ErrorStats::default(), ErrorStats::default(), 0);
        for &l in &lights {
            let v = r.read_visibility(l).unwrap().unwrap();
            let truth = reference(r.scene(), surface, l, 1);
            s.merge(&ErrorStats::compare(&v, &truth));
            let mask: Vec<bool> = surface.positions.iter().map(|p| chair.contains(*p)).collect();
            on_chair.merge(&ErrorStats::compare_masked(&v, &truth, &mask));
            shadowed += truth.iter().zip(&mask).filter(|(t, m)| **m && **t < 0.5).count();
        }
        (s.wrong_frac(), on_chair.wrong_frac(), on_chair.pixels, shadowed)
    };
    let view = scene.view("default").unwrap().clone();
    let gpu = gpu();
    let spec = TechniqueSpec::parse("hard", &[]).unwrap();
    const SIZE: u32 = 128;
    let mut r = Renderer::new(&gpu, scene, &view, SIZE, SIZE);
    for &l in &lights {
        r.set_technique(l, &spec).unwrap();
    }
    let chair = r.shadows.live().find_instance("chair east").unwrap();
    let t = r.shadows.live().instance(chair).unwrap().transform;
    let to = Affine3A::from_translation(Vec3::new(-0.6, 0.0, 0.4)) * t;
    r.apply(Edit::Mobility { instance: chair, mobility: Mobility::Temporary }).unwrap();
    r.apply(Edit::Transform { instance: chair, transform: to }).unwrap();
    r.render().unwrap();
    let surface = r.read_surface().unwrap();
    let bounds = r.shadows.live().instances()[r.shadows.live().instance_index(chair).unwrap()].bounds;
    let e = Vec3::splat(0.01);
    let bounds = Aabb::new(bounds.min - e, bounds.max + e);
    let (dragged, dragged_chair, n, shadowed) = wrong(&mut r, &surface, &bounds);
    r.apply(Edit::Mobility { instance: chair, mobility: Mobility::Static }).unwrap();
    r.render().unwrap();
    let (resting, resting_chair, _, _) = wrong(&mut r, &surface, &bounds);
    println!(
        "wrong_frac: dragged {dragged:.5}, at rest {resting:.5}; on the chair ({n} pixel-lights, {shadowed} in shadow) {dragged_chair:.5}, {resting_chair:.5}"
    );
    // Measured 0.00151 dragged (256² object maps at 128 × 128) against 0.00123 at rest (when every
    // light's dragged-object pass read the last light's views, 0.021 at 96²); margin: 0.1 points.
    assert!(dragged <= resting + 0.001, "dragged {dragged} vs at rest {resting}");
    // The chair itself, dragged, takes the permanent casters' shadow from the whole scene's maps
    // (256² a face) rather than the techniques' layers, which are of the floor behind it: measured
    // 0.0164 wrong against 0.0073 at rest (`hard`'s own 2048² maps), 0.108 when it took the layers
    // behind; margin: 0.01 above the measured difference. The case must be there: 326 of the
    // chair's pixel-lights in shadow (at least 100).
    assert!(shadowed >= 100, "{shadowed} shadowed pixel-lights on the chair");
    assert!(dragged_chair <= resting_chair + 0.02, "on the chair: dragged {dragged_chair} vs at rest {resting_chair}");
}

/// Bad edits through the engine: errors that change nothing, and the next frame renders.
#[test]
fn bad_edits_through_the_engine_change_nothing() {
    let mut r = renderer("room", "hard:map_size=128", &[LightId(0)], (32, 24));
    r.render().unwrap();
    let before = r.shadows.live().scene().clone();
    assert!(matches!(r.resize(0, 10), Err(EditError::BadSize { .. })));
    assert!(r.resize(1 << 20, 10).is_err());
    assert!(r.apply(Edit::Light { light: LightId(0), change: LightChange::Radius(f32::NAN) }).is_err());
    let chair = r.shadows.live().find_instance("chair east").unwrap();
    let nan = Affine3A::from_translation(Vec3::NAN);
    assert!(matches!(r.apply(Edit::Transform { instance: chair, transform: nan }), Err(EditError::BadInstance { .. })));
    // Finite moves whose scene would have an infinite extent, as a scene file may not (a move to
    // 3e38 m once went through and overflowed the truth's BVH build): a chair 1e20 m away makes
    // the room's diagonal overflow, and so does a copy of the chair added there.
    let far = Affine3A::from_translation(Vec3::new(1e20, 0.0, 0.0));
    assert!(matches!(r.apply(Edit::Transform { instance: chair, transform: far }), Err(EditError::BadInstance { .. })));
    let mut copy = r.shadows.live().instance(chair).unwrap().clone();
    copy.transform = far;
    copy.name = "far chair".into();
    assert!(matches!(r.apply(Edit::AddInstance(Box::new(copy))), Err(EditError::BadInstance { .. })));
    assert_eq!(r.shadows.live().scene(), &before);
    let w = r.render().unwrap().work;
    assert!(!w.rebuilt_anything(), "nothing changed, nothing rebuilt: {w:?}");
}

/// The frame right after an edit shows the edit: the G-buffer draws the instances as they are now
/// (it once drew the previous frame's groups over the new instance buffer after a removal).
#[test]
fn the_frame_after_an_edit_draws_the_edited_scene() {
    let mut r = renderer("room", "hard:map_size=128", &[LightId(0)], (48, 36));
    r.render().unwrap();
    let edits = |r: &Renderer| {
        let live = r.shadows.live();
        let (cup, chair) = (live.find_instance("cup").unwrap(), live.find_instance("chair south").unwrap());
        let t = live.instance(chair).unwrap().transform;
        [
            Edit::RemoveInstance(cup),
            Edit::Transform { instance: chair, transform: Affine3A::from_translation(Vec3::new(0.3, 0.0, 0.0)) * t },
            Edit::Mobility { instance: chair, mobility: Mobility::Dynamic },
        ]
    };
    for edit in edits(&r) {
        let what = format!("{edit:?}");
        r.apply(edit).unwrap();
        r.render().unwrap();
        let live_surface = r.read_surface().unwrap();
        let view = r.scene().view("default").unwrap().clone();
        let mut fresh = Renderer::new(&gpu(), r.scene().clone(), &view, 48, 36);
        fresh.render().unwrap();
        let fresh_surface = fresh.read_surface().unwrap();
        assert!(live_surface.positions == fresh_surface.positions, "after {what} the G-buffer lags");
    }
}

/// Issue 17 item 8: 64 point lights with `hard` at its default 2048² maps ask for about 12.9 GB
/// (six faces each, doubled for the room's dynamic chair's composite copies); under the default
/// map budget they allocate at most the budget, the run names every light it cut, and every
/// light still casts its shadow.
#[test]
fn sixty_four_lights_fit_the_map_budget_and_all_still_cast() {
    use shadowlab_core::{Light, LightKind};
    use shadowlab_reference::bvh::{SceneBvh, Selection};
    use shadowlab_reference::visibility::{ReferenceSettings, light_visibility};
    let mut scene = load_scene("room").unwrap().scene;
    // 60 more point lamps, 10 × 6 under the 2.6 m ceiling, each reaching 3 m.
    for i in 0..60 {
        let (x, z) = (-2.0 + 4.0 * (i % 10) as f32 / 9.0, -1.5 + 3.0 * (i / 10) as f32 / 5.0);
        let mut lamp = Light::new(
            format!("grid {i}"),
            LightKind::Point { position: Vec3::new(x, 2.1, z), radius: 0.0 },
            Vec3::ONE,
            0.05,
        );
        lamp.range = Some(3.0);
        scene.lights.push(lamp);
    }
    scene.scale_emitters(0.0);
    assert_eq!(scene.lights.len(), 64);
    let view = scene.view("default").unwrap().clone();
    let (w, h) = (48, 36);
    let mut r = Renderer::new(&gpu(), scene, &view, w, h);
    let spec = TechniqueSpec::parse("hard", &[]).unwrap();
    for l in 0..64 {
        r.set_technique(LightId(l), &spec).unwrap();
    }
    assert_eq!(r.shadows.map_budget(), Some(shadowlab::DEFAULT_MAP_BUDGET));
    r.render().unwrap();
    let memory = r.shadows.memory_bytes();
    let cut = r.shadows.map_reductions();
    println!("memory {:.1} MiB; {} lights cut, e.g. {:?}", memory as f64 / (1 << 20) as f64, cut.len(), cut.first());
    assert!(memory <= shadowlab::DEFAULT_MAP_BUDGET, "{memory} bytes of shadow data over the budget");
    // What the cut lights asked for alone is over the budget: the test is not vacuous.
    let asked: u64 = cut.iter().map(|&(_, a, _)| 6 * 4 * u64::from(a) * u64::from(a)).sum();
    assert!(asked > shadowlab::DEFAULT_MAP_BUDGET, "asked {asked}");
    assert!(cut.iter().all(|&(_, asked, granted)| granted < asked && granted >= 16), "{cut:?}");
    // Every light is cut (measured: all 64; the sun's one view, doubled, asks 32 MiB of a 16 MiB share).
    assert_eq!(cut.len(), 64, "{} lights cut", cut.len());

    // Every light still casts: where the truth shadows at least 10 relevant pixels, the light's
    // layer shadows at least half of them (measured: 0.889 at worst, at 48 × 36).
    let surface = r.read_surface().unwrap();
    let bvh = SceneBvh::build(r.scene(), Selection::Casters);
    let settings = ReferenceSettings { samples: 1, seed: 1 };
    let (mut checked, mut worst) = (0, 1.0f64);
    for l in 0..64u32 {
        let light = &r.scene().lights[l as usize];
        let truth = light_visibility(&bvh, &surface, light, l, &settings, None).values;
        let got = r.read_visibility(LightId(l)).unwrap().unwrap();
        let shadowed: Vec<usize> =
            (0..truth.len()).filter(|&i| surface.is_relevant(i, light) && truth[i] < 0.5).collect();
        if shadowed.len() < 10 {
            continue;
        }
        checked += 1;
        let kept = shadowed.iter().filter(|&&i| got[i] < 0.5).count();
        worst = worst.min(kept as f64 / shadowed.len() as f64);
        assert!(2 * kept >= shadowed.len(), "light '{}': {kept} of {} shadowed pixels", light.name, shadowed.len());
    }
    println!("{checked} lights checked, the worst keeps {worst:.3} of its shadowed pixels");
    // Most lights shadow something in view (measured: 62 of 64); at least half must, or the
    // check says little.
    assert!(checked >= 32, "only {checked} lights shadow 10 pixels: the check says little");

    // The shares are planned when the lights change, not when the camera moves: a camera move
    // re-renders no map, and the live engine still equals a fresh one (which takes the same plan).
    let table = r.scene().view("table").unwrap().clone();
    r.set_view(&table);
    let work = r.render().unwrap().work;
    assert_eq!(work.map_views, 0, "a camera move re-rendered maps under the budget: {work:?}");
    let (live, fresh) = (r.live_visibility().unwrap(), r.fresh_visibility().unwrap());
    assert_eq!(live.len(), 64);
    for ((l, a), (_, b)) in live.iter().zip(&fresh) {
        assert!(a == b, "light {l}: the live engine differs from a fresh one under the budget");
    }

    // Edits that change the demands re-plan the shares: a light removed (the others' shares grow)
    // and a lamp moved; after each the live engine equals a fresh one.
    r.apply(Edit::RemoveLight(LightId(63))).unwrap();
    let moved = r.scene().lights[10].position().unwrap() + Vec3::new(0.1, 0.0, 0.1);
    r.apply(Edit::Light { light: LightId(10), change: LightChange::Position(moved) }).unwrap();
    r.render().unwrap();
    let (live, fresh) = (r.live_visibility().unwrap(), r.fresh_visibility().unwrap());
    assert_eq!(live.len(), 63);
    for ((l, a), (_, b)) in live.iter().zip(&fresh) {
        assert!(a == b, "light {l}: after the edits the live engine differs from a fresh one under the budget");
    }

    // The chair picked up where it stands: every light's layer now comes from the dragged objects'
    // lookup (a workgroup per block and 32 lights, so 63 lights take two words) and must show
    // about what the light's own maps showed. A light read from another's entry or layer would
    // differ over a large part of its pixels.
    r.set_view(&view);
    r.render().unwrap();
    let before: Vec<(usize, Vec<f32>)> = r.live_visibility().unwrap();
    let chair = r.shadows.live().find_instance("chair east").unwrap();
    r.apply(Edit::Mobility { instance: chair, mobility: Mobility::Temporary }).unwrap();
    let work = r.render().unwrap().work;
    assert!(work.temporary_views >= 32, "the chair's pass runs for the lights: {work:?}");
    let surface = r.read_surface().unwrap();
    let after = r.live_visibility().unwrap();
    let (mut changed, mut pixels) = (0usize, 0usize);
    for ((l, a), (_, b)) in before.iter().zip(&after) {
        let light = &r.scene().lights[*l];
        let relevant: Vec<usize> = (0..a.len()).filter(|&i| surface.is_relevant(i, light)).collect();
        changed += relevant.iter().filter(|&&i| (a[i] - b[i]).abs() > 0.5).count();
        pixels += relevant.len();
    }
    let changed = changed as f64 / pixels as f64;
    println!("picked up: {changed:.5} of the lights' relevant pixels changed");
    // Measured: 0.00031–0.00034 at 48 × 36 (edges: the chair's own map against the light's cube map; at
    // worst 0.003 of one light's pixels). With the lights past the 32nd reading the first 32's
    // entries (their chair shadows lost), 0.0026. Bound: 0.001.
    assert!(changed <= 0.001, "{changed:.5} of the pixels changed at the pick-up");
}
