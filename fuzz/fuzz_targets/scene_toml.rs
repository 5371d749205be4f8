//! The TOML scene-file loader on arbitrary bytes: an error or a valid scene, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use shadowlab_core::LoadOptions;

fuzz_target!(|data: &[u8]| {
    // A directory that does not exist: models named by the input are not found.
    let path = std::path::Path::new("/nonexistent-shadowlab-fuzz/input.toml");
    let _ = shadowlab_core::load::parse_file_bytes(data, path, LoadOptions::default());
});
