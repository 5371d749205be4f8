//! The obj loader on arbitrary bytes: an error or a valid scene, never a panic or a hang.
#![no_main]

use libfuzzer_sys::fuzz_target;
use shadowlab_core::LoadOptions;

fuzz_target!(|data: &[u8]| {
    // A directory that does not exist: libraries and buffers named by the input are not found.
    let path = std::path::Path::new("/nonexistent-shadowlab-fuzz/input.obj");
    let options = LoadOptions { emissive_lights: data.len() % 2 == 0 };
    let _ = shadowlab_core::load::parse_file_bytes(data, path, options);
});
