//! `lightmaps` (Toromanoff 2005 alg. F–H): receiver light maps against the closed form of the
//! `penumbra` scene and the ray-traced truth, and what a camera path costs once they are filled.

mod common;

use shadowlab::{Renderer, TechniqueSpec};
use shadowlab_core::{LightId, load_scene};
use shadowlab_reference::metrics::ErrorStats;

use common::{gpu, reference, render};

/// On the penumbra's ground (a receiver) the light map is the area light's visibility in the
/// ground's plane: it must follow the closed form as closely as `sampled` with the same samples.
#[test]
fn light_maps_follow_the_closed_form_penumbra() {
    let gpu = gpu();
    let scene = load_scene("penumbra").unwrap().scene;
    let setup = shadowlab_core::scenes::penumbra::PenumbraSetup::default();
    let view = scene.view("top").unwrap().clone();
    let rmse = |spec: &str| {
        let run = render(&gpu, &scene, &view, 96, spec, &[LightId(0)]);
        let v = run.visibility(LightId(0));
        let (mut sum, mut n) = (0.0f64, 0usize);
        for (i, &x) in v.iter().enumerate() {
            let p = run.surface.positions[i];
            if !run.surface.covered[i] || p.y.abs() > 1e-3 {
                continue; // ground pixels only
            }
            sum += f64::from(x - setup.visibility(p)).powi(2);
            n += 1;
        }
        assert!(n > 4000, "{spec}: the ground fills the view ({n})");
        (sum / n as f64).sqrt()
    };
    let maps = rmse("lightmaps:samples=64,rest=hard");
    let sampled = rmse("sampled:samples=64");
    println!("penumbra ground RMSE vs closed form: lightmaps {maps:.4}, sampled {sampled:.4}");
    // Measured lightmaps 0.0081, sampled 0.0066 (both: 8 × 8 samples make 8 steps across the
    // penumbra; the light map adds its 2 cm texels); bound: within 1.5× of sampled's and 0.02.
    assert!(maps < 0.02 && maps < 1.5 * sampled, "{maps} vs {sampled}");
}

/// In the room, light maps on the floor, walls and ceiling and `volumes` elsewhere are closer to
/// the truth than hard shadow maps, and near `sampled` with the same samples.
#[test]
fn light_maps_in_the_room_beat_hard_shadows() {
    let gpu = gpu();
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let lights: Vec<LightId> = (0..scene.lights.len() as u32).map(LightId).collect();
    let error = |spec: &str| {
        let run = render(&gpu, &scene, &view, 96, spec, &lights);
        let mut stats = ErrorStats::default();
        for &l in &lights {
            stats.merge(&ErrorStats::compare(&run.visibility(l), &reference(&scene, &run.surface, l, 64)));
        }
        stats.rmse()
    };
    let (maps, hard, sampled) = (error("lightmaps:samples=36"), error("hard"), error("sampled:samples=36"));
    println!("room RMSE: lightmaps {maps:.4}, hard {hard:.4}, sampled {sampled:.4}");
    // Measured 0.0387, 0.0697, 0.0368: margins of 15% on the ordering against hard and 40% above
    // sampled.
    assert!(maps < 0.85 * hard, "{maps} vs hard {hard}");
    assert!(maps < 1.4 * sampled, "{maps} vs sampled {sampled}");
}

/// Once filled, light maps are view-independent: a camera path over a still scene fills nothing.
#[test]
fn a_camera_path_refills_no_light_map() {
    let gpu = gpu();
    let scene = load_scene("room").unwrap().scene;
    let views: Vec<_> = ["default", "table", "window", "sofa"].map(|v| scene.view(v).unwrap().clone()).into();
    let mut renderer = Renderer::new(&gpu, scene.clone(), &views[0], 64, 48);
    let spec = TechniqueSpec::parse("lightmaps:samples=16,rest=hard", &[]).unwrap();
    for l in 0..scene.lights.len() as u32 {
        renderer.set_technique(LightId(l), &spec).unwrap();
    }
    let first = renderer.render().unwrap().work;
    assert!(first.lightmap_samples > 0, "the first frame fills the maps: {first:?}");
    for v in views.iter().cycle().skip(1).take(6) {
        renderer.set_view(v);
        let w = renderer.render().unwrap().work;
        assert_eq!((w.lightmap_samples, w.map_views), (0, 0), "moving to '{}' re-rendered {w:?}", v.name);
    }
}

/// `fill=smoothies` (Toromanoff alg. E in light maps): the centre's umbra with the smoothies' outer
/// penumbra, as the `smoothies` technique draws it, at the cost of one pass per light map.
#[test]
fn smoothie_filled_light_maps_follow_the_smoothies_technique() {
    let gpu = gpu();
    let scene = load_scene("penumbra").unwrap().scene;
    let setup = shadowlab_core::scenes::penumbra::PenumbraSetup::default();
    let view = scene.view("top").unwrap().clone();
    let ground = |spec: &str| {
        let run = render(&gpu, &scene, &view, 96, spec, &[LightId(0)]);
        let v = run.visibility(LightId(0));
        let (mut sum, mut n, mut soft) = (0.0f64, 0usize, 0usize);
        for (i, &x) in v.iter().enumerate() {
            let p = run.surface.positions[i];
            if !run.surface.covered[i] || p.y.abs() > 1e-3 {
                continue;
            }
            sum += f64::from(x - setup.visibility(p)).powi(2);
            n += 1;
            soft += usize::from(x > 0.02 && x < 0.98);
        }
        ((sum / n.max(1) as f64).sqrt(), soft)
    };
    let (maps, maps_soft) = ground("lightmaps:fill=smoothies,rest=hard");
    let (technique, technique_soft) = ground("smoothies");
    let (hard, _) = ground("lightmaps:fill=hard,rest=hard");
    println!(
        "penumbra RMSE: smoothie light maps {maps:.4} ({maps_soft} soft px), smoothies {technique:.4} ({technique_soft}), hard light maps {hard:.4}"
    );
    // Measured 0.1014 against 0.1003 for the technique: both keep the hard umbra and add the outer
    // penumbra only, too dark for this 0.5 m light (hard light maps, the umbra alone: 0.0861).
    // Bound: within 20% of the technique.
    assert!(maps < 1.2 * technique, "{maps} vs {technique}, hard {hard}");
    // They draw a penumbra: partly lit pixels, at least three quarters as many as the technique
    // (measured 576 against 432).
    assert!(4 * maps_soft > 3 * technique_soft && maps_soft > 200, "{maps_soft} vs {technique_soft}");
}

/// The receivers' planes are kept per instance (`receivers::PatchCache`): after a receiver moves,
/// the scene loses an instance and the receiver moves back, the light maps equal a fresh engine's
/// on the same state.
#[test]
fn light_maps_follow_moved_receivers_as_a_fresh_engine_does() {
    use glam::{Affine3A, Vec3};
    use shadowlab::live::Edit;
    use shadowlab_core::Role;
    let mut r = room_with("lightmaps:samples=4,texel=0.05,rest=hard");
    r.render().unwrap();
    // The floor: the furniture's shadows fall on it, so a stale rectangle would show.
    let live = r.shadows.live();
    let i = live.scene().instances.iter().position(|i| i.name == "floor").unwrap();
    assert_eq!(live.scene().instances[i].role, Some(Role::Receiver));
    let (id, inst) = (live.instances()[i].id, live.scene().instances[i].clone());
    let edits = [
        Edit::Transform {
            instance: id,
            transform: Affine3A::from_translation(Vec3::new(0.2, 0.0, -0.1)) * inst.transform,
        },
        Edit::RemoveInstance(r.shadows.live().find_instance("cup").unwrap()),
        Edit::Transform { instance: id, transform: inst.transform },
    ];
    for edit in edits {
        let what = format!("{edit:?}");
        r.apply(edit).unwrap();
        r.render().unwrap();
        let (live, fresh) = (r.live_visibility().unwrap(), r.fresh_visibility().unwrap());
        for ((l, a), (_, b)) in live.iter().zip(&fresh) {
            let rmse = shadowlab_reference::metrics::rmse_between(a, b);
            println!("light {l}: RMSE {rmse} against a fresh engine");
            // Measured 0 (the same maps filled from the same samples); 1e-3 is the margin
            // for soft techniques.
            assert!(
                rmse <= 1e-3,
                "light {l} after {}: RMSE {rmse} against a fresh engine",
                &what[..what.len().min(60)]
            );
        }
    }
}

/// A caster's edit refills only the texels it can shadow, before or after the edit (the rest of a
/// light map is the same sum of the same samples): picking a chair up, releasing it elsewhere,
/// moving it and removing it each refill a fraction of what the first frame filled per sample, and
/// leave every light exactly equal to a fresh engine's.
#[test]
fn a_casters_edit_refills_only_the_texels_it_can_shadow() {
    use glam::{Affine3A, Vec3};
    use shadowlab::live::Edit;
    use shadowlab_core::Mobility;
    let mut r = room_with("lightmaps:samples=9,texel=0.05,rest=hard");
    let first = r.render().unwrap().work;
    let per_sample = |w: &shadowlab::live::Work| f64::from(w.lightmap_texels) / f64::from(w.lightmap_samples.max(1));
    let full = per_sample(&first);
    assert!(first.lightmap_samples > 0 && full > 0.0, "{first:?}");
    let chair = r.shadows.live().find_instance("chair east").unwrap();
    let t = r.shadows.live().instance(chair).unwrap().transform;
    let there = Affine3A::from_translation(Vec3::new(-1.0, 0.0, 0.6)) * t;
    let edits = [
        ("picked up", Edit::Mobility { instance: chair, mobility: Mobility::Temporary }),
        ("dragged", Edit::Transform { instance: chair, transform: there }),
        ("released", Edit::Mobility { instance: chair, mobility: Mobility::Static }),
        ("moved back", Edit::Transform { instance: chair, transform: t }),
        ("removed", Edit::RemoveInstance(chair)),
    ];
    for (what, edit) in edits {
        r.apply(edit).unwrap();
        let w = r.render().unwrap().work;
        let share = per_sample(&w) / full;
        println!(
            "{what}: {} samples, {:.0} texels a sample = {share:.3} of the first frame's",
            w.lightmap_samples,
            per_sample(&w)
        );
        if what == "dragged" {
            assert_eq!(w.lightmap_samples, 0, "a drag step refills nothing: {w:?}");
        } else {
            assert!(w.lightmap_samples > 0, "{what}: the chair shadows some light map: {w:?}");
            // Measured 0.16–0.27 (the chair's shadows on the floor and walls, from four lights,
            // some of them low); a whole map per sample would be 1 (about 0.8 for the largest
            // maps), so 0.5 leaves a margin of 2× over what was measured.
            assert!(share < 0.5, "{what}: {share:.3} of the first frame's texels a sample");
        }
        let (live, fresh) = (r.live_visibility().unwrap(), r.fresh_visibility().unwrap());
        for ((l, a), (_, b)) in live.iter().zip(&fresh) {
            assert!(a == b, "{what}: light {l} differs from a fresh engine");
        }
    }
}

/// `room` at 64 × 48 from its default view, `spec` on every light.
fn room_with(spec: &str) -> Renderer {
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let mut r = Renderer::new(&gpu(), scene.clone(), &view, 64, 48);
    let spec = TechniqueSpec::parse(spec, &[]).unwrap();
    for l in 0..scene.lights.len() as u32 {
        r.set_technique(LightId(l), &spec).unwrap();
    }
    r
}
