//! The glTF/GLB loader on arbitrary bytes: an error or a valid scene, never a panic or a hang.
#![no_main]

use libfuzzer_sys::fuzz_target;
use shadowlab_core::LoadOptions;

static QUIET: std::sync::Once = std::sync::Once::new();

fuzz_target!(|data: &[u8]| {
    // The loader turns the gltf crate's own panics into errors (`load/gltf.rs`, `guarded`);
    // libfuzzer's hook would abort on them before they are caught. A panic anywhere else still
    // unwinds to libfuzzer, which aborts and keeps the input.
    QUIET.call_once(|| std::panic::set_hook(Box::new(|_| {})));
    // A directory that does not exist: buffers named by the input are not found.
    let path = std::path::Path::new("/nonexistent-shadowlab-fuzz/input.glb");
    let options = LoadOptions { emissive_lights: data.len() % 2 == 0 };
    let _ = shadowlab_core::load::parse_file_bytes(data, path, options);
});
