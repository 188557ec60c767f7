//! The precompute's path budget (`budget`, a scene-derived default of issue #13): the tuned
//! scenes fit under it unchanged; a scene with much glossy area has its point budgets scaled down
//! together to about the budget; `budget=0` and `profile=paper` lift it.

use glimpse_render::Params;
use glimpse_wavecache::cache::{classes_and_areas, plan_points};
use glimpse_wavecache::{DEFAULT_PATH_BUDGET, WavecacheParams};

fn plan(spec: &str, pairs: &[&str]) -> glimpse_wavecache::cache::PointPlan {
    let scene = glimpse_scene::load(spec).expect("scene loads");
    let frame = scene.at(0.0);
    let p = WavecacheParams::read(&Params::parse(pairs).unwrap()).unwrap();
    let (classes, areas) = classes_and_areas(&frame, &p);
    plan_points(&scene, &p, &classes, &areas)
}

#[test]
fn the_budget_scales_only_scenes_over_it() {
    let root = env!("CARGO_MANIFEST_DIR");
    let bunny = format!("{root}/scenes/bunny-glossy.toml");
    let shared = std::path::Path::new(root).join("../../../shared/scenes/stanford-bunny").exists();
    if !shared {
        println!("skipping bunny-glossy: ../shared/scenes is missing");
    }
    for tuned in ["glossy"].into_iter().chain(shared.then_some(bunny.as_str())) {
        let p = plan(tuned, &[]);
        println!("{tuned}: {:.1}M paths planned, scale {:.3}", p.paths as f64 / 1e6, p.scale);
        assert_eq!(p.scale, 1.0, "{tuned} is one of the tuned scenes: its plan must not change");
    }
    // Every suite scene's plan (those whose files are present), and one over the budget.
    let mut over = None;
    let mut names: Vec<_> = std::fs::read_dir(format!("{root}/../../scenes/suite")).unwrap().flatten().map(|e| e.path()).collect();
    names.sort();
    for path in names {
        let spec = path.display().to_string();
        if glimpse_scene::load(&spec).is_err() {
            println!("{spec}: does not load here (../shared missing?), skipped");
            continue;
        }
        let p = plan(&spec, &["budget=0"]);
        println!("{spec}: {:.1}M paths without a budget", p.paths as f64 / 1e6);
        if p.paths > DEFAULT_PATH_BUDGET && over.is_none() {
            over = Some(spec);
        }
    }
    // A scene built to be over it: the glossy scene with four times the glossy points.
    let _ = over;
    let full = plan("glossy", &["budget=0", "glossy_points=16000"]);
    let scaled = plan("glossy", &["glossy_points=16000"]);
    println!(
        "glossy, glossy_points=16000: {:.1}M paths without a budget, {:.1}M with the default {:.0}M (scale {:.3})",
        full.paths as f64 / 1e6,
        scaled.paths as f64 / 1e6,
        DEFAULT_PATH_BUDGET as f64 / 1e6,
        scaled.scale
    );
    assert!(full.paths > DEFAULT_PATH_BUDGET && full.scale == 1.0);
    assert!(scaled.scale < 1.0);
    // Within 10 % of the budget (the per-mesh minimum of points can add a little).
    assert!(scaled.paths as f64 <= DEFAULT_PATH_BUDGET as f64 * 1.1, "{} paths", scaled.paths);
    assert!(scaled.points.iter().zip(&full.points).all(|(s, f)| s <= f));
    assert_eq!(plan("glossy", &["profile=paper"]).scale, 1.0, "the paper's profile has no budget");
    assert!(WavecacheParams::read(&Params::parse(&["budget=-1"]).unwrap()).is_err());
}
