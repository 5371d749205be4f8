//! Hard shadows on a kilometre-scale outdoor view (issue 19): the generated `city` seen from street
//! level under a mid (35°) and a low (8°) sun, every technique against the ray-traced truth.

mod common;

use shadowlab::{Renderer, TechniqueSpec};
use shadowlab_core::{LightId, Scene, load_scene};
use shadowlab_reference::metrics::ErrorStats;

use common::{gpu, reference};

const W: u32 = 256;
const H: u32 = 192;

/// One renderer per sun, techniques switched in place: the surface (and so the truth) is shared.
struct Street {
    renderer: Renderer,
    truth: Vec<f32>,
    /// Relevant pixels farther than two pixels from any edge of the truth's shadows.
    away_from_edges: Vec<bool>,
    /// The truth averaged over 4 × 4 samples of each pixel's area (traced when first asked for): a
    /// pole's shadow thinner than a pixel, which the pixel-centre truth misses, covers part of a
    /// pixel here.
    area_truth: Option<Vec<f32>>,
    scene: Scene,
    view: shadowlab_core::View,
}

impl Street {
    fn new(elevation: f32) -> Self {
        let scene: Scene = load_scene(&format!("city:elevation={elevation}")).unwrap().scene;
        let view = scene.view("street").unwrap().clone();
        let mut renderer = Renderer::new(&gpu(), scene.clone(), &view, W, H);
        renderer.set_technique(LightId(0), &TechniqueSpec::parse("hard", &[]).unwrap()).unwrap();
        renderer.render().unwrap();
        let surface = renderer.read_surface().unwrap();
        let truth = reference(&scene, &surface, LightId(0), 1);
        let away_from_edges = away_from_edges(&truth, 2);
        Self { renderer, truth, away_from_edges, area_truth: None, scene, view }
    }

    fn visibility(&mut self, spec: &str) -> Vec<f32> {
        self.renderer.set_technique(LightId(0), &TechniqueSpec::parse(spec, &[]).unwrap()).unwrap();
        // Two frames: what the GPU measures of the visible depths arrives a frame late (PSM's near).
        self.renderer.render().unwrap();
        self.renderer.render().unwrap();
        self.renderer.read_visibility(LightId(0)).unwrap().unwrap()
    }

    /// Wrong pixels (|V − V_ref| > 0.1) away from the truth's shadow edges, and over all relevant ones.
    fn wrong(&mut self, spec: &str) -> (f64, f64) {
        let v = self.visibility(spec);
        (
            ErrorStats::compare_masked(&v, &self.truth, &self.away_from_edges).wrong_frac(),
            ErrorStats::compare(&v, &self.truth).wrong_frac(),
        )
    }
}

/// The truth at 4 × 4 points of each pixel, averaged over the points that see geometry (NaN where
/// none does).
fn area_truth(scene: &Scene, view: &shadowlab_core::View) -> Vec<f32> {
    const S: u32 = 4;
    let mut fine = Renderer::new(&gpu(), scene.clone(), view, W * S, H * S);
    fine.render().unwrap();
    let t = reference(scene, &fine.read_surface().unwrap(), LightId(0), 1);
    (0..W * H)
        .map(|i| {
            let (x, y) = (i % W, i / W);
            let (mut sum, mut n) = (0.0, 0);
            for dy in 0..S {
                for dx in 0..S {
                    let v = t[((y * S + dy) * W * S + x * S + dx) as usize];
                    if !v.is_nan() {
                        sum += v;
                        n += 1;
                    }
                }
            }
            if n == 0 { f32::NAN } else { sum / n as f32 }
        })
        .collect()
}

/// Relevant pixels whose (2r + 1)² neighbourhood holds no other truth value than their own: a
/// shadow edge seen at a grazing angle moves by pixels with a millimetre of surface (even exact
/// volumes differ there), while what a broken warp draws lies far from any edge.
fn away_from_edges(truth: &[f32], r: i32) -> Vec<bool> {
    let at = |x: i32, y: i32| -> Option<f32> {
        (x >= 0 && y >= 0 && x < W as i32 && y < H as i32).then(|| truth[(y * W as i32 + x) as usize])
    };
    (0..truth.len())
        .map(|i| {
            let (x, y) = ((i as u32 % W) as i32, (i as u32 / W) as i32);
            let v = truth[i];
            !v.is_nan()
                && (-r..=r).all(|dy| {
                    (-r..=r).all(|dx| at(x + dx, y + dy).is_none_or(|u| u.is_nan() || (u > 0.5) == (v > 0.5)))
                })
        })
        .collect()
}

#[test]
fn warps_never_make_a_map_worse() {
    let warps = ["psm", "lispsm", "repar", "arbitrary,warp_strength=0.5"];
    let partitions = ["splits=1", "splits=4,scheme=uniform", "splits=4,scheme=log", "splits=4,scheme=practical"];
    let mut failures = Vec::new();
    for elevation in [35.0, 8.0] {
        let mut street = Street::new(elevation);
        for partition in partitions {
            // The same focus unwarped: free, as a warped map's is (`quantize` applies to unwarped
            // maps only; it moves the 8° sun's grazing edge across the street by rows: practical
            // splits 2.17% wrong free, 2.06% quantised).
            let plain = format!("cascaded:{partition},quantize=false");
            let (base, base_all) = street.wrong(&plain);
            for warp in warps {
                let spec = format!("cascaded:{partition},warp={warp}");
                let (w, all) = street.wrong(&spec);
                println!(
                    "{elevation}°: {spec}: {:.3}% (unwarped {:.3}%) away from edges, {:.3}% (unwarped {:.3}%) in all",
                    100.0 * w,
                    100.0 * base,
                    100.0 * all,
                    100.0 * base_all
                );
                // The bound: a warp adds at most 0.1 points of wrong pixels to the same
                // partition unwarped, over all relevant pixels and away from the truth's edges
                // (measured at most +0.068 points in all: log splits with PSM at 8°; +0.064 away
                // from edges: practical splits with η = 0.5 at 35°). Before warped maps stored linear
                // depth, PSM drew rows of false shadow over the whole lit street (52% wrong at
                // 35°; log splits with LiSPSM 21%); before PSM took the visible near plane, its
                // far texels shadowed thin lit poles (+0.11 points away from edges).
                if w > base + 0.001 || all > base_all + 0.001 {
                    failures.push(format!("{elevation}°: {spec} {w} / {all} vs unwarped {base} / {base_all}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Issue 19 item 2: four `scheme=auto` splits (fitted to the visible depths of the frame before,
/// SDSM) within 0.05 points of wrong pixels of the best fixed scheme on the street, under a 35° and
/// an 8° sun.
#[test]
fn auto_splits_match_the_best_fixed_scheme() {
    let mut failures = Vec::new();
    for elevation in [35.0, 8.0] {
        let mut street = Street::new(elevation);
        let (_, auto) = street.wrong("cascaded:splits=4,scheme=auto");
        let fitted = street.renderer.shadows.stats().extra.iter().any(|(k, v)| k.ends_with("auto_fitted") && *v == 1.0);
        assert!(fitted, "{elevation}°: the second frame is fitted to the first's samples");
        let fixed: Vec<(&str, f64)> = ["uniform", "log", "practical"]
            .into_iter()
            .map(|s| (s, street.wrong(&format!("cascaded:splits=4,scheme={s}")).1))
            .collect();
        let best = fixed.iter().map(|f| f.1).fold(f64::INFINITY, f64::min);
        println!(
            "{elevation}°: auto {:.3}%, {}",
            100.0 * auto,
            fixed.iter().map(|(s, w)| format!("{s} {:.3}%", 100.0 * w)).collect::<Vec<_>>().join(", ")
        );
        // The bound, 0.05 points over the best fixed scheme, nothing added. Measured
        // (256×192, llvmpipe): 35° auto 0.065% against log 0.062% (+0.003 points; uniform 0.799%,
        // practical 0.463%); 8° auto 1.715% against log 1.746% (uniform 4.825%, practical 2.063%).
        if auto > best + 0.0005 {
            failures.push(format!("{elevation}°: auto {auto} vs best fixed {best}"));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

impl Street {
    /// Pixels fully lit over their whole area (every one of the area truth's 4 × 4 samples), with
    /// no pixel within two that is not, that `spec` darkens below 0.98, as a fraction of those
    /// pixels; and the wrong fraction over all relevant pixels against the pixel-centre truth.
    fn acne(&mut self, spec: &str) -> (f64, f64) {
        let v = self.visibility(spec);
        let (scene, view) = (&self.scene, &self.view);
        let area = self.area_truth.get_or_insert_with(|| area_truth(scene, view));
        let lit_at = |x: i32, y: i32| -> bool {
            x < 0 || y < 0 || x >= W as i32 || y >= H as i32 || {
                let a = area[(y * W as i32 + x) as usize];
                a.is_nan() || a >= 1.0
            }
        };
        let lit: Vec<bool> = (0..area.len())
            .map(|i| {
                let (x, y) = ((i as u32 % W) as i32, (i as u32 / W) as i32);
                !area[i].is_nan() && (-2..=2).all(|dy| (-2..=2).all(|dx| lit_at(x + dx, y + dy)))
            })
            .collect();
        let count = lit.iter().filter(|&&m| m).count().max(1);
        let darkened = v.iter().zip(&lit).filter(|&(&v, &m)| m && (v.is_nan() || v < 0.98)).count();
        (darkened as f64 / count as f64, ErrorStats::compare(&v, &self.truth).wrong_frac())
    }
}

/// Issue 19 item 3: filters leave lit streets lit. Every `pcf` kernel, `pcss` and every `kernel=`
/// of `cascaded` (one map and four splits), at its defaults, darkens at most 0.1% of the pixels lit
/// over their whole area away from shadow edges, under a 35° and an 8° sun.
#[test]
fn filters_leave_lit_streets_lit() {
    let filtered = [
        ("hard", "pcf"),
        ("hard", "pcf:kernel=box"),
        ("hard", "pcf:kernel=rotated"),
        ("hard", "pcss"),
        ("cascaded", "cascaded:kernel=box"),
        ("cascaded", "cascaded:kernel=poisson"),
        ("cascaded", "cascaded:kernel=rotated"),
        ("cascaded:splits=4", "cascaded:splits=4,kernel=box"),
        ("cascaded:splits=4", "cascaded:splits=4,kernel=poisson"),
        ("cascaded:splits=4", "cascaded:splits=4,kernel=rotated"),
    ];
    let mut failures = Vec::new();
    for elevation in [35.0, 8.0] {
        let mut street = Street::new(elevation);
        for (plain, spec) in filtered {
            let (base, base_all) = street.acne(plain);
            let (dark, all) = street.acne(spec);
            println!(
                "{elevation}°: {spec}: {:.3}% of lit pixels darkened ({plain}: {:.3}%), {:.3}% wrong in all ({:.3}%)",
                100.0 * dark,
                100.0 * base,
                100.0 * all,
                100.0 * base_all
            );
            // The bound, 0.1% of lit pixels. Measured at most 0.078% (one map, fitted to
            // the samples by the default scheme=auto, with a box kernel at 8°; with the practical
            // scheme before it: at most 0.044%, pcf and pcss at 8°, one map with a box kernel
            // 0.034% at 35°, 0.076% before its focus was quantised; the unfiltered lookups
            // 0.000–0.024%). Before
            // the blur was bounded in screen pixels (`max_blur`, pcss's smallest filter) and taps
            // allowed for creases (`crease_slope`): pcf 2.6% at 35° and 20% at 8° (kernel=box
            // 32%), one map with Poisson 17% at 8°, pcss 0.78% and 3.0%; without the crease bias,
            // one map with a box kernel 0.165% at 8°.
            if dark > 0.001 {
                failures.push(format!("{elevation}°: {spec} darkens {dark} of lit pixels ({plain}: {base})"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Issue 19 item 5: which techniques keep the shadows of casters thinner than a texel. The lamp
/// posts (0.3 m thick; a texel of a whole-city map is about 1 m) are taken out of the casters for a
/// second truth: the pixels the posts alone shadow are their shadows, and a technique keeps such a
/// pixel when it puts it below ½.
#[test]
fn thin_casters_keep_their_shadows() {
    let specs = [
        "hard",
        "pcf",
        "cascaded",
        "cascaded:warp=lispsm",
        "cascaded:splits=4,quantize=false",
        "cascaded:splits=4",
        "cascaded:splits=4,scheme=log",
        "cascaded:splits=4,scheme=log,stabilize=true",
        "cascaded:splits=4,scheme=practical",
        "cascaded:scheme=practical",
        "hard:map_size=8192",
        "volumes",
    ];
    let mut failures = Vec::new();
    for elevation in [35.0, 8.0] {
        let mut street = Street::new(elevation);
        let surface = street.renderer.read_surface().unwrap();
        let mut no_posts: Scene = load_scene(&format!("city:elevation={elevation}")).unwrap().scene;
        for i in no_posts.instances.iter_mut().filter(|i| i.name.starts_with("pole")) {
            i.casts_shadows = false;
        }
        let without = reference(&no_posts, &surface, LightId(0), 1);
        let posts: Vec<bool> = street.truth.iter().zip(&without).map(|(&t, &w)| t == 0.0 && w == 1.0).collect();
        let count = posts.iter().filter(|&&p| p).count();
        println!("{elevation}°: {count} pixels in the posts' shadows");
        // A check that the posts' shadows are in view at all (measured 341 and 458 pixels).
        assert!(count > 50, "{elevation}°: the posts shadow {count} pixels");
        for spec in specs {
            let v = street.visibility(spec);
            let kept = v.iter().zip(&posts).filter(|&(&v, &p)| p && v < 0.5).count() as f64 / count as f64;
            println!("{elevation}°: {spec}: keeps {:.1}% of the posts' shadow pixels", 100.0 * kept);
            // Volumes are exact but for the rasterisation of their faces, and four log-spaced
            // splits give the street's near posts texels of centimetres (measured: volumes 98.2% at
            // 35°, 96.9% at 8°; splits=4,scheme=log 97.9% and 94.8%; for contrast one 2048² map,
            // `hard`, 4.7% and 4.1%). Bound: 0.9, about five points under the lowest.
            let keeps = matches!(spec, "volumes" | "cascaded:splits=4,scheme=log");
            if keeps && kept < 0.9 {
                failures.push(format!("{elevation}°: {spec} keeps {kept}"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Issue 19 item 4: focus without flicker. Focused `cascaded` along the city's walk (60 frames down
/// the main street) shimmers no more than 1.5× `hard`.
#[test]
fn focused_maps_do_not_flicker_along_the_street() {
    let s = common::path_flicker(
        "city",
        "walk",
        W,
        H,
        &[
            "hard",
            "cascaded",
            "cascaded:stabilize=true",
            "cascaded:scheme=practical",
            "cascaded:scheme=practical,stabilize=true",
            "cascaded:splits=4",
            "cascaded:splits=4,scheme=practical",
            "cascaded:splits=4,scheme=log",
        ],
    );
    for (spec, f) in [
        "cascaded:scheme=practical",
        "cascaded:scheme=practical,stabilize=true",
        "cascaded:splits=4",
        "cascaded:splits=4,scheme=practical",
        "cascaded:splits=4,scheme=log",
    ]
    .iter()
    .zip(&s[3..])
    {
        println!("flicker: {spec} {:.4}%", 100.0 * f.fraction());
    }
    let [hard, focused, stable] = [&s[0], &s[1], &s[2]].map(|f| f.fraction());
    println!("flicker: hard {:.4}%, focused {:.4}%, stabilised {:.4}%", 100.0 * hard, 100.0 * focused, 100.0 * stable);
    // A check that the walk was measured over its frames (measured 1,899,195 pixel pairs each).
    assert!(s.iter().all(|f| f.pixels > 1_000_000));
    // The bound. Measured (256×192, llvmpipe): hard 0.047%, focused 0.021% (the default
    // scheme=auto; 0.011% with the practical scheme, 0.291% before the focus box was quantised),
    // stabilised 0.054% (practical 0.017%; auto before its stabilised extent took whole octaves
    // 0.42%); four splits auto 0.032%, practical 0.379%, log 0.054%.
    assert!(focused <= 1.5 * hard, "focused {focused} against hard {hard}");
}
