//! `shadowlab calibrate` and `--technique auto`, end to end: the calibration file's keys
//! (docs/calibration-format.md), the choice shown by compare and render, and the acceptance check
//! of issue 12 item 5 on real calibrations of `room`, `penumbra` and `terrain`: the automatic
//! choice's error is within 10% of the best candidate that fits the same share, and it never picks
//! one that does not fit while one does.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;
use shadowlab::auto::{Calibration, CandidateFigures, LightFigures, Preference, choose};

fn shadowlab(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shadowlab")).args(args).output().expect("the binary runs")
}

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shadowlab-calibrate-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn ok(out: &Output) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "stdout: {stdout}\nstderr: {}", String::from_utf8_lossy(&out.stderr));
    stdout
}

fn json(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))).unwrap()
}

/// The calibration file read as an outside script would, by its documented keys (null: NaN).
fn calibration(file: &Value) -> Calibration {
    let num = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    Calibration {
        scene: file["scene"].as_str().unwrap().to_owned(),
        lights: file["lights"]
            .as_array()
            .unwrap()
            .iter()
            .map(|l| LightFigures {
                index: l["index"].as_u64().unwrap() as u32,
                name: l["name"].as_str().unwrap().to_owned(),
                light_type: l["type"].as_str().unwrap().to_owned(),
                candidates: l["candidates"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|c| CandidateFigures {
                        spec: c["spec"].as_str().unwrap().to_owned(),
                        cost_ms: num(&c["cost_ms"]),
                        still_ms: num(&c["still_ms"]),
                        rmse: num(&c["rmse"]),
                        wrong_frac: num(&c["wrong_frac"]),
                        memory_bytes: c["memory_bytes"].as_u64().unwrap(),
                    })
                    .collect(),
            })
            .collect(),
    }
}

/// Runs `calibrate` with `extra` arguments into `dir/cal.json` and reads it back.
fn calibrate(dir: &Path, extra: &[&str]) -> Value {
    let out = dir.join("cal.json");
    let mut args = vec!["calibrate", "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    ok(&shadowlab(&args));
    assert!(dir.join("report.html").is_file(), "calibrate wrote no report.html");
    json(&out)
}

#[test]
fn calibrate_writes_the_documented_file_and_auto_uses_it() {
    let dir = temp("penumbra");
    let file = calibrate(
        &dir,
        &[
            "--scene",
            "penumbra",
            "--size",
            "32x24",
            "--candidate",
            "hard",
            "--candidate",
            "pcss",
            "--samples",
            "16",
            "--frames",
            "1",
            "--warmup",
            "0",
        ],
    );
    for key in ["scene", "views", "width", "height", "adapter", "reference", "lights"] {
        assert!(!file[key].is_null(), "cal.json lacks '{key}'");
    }
    assert_eq!(file["scene"], "penumbra");
    // No --view: all the scene's views, at most four (penumbra has three).
    assert_eq!(file["views"], serde_json::json!(["default", "top", "low"]));
    assert_eq!((file["width"].as_u64(), file["height"].as_u64()), (Some(32), Some(24)));
    for key in ["name", "backend", "device_type"] {
        assert!(file["adapter"][key].is_string(), "adapter.{key}");
    }
    assert_eq!(file["reference"]["samples"], 16);
    assert!(file["reference"]["seed"].is_u64());
    let lights = file["lights"].as_array().unwrap();
    assert_eq!(lights.len(), 1);
    let light = &lights[0];
    assert_eq!(
        (light["index"].as_u64(), light["name"].as_str(), light["type"].as_str()),
        (Some(0), Some("panel"), Some("rect"))
    );
    let specs: Vec<&str> =
        light["candidates"].as_array().unwrap().iter().map(|c| c["spec"].as_str().unwrap()).collect();
    assert_eq!(specs, ["hard", "pcss"]);
    for c in light["candidates"].as_array().unwrap() {
        for key in ["cost_ms", "still_ms", "rmse", "wrong_frac"] {
            // Costs are clamped at 0 (noise around a zero cost); errors are fractions of [0, 1].
            assert!(c[key].as_f64().is_some_and(|x| x >= 0.0), "{key}: {c}");
        }
        assert!(c["rmse"].as_f64().unwrap() <= 1.0 && c["wrong_frac"].as_f64().unwrap() <= 1.0, "{c}");
        // Both keep a 2048² map of 4-byte depth at least.
        assert!(c["memory_bytes"].as_u64().unwrap() >= 2048 * 2048 * 4, "{c}");
    }
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert!(html.contains("panel") && html.contains("pcss") && html.contains("default budget"));

    // compare with `auto`: metrics.json names each light's spec and why, and the choice is the one
    // `shadowlab::auto` makes from the file at the default budget.
    let cal = calibration(&file);
    let expected = choose(&cal, cal.default_budget_ms(), Preference::Balanced);
    let cal_path = dir.join("cal.json");
    let cmp = dir.join("compare");
    ok(&shadowlab(&[
        "compare",
        "--scene",
        "penumbra",
        "--size",
        "32x24",
        "--samples",
        "16",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--technique",
        "hard",
        "--technique",
        "auto",
        "--calibration",
        cal_path.to_str().unwrap(),
        "--out",
        cmp.to_str().unwrap(),
    ]));
    let m = json(&cmp.join("metrics.json"));
    let auto = m["auto"].as_array().expect("metrics.json has 'auto'");
    assert_eq!(auto.len(), 1);
    assert_eq!(auto[0]["light"], 0);
    assert_eq!(auto[0]["spec"].as_str(), Some(expected[0].spec.as_str()));
    assert!(auto[0]["reason"].as_str().is_some_and(|r| r.starts_with("lowest RMSE")), "{}", auto[0]);
    let ids: Vec<&str> = m["techniques"].as_array().unwrap().iter().map(|t| t["id"].as_str().unwrap()).collect();
    assert_eq!(ids, ["hard", "auto"]);
    assert_eq!(m["techniques"][1]["lights"][0]["spec"].as_str(), Some(expected[0].spec.as_str()));
    assert_eq!(m["auto_budget"]["preference"], "balanced");
    let html = std::fs::read_to_string(cmp.join("report.html")).unwrap();
    assert!(html.contains("which light got what, and why"));

    // render with a budget nothing fits: the cheapest, said so.
    let png = dir.join("auto.png");
    let stdout = ok(&shadowlab(&[
        "render",
        "--scene",
        "penumbra",
        "--size",
        "32x24",
        "--technique",
        "auto",
        "--calibration",
        cal_path.to_str().unwrap(),
        "--budget-ms",
        "0",
        "--out",
        png.to_str().unwrap(),
    ]));
    let cheapest = cal.lights[0].candidates.iter().min_by(|a, b| a.cost_ms.total_cmp(&b.cost_ms)).unwrap();
    // Unless a cost is exactly 0 (then it fits a zero budget).
    if cheapest.cost_ms > 0.0 {
        assert!(stdout.contains(&format!("light 0 'panel' → {}: nothing fits: cheapest", cheapest.spec)), "{stdout}");
    }
    assert!(png.is_file());
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn auto_options_are_checked() {
    let dir = temp("errors");
    std::fs::create_dir_all(&dir).unwrap();
    let fails = |args: &[&str], message: &str| {
        let out = shadowlab(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(stderr.contains(message), "{args:?}: expected '{message}' in: {stderr}");
    };
    let png = dir.join("x.png");
    let png = png.to_str().unwrap();
    fails(&["render", "--scene", "penumbra", "--budget-ms", "3", "--out", png], "go with --technique auto");
    fails(
        &["analyze", "--scene", "penumbra", "--technique", "auto", "--out", png],
        "is for render, compare, bench and play",
    );
    fails(
        &[
            "render",
            "--scene",
            "penumbra",
            "--technique",
            "auto",
            "--calibration",
            "/nonexistent/cal.json",
            "--out",
            png,
        ],
        "reading calibration /nonexistent/cal.json",
    );
    let bad = dir.join("bad.json");
    std::fs::write(&bad, "{\"scene\": \"room\"}").unwrap();
    fails(
        &["render", "--scene", "penumbra", "--technique", "auto", "--calibration", bad.to_str().unwrap(), "--out", png],
        "missing field",
    );
    let other = dir.join("other.json");
    std::fs::write(
        &other,
        r#"{"scene": "room", "views": ["default"], "width": 8, "height": 8,
            "adapter": {"name": "x", "backend": "vulkan", "device_type": "cpu"},
            "reference": {"samples": 1, "seed": 1}, "lights": []}"#,
    )
    .unwrap();
    fails(
        &[
            "render",
            "--scene",
            "penumbra",
            "--technique",
            "auto",
            "--calibration",
            other.to_str().unwrap(),
            "--out",
            png,
        ],
        "is for scene 'room', not 'penumbra'",
    );
    fails(&["calibrate", "--scene", "penumbra", "--view", "nowhere", "--out", png], "has no view 'nowhere'");
    std::fs::remove_dir_all(dir).ok();
}

/// The acceptance check on one calibration: for budgets from far too small to ample (and shares
/// exactly at candidates' costs, the boundary), under every preference, each light's choice fits
/// its share whenever some candidate does and its RMSE is within 10% of the best that fits;
/// when nothing fits it is the cheapest. Returns the number of (budget, light) cases checked.
fn check_choices(cal: &Calibration) -> usize {
    let n = cal.lights.len() as f64;
    let default = cal.default_budget_ms();
    let mut budgets: Vec<f64> = [0.0, 1.0 / 16.0, 0.25, 1.0, 4.0, 16.0].iter().map(|f| f * default).collect();
    budgets.extend(cal.lights.iter().flat_map(|l| l.candidates.iter().map(|c| c.cost_ms * n)));
    let mut cases = 0;
    for &budget in &budgets {
        for preference in Preference::ALL {
            for (light, c) in cal.lights.iter().zip(choose(cal, budget, preference)) {
                let share = budget * preference.budget_factor() / n;
                assert!((c.share_ms - share).abs() <= 1e-9 * share.max(1.0), "{c:?}");
                let fitting: Vec<&CandidateFigures> = light.candidates.iter().filter(|x| x.cost_ms <= share).collect();
                match fitting.iter().map(|x| x.rmse).min_by(f64::total_cmp) {
                    Some(best) => {
                        assert!(c.fits && c.cost_ms <= share, "{}: budget {budget}: {c:?} does not fit", cal.scene);
                        // The issue's acceptance margin: within 10% of the best that fits (by
                        // construction the same RMSE up to auto::TIE_RMSE = 1e-6).
                        assert!(c.rmse <= 1.10 * best + 1e-6, "{}: budget {budget}: {c:?}, best {best}", cal.scene);
                    }
                    None => {
                        let cheapest = light.candidates.iter().map(|x| x.cost_ms).min_by(f64::total_cmp).unwrap();
                        assert!(!c.fits && c.cost_ms == cheapest, "{c:?}");
                        assert!(c.reason.starts_with("nothing fits: cheapest"), "{c:?}");
                    }
                }
                cases += 1;
            }
        }
    }
    cases
}

/// Calibrates `scene` on one view at 64×48, checks the choices on the figures, then runs `compare
/// --technique auto` on that view at `budget_factor` × the default budget and checks that each
/// light's RMSE measured there is within 10% of the best candidate that fits its share.
fn acceptance(scene: &str, view: &str, candidates: &[&str], budget_factor: f64) {
    let dir = temp(&format!("accept-{scene}"));
    let mut args =
        vec!["--scene", scene, "--view", view, "--size", "64x48", "--samples", "16", "--frames", "1", "--warmup", "1"];
    for c in candidates {
        args.extend_from_slice(&["--candidate", c]);
    }
    let file = calibrate(&dir, &args);
    let cal = calibration(&file);
    for l in &cal.lights {
        assert!(!l.candidates.is_empty(), "{scene}: light '{}' has no candidate", l.name);
    }
    assert!(check_choices(&cal) > 0);

    let budget = budget_factor * cal.default_budget_ms();
    let choices = choose(&cal, budget, Preference::Balanced);
    let cmp = dir.join("compare");
    let cal_path = dir.join("cal.json");
    let budget_text = format!("{budget}");
    ok(&shadowlab(&[
        "compare",
        "--scene",
        scene,
        "--view",
        view,
        "--size",
        "64x48",
        "--samples",
        "16",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--technique",
        "auto",
        "--calibration",
        cal_path.to_str().unwrap(),
        "--budget-ms",
        &budget_text,
        "--out",
        cmp.to_str().unwrap(),
    ]));
    let m = json(&cmp.join("metrics.json"));
    let measured = m["techniques"][0]["lights"].as_array().unwrap();
    for (c, light) in choices.iter().zip(&cal.lights) {
        let auto = m["auto"].as_array().unwrap().iter().find(|a| a["light"] == c.light).unwrap();
        assert_eq!(auto["spec"].as_str(), Some(c.spec.as_str()), "{scene}: {auto}");
        let here = measured.iter().find(|l| l["index"] == c.light).unwrap()["rmse"].as_f64().unwrap();
        let best = light.candidates.iter().filter(|x| x.cost_ms <= c.share_ms).map(|x| x.rmse).min_by(f64::total_cmp);
        eprintln!(
            "{scene} budget {budget:.2} ms: light {} '{}' → {} (RMSE here {here:.4}, best fitting {best:?})",
            c.light, c.name, c.spec
        );
        if let Some(best) = best {
            // Measured: the same figure to 4 decimals (the same surface, reference and technique as
            // the calibration; every light's visibility is its own). Margin: the issue's 10%.
            assert!(
                here <= 1.10 * best + 1e-4,
                "{scene}: light '{}' {}: RMSE {here} against best {best}",
                c.name,
                c.spec
            );
        }
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn acceptance_on_penumbra() {
    // Every default candidate that runs on a rect light.
    acceptance(
        "penumbra",
        "default",
        &[
            "hard",
            "pcf",
            "pcss",
            "smoothies",
            "volumes",
            "lightmaps:samples=16",
            "lightmaps",
            "sampled:samples=16,mode=array",
        ],
        0.5,
    );
}

#[test]
fn acceptance_on_room() {
    // A cheap-to-dear subset (the 64-sample `lightmaps` and `smoothies` cost the most time here
    // and add no new kind of candidate).
    acceptance(
        "room",
        "default",
        &[
            "hard",
            "pcf",
            "pcss",
            "volumes",
            "lightmaps:samples=16",
            "sampled:samples=16,mode=array",
            "cascaded:splits=4,scheme=practical",
        ],
        // A quarter of the default budget: a share of the mean `hard` cost, below the point
        // lamps' (cube maps): they get `volumes`, the spot and the sun `pcss` (measured).
        0.25,
    );
}

#[test]
fn acceptance_on_terrain() {
    // `lightmaps` cannot run on terrain (its receivers need more layers than a texture array has).
    acceptance("terrain", "ground", &["hard", "pcf", "pcss", "volumes", "cascaded:splits=4,scheme=practical"], 1.0);
}
