//! WGSL composition: shared code lives in `src/shaders/` and is included, never copied.
//!
//! WGSL has no include mechanism, so a line `// #include "name.wgsl"` is replaced by the shared
//! module of that name (each included once per shader, in order). Blocks between `// #ifdef NAME`,
//! `// #else` and `// #endif` are kept or dropped by the defines given (blocks nest). Directives are
//! comments, so every file stays valid WGSL for editors and validators.

/// The shared modules, by the name used in `#include` lines.
const SHARED: &[(&str, &str)] = &[
    ("common.wgsl", include_str!("shaders/common.wgsl")),
    ("instance.wgsl", include_str!("shaders/instance.wgsl")),
    ("alpha_mask.wgsl", include_str!("shaders/alpha_mask.wgsl")),
    ("lights.wgsl", include_str!("shaders/lights.wgsl")),
    ("shadowmap.wgsl", include_str!("shaders/shadowmap.wgsl")),
    ("resolve.wgsl", include_str!("shaders/resolve.wgsl")),
    ("per_pixel.wgsl", include_str!("shaders/per_pixel.wgsl")),
    ("maplookup.wgsl", include_str!("shaders/maplookup.wgsl")),
    ("footprint.wgsl", include_str!("shaders/footprint.wgsl")),
    ("horizon.wgsl", include_str!("shaders/horizon.wgsl")),
    ("pcfkernel.wgsl", include_str!("shaders/pcfkernel.wgsl")),
    ("selection.wgsl", include_str!("shaders/selection.wgsl")),
    ("samples.wgsl", include_str!("shaders/samples.wgsl")),
    ("patches.wgsl", include_str!("shaders/patches.wgsl")),
    ("volumes_common.wgsl", include_str!("techniques/volumes/common.wgsl")),
];

/// Expands `// #include "name"` directives. Panics on an unknown include: shaders are compiled into
/// the binary, so that is a programming error caught by the tests, never user input.
pub fn compose(source: &str, defines: &[&str]) -> String {
    let mut out = String::with_capacity(source.len() * 2);
    let mut seen: Vec<&str> = Vec::new();
    expand(source, defines, &mut out, &mut seen);
    out
}

fn expand<'a>(source: &'a str, defines: &[&str], out: &mut String, seen: &mut Vec<&'a str>) {
    // The open #ifdef blocks, innermost last: whether each one's current branch is taken. A line
    // is kept when every enclosing branch is.
    let mut open: Vec<bool> = Vec::new();
    for line in source.lines() {
        let t = line.trim();
        if let Some(name) = t.strip_prefix("// #ifdef") {
            open.push(defines.contains(&name.trim()));
            continue;
        }
        if t == "// #else" {
            if let Some(top) = open.last_mut() {
                *top = !*top;
            }
            continue;
        }
        if t == "// #endif" {
            open.pop();
            continue;
        }
        if open.contains(&false) {
            continue;
        }
        let directive = t.strip_prefix("// #include").map(|rest| rest.trim().trim_matches('"'));
        match directive {
            Some(name) => {
                let (key, text) =
                    SHARED.iter().find(|(n, _)| *n == name).unwrap_or_else(|| panic!("unknown WGSL include '{name}'"));
                if !seen.contains(key) {
                    seen.push(key);
                    out.push_str(&format!("// ---- {key} ----\n"));
                    expand(text, defines, out, seen);
                    out.push_str(&format!("// ---- end {key} ----\n"));
                }
            }
            None => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
}

/// Composes and compiles a WGSL module.
pub fn module(device: &wgpu::Device, label: &str, source: &str) -> wgpu::ShaderModule {
    module_with(device, label, source, &[])
}

/// Composes with `defines` and compiles a WGSL module.
pub fn module_with(device: &wgpu::Device, label: &str, source: &str, defines: &[&str]) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(compose(source, defines).into()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn includes_expand_once() {
        let s = compose(
            "// #include \"common.wgsl\"\n// #include \"lights.wgsl\"\n// #include \"common.wgsl\"\nfn main() {}\n",
            &[],
        );
        assert_eq!(s.matches("---- common.wgsl ----").count(), 1);
        assert!(s.contains("struct Camera"));
        assert!(s.contains("fn main() {}"));
    }

    #[test]
    fn ifdef_selects_a_branch() {
        let src = "a\n// #ifdef X\nb\n// #else\nc\n// #endif\nd\n";
        assert_eq!(compose(src, &["X"]), "a\nb\nd\n");
        assert_eq!(compose(src, &[]), "a\nc\nd\n");
    }

    #[test]
    fn ifdef_blocks_nest() {
        let src = "// #ifdef X\nx\n// #ifdef Y\nxy\n// #else\nx-\n// #endif\nx2\n// #else\n-\n// #ifdef Y\n-y\n// #endif\n// #endif\nend\n";
        assert_eq!(compose(src, &["X", "Y"]), "x\nxy\nx2\nend\n");
        assert_eq!(compose(src, &["X"]), "x\nx-\nx2\nend\n");
        assert_eq!(compose(src, &["Y"]), "-\n-y\nend\n");
        assert_eq!(compose(src, &[]), "-\nend\n");
    }
}
