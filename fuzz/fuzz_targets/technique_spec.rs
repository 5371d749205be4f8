//! The technique-spec parser (`pcf:taps=16` plus `--set K=V` assignments) on arbitrary text:
//! the input up to its first NUL is the spec, each later NUL-separated part an assignment.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let mut parts = text.split('\0');
    let spec = parts.next().unwrap_or_default();
    let global: Vec<String> = parts.map(str::to_owned).collect();
    let _ = shadowlab::TechniqueSpec::parse(spec, &global);
});
