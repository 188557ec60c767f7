//! The DVF's defaults and `profile=paper`: ours traces both hemispheres (double-sided surfaces
//! are common in real scenes), traces rays no sample saw, and sizes the sample budget from the
//! frame; the paper's profile is its Sponza configuration; an explicit key overrides either.

use glimpse_dvf::{AutoBudget, DvfParams, Rounding, Sides};
use glimpse_render::Params;

fn read(pairs: &[&str]) -> DvfParams {
    DvfParams::default().read(&Params::parse(pairs).expect("valid pairs")).expect("valid params")
}

#[test]
fn defaults_and_the_paper_profile() {
    let ours = read(&[]);
    assert!(ours.sides == Sides::Both && ours.trace_unknown && ours.auto == AutoBudget::ALL);
    let paper = read(&["profile=paper"]);
    assert_eq!((paper.points, paper.grid, paper.rounding), (10_000_000, 77, Rounding::Ceil));
    assert!(paper.sides == Sides::Front && !paper.trace_unknown && paper.auto == AutoBudget::default());
    assert_eq!(paper, DvfParams::paper(), "the profile is the paper's settings, nothing else");
    let (front, seen) = (read(&["sides=front"]), read(&["sides=seen"]));
    assert_eq!((front.sides, seen.sides, read(&["profile=paper", "sides=both"]).sides), (Sides::Front, Sides::Seen, Sides::Both));
    // Which instances trace their back hemisphere: all, none, or the camera probe's.
    assert_eq!(ours.back_instances(3, || vec![2]), vec![0, 1, 2]);
    assert_eq!(front.back_instances(3, || vec![2]), Vec::<u32>::new());
    assert_eq!(paper.back_instances(3, || vec![2]), Vec::<u32>::new());
    assert_eq!(seen.back_instances(4, || vec![2]), vec![2]);
    assert!(DvfParams::default().read(&Params::parse(&["sides=auto"]).unwrap()).is_err());
    assert!(!read(&["unknown=skip"]).trace_unknown);
    // An explicit number turns that key's automatic choice off, and only that one.
    let fixed = read(&["points=40000"]);
    assert_eq!((fixed.points, fixed.auto.points, fixed.auto.grid), (40_000, false, true));
    assert!(DvfParams::default().read(&Params::parse(&["profile=fast"]).unwrap()).is_err());
    assert!(DvfParams::default().read(&Params::parse(&["points=many"]).unwrap()).is_err());
}

#[test]
fn the_automatic_budget_follows_the_frame() {
    let auto = read(&[]);
    // 1280×720: about the 40,000 samples and 40 cells measured best on Sponza.
    let hd = auto.for_frame(1280 * 720, 66_000);
    assert_eq!((hd.points, hd.grid, hd.rounding), (38_400, 39, Rounding::Ceil));
    // Tiny frames keep a floor of 10,000 samples; huge ones stop at the paper's 10M.
    assert_eq!(auto.for_frame(64 * 64, 12).points, 10_000);
    assert_eq!(auto.for_frame(1 << 40, 12).points, 10_000_000);
    assert_eq!(auto.for_frame(1 << 40, 12).grid, 77);
    // More triangles than samples: the rounded running total, not one sample per triangle.
    assert_eq!(auto.for_frame(320 * 180, 1_041_765).rounding, Rounding::Cumulative);
    assert_eq!(read(&["rounding=round"]).for_frame(320 * 180, 1_041_765).rounding, Rounding::Round);
    assert_eq!(read(&["rounding=cumulative"]).for_frame(64, 2).rounding, Rounding::Cumulative);
    // Explicit keys are kept.
    let fixed = read(&["points=5000", "grid=12", "rounding=ceil"]).for_frame(1280 * 720, 2_000_000);
    assert_eq!((fixed.points, fixed.grid, fixed.rounding), (5000, 12, Rounding::Ceil));
}

/// `unshadowed=auto` keeps the paper's SH E_unshad for low-frequency light and takes it from the
/// fragment's own rays where N_r rays of the map are noisy (a small bright sun): measured, not
/// assumed, from the map's cosine-weighted second moment.
#[test]
fn unshadowed_follows_the_map_frequency() {
    use glimpse_core::Vec3;
    use glimpse_dvf::{SH_MAX_RELATIVE_NOISE, Unshadowed, choose_unshadowed, cosine_estimator_noise};
    use glimpse_scene::Environment;
    let constant = cosine_estimator_noise(&Environment::constant(Vec3::splat(0.8)), 128);
    let overcast = cosine_estimator_noise(&Environment::procedural_sky(256, Vec3::new(0.3, 1.0, 0.2), 0.0), 128);
    let sunny = cosine_estimator_noise(&Environment::procedural_sky(256, Vec3::new(0.3, 1.0, 0.2), 2000.0), 128);
    println!(
        "relative noise of 128 rays: constant {constant:.4}, sky without sun {overcast:.4}, sky with sun {sunny:.4} (threshold {SH_MAX_RELATIVE_NOISE})"
    );
    assert!(constant < 1e-3);
    assert!(overcast < sunny);
    assert_eq!(choose_unshadowed(constant, 0.0), Unshadowed::Sh);
    assert_eq!(choose_unshadowed(overcast, 0.2), Unshadowed::Sh);
    assert_eq!(choose_unshadowed(sunny, 0.0), Unshadowed::Rays);
    // An enclosed field takes the rays even under a low-frequency map.
    assert_eq!(choose_unshadowed(constant, 0.9), Unshadowed::Rays);
    assert!(read(&[]).auto.unshadowed && !read(&["profile=paper"]).auto.unshadowed);
    let fixed = read(&["unshadowed=sh"]);
    assert!(!fixed.auto.unshadowed && fixed.unshadowed == Unshadowed::Sh);
    assert_eq!(read(&["profile=paper", "unshadowed=rays"]).unshadowed, Unshadowed::Rays);
}
