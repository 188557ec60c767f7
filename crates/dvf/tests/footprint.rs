//! `footprint=around` (ours): a fragment reads the union of the masks of the 2×2×2 cells around
//! it, so a pixel is trusted only where the samples of every nearby cell agree. Against
//! `env-exact` on the same rays, on the Cornell box, where a cell's samples on one wall decide
//! for fragments on the wall or box beside them.

mod common;

use glimpse_core::{Aabb, Vec3};
use glimpse_dvf::grid::Grid;
use glimpse_dvf::technique::EnvDvf;
use glimpse_render::env::EnvExact;
use glimpse_render::metrics::rmse;
use glimpse_render::{FrameContext, Params, Settings, Stats, Technique};

/// The image and the render's stats.
fn render(t: &mut dyn Technique, ctx: &FrameContext) -> (glimpse_core::Image, Stats) {
    let (img, _, stats) = common::render(t, ctx);
    (img, stats)
}

#[test]
fn the_cells_around_a_point_surround_it() {
    let grid = Grid::from_bounds(Aabb::new(Vec3::ZERO, Vec3::splat(4.0)), 4);
    let cell = |x: usize, y: usize, z: usize| (z * 4 + y) * 4 + x;
    // Just past the centre of cell (1, 1, 1): itself and the cells above it on each axis.
    let mut around = grid.cells_around(Vec3::splat(1.6)).to_vec();
    around.sort();
    let mut expected: Vec<usize> = (0..8).map(|i| cell(1 + (i & 1), 1 + ((i >> 1) & 1), 1 + ((i >> 2) & 1))).collect();
    expected.sort();
    assert_eq!(around, expected);
    // Just before it: the cells below on each axis.
    let mut below = grid.cells_around(Vec3::splat(1.4)).to_vec();
    below.sort();
    let mut expected: Vec<usize> = (0..8).map(|i| cell(i & 1, (i >> 1) & 1, (i >> 2) & 1)).collect();
    expected.sort();
    assert_eq!(below, expected);
    // In a corner cell's outer half the grid's face clamps: only the corner cell repeats.
    assert!(grid.cells_around(Vec3::splat(0.1)).iter().all(|&c| c == cell(0, 0, 0)));
    assert!(grid.cells_around(Vec3::splat(3.99)).iter().all(|&c| c == cell(3, 3, 3)));
    // Every one holds the point's own cell among them.
    for p in [Vec3::new(0.3, 2.7, 3.2), Vec3::new(3.5, 0.5, 1.0), Vec3::splat(2.0)] {
        assert!(grid.cells_around(p).contains(&grid.cell_of(p)), "{p:?}");
    }
}

#[test]
fn the_neighbourhood_footprint_follows_env_exact() {
    let scene = glimpse_scene::load("cornell-lit").unwrap();
    let ctx = FrameContext::new(&scene, 0.0, 96, 64);
    let settings = Settings { spp: 1, seed: 0 };
    let (reference, exact_stats) = render(&mut EnvExact::new(&settings, &Params::default()).unwrap(), &ctx);
    let mut results = Vec::new();
    // unshadowed=rays: E_unshad from the same rays, so only the masks' decisions differ.
    for footprint in ["footprint=cell", "footprint=around"] {
        let mut t = EnvDvf::new(&settings, &Params::parse(&["unshadowed=rays", footprint]).unwrap()).unwrap();
        let (img, stats) = render(&mut t, &ctx);
        let e = rmse(&img, &reference, None).unwrap();
        println!("{footprint}: RMSE {e:.5} against env-exact on the same rays; {} rays ({} for env-exact)", stats.rays, exact_stats.rays);
        results.push((e, stats.rays));
    }
    let ((cell, cell_rays), (around, around_rays)) = (results[0], results[1]);
    assert!(around <= 0.003 && around < 0.2 * cell, "around {around} vs cell {cell}");
    // It traces more rays than one cell's masks ask for, and still fewer than env-exact (at
    // this size most rays are traced either way: 6,144 pixels against a 10,000-sample field).
    assert!(around_rays > cell_rays && around_rays < exact_stats.rays, "{around_rays} vs {cell_rays}, exact {}", exact_stats.rays);
}
