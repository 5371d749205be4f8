//! The truth against an independent tracer: `scripts/embree_check.py` (Intel Embree 4 through
//! the `embreex` package) traces the rays of `shadowlab reference` on three scenes from the
//! geometry `shadowlab export` writes, and fails on any unexplained hard-light difference or an
//! area-light estimate outside the Monte-Carlo noise (the script's doc says how).
//!
//! Python with `embreex` and `numpy` is not part of the Rust toolchain: without them the test says
//! so and passes, unless `SHADOWLAB_REQUIRE_EMBREE` is set (`.ci/run` installs them and sets it,
//! so CI always runs the check).

use std::path::Path;
use std::process::Command;

#[test]
fn the_truth_agrees_with_embree_on_three_scenes() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let required = std::env::var_os("SHADOWLAB_REQUIRE_EMBREE").is_some();
    let available =
        Command::new("python3").args(["-c", "import embreex, numpy"]).output().is_ok_and(|o| o.status.success());
    if !available {
        assert!(!required, "SHADOWLAB_REQUIRE_EMBREE is set but python3 cannot import embreex and numpy");
        eprintln!("skipped: python3 with embreex and numpy is missing (pip install embreex numpy)");
        return;
    }
    let out = Command::new("python3")
        .arg(repo.join("scripts/embree_check.py"))
        .args(["--shadowlab", env!("CARGO_BIN_EXE_shadowlab"), "--size", "128x96"])
        .output()
        .expect("python3 runs");
    let text = String::from_utf8_lossy(&out.stdout);
    println!("{text}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "the Embree cross-check failed:\n{text}");
    assert!(text.contains("the truth agrees with Embree"), "{text}");
}
