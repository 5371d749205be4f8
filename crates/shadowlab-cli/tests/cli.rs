//! The command-line contract of DESIGN.md §6, end to end: files written, JSON keys present, clear
//! errors with a non-zero exit code for bad input.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn shadowlab(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shadowlab")).args(args).output().expect("the binary runs")
}

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shadowlab-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "stdout: {}\nstderr: {}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn fails_with(args: &[&str], message: &str) {
    let out = shadowlab(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{args:?} succeeded");
    assert!(stderr.contains(message), "{args:?}: expected '{message}' in: {stderr}");
    // Said once: a cause already quoted by its error is not repeated.
    assert_eq!(stderr.matches(message).count(), 1, "{args:?}: repeated message in: {stderr}");
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))).unwrap()
}

#[test]
fn compare_writes_every_file_and_key() {
    let out_dir = temp("compare-penumbra");
    let out = out_dir.to_str().unwrap();
    ok(&shadowlab(&[
        "compare",
        "--scene",
        "penumbra",
        "--size",
        "48x48",
        "--samples",
        "16",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--out",
        out,
    ]));
    let m = json(&out_dir.join("metrics.json"));
    for key in ["scene", "view", "width", "height", "adapter", "reference", "techniques"] {
        assert!(!m[key].is_null(), "metrics.json lacks '{key}'");
    }
    for key in ["name", "backend", "device_type"] {
        assert!(m["adapter"][key].is_string(), "adapter.{key}");
    }
    for key in ["samples", "seed", "seconds", "noise_floor_rmse"] {
        assert!(m["reference"][key].is_number(), "reference.{key}");
    }
    // The penumbra's panel is an area light: it takes the samples asked, and says so per light.
    assert_eq!((m["reference"]["samples"].as_u64(), m["reference"]["samples_asked"].as_u64()), (Some(16), Some(16)));
    assert_eq!(m["lights"][0]["samples"].as_u64(), Some(16));
    let techniques = m["techniques"].as_array().unwrap();
    let ids: Vec<&str> = techniques.iter().map(|t| t["id"].as_str().unwrap()).collect();
    assert_eq!(ids, ["none", "hard", "pcf", "sampled"]);
    for t in techniques {
        for key in [
            "id",
            "spec",
            "params",
            "rmse",
            "mae",
            "max_abs",
            "wrong_frac",
            "penumbra_rmse",
            "lit_darkened_frac",
            "shadow_brightened_frac",
            "flip_mean",
            "image_rmse",
            "lights",
            "gpu_ms",
            "cpu_ms",
            "memory_bytes",
        ] {
            assert!(t.get(key).is_some(), "technique {} lacks '{key}'", t["spec"]);
        }
        assert!(t["image_rmse"].as_f64().is_some_and(|x| (0.0..=1.0).contains(&x)), "{}", t["image_rmse"]);
        assert!(t["gpu_ms"].get("median").is_some() && t["gpu_ms"].get("passes").is_some());
        assert!(t["cpu_ms"]["median"].is_number());
        for l in t["lights"].as_array().unwrap() {
            for key in [
                "index",
                "name",
                "rmse",
                "mae",
                "max_abs",
                "wrong_frac",
                "penumbra_rmse",
                "relevant_pixels",
                "lit_darkened_frac",
                "shadow_brightened_frac",
            ] {
                assert!(l.get(key).is_some(), "light entry lacks '{key}'");
            }
            for key in ["lit_darkened_frac", "shadow_brightened_frac"] {
                // Fractions of the relevant pixels.
                assert!(l[key].as_f64().is_some_and(|x| (0.0..=1.0).contains(&x)), "light {key}: {}", l[key]);
            }
        }
        let slug = t["spec"].as_str().unwrap();
        for file in
            [format!("{slug}.png"), format!("{slug}-light0-panel.png"), format!("{slug}-light0-panel-error.png")]
        {
            assert!(out_dir.join(&file).is_file(), "missing {file}");
        }
    }
    for file in
        ["report.html", "quality_time.svg", "reference.png", "reference-light0-panel.png", "reference-light0-panel.f32"]
    {
        assert!(out_dir.join(file).is_file(), "missing {file}");
    }
    let html = std::fs::read_to_string(out_dir.join("report.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("data:image/png;base64,") && html.contains("sampled"));
    assert!(html.contains("lit darkened") && html.contains("shadow brightened") && html.contains("truth's penumbra"));
    // `none` ignores every shadow: it must be the worst.
    let rmse = |i: usize| techniques[i]["rmse"].as_f64().unwrap();
    assert!(rmse(0) > rmse(1) && rmse(0) > rmse(3));
    // `none` writes V = 1 everywhere: it darkens nothing and leaks light into the whole umbra (the
    // scene's occluder is wider than the light, so the umbra is not empty).
    assert_eq!(techniques[0]["lit_darkened_frac"].as_f64(), Some(0.0));
    assert!(techniques[0]["shadow_brightened_frac"].as_f64().unwrap() > 0.0, "{}", techniques[0]);
    // In the lit images too: no shadow at all is further from the reference than soft ones.
    let image = |i: usize| techniques[i]["image_rmse"].as_f64().unwrap();
    assert!(image(0) > image(3), "none {} vs sampled {}", image(0), image(3));
    std::fs::remove_dir_all(out_dir).ok();
}

#[test]
fn compare_runs_on_room_with_configured_techniques() {
    let out_dir = temp("compare-room");
    let out = out_dir.to_str().unwrap();
    ok(&shadowlab(&[
        "compare",
        "--scene",
        "room",
        "--size",
        "40x40",
        "--samples",
        "4",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--technique",
        "hard",
        "--technique",
        "pcf:kernel=box,taps=9",
        "--technique",
        "sampled:samples=4",
        "--set",
        "map_size=512",
        "--out",
        out,
    ]));
    let m = json(&out_dir.join("metrics.json"));
    let t = m["techniques"].as_array().unwrap();
    assert_eq!(t[1]["spec"], "pcf:kernel=box,taps=9");
    assert_eq!(t[1]["params"]["taps"], 9);
    assert_eq!(t[1]["params"]["map_size"], 512, "--set reaches every technique that has the parameter");
    assert_eq!(t[0]["lights"].as_array().unwrap().len(), 4);
    std::fs::remove_dir_all(out_dir).ok();
}

/// A technique that does not take some lights (`cascaded`: directional and spot only) does not abort
/// the comparison: those lights are shadowed by `hard` and marked, the technique's figures leave them
/// out, and a technique that takes none of the lights is skipped with a warning.
#[test]
fn compare_reports_the_rest_when_a_technique_does_not_fit_a_light() {
    let out_dir = temp("compare-unsupported");
    let out = out_dir.to_str().unwrap();
    let args = ["--size", "32x32", "--samples", "4", "--frames", "1", "--warmup", "0", "--set", "map_size=256"];
    let run = |scene: &str| {
        let mut all = vec!["compare", "--scene", scene, "--technique", "cascaded", "--technique", "hard", "--out", out];
        all.extend(args);
        shadowlab(&all)
    };
    let room = run("room");
    ok(&room);
    let stderr = String::from_utf8_lossy(&room.stderr);
    assert!(stderr.contains("'cascaded' does not support point light 'ceiling lamp'"), "{stderr}");
    let m = json(&out_dir.join("metrics.json"));
    let cascaded = &m["techniques"][0];
    assert_eq!(cascaded["spec"], "cascaded");
    let marked: Vec<&str> = cascaded["lights"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|l| l["not_applicable"] == true)
        .map(|l| l["name"].as_str().unwrap())
        .collect();
    assert_eq!(marked, ["ceiling lamp", "accent"], "the point lights fall back to hard");
    assert!(m["techniques"][1]["lights"].as_array().unwrap().iter().all(|l| l.get("not_applicable").is_none()));
    // `penumbra` has one rect light: `cascaded` is skipped, `hard` reported.
    let penumbra = run("penumbra");
    ok(&penumbra);
    assert!(String::from_utf8_lossy(&penumbra.stderr).contains("'cascaded' supports none of the lights"));
    let m = json(&out_dir.join("metrics.json"));
    let specs: Vec<&str> = m["techniques"].as_array().unwrap().iter().map(|t| t["spec"].as_str().unwrap()).collect();
    assert_eq!(specs, ["hard"]);
    std::fs::remove_dir_all(out_dir).ok();
}

/// `inspect` loads a scene and summarises it without a GPU: the topology of each mesh (what shadow
/// volumes must cope with), lights, views and the loader's warnings.
#[test]
fn inspect_summarises_a_scene_without_a_gpu() {
    let out = shadowlab(&["inspect", "--scene", "room", "--json"]);
    ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["triangles"].as_u64().unwrap() > 1000);
    assert_eq!(v["lights"].as_array().unwrap().len(), 4);
    assert!(v["meshes"].as_array().unwrap().iter().all(|m| m["topology"] == "closed"), "room is built of solids");
    // One triangle is an open mesh with three boundary edges; the missing .mtl is a warning.
    let dir = temp("inspect");
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("tri.obj");
    std::fs::write(&obj, "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let out = shadowlab(&["inspect", "--scene", obj.to_str().unwrap(), "--json"]);
    ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["meshes"][0]["topology"], "open");
    assert_eq!(v["meshes"][0]["boundary_edges"], 3);
    assert!(v["warnings"].as_array().unwrap().iter().any(|w| w.as_str().unwrap().contains("gone.mtl")));
    fails_with(&["inspect", "--scene", dir.join("none.obj").to_str().unwrap()], "no such file");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn listings_are_json() {
    let out = shadowlab(&["scenes", "--json"]);
    ok(&out);
    let scenes: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let names: Vec<&str> = scenes.as_array().unwrap().iter().map(|s| s["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["room", "penumbra", "columns", "terrain", "city"]);
    assert!(scenes[0]["triangles"].as_u64().unwrap() > 20_000);
    let out = shadowlab(&["techniques", "--json"]);
    ok(&out);
    let t: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let pcf = t.as_array().unwrap().iter().find(|t| t["id"] == "pcf").unwrap();
    assert!(
        pcf["params"].as_array().unwrap().iter().any(|p| p["name"] == "kernel" && p["range"] == "box|poisson|rotated")
    );
}

#[test]
fn render_reference_and_bench_run() {
    let dir = temp("misc");
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("r.png");
    ok(&shadowlab(&[
        "render",
        "--scene",
        "columns",
        "--size",
        "32x24",
        "--technique",
        "pcf",
        "--out",
        png.to_str().unwrap(),
    ]));
    assert!(png.is_file());
    let refdir = dir.join("ref");
    ok(&shadowlab(&[
        "reference",
        "--scene",
        "penumbra",
        "--size",
        "16x16",
        "--samples",
        "4",
        "--out",
        refdir.to_str().unwrap(),
    ]));
    for f in
        ["reference.json", "light0-panel.png", "light0-panel.f32", "light0-panel.json", "positions.f32", "normals.f32"]
    {
        assert!(refdir.join(f).is_file(), "missing {f}");
    }
    let summary = json(&refdir.join("reference.json"));
    assert_eq!((summary["samples"].as_u64(), summary["samples_asked"].as_u64()), (Some(4), Some(4)), "{summary}");
    // The same panel made hard (issue 19 item 6): one ray per pixel, reported as 1, whatever was asked.
    let hard_dir = dir.join("ref-hard");
    let out = shadowlab(&[
        "reference",
        "--scene",
        "penumbra",
        "--size",
        "16x16",
        "--samples",
        "64",
        "--emitter-scale",
        "0",
        "--out",
        hard_dir.to_str().unwrap(),
    ]);
    ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 ray per pixel (hard lights)"), "{out:?}");
    let summary = json(&hard_dir.join("reference.json"));
    assert_eq!((summary["samples"].as_u64(), summary["samples_asked"].as_u64()), (Some(1), Some(64)), "{summary}");
    assert_eq!(summary["lights"][0]["samples"].as_u64(), Some(1));
    // One ray for each relevant pixel, no more.
    assert_eq!(summary["lights"][0]["rays"], summary["lights"][0]["relevant_pixels"], "{summary}");
    let bench = dir.join("bench.json");
    // `bench` on the penumbra at 32², two frames, with `techniques` flags; its stdout and JSON.
    let run_bench = |techniques: &[&str]| {
        let mut args = vec!["bench", "--scene", "penumbra", "--size", "32x32", "--frames", "2", "--warmup", "0"];
        args.extend_from_slice(techniques);
        args.extend(["--json", bench.to_str().unwrap()]);
        let out = shadowlab(&args);
        ok(&out);
        (String::from_utf8_lossy(&out.stdout).into_owned(), json(&bench))
    };
    let (stdout, b) = run_bench(&["--techniques", "hard,pcf"]);
    assert!(stdout.contains("shadow") && stdout.contains("×hard"), "{stdout}");
    assert_eq!(b["techniques"][0]["time_ratio_over_hard"], 1.0);
    // `hard` with parameters is the baseline when plain `hard` is not benched.
    let (_, b) = run_bench(&["--technique", "pcf", "--technique", "hard:map_size=512"]);
    assert_eq!(b["techniques"][1]["time_ratio_over_hard"], 1.0);
    assert!(b["techniques"][0]["time_ratio_over_hard"].as_f64().is_some());
    // The default map budget holds the penumbra's one light: nothing cut, nothing said.
    assert_eq!(b["techniques"][0]["map_budget"]["budget_bytes"], 1u64 << 30);
    assert_eq!(b["techniques"][0]["map_budget"]["reduced"].as_array().map(Vec::len), Some(0));
    // A 1 MiB budget cuts its 2048² map (16 MiB) to 512² (exactly 1 MiB) and says so, on stderr
    // and in the JSON.
    let mut args = vec!["bench", "--scene", "penumbra", "--size", "32x32", "--frames", "1", "--warmup", "0"];
    args.extend(["--technique", "hard", "--map-budget", "1", "--json", bench.to_str().unwrap()]);
    let out = shadowlab(&args);
    ok(&out);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("cut to fit the 1 MiB map budget") && stderr.contains("2048² → 512²"), "{stderr}");
    let b = json(&bench);
    let reduced = &b["techniques"][0]["map_budget"]["reduced"][0];
    assert_eq!((reduced["asked"].as_u64(), reduced["granted"].as_u64()), (Some(2048), Some(512)), "{b}");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn gl_backend_smoke() {
    let dir = temp("gl");
    let out = dir.to_str().unwrap();
    ok(&shadowlab(&[
        "--backend",
        "gl",
        "compare",
        "--scene",
        "penumbra",
        "--size",
        "32x32",
        "--samples",
        "4",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--techniques",
        "hard",
        "--out",
        out,
    ]));
    let m = json(&dir.join("metrics.json"));
    assert_eq!(m["adapter"]["backend"], "gl");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bad_input_gives_clear_errors() {
    let out = temp("bad");
    let o = out.to_str().unwrap();
    fails_with(&["compare", "--technique", "shadowz", "--out", o], "unknown technique 'shadowz'");
    fails_with(&["compare", "--scene", "rooom", "--out", o], "unknown scene 'rooom'");
    fails_with(&["compare", "--set", "map_size", "--out", o], "expected KEY=VALUE");
    fails_with(&["compare", "--set", "map_size=0", "--out", o], "out of range");
    fails_with(&["compare", "--set", "colour=red", "--out", o], "unknown parameter 'colour'");
    fails_with(&["compare", "--technique", "pcf:taps=many", "--out", o], "expected an integer");
    fails_with(&["render", "--technique", "volumes:samples=0", "--out", "x.png"], "out of range 1..=1024");
    fails_with(&["render", "--scene", "no/such/scene.obj", "--out", "x.png"], "no such file");
    fails_with(&["render", "--view", "attic", "--out", "x.png"], "no view 'attic'");
    fails_with(&["render", "--lights", "moon", "--out", "x.png"], "no light 'moon'");
    fails_with(&["render", "--size", "0x10", "--out", "x.png"], "must be between 1x1 and 8192x8192");
    fails_with(&["render", "--emitter-scale", "NaN", "--out", "x.png"], "emitter-scale");
    fails_with(&["reference", "--scene", "terrain:sun=90", "--out", o], "'sun' = '90': out of range");
    // Random bytes named .glb: said to be no glTF, not a JSON parser's complaint.
    std::fs::create_dir_all(&out).unwrap();
    let glb = out.join("noise.glb");
    std::fs::write(&glb, (0..200u32).map(|i| (i * 97 % 251) as u8).collect::<Vec<u8>>()).unwrap();
    fails_with(&["render", "--scene", glb.to_str().unwrap(), "--out", "x.png"], "not a glTF or GLB file");
    // `--out` of `render` is checked before rendering: a directory, or not a PNG name.
    fails_with(&["render", "--out", o], "is a directory: name the PNG file to write");
    fails_with(&["render", "--out", "x.jpg"], "name a file ending in .png");
    // An unknown path is refused before the reference is traced (which reports itself on stderr).
    let args = ["compare", "--scene", "room", "--size", "64x64", "--path", "nowhere", "--out", o];
    fails_with(&args, "'nowhere' is neither a path (the scene has none)");
    let stderr = String::from_utf8_lossy(&shadowlab(&args).stderr).into_owned();
    assert!(!stderr.contains("reference:"), "checked after tracing: {stderr}");
    std::fs::remove_dir_all(out).ok();
}

/// `precompute` writes a light-mesh file without a GPU and reports what it made; `render
/// --light-meshes` takes it, and warns and recomputes for another scene's file; a missing file or a
/// dynamic light is a clear error.
#[test]
fn precompute_writes_light_meshes_that_the_engine_takes() {
    let dir = temp("precompute");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("columns.lmesh");
    let f = file.to_str().unwrap();
    let out = shadowlab(&["precompute", "--scene", "columns", "--out", f, "--json"]);
    ok(&out);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["lights"].as_array().unwrap().len(), 4, "columns has four static lamps");
    assert_eq!(report["bytes"].as_u64().unwrap(), std::fs::metadata(&file).unwrap().len());
    for light in report["lights"].as_array().unwrap() {
        for key in ["receiver_triangles", "pieces", "lit_pieces", "triangles", "seconds"] {
            assert!(light[key].is_number(), "precompute JSON lacks '{key}'");
        }
    }
    let png = dir.join("c.png");
    let render = |scene: &str| {
        shadowlab(&[
            "render",
            "--scene",
            scene,
            "--size",
            "32x32",
            "--technique",
            "lightmesh",
            "--light-meshes",
            f,
            "--out",
            png.to_str().unwrap(),
        ])
    };
    let same = render("columns");
    ok(&same);
    assert!(!String::from_utf8_lossy(&same.stderr).contains("warning"), "the file fits columns");
    let other = render("room");
    ok(&other);
    assert!(
        String::from_utf8_lossy(&other.stderr).contains("made for another scene"),
        "room refuses columns' file: {}",
        String::from_utf8_lossy(&other.stderr)
    );
    // The fill view: volume fragments per pixel; maps have none.
    let fill = shadowlab(&[
        "render",
        "--scene",
        "columns",
        "--size",
        "32x32",
        "--technique",
        "lightmesh",
        "--overlay",
        "fill",
        "--out",
        png.to_str().unwrap(),
    ]);
    ok(&fill);
    assert!(String::from_utf8_lossy(&fill.stdout).contains("volume fill:"), "the fill summary is printed");
    fails_with(
        &["render", "--scene", "columns", "--size", "32x32", "--overlay", "fill", "--out", png.to_str().unwrap()],
        "overlay 'fill' needs shadow volumes",
    );
    let missing = dir.join("none.lmesh");
    fails_with(
        &["render", "--scene", "columns", "--light-meshes", missing.to_str().unwrap(), "--out", png.to_str().unwrap()],
        "No such file",
    );
    fails_with(&["precompute", "--scene", "columns", "--out", dir.to_str().unwrap()], "is a directory");
    fails_with(&["precompute", "--scene", "columns", "--lights", "lamp 9", "--out", f], "no light 'lamp 9'");
}

/// `shadowlab view` opens the viewer's window (under Xvfb here) and closes after `--frames`; a bad
/// scene is an error before any window opens.
#[test]
fn view_opens_the_viewer_window() {
    fails_with(&["view", "--scene", "no-such-scene", "--frames", "1"], "no-such-scene");
    if Command::new("xvfb-run").arg("--help").output().is_err() {
        // CI installs xvfb (.ci/run).
        assert!(std::env::var_os("CI").is_none(), "xvfb-run is missing on CI");
        eprintln!("skipped the window: xvfb-run is not installed");
        return;
    }
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 640x480x24"])
        .arg(env!("CARGO_BIN_EXE_shadowlab"))
        .args(["view", "--scene", "penumbra", "--size", "96x64", "--frames", "3"])
        .output()
        .expect("xvfb-run runs");
    ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("3 frames"));
}

/// `export` writes the geometry and its description (no GPU), and refuses what it cannot write.
#[test]
fn export_writes_the_traced_triangles_and_their_description() {
    let dir = temp("export");
    let obj = dir.join("room.obj");
    ok(&shadowlab(&["export", "--scene", "room", "--lights", "sun", "--out", obj.to_str().unwrap()]));
    let desc = json(&dir.join("room.json"));
    let text = std::fs::read_to_string(&obj).unwrap();
    let faces = text.lines().filter(|l| l.starts_with("f ")).count() as u64;
    assert_eq!(desc["triangles"].as_u64(), Some(faces));
    let per_instance: u64 =
        desc["instances"].as_array().unwrap().iter().map(|i| i["triangles"].as_u64().unwrap()).sum();
    assert_eq!(per_instance, faces);
    // `--lights` chooses as in `reference`: the sun only, with its index in the scene.
    let lights = desc["lights"].as_array().unwrap();
    assert_eq!(lights.len(), 1);
    assert_eq!((lights[0]["name"].as_str(), lights[0]["type"].as_str()), (Some("sun"), Some("directional")));
    assert_eq!(lights[0]["index"].as_u64(), Some(3));
    for key in ["scale", "ulps", "scene_diagonal"] {
        assert!(desc["ray_offset"][key].is_number(), "ray_offset.{key}");
    }
    let glb = dir.join("room.glb");
    ok(&shadowlab(&["export", "--scene", "room", "--out", glb.to_str().unwrap()]));
    assert_eq!(&std::fs::read(&glb).unwrap()[0..4], b"glTF");
    fails_with(
        &["export", "--scene", "room", "--out", dir.join("room.stl").to_str().unwrap()],
        "must end in .obj or .glb",
    );
    fails_with(&["export", "--scene", "no-such-scene", "--out", obj.to_str().unwrap()], "not a built-in scene");
    let _ = std::fs::remove_dir_all(&dir);
}
