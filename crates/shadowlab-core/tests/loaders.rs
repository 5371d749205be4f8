//! Loader tests on real files: every model in ../shared/assets, the hand-written fixtures, and a
//! fuzz-style pass that feeds truncated and byte-flipped files to every loader (an error or a scene,
//! never a panic).

use std::path::{Path, PathBuf};

use shadowlab_core::load::{gltf, load_file, load_scene, obj, scene_file};
use shadowlab_core::sampling::Rng;
use shadowlab_core::{LightKind, Topology};

fn assets() -> PathBuf {
    let dir = std::env::var_os("SHADOWLAB_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/assets"));
    assert!(dir.is_dir(), "assets not found at {} (set SHADOWLAB_ASSETS)", dir.display());
    dir
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

/// Triangle counts and closedness from ../shared/assets/INVENTORY.md.
#[test]
fn every_asset_loads_with_its_inventory_counts() {
    let cases: &[(&str, usize, Option<bool>)] = &[
        ("stanford-bunny/stanford-bunny.obj", 69_451, Some(false)),
        ("stanford-bunny/bunny_closed_hr.obj", 59_664, Some(true)),
        ("stanford-dragon/dragon.obj", 100_000, Some(true)),
        ("stanford-armadillo/armadillo.obj", 86_482, Some(true)),
        ("stanford-happy-buddha/buddha.obj", 112_876, None),
        ("horse/horse.obj", 96_966, Some(true)),
        ("sibenik/sibenik.obj", 75_165, None),
        ("sponza-dabrovic/sponza.obj", 66_454, None),
        ("cornell-box/CornellBox-Original.obj", 36, None),
        ("cornell-box/CornellBox.glb", 36, None),
    ];
    let dir = assets();
    for &(file, triangles, closed) in cases {
        let loaded = load_scene(dir.join(file).to_str().unwrap()).unwrap_or_else(|e| panic!("{file}: {e}"));
        let s = &loaded.scene;
        assert_eq!(s.stats().triangles, triangles, "{file}");
        assert!(!s.views.is_empty() && !s.lights.is_empty(), "{file}: defaults added");
        if let Some(closed) = closed {
            let m = &s.meshes[0];
            assert_eq!(Topology::build(m).report().is_closed_manifold(), closed, "{file}");
        }
    }
}

#[test]
fn asset_quirks() {
    let dir = assets();
    // The dragon names a missing MTL: a warning, not an error.
    let dragon = load_scene(dir.join("stanford-dragon/dragon.obj").to_str().unwrap()).unwrap();
    assert!(dragon.warnings.iter().any(|w| w.contains("dragon.mtl")), "{:?}", dragon.warnings);
    // The bunny's open base: 223 boundary edges.
    let bunny = load_scene(dir.join("stanford-bunny/stanford-bunny.obj").to_str().unwrap()).unwrap();
    assert_eq!(Topology::build(&bunny.scene.meshes[0]).report().boundary_edges, 223);
    // The Cornell OBJ (CRLF, tabs, quads, negative indices) takes its colours from the MTL.
    let cornell = load_scene(dir.join("cornell-box/CornellBox-Original.obj").to_str().unwrap()).unwrap();
    let names: Vec<&str> = cornell.scene.materials.iter().map(|m| m.name.as_str()).collect();
    assert!(names.contains(&"leftWall") && names.contains(&"light"), "{names:?}");
    let light = cornell.scene.materials.iter().find(|m| m.name == "light").unwrap();
    assert!(light.emissive.x > 1.0, "Ke of the light material is read");
    let left = cornell.scene.materials.iter().find(|m| m.name == "leftWall").unwrap();
    assert!(left.base_color.x > 0.5 && left.base_color.y < 0.2, "{}", left.base_color);
}

#[test]
fn gltf_fixture_reads_nodes_lights_cameras_materials() {
    for file in ["card.gltf", "card-external.gltf"] {
        let l = gltf::load(&data(file)).unwrap();
        let s = &l.scene;
        assert_eq!(s.instances.len(), 2, "{file}");
        let card = s.instances.iter().find(|i| i.name == "card").unwrap();
        assert_eq!(card.transform.translation.y, 1.0);
        assert!(s.material(card.material).double_sided);
        assert_eq!(s.lights.len(), 2);
        match s.lights[0].kind {
            LightKind::Spot { position, direction, inner_angle, outer_angle, .. } => {
                assert_eq!(position.y, 4.0);
                // The node is turned −90° about x: −Z (the glTF light axis) becomes −Y.
                assert!((direction - glam::Vec3::NEG_Y).length() < 1e-5, "{direction}");
                assert_eq!((inner_angle, outer_angle), (0.3, 0.6));
            }
            ref k => panic!("{k:?}"),
        }
        assert_eq!(s.lights[0].range, Some(30.0));
        assert_eq!(s.views.len(), 1);
        assert_eq!(s.views[0].name, "front");
        assert!((s.views[0].fov_y - 0.8).abs() < 1e-6);
        s.validate().unwrap();
    }
}

#[test]
fn obj_fixture_groups_materials_and_reports_open_mesh() {
    let l = obj::load(&data("small.obj")).unwrap();
    let s = &l.scene;
    assert_eq!(s.meshes.len(), 2);
    assert_eq!(s.materials[0].name, "paint");
    assert_eq!(s.materials[0].base_color, glam::Vec3::new(0.8, 0.7, 0.6));
    assert_eq!(s.meshes[0].triangle_count(), 10);
    let r = Topology::build(&s.meshes[0]).report();
    assert_eq!(r.boundary_edges, 4, "one face missing: its four edges are open");
}

#[test]
fn malformed_inputs_give_their_errors() {
    let p = Path::new("bad.obj");
    let check = |text: &str, want: &[&str]| {
        let e = obj::parse(text.as_bytes(), p).expect_err(text).to_string();
        for w in want {
            assert!(e.contains(w), "{text:?}: {e}");
        }
    };
    check("v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n", &["bad.obj:line 2", "not finite"]);
    check("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", &["line 4", "out of range"]);
    check("# nothing\n", &["no faces"]);

    let g = |json: &str| gltf::parse(json.as_bytes(), Path::new("bad.gltf")).unwrap_err().to_string();
    let e = g("{\"asset\":{\"version\":\"2.0\"}}");
    assert!(e.contains("bad.gltf") && e.contains("no scene"), "{e}");
    let e = g("{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":3}]}");
    assert!(e.contains("nodes[0].mesh"), "{e}");
    let e = g("{ not json");
    assert!(e.contains("bad.gltf"), "{e}");
    // NaN in the position data: edit the fixture's buffer.
    let mut bin = std::fs::read(data("card.bin")).unwrap();
    bin[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
    let dir = std::env::temp_dir().join(format!("shadowlab-nan-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("card.bin"), &bin).unwrap();
    std::fs::copy(data("card-external.gltf"), dir.join("card.gltf")).unwrap();
    let e = gltf::load(&dir.join("card.gltf")).unwrap_err().to_string();
    assert!(e.contains("meshes[0].primitives[0].attributes.POSITION[0]") && e.contains("not finite"), "{e}");
    // Out-of-range index.
    let mut bin = std::fs::read(data("card.bin")).unwrap();
    bin[36..38].copy_from_slice(&7u16.to_le_bytes());
    std::fs::write(dir.join("card.bin"), &bin).unwrap();
    let e = gltf::load(&dir.join("card.gltf")).unwrap_err().to_string();
    assert!(e.contains("meshes[0].primitives[0].indices") && e.contains("out of range"), "{e}");
    // A missing buffer file.
    std::fs::remove_file(dir.join("card.bin")).unwrap();
    let e = gltf::load(&dir.join("card.gltf")).unwrap_err().to_string();
    assert!(e.contains("card.gltf") && e.contains("buffers"), "{e}");
    std::fs::remove_dir_all(&dir).ok();

    let t = |text: &str| scene_file::parse(text, Path::new("bad.toml")).unwrap_err().to_string();
    assert!(t("[[light]]\ntype = \"spot\"\nposition=[0,1,0]\ndirection=[0,-1,0]\nradius = -1\n").contains("radius"));
    assert!(t("[[object]]\nprimitive = { type = \"plane\", size = [0, 1] }\n").contains("width"));
    assert!(t("[[view]]\nname=\"v\"\nposition=[0,0,0]\ntarget=[0,0,0]\n").contains("target coincides"));

    let e = load_file(Path::new("no/such/file.obj")).unwrap_err().to_string();
    assert!(e.contains("no/such/file.obj") && e.contains("no such file"), "{e}");
    let e = load_scene("scene.fbx").unwrap_err().to_string();
    assert!(e.contains("scene.fbx"), "{e}");
}

#[test]
fn example_scene_file_loads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/bunny-plane.toml");
    let l = load_scene(path.to_str().unwrap()).unwrap();
    assert_eq!(l.scene.instances.len(), 2);
    assert_eq!(l.scene.views.len(), 4);
    assert!(l.scene.view("azri").is_some());
    assert!(matches!(l.scene.lights[0].kind, LightKind::Rect { .. }));
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
}

/// Truncations at many lengths and random byte flips: every loader returns, never panics.
#[test]
fn fuzzed_files_never_panic() {
    let dir = assets();
    let inputs: Vec<(PathBuf, Vec<u8>)> = [
        data("small.obj"),
        data("card.gltf"),
        dir.join("cornell-box/CornellBox-Original.obj"),
        dir.join("cornell-box/CornellBox.glb"),
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/bunny-plane.toml"),
    ]
    .into_iter()
    .map(|p| {
        let bytes = std::fs::read(&p).unwrap();
        (p, bytes)
    })
    .collect();
    let run = |path: &Path, bytes: &[u8]| {
        let ext = path.extension().unwrap().to_str().unwrap();
        // The result does not matter; returning does.
        let _ = match ext {
            "obj" => obj::parse(bytes, path).map(|_| ()),
            "gltf" | "glb" => gltf::parse(bytes, path).map(|_| ()),
            _ => scene_file::parse(&String::from_utf8_lossy(bytes), path).map(|_| ()),
        };
    };
    let mut rng = Rng::new(2026);
    for (path, bytes) in &inputs {
        let step = (bytes.len() / 97).max(1);
        for len in (0..bytes.len()).step_by(step) {
            run(path, &bytes[..len]);
        }
        for _ in 0..300 {
            let mut b = bytes.clone();
            for _ in 0..1 + (rng.next_u64() % 4) as usize {
                let i = (rng.next_u64() % b.len() as u64) as usize;
                b[i] ^= 1 << (rng.next_u64() % 8);
            }
            run(path, &b);
        }
    }
}

/// The full example in docs/scene-format.md parses and is what it says.
#[test]
fn documented_example_is_valid() {
    let doc_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/scene-format.md");
    let doc = std::fs::read_to_string(&doc_path).unwrap();
    let start = doc.find("```toml\n").expect("example block") + "```toml\n".len();
    let end = start + doc[start..].find("```").unwrap();
    let l = scene_file::parse(&doc[start..end], &doc_path).unwrap_or_else(|e| panic!("{e}"));
    let s = &l.scene;
    s.validate().unwrap();
    assert_eq!(s.name, "example");
    let kinds: Vec<&str> = s.lights.iter().map(|l| l.type_name()).collect();
    // The base scene's panel first, then the file's four lights.
    assert_eq!(kinds, ["rect", "rect", "point", "spot", "directional"]);
    assert!(s.instances.iter().any(|i| i.name == "bunny"));
    assert_eq!(s.path("swing").unwrap().views().len(), 30);
}

/// The Cornell box lit by its own ceiling panel (`Ke 17 12 4` in the MTL) instead of a default sun,
/// by the loader option and by a scene file's `emissive_lights = true`.
#[test]
fn the_cornell_panel_becomes_its_light() {
    let obj = assets().join("cornell-box/CornellBox-Original.obj");
    let options = shadowlab_core::LoadOptions { emissive_lights: true };
    let lit = shadowlab_core::load_scene_with(obj.to_str().unwrap(), options).unwrap();
    let check = |scene: &shadowlab_core::Scene| {
        assert_eq!(scene.lights.len(), 1, "the panel, and no default sun");
        match scene.lights[0].kind {
            LightKind::Rect { direction, width, height, .. } => {
                assert!(direction.y < -0.999, "the panel faces down: {direction}");
                let (a, b) = (width.max(height), width.min(height));
                // The OBJ's panel: 0.47 × 0.38 m, up to f32 round-off of its coordinates (1e-4).
                assert!((a - 0.47).abs() < 1e-4 && (b - 0.38).abs() < 1e-4, "{width} × {height}");
            }
            ref k => panic!("{k:?}"),
        }
        let panel = scene.instances.iter().find(|i| i.name.ends_with("light")).expect("the panel instance");
        assert!(!panel.casts_shadows, "the panel is the light, not an occluder of it");
    };
    check(&lit.scene);
    // Without the option: the default sun.
    let plain = load_scene(obj.to_str().unwrap()).unwrap();
    assert_eq!(plain.scene.lights[0].type_name(), "directional");
    // A scene file asks for it with a key.
    let dir = std::env::temp_dir().join(format!("shadowlab-cornell-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let toml = dir.join("cornell.toml");
    std::fs::write(&toml, format!("emissive_lights = true\n\n[[object]]\nfile = {:?}\n", obj.to_str().unwrap()))
        .unwrap();
    check(&load_scene(toml.to_str().unwrap()).unwrap().scene);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn gltf_alpha_mask_and_factor_alpha_are_read() {
    let text = std::fs::read_to_string(data("card.gltf")).unwrap();
    let masked = text.replacen(
        "\"doubleSided\": true,",
        "\"doubleSided\": true, \"alphaMode\": \"MASK\", \"alphaCutoff\": 0.3,",
        1,
    );
    let masked = masked.replacen("0.1,\n     1\n    ]", "0.1,\n     0.7\n    ]", 1);
    assert_ne!(masked, text, "the fixture's material was not found");
    let l = gltf::parse(masked.as_bytes(), &data("card.gltf")).unwrap();
    let card = l.scene.instances.iter().find(|i| i.name == "card").unwrap();
    let m = l.scene.material(card.material);
    assert_eq!(m.alpha_mode, shadowlab_core::AlphaMode::Mask { cutoff: 0.3 });
    assert_eq!(m.base_alpha, 0.7);
    // Without `alphaMode` a material is opaque, whatever its alpha (glTF's default).
    let l = gltf::load(&data("card.gltf")).unwrap();
    let card = l.scene.instances.iter().find(|i| i.name == "card").unwrap();
    assert_eq!(l.scene.material(card.material).alpha_mode, shadowlab_core::AlphaMode::Opaque);
}

/// A scene file's `alpha_cutoff` makes a material alpha-masked; a cutoff out of [0, 1] is an error
/// naming the material.
#[test]
fn scene_file_alpha_keys() {
    let toml = |cutoff: f32| {
        format!("base = \"penumbra\"\n[[material]]\nname = \"leaf\"\nalpha = 0.6\nalpha_cutoff = {cutoff}\n")
    };
    let l = scene_file::parse(&toml(0.25), Path::new("leaf.toml")).unwrap();
    let leaf = l.scene.materials.iter().find(|m| m.name == "leaf").unwrap();
    assert_eq!(leaf.alpha_mode, shadowlab_core::AlphaMode::Mask { cutoff: 0.25 });
    assert_eq!(leaf.base_alpha, 0.6);
    let e = scene_file::parse(&toml(1.5), Path::new("leaf.toml")).unwrap_err().to_string();
    assert!(e.contains("leaf") && e.contains("cutoff"), "{e}");
}
