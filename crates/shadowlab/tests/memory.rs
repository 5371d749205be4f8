//! The process's memory over many frames (alone in its binary: the resident set is the
//! process's, and tests running beside it would move it).

mod common;

use shadowlab::{Renderer, TechniqueSpec};
use shadowlab_core::{LightId, load_scene};

/// The resident set, in KiB (Linux).
fn resident_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status.lines().find(|l| l.starts_with("VmRSS:"))?.split_whitespace().nth(1)?.parse().ok()
}

/// Still frames of `room` with light maps on every light, after the first fills, hold the
/// process's memory: lavapipe (Mesa 22.3) kept a compiled copy of a shader at every draw after a
/// light's uniform buffer was bound, 2.9 MB a frame (`util::branch_buffer`).
#[test]
fn still_frames_do_not_grow_the_process() {
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let mut r = Renderer::new(&common::gpu(), scene, &view, 64, 48);
    let spec = TechniqueSpec::parse("lightmaps:samples=4", &[]).unwrap();
    for l in 0..4 {
        r.set_technique(LightId(l), &spec).unwrap();
    }
    for _ in 0..30 {
        r.render().unwrap();
    }
    let Some(before) = resident_kib() else {
        println!("no /proc/self/status: nothing to measure here");
        return;
    };
    for _ in 0..200 {
        r.render().unwrap();
    }
    let grown = resident_kib().unwrap().saturating_sub(before);
    println!("200 still frames grew the process by {grown} KiB");
    // Measured here: 0 KiB with the light's buffer as storage, 571 868 KiB with it a uniform;
    // 64 MiB leaves room for the allocator and the driver's caches.
    assert!(grown < 64 * 1024, "200 still frames grew the process by {grown} KiB");
}
