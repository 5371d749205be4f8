//! Throughput of the ground truth on `room`: 256 × 256 pixels, 64 emitter samples per light, all
//! four lights. Criterion reports the time per frame; shadow rays per second are printed once.

use criterion::{Criterion, criterion_group, criterion_main};
use shadowlab_core::load_scene;
use shadowlab_reference::{ReferenceSettings, SceneBvh, Selection, reference, trace_surface};

fn bench(c: &mut Criterion) {
    let scene = load_scene("room").expect("built-in scene").scene;
    let view = scene.view("default").expect("default view").clone();
    let surface = trace_surface(&SceneBvh::build(&scene, Selection::All), &scene, &view, 256, 256);
    let bvh = SceneBvh::build(&scene, Selection::Casters);
    let lights: Vec<_> = scene.lights.iter().enumerate().map(|(i, l)| (i as u32, l)).collect();
    let settings = ReferenceSettings { samples: 64, seed: 1 };
    let once = reference(&bvh, &surface, &lights, &settings, None);
    println!("room 256x256, 64 samples/light: {} shadow rays, {:.2} M rays/s", once.rays, once.rays_per_second() / 1e6);
    let mut group = c.benchmark_group("reference");
    group.sample_size(10);
    group.bench_function("room_256x256_64spp_4lights", |b| {
        b.iter(|| reference(&bvh, &surface, &lights, &settings, None))
    });
    group.bench_function("bvh_build_room", |b| b.iter(|| SceneBvh::build(&scene, Selection::Casters)));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
