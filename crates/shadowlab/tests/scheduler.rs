//! Fills spread over frames (Toromanoff 2005 alg. 13–15) with a scripted clock: fixed unit costs
//! and render time, so that what each frame may do is known exactly and nothing depends on timing.

mod common;

use glam::Vec3;
use shadowlab::live::scheduler::{CostModel, UnitKind};
use shadowlab::{Edit, Renderer, TechniqueSpec};
use shadowlab_core::{LightId, load_scene};

use common::gpu;

/// Room, `hard` on the ceiling lamp (six cube faces) and the sun (one view): seven views. Each view
/// costs 1 ms, rendering 10 ms; a 13 ms target leaves 13 − 10 − 1.3 = 1.7 ms: one view a frame.
fn sliced() -> Renderer {
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let mut r = Renderer::new(&gpu(), scene, &view, 48, 36);
    let hard = TechniqueSpec::parse("hard:map_size=256", &[]).unwrap();
    for l in [0, 3] {
        r.set_technique(LightId(l), &hard).unwrap();
    }
    r.shadows.script_costs(CostModel::scripted(&[(UnitKind::MapView, 1.0)]), 10.0);
    r.set_target_ms(Some(13.0));
    r
}

/// Whether the first shadowed light's visibility equals a fresh engine's exactly.
fn first_light_equals_fresh(r: &Renderer) -> bool {
    r.live_visibility().unwrap()[0].1 == r.fresh_visibility().unwrap()[0].1
}

/// Cache fills a frame made: maps, light-map samples, volumes, light meshes (not the dragged
/// objects' own views, drawn every step).
fn fills(w: &shadowlab::Work) -> u32 {
    w.map_views + w.lightmap_samples + w.volume_objects + w.light_meshes
}

fn visibility(r: &Renderer) -> Vec<Vec<f32>> {
    r.live_visibility().unwrap().into_iter().map(|(_, v)| v).collect()
}

/// At start-up nothing is shown until a light's every view is rendered (all or nothing), one view a
/// frame, and its unshadowed layer is not resolved again meanwhile; then it equals a fresh
/// engine's, and its level never goes back.
#[test]
fn start_up_fills_one_view_a_frame_and_shows_a_light_only_when_complete() {
    let mut r = sliced();
    let mut levels = Vec::new();
    for frame in 0..10 {
        let w = r.render().unwrap().work;
        // The budget is never exceeded but by the one unit every frame runs (a view, with its
        // composite copy where the dynamic chair reaches it).
        let views = w.map_views - w.composite_views;
        assert!(views <= 1, "frame {frame} rendered {views} views");
        assert!(w.planned_ms <= w.budget_ms || views == 1, "frame {frame}: {w:?}");
        let l: Vec<u32> = r.shadows.levels().iter().map(|x| x.1).collect();
        for (now, before) in l.iter().zip(levels.last().unwrap_or(&vec![0, 0])) {
            assert!(now >= before, "frame {frame}: a level went down: {l:?}");
        }
        // A light still unshadowed keeps its layer while its views fill out of sight: a frame
        // that shows no light anew resolves nothing (frame 0 resolves every light once).
        if frame > 0 && levels.last() == Some(&l) {
            assert_eq!(w.resolves, 0, "frame {frame}: no level changed, yet a layer was resolved: {w:?}");
        }
        // Unshadowed lights are exactly 1 wherever relevant.
        for (light, v) in r.shadows.levels().iter().zip(visibility(&r)) {
            if light.1 == 0 {
                assert!(v.iter().all(|&x| x == 1.0), "frame {frame}: light {:?} shows a half state", light.0);
            }
        }
        levels.push(l);
    }
    // Seven views, one per frame: the sun (one view) is complete in its first frame or after
    // the lamp's six, the lamp after six frames at the latest... both by the seventh.
    assert_eq!(levels[6], vec![1, 1], "{levels:?}");
    assert!(levels[0].contains(&0), "something waited: {levels:?}");
    let fresh = r.fresh_visibility().unwrap();
    for ((_, f), v) in fresh.iter().zip(visibility(&r)) {
        assert!(f == &v, "complete, the sliced engine equals a fresh one");
    }
}

/// A chair moved across the room: until every view it was or is in is rendered anew, the old
/// complete maps are shown (no half state), then the new ones, equal to a fresh engine's.
#[test]
fn a_moved_chair_shows_its_old_shadows_until_all_new_views_are_done() {
    let mut r = sliced();
    for _ in 0..8 {
        r.render().unwrap();
    }
    assert_eq!(r.shadows.levels().iter().map(|x| x.1).collect::<Vec<_>>(), vec![1, 1]);
    let before = visibility(&r);
    let surface_before = r.read_surface().unwrap();
    let chair = r.shadows.live().find_instance("chair north-west").unwrap();
    let t = r.shadows.live().instance(chair).unwrap().transform;
    let across = glam::Affine3A::from_translation(Vec3::new(1.6, 0.0, 1.2)) * t;
    r.apply(Edit::Transform { instance: chair, transform: across }).unwrap();
    let mut frames = 0;
    let mut rendered = 0;
    loop {
        let w = r.render().unwrap().work;
        frames += 1;
        let views = w.map_views - w.composite_views;
        assert!(views <= 1, "frame {frames}: {w:?}");
        rendered += views;
        let now = visibility(&r);
        if r.shadows.levels().iter().all(|l| l.2) {
            let fresh = r.fresh_visibility().unwrap();
            for (f, v) in fresh.iter().zip(&now) {
                assert!(&f.1 == v, "the new state equals a fresh engine's");
            }
            break;
        }
        // Until the update is complete the old maps are shown: wherever the surface itself did not
        // change (away from the chair's old and new places), the visibility is exactly the old one.
        // (All or nothing holds per light: a light whose update is complete shows its new state.)
        let surface = r.read_surface().unwrap();
        let pending: Vec<bool> = r.shadows.levels().iter().map(|l| !l.2).collect();
        let mut kept = 0;
        for i in 0..surface.len() {
            if surface.positions[i] == surface_before.positions[i] && surface.normals[i] == surface_before.normals[i] {
                kept += 1;
                for (light, (b, n)) in before.iter().zip(&now).enumerate().filter(|(l, _)| pending[*l]) {
                    assert_eq!(b[i], n[i], "frame {frames}, light {light}, pixel {i}: a half-updated map is shown");
                }
            }
        }
        // Most of the image is the same surface (measured 1,530 of 1,728 pixels).
        assert!(kept * 2 > surface.len(), "{kept}");
        assert!(frames < 30, "the update never completed");
    }
    // At one view a frame, as many frames as stale views (and at least two: the update was spread).
    assert!(frames >= 2 && rendered as usize >= frames - 1, "{frames} frames, {rendered} views");
}

/// Room, 16-sample light maps (`hard` elsewhere) on the ceiling lamp. Map views cost 0.1 ms (the
/// rest's six faces in the first frame), samples 1 ms, rendering 10 ms: a 16 ms target leaves
/// 4.4 ms, four samples a frame.
fn sliced_light_maps() -> Renderer {
    sliced_light_maps_of(16, 16.0)
}

/// As [`sliced_light_maps`], with `samples` emitter samples and a target of `target_ms`.
fn sliced_light_maps_of(samples: u32, target_ms: f64) -> Renderer {
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let mut r = Renderer::new(&gpu(), scene, &view, 48, 36);
    let spec = TechniqueSpec::parse(&format!("lightmaps:samples={samples},texel=0.05,rest=hard"), &[]).unwrap();
    r.set_technique(LightId(0), &spec).unwrap();
    let costs = CostModel::scripted(&[(UnitKind::MapView, 0.1), (UnitKind::LightMapSample, 1.0)]);
    r.shadows.script_costs(costs, 10.0);
    r.set_target_ms(Some(target_ms));
    r
}

/// Up to 255 samples share a render pass, each marking the stencil with its number there. 300
/// samples filled over frames, about 100 a frame (a 130 ms target leaves 107 ms), end exactly
/// where a fresh engine's fill of all 300 at once does (a pass of 255 and one of 45). With one
/// mark for every sample of a pass (each reading the earlier ones' shadows as its own) the two
/// differ: checked by making the change.
#[test]
fn more_samples_than_a_pass_holds_add_up_as_over_frames() {
    let mut r = sliced_light_maps_of(300, 130.0);
    let mut frames = 0;
    while !r.shadows.levels()[0].2 {
        let w = r.render().unwrap().work;
        // The scripted clock's bound, not a measurement: 130 − 10 − 13 = 107 ms of budget at 1 ms
        // a sample, one more for rounding.
        assert!(w.lightmap_samples <= 108, "frame {frames}: {w:?}");
        frames += 1;
        assert!(frames < 60, "the light maps never completed");
    }
    assert_eq!(r.shadows.levels()[0].3, 300);
    assert!(first_light_equals_fresh(&r), "300 samples over frames equal 300 at once");
}

/// Light maps filled a few samples a frame: the light shows `rest`'s shadows until every lit
/// receiver has four samples, then climbs the ladder (4, 16 samples) without ever going down, and
/// ends exactly where a fresh engine filling everything at once does (same samples, same order).
#[test]
fn light_maps_accumulate_samples_over_frames_up_the_ladder() {
    let mut r = sliced_light_maps();
    let mut seen = Vec::new();
    for frame in 0..200 {
        let w = r.render().unwrap().work;
        assert!(w.lightmap_samples <= 5, "frame {frame}: {w:?}");
        let (_, level, current, samples) = r.shadows.levels()[0];
        if let Some(&(last, _)) = seen.last() {
            assert!(level >= last, "frame {frame}: the level went down from {last} to {level}");
        }
        seen.push((level, samples));
        if current {
            break;
        }
    }
    let levels: Vec<u32> = seen.iter().map(|s| s.0).collect();
    println!("levels over frames: {levels:?}, samples {:?}", seen.iter().map(|s| s.1).collect::<Vec<_>>());
    // Level 1 (the rest only) first, then 2 (every lit receiver at 4 samples), then 3 (16).
    assert_eq!(levels.first(), Some(&1));
    assert!(levels.contains(&2) && levels.last() == Some(&3), "{levels:?}");
    assert_eq!(seen.last().unwrap().1, 16);
    assert!(first_light_equals_fresh(&r), "sixteen samples accumulated over frames equal sixteen at once");
}

/// Renders until the first light shows its current state at its top level.
fn settle(r: &mut Renderer) {
    for _ in 0..200 {
        r.render().unwrap();
        if r.shadows.levels()[0].2 {
            return;
        }
    }
    panic!("the light maps never completed");
}

/// The frames of a pick-up staged for `lights` lights (a budget below the render time): one that
/// draws the permanent surface and turns no light, then two a light, which resolves its layer over
/// the permanent surface while still held, then joins the dragged objects' pass. Asserts that
/// shape (the lights held, which frames resolve, no cache fill beside it) and returns the frames'
/// work.
fn staged_turns(r: &mut Renderer, lights: u32) -> Vec<shadowlab::Work> {
    let work: Vec<shadowlab::Work> = (0..2 * lights + 1).map(|_| r.render().unwrap().work).collect();
    let held: Vec<u32> = work.iter().map(|w| w.held_lights).collect();
    let resolves: Vec<u32> = work.iter().map(|w| w.resolves).collect();
    let expect_held: Vec<u32> = (0..=2 * lights).map(|f| lights - f / 2).collect();
    let expect_resolves: Vec<u32> = (0..=2 * lights).map(|f| f % 2).collect();
    assert_eq!((held, resolves), (expect_held, expect_resolves), "a staged pick-up: {work:?}");
    assert!(work.iter().all(|w| fills(w) == 0), "the pick-up's pieces are their frames' work: {work:?}");
    work
}

/// Light maps the last frame showed anew (a fill or a rung promoted), over every light.
fn light_maps_shown(r: &Renderer) -> f64 {
    r.shadows.stats().extra.iter().filter(|(k, _)| k.ends_with("light_maps_filled")).map(|(_, v)| v).sum()
}

/// A refill spread over frames accumulates out of sight: a frame that adds samples without showing
/// a new rung of the ladder resolves no light again and redraws none of the dragged chair's maps
/// (each one did both before, and showed every sample added); a frame that shows one resolves that
/// light alone, and the end equals a fresh engine.
#[test]
fn frames_that_only_accumulate_out_of_sight_resolve_nothing() {
    use shadowlab_core::Mobility;
    let mut r = sliced_light_maps();
    settle(&mut r);
    let chair = r.shadows.live().find_instance("chair east").unwrap();
    r.apply(Edit::Mobility { instance: chair, mobility: Mobility::Temporary }).unwrap();
    // A budget below the render time stages the pick-up: a frame draws the permanent surface, the
    // next resolves the light over it, the third joins the chair's pass.
    let pick_up = staged_turns(&mut r, 1);
    assert_eq!(
        pick_up.iter().map(|w| w.resolves).sum::<u32>(),
        1,
        "the pick-up resolves the light over the permanent surface"
    );
    // The chair's own view from the ceiling lamp (one frustum: it is far from the lamp), and the
    // lamp's cube faces of the permanent casters that the chair reaches.
    let mut faces = pick_up[2].temporary_views - 1;
    let (mut quiet, mut shows) = (0, 0);
    for frame in 1..100 {
        let w = r.render().unwrap().work;
        if light_maps_shown(&r) > 0.0 {
            shows += 1;
            assert_eq!(w.resolves, 1, "frame {frame} shows a rung: the light map's light alone resolves: {w:?}");
            // The chair's view again, and faces drawn for the first time when the frame has room.
            faces += w.temporary_views - 1;
        } else if w.lightmap_samples > 0 {
            quiet += 1;
            assert_eq!((w.resolves, w.temporary_views), (0, 0), "frame {frame} only accumulates: {w:?}");
        }
        if r.shadows.levels()[0].2 {
            break;
        }
    }
    assert!(quiet >= 2 && shows >= 1, "{quiet} frames only accumulated, {shows} showed a rung");
    // A rung shown changes the light maps alone: the pixels off the receivers (`volumes`') are kept.
    let kept: f64 = r.shadows.stats().extra.iter().filter(|(k, _)| k.ends_with("rest_kept")).map(|(_, v)| v).sum();
    assert!(kept >= f64::from(shows), "{kept} resolves kept the rest's pixels, {shows} rungs shown");
    // Each face is drawn once (each show drew all six again before they were kept).
    assert!(faces <= 6, "{faces} faces of the whole scene drawn for a six-face cube");
    assert!(first_light_equals_fresh(&r), "the refilled light maps equal a fresh engine's");
}

/// A drag that begins under a target moves one light at a time to the permanent surface and the
/// dragged chair's own pass: each other light keeps, exactly, the layer it showed before the drag
/// (the chair where it was), and is not current until its turn. A camera move or another
/// instance's edit ends the wait at once. The release goes back the same way. After each, every light equals a fresh engine's.
#[test]
fn a_drag_under_a_target_moves_one_light_a_frame() {
    use shadowlab_core::Mobility;
    for interrupt in ["none", "camera", "edit"] {
        let camera_moves = interrupt != "none";
        let mut r = sliced_light_maps();
        let hard = TechniqueSpec::parse("hard:map_size=256", &[]).unwrap();
        for l in 1..4 {
            r.set_technique(LightId(l), &hard).unwrap();
        }
        settle(&mut r);
        for _ in 0..10 {
            r.render().unwrap();
        }
        let before = visibility(&r);
        let lights = before.len();
        assert_eq!(lights, 4, "room's four lights are shadowed");
        let chair = r.shadows.live().find_instance("chair east").unwrap();
        r.apply(Edit::Mobility { instance: chair, mobility: Mobility::Temporary }).unwrap();
        let mut held_seen = Vec::new();
        for frame in 0..2 * lights + 1 {
            let w = r.render().unwrap().work;
            let now = visibility(&r);
            let kept = now.iter().zip(&before).filter(|(a, b)| a == b).count();
            let waiting = r.shadows.levels().iter().filter(|l| !l.2).count();
            if frame == 1 && camera_moves {
                assert_eq!((w.held_lights, w.resolves as usize), (0, lights), "{interrupt}: every light resolves");
                break;
            }
            // One light at a time takes the chair's pass (the budget is below the render time:
            // after the permanent surface's frame, two frames a light); the others wait, not
            // current, showing their layers of before the drag bit for bit.
            let held = w.held_lights as usize;
            held_seen.push(held);
            assert!(kept >= held && waiting >= held, "frame {frame}: {kept} layers kept, {waiting} not current");
            // The light's turn is the frame's work: the maps the pick-up made stale (the hard
            // lights' static maps held the chair) wait for the frames after.
            assert_eq!(fills(&w), 0, "frame {frame}: a turn and fills in one frame: {w:?}");
            if frame == 0 && interrupt == "camera" {
                let view = r.scene().view("table").unwrap().clone();
                r.set_view(&view);
            }
            if frame == 0 && interrupt == "edit" {
                // Another instance moved: the layers kept show it where it was.
                let table = r.shadows.live().find_instance("table").unwrap();
                let t = r.shadows.live().instance(table).unwrap().transform;
                let moved = glam::Affine3A::from_translation(Vec3::new(0.2, 0.0, 0.0)) * t;
                r.apply(Edit::Transform { instance: table, transform: moved }).unwrap();
            }
        }
        if !camera_moves {
            assert_eq!(held_seen, [4, 4, 3, 3, 2, 2, 1, 1, 0], "one light at a time");
        }
        let all_equal_fresh = |r: &mut Renderer, when: &str| {
            settle(r);
            for _ in 0..3 {
                r.render().unwrap();
            }
            assert!(r.shadows.levels().iter().all(|l| l.2), "{when}: every light current: {:?}", r.shadows.levels());
            let fresh = r.fresh_visibility().unwrap();
            for ((light, f), v) in fresh.iter().zip(visibility(r)) {
                assert!(f == &v, "{when}: light {light} equals a fresh engine's (interrupted: {interrupt})");
            }
        };
        all_equal_fresh(&mut r, "dragging");
        if camera_moves {
            continue;
        }
        // Released where it stands: the lights go back one a frame too.
        let during = visibility(&r);
        r.apply(Edit::Mobility { instance: chair, mobility: Mobility::Static }).unwrap();
        for frame in 0..lights {
            let w = r.render().unwrap().work;
            let kept = visibility(&r).iter().zip(&during).filter(|(a, b)| a == b).count();
            let held = w.held_lights as usize;
            assert_eq!(held, lights - 1 - frame, "release, frame {frame}: one light a frame: {w:?}");
            assert!(kept >= held, "release, frame {frame}: {kept} layers kept");
            // The hard lights' maps take the chair in after the turns.
            assert_eq!(w.map_views + w.lightmap_samples, 0, "release, frame {frame}: a turn and fills: {w:?}");
        }
        all_equal_fresh(&mut r, "released");
    }
}

/// `room` at 48 × 36 from `view`, `spec` on the lights `lights` (the others as a renderer starts), a scripted
/// clock (`cost` per unit of its kind, 10 ms of rendering) under a 16 ms target, 30 frames to
/// settle, then `object` picked up: the renderer and the object.
fn picked_up(
    view: &str,
    spec: &str,
    lights: std::ops::Range<u32>,
    cost: (UnitKind, f64),
    object: &str,
) -> (Renderer, shadowlab::InstanceId) {
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view(view).unwrap().clone();
    let mut r = Renderer::new(&gpu(), scene, &view, 48, 36);
    let spec = TechniqueSpec::parse(spec, &[]).unwrap();
    for l in lights {
        r.set_technique(LightId(l), &spec).unwrap();
    }
    r.shadows.script_costs(CostModel::scripted(&[cost]), 10.0);
    r.set_target_ms(Some(16.0));
    for _ in 0..30 {
        r.render().unwrap();
    }
    let id = r.shadows.live().find_instance(object).unwrap();
    r.apply(Edit::Mobility { instance: id, mobility: shadowlab_core::Mobility::Temporary }).unwrap();
    (r, id)
}

/// Lights that join a drag one a frame each add their views of the whole scene (the permanent
/// casters' shadow on the dragged object) to one array, which grows as they come. Those drawn
/// before a growth are copied into the larger array, not drawn again; once the object moves,
/// every light looks them up. The chair south, seen from under the table, takes the shadows of
/// the table and the other chairs: with the copy left out (the earlier lights' layers of the
/// new array empty, so lit), 87 and 119 of its pixels differ from a fresh engine for the
/// ceiling lamp and the sun; with it, none.
#[test]
fn views_of_the_whole_scene_survive_the_arrays_growth() {
    let (mut r, chair) = picked_up("under_table", "hard:map_size=256", 0..4, (UnitKind::MapView, 0.1), "chair south");
    // One light at a time: 1, 1, 6 and 6 slots, the array growing to 2, 8 and 16 layers.
    staged_turns(&mut r, 4);
    for _ in 0..8 {
        r.render().unwrap();
    }
    assert!(r.shadows.levels().iter().all(|l| l.2), "every light current: {:?}", r.shadows.levels());
    let t = r.shadows.live().instance(chair).unwrap().transform;
    let step = glam::Affine3A::from_translation(Vec3::new(0.05, 0.0, 0.05)) * t;
    r.apply(Edit::Transform { instance: chair, transform: step }).unwrap();
    let w = r.render().unwrap().work;
    assert_eq!(w.resolves, 0, "a drag step resolves no light: {w:?}");
    let fresh = r.fresh_visibility().unwrap();
    for ((light, f), (_, v)) in fresh.iter().zip(r.live_visibility().unwrap()) {
        let differ = f.iter().zip(&v).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "light {light}: {differ} pixels differ from a fresh engine");
    }
}

/// Under a target a point lamp's cube of the whole scene draws, when the lamp joins a drag, only
/// the faces the dragged object reaches; the others wait for a frame with room (one a frame
/// here), or for the object to reach them. The chair south is dragged 0.85 m diagonally from
/// under the table, and every step equals a fresh engine. Drawing only the faces a frame has
/// room for, reached or not, leaves 87 of the chair's pixels lit under the table's shadow at the
/// first step.
#[test]
fn a_cube_of_the_whole_scene_draws_the_faces_a_dragged_object_reaches() {
    // A view costs more than any frame's budget: one unit a frame, the first asked for.
    let (mut r, chair) = picked_up("under_table", "hard:map_size=256", 0..1, (UnitKind::MapView, 100.0), "chair south");
    let w = staged_turns(&mut r, 1)[2];
    // The atlas's view of the chair, and the cube's faces it reaches (below and one side).
    assert!(w.temporary_views < 1 + 6, "the lamp joined with some of its faces: {w:?}");
    let start = r.shadows.live().instance(chair).unwrap().transform;
    for step in 1..=12 {
        let by = Vec3::new(0.05, 0.0, 0.05) * step as f32;
        r.apply(Edit::Transform { instance: chair, transform: glam::Affine3A::from_translation(by) * start }).unwrap();
        r.render().unwrap();
        let fresh = r.fresh_visibility().unwrap();
        let live = r.live_visibility().unwrap();
        let differ = fresh[0].1.iter().zip(&live[0].1).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "step {step}: {differ} pixels differ from a fresh engine");
    }
}

/// Under a target each light's turn at a pick-up resolves, for `volumes`, only the pixels the
/// chair covered or shadowed (its layer of before copied around them): the turned light equals a
/// fresh engine at once, the waiting ones still show the chair where it was. Copying nothing
/// around the region leaves the rest of the layer dark (0): the first light differs at once. At the
/// release each turned light equals a fresh engine at once too.
///
/// Under a budget below the render time (16 ms target, 10 ms rendering) the turn is staged (the
/// light's layer over the permanent surface a frame before it joins the chair's pass), and the
/// light equals a fresh engine when it joins; above it (40 ms), one frame a light.
#[test]
fn a_turn_at_a_pick_up_resolves_only_what_the_object_changed() {
    for staged in [true, false] {
        a_turn_at_a_pick_up_resolves_only_what_the_object_changed_when(staged);
    }
}

fn a_turn_at_a_pick_up_resolves_only_what_the_object_changed_when(staged: bool) {
    let (mut r, chair) = picked_up("default", "volumes", 0..4, (UnitKind::VolumeObject, 0.01), "chair east");
    if !staged {
        r.set_target_ms(Some(40.0));
    }
    // The lights whose turn came (those no longer held) equal a fresh engine, bit for bit.
    let turned_equal_fresh = |r: &Renderer, turned: usize, when: &str| {
        let fresh = r.fresh_visibility().unwrap();
        let live = r.live_visibility().unwrap();
        let differ: Vec<usize> =
            fresh.iter().zip(&live).map(|(f, v)| f.1.iter().zip(&v.1).filter(|(a, b)| a != b).count()).collect();
        let equal = differ.iter().filter(|&&d| d == 0).count();
        assert!(equal >= turned, "{when}: {turned} lights turned, {equal} equal a fresh engine: {differ:?}");
    };
    if staged {
        let w = r.render().unwrap().work;
        assert_eq!((w.resolves, w.held_lights), (0, 4), "the permanent surface's frame: {w:?}");
    }
    for light in 0..4 {
        if staged {
            let w = r.render().unwrap().work;
            assert_eq!(
                (w.resolves, w.region_resolves, w.held_lights),
                (1, 1, 4 - light),
                "light {light}, first: {w:?}"
            );
            turned_equal_fresh(&r, light as usize, &format!("pick-up, light {light}'s first frame"));
            let w = r.render().unwrap().work;
            assert_eq!((w.resolves, w.held_lights), (0, 3 - light), "light {light}, second: {w:?}");
        } else {
            let w = r.render().unwrap().work;
            assert_eq!((w.resolves, w.region_resolves, w.held_lights), (1, 1, 3 - light), "light {light}: {w:?}");
        }
        turned_equal_fresh(&r, light as usize + 1, &format!("pick-up, light {light}"));
    }
    // Dragged elsewhere and released: each light's turn takes the chair's new volumes in with it.
    // The turn's frame runs no other fill, but the light cannot show its new state without them:
    // they are charged to the turn (`FrameContext::take_needed_units`; asked of the spent budget
    // instead, the turned light shows no shadow of the chair until a later frame).
    let t = r.shadows.live().instance(chair).unwrap().transform;
    let moved = glam::Affine3A::from_translation(Vec3::new(-2.0, 0.0, -1.2)) * t;
    r.apply(Edit::Transform { instance: chair, transform: moved }).unwrap();
    // Released where the last frame showed it, or moved and released between two frames: each
    // turn resolves only the pixels the chair covers or shadows now, over the light's layer of
    // the permanent surface, which the release keeps (copying nothing, 5 and 16 of the last two
    // turned lights' pixels keep the chair's shadow where the last frame put it).
    if !staged {
        r.render().unwrap();
    }
    r.apply(Edit::Mobility { instance: chair, mobility: shadowlab_core::Mobility::Static }).unwrap();
    for frame in 0..4 {
        let w = r.render().unwrap().work;
        assert_eq!((w.resolves, w.region_resolves, w.held_lights), (1, 1, 3 - frame), "release, frame {frame}: {w:?}");
        turned_equal_fresh(&r, frame as usize + 1, &format!("release, frame {frame}"));
    }
}

/// A staged turn joins the dragged objects' pass over the layer its first frame resolved only
/// while that layer is kept: a light added between the two frames makes every light's layer over
/// the permanent surface anew (an array of one more), and the turn then resolves again in its
/// second frame. Joining over the lost layer (the new array's, never written) leaves 996 of the
/// turned light's 1 728 pixels unlike a fresh engine's.
#[test]
fn a_staged_turn_resolves_again_when_its_first_frames_layer_is_lost() {
    let (mut r, _) = picked_up("default", "volumes", 0..4, (UnitKind::VolumeObject, 0.01), "chair east");
    let surface = r.render().unwrap().work;
    let first = r.render().unwrap().work;
    assert_eq!((surface.resolves, first.resolves, first.held_lights), (0, 1, 4), "staged: {surface:?} {first:?}");
    let lamp = r.scene().lights[0].clone();
    let added = r.apply(Edit::AddLight(Box::new(lamp))).unwrap().light.unwrap();
    r.set_technique(added, &TechniqueSpec::parse("volumes", &[]).unwrap()).unwrap();
    let w = r.render().unwrap().work;
    assert_eq!(w.held_lights, 3, "the staged light joined: {w:?}");
    assert!(w.resolves >= 2, "the staged light resolved again (and the new one): {w:?}");
    let fresh = r.fresh_visibility().unwrap();
    let live = r.live_visibility().unwrap();
    let turned: Vec<LightId> = r.shadows.levels().iter().filter(|l| l.2 && l.0 != added).map(|l| l.0).collect();
    assert_eq!(turned.len(), 1, "one of the four turned: {:?}", r.shadows.levels());
    // No light was removed: ids are indices.
    let index = turned[0].0 as usize;
    let (f, v) = (&fresh.iter().find(|f| f.0 == index).unwrap().1, &live.iter().find(|l| l.0 == index).unwrap().1);
    let differ = f.iter().zip(v).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "light {:?}: {differ} pixels differ from a fresh engine", turned[0]);
}

/// A pick-up spread over frames refills the texels the chair shadowed; the chair is released
/// elsewhere while those texels show a rung of fewer samples than the rest, so the release's
/// refill takes them in with the chair's new shadow, and the end equals a fresh engine's exactly.
#[test]
fn a_release_before_a_pick_ups_refill_ends_completes_its_texels_too() {
    use shadowlab_core::Mobility;
    let mut r = sliced_light_maps();
    settle(&mut r);
    let chair = r.shadows.live().find_instance("chair east").unwrap();
    let t = r.shadows.live().instance(chair).unwrap().transform;
    r.apply(Edit::Mobility { instance: chair, mobility: Mobility::Temporary }).unwrap();
    // Until the refilled texels show a rung below all 16 samples.
    let mut shown = 16;
    for _ in 0..20 {
        r.render().unwrap();
        shown = r.shadows.levels()[0].3;
        if shown < 16 {
            break;
        }
    }
    assert!((1..16).contains(&shown), "the pick-up's refill shows a first rung: {shown} samples");
    let there = glam::Affine3A::from_translation(Vec3::new(-1.0, 0.0, 0.6)) * t;
    r.apply(Edit::Transform { instance: chair, transform: there }).unwrap();
    r.apply(Edit::Mobility { instance: chair, mobility: Mobility::Static }).unwrap();
    settle(&mut r);
    assert!(first_light_equals_fresh(&r), "the light maps equal a fresh engine's");
}

/// A ladder (Toromanoff §VII.2: a cheap shadow at once, better ones as they are filled): `hard`
/// then light maps. The light shows hard shadows within the first frames, then the light maps'
/// rungs; levels never go down in a still scene; at the end it equals a fresh engine on the same
/// ladder (which shows the best rung). Frames over the target then step the quality cap down (with
/// hysteresis), and the light shows its hard shadows again.
#[test]
fn a_ladder_climbs_from_hard_shadows_to_light_maps_and_steps_down_when_frames_are_slow() {
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let mut r = Renderer::new(&gpu(), scene, &view, 48, 36);
    let ladder = [
        TechniqueSpec::parse("hard:map_size=256", &[]).unwrap(),
        TechniqueSpec::parse("lightmaps:samples=16,texel=0.05,rest=hard", &[]).unwrap(),
    ];
    r.shadows.set_ladder(LightId(0), &ladder, 48, 36).unwrap();
    let costs = CostModel::scripted(&[(UnitKind::MapView, 1.0), (UnitKind::LightMapSample, 1.0)]);
    r.shadows.script_costs(costs, 10.0);
    r.set_target_ms(Some(16.0));
    let mut levels = Vec::new();
    for frame in 0..300 {
        r.render().unwrap();
        let (_, level, current, _) = r.shadows.levels()[0];
        if let Some(&last) = levels.last() {
            assert!(level >= last, "frame {frame}: level {last} → {level}");
        }
        levels.push(level);
        if current {
            break;
        }
    }
    println!("ladder levels: {levels:?}");
    // 0 until the six hard faces are in (four 1 ms views a frame in a 4.4 ms budget: two frames),
    // 1 with hard shadows, 2 once the light maps' own hard maps are in, 3 and 4 when every lit
    // receiver has 4 and 16 samples.
    assert_eq!(levels.last(), Some(&4), "{levels:?}");
    assert!(levels.contains(&1) && levels.iter().position(|&l| l == 1) < levels.iter().position(|&l| l >= 2));
    let fresh = r.fresh_visibility().unwrap();
    assert!(fresh[0].1 == r.live_visibility().unwrap()[0].1, "the best rung equals a fresh engine's");
    // Three frames over the target: one rung down (hard shadows shown).
    let work = shadowlab::Work::default();
    for _ in 0..3 {
        r.shadows.observe(&work, 0.0, 100.0);
    }
    assert_eq!(r.shadows.quality_cap(), 1);
    r.render().unwrap();
    assert_eq!(r.shadows.levels()[0].1, 1, "the cheap rung is shown");
}

/// Volumes (Toromanoff alg. 14): one object's volumes is a unit; a light is shadowed by volumes only
/// once every object's are extracted, then equals a fresh engine.
#[test]
fn volumes_are_extracted_a_few_objects_a_frame_and_shown_when_all_are_in() {
    let scene = load_scene("room").unwrap().scene;
    let casters = scene.instances.iter().filter(|i| i.casts_shadows).count() as u32;
    let view = scene.view("default").unwrap().clone();
    let mut r = Renderer::new(&gpu(), scene, &view, 48, 36);
    r.set_technique(LightId(0), &TechniqueSpec::parse("volumes", &[]).unwrap()).unwrap();
    // 1 ms an object, 10 ms rendering: a 16 ms target leaves 4.4 ms, four objects a frame.
    r.shadows.script_costs(CostModel::scripted(&[(UnitKind::VolumeObject, 1.0)]), 10.0);
    r.set_target_ms(Some(16.0));
    let mut frames = 0;
    let mut extracted = 0;
    loop {
        let w = r.render().unwrap().work;
        frames += 1;
        assert!(w.volume_objects <= 4, "frame {frames}: {w:?}");
        extracted += w.volume_objects;
        let level = r.shadows.levels()[0].1;
        if extracted < casters {
            assert_eq!(level, 0, "frame {frames}: shown with {extracted} of {casters} objects");
        } else {
            assert_eq!(level, 1, "frame {frames}: every object is in");
            break;
        }
        assert!(frames < 50);
    }
    assert_eq!(frames, casters.div_ceil(4), "{casters} objects, four a frame");
    let fresh = r.fresh_visibility().unwrap();
    assert!(fresh[0].1 == r.live_visibility().unwrap()[0].1);
}

/// Two point lamps of six views each, one view a frame: the lamp that may shade more of the screen,
/// then the nearer, is filled first (issue 12's priority), whichever its id. From the default view
/// the eye is within the ceiling lamp's range (12 m) and 5.5 m from the accent light (range 4 m:
/// part of the screen); from the sofa within both ranges, and the accent light on the bookcase is
/// nearer (1.5 m against 1.8 m).
#[test]
fn the_lamp_largest_on_screen_then_nearest_is_filled_first() {
    for (view, first) in [("default", 0), ("sofa", 2)] {
        let scene = load_scene("room").unwrap().scene;
        let v = scene.view(view).unwrap().clone();
        let mut r = Renderer::new(&gpu(), scene, &v, 48, 36);
        let hard = TechniqueSpec::parse("hard:map_size=128", &[]).unwrap();
        for l in [0, 2] {
            r.set_technique(LightId(l), &hard).unwrap();
        }
        r.shadows.script_costs(CostModel::scripted(&[(UnitKind::MapView, 1.0)]), 10.0);
        r.set_target_ms(Some(13.0));
        let mut shown_at = std::collections::HashMap::new();
        for frame in 0..14 {
            r.render().unwrap();
            for (light, level, current, _) in r.shadows.levels() {
                if level > 0 && current {
                    shown_at.entry(light.0).or_insert(frame);
                }
            }
        }
        let other = if first == 0 { 2 } else { 0 };
        assert!(shown_at[&first] < shown_at[&other], "view {view}: shown at {shown_at:?}");
    }
}

/// The preference scales the target at run time: with `Quality` the 13 ms target becomes 26 ms, so
/// the seven 1 ms views fit the first frame's 26 − 10 − 2.6 ms budget; balanced, one view a frame.
#[test]
fn a_preference_for_quality_doubles_the_frame_time_kept_to() {
    let mut r = sliced();
    r.shadows.set_preference(shadowlab::auto::Preference::Quality);
    assert_eq!(r.shadows.frame_target_ms(), Some(26.0));
    let w = r.render().unwrap().work;
    assert_eq!(w.map_views - w.composite_views, 7, "{w:?}");
    assert!(r.shadows.levels().iter().all(|l| l.1 == 1 && l.2), "{:?}", r.shadows.levels());
    let mut r = sliced();
    r.shadows.set_preference(shadowlab::auto::Preference::Speed);
    let w = r.render().unwrap().work;
    assert_eq!(w.map_views - w.composite_views, 1, "at least one unit a frame: {w:?}");
}
