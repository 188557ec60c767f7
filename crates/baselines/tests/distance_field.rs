//! Checks of the distance-field baseline: jump flooding against a brute-force nearest seed, the
//! mip levels as lower bounds, sphere tracing against exact rays, and the equal-storage claim.
//! Each prints what it measured before asserting.

use glimpse_baselines::distance_field::jump_flood;
use glimpse_baselines::{DfParams, DfScene, DistanceField, SphereTraceParams};
use glimpse_core::sampling::cosine_hemisphere;
use glimpse_core::{Frame, Ray, Rng, Vec3};
use glimpse_trace::{ExactTracer, GBuffer, Visibility};
use glimpse_voxel::{Grid, OccupancyMap, Word};

/// A sparse random BOM: `count` occupied cells.
fn sparse_bom<W: Word>(count: usize, seed: u64) -> (OccupancyMap<W>, Vec<Vec3>) {
    let mut rng = Rng::new(seed, 0);
    let mut bom = OccupancyMap::<W>::empty();
    let mut centres = Vec::new();
    for _ in 0..count {
        let (x, y, z) = (rng.below(W::BITS), rng.below(W::BITS), rng.below(W::BITS));
        bom.set(x, y, z);
        centres.push(Vec3::new(x as f32, y as f32, z as f32) + Vec3::splat(0.5));
    }
    (bom, centres)
}

fn nearest(centres: &[Vec3], q: Vec3) -> f32 {
    centres.iter().map(|c| c.distance(q)).fold(f32::INFINITY, f32::min)
}

#[test]
fn check_01_jump_flooding_matches_brute_force() {
    let (bom, centres) = sparse_bom::<u32>(60, 1);
    let seeds = jump_flood(&bom);
    let field = DistanceField::from_bom(&bom, Grid::around(glimpse_core::Aabb::new(Vec3::ZERO, Vec3::ONE), 32, Vec3::ZERO));
    let (mut exact, mut worst, mut cells) = (0u32, 0.0f32, 0u32);
    for z in 0..32 {
        for y in 0..32 {
            for x in 0..32 {
                let truth = nearest(&centres, Vec3::new(x as f32, y as f32, z as f32) + Vec3::splat(0.5));
                let got = field.cell(x, y, z);
                worst = worst.max(got - truth);
                exact += ((got - truth).abs() < 0.01) as u32;
                cells += 1;
            }
        }
    }
    let seeded = seeds.iter().filter(|&&s| s != u32::MAX).count();
    println!(
        "check 1: JFA+1 on 32³ with 60 seeds: {exact}/{cells} cells at the exact nearest-centre distance, worst overestimate {worst:.3} cells; {seeded} cells have a seed"
    );
    assert_eq!(seeded, 32 * 32 * 32);
    assert!(exact as f64 >= 0.999 * cells as f64 && worst < 0.5);
}

#[test]
fn check_02_mip_levels_are_lower_bounds() {
    let (bom, centres) = sparse_bom::<u64>(200, 2);
    let field = DistanceField::from_bom(&bom, Grid::around(glimpse_core::Aabb::new(Vec3::ZERO, Vec3::ONE), 64, Vec3::ZERO));
    let mut rng = Rng::new(2, 2);
    let (mut violations, mut gain1, mut gain2) = (0u32, 0.0f64, 0.0f64);
    let n = 20_000;
    for _ in 0..n {
        let q = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 64.0;
        let truth = nearest(&centres, q);
        let (b1, b2) = (field.bound(1, q), field.bound(2, q));
        violations += (b1 > truth + 0.01 || b2 > truth + 0.01) as u32;
        gain1 += (b1 / truth.max(1e-3)) as f64;
        gain2 += (b2 / truth.max(1e-3)) as f64;
    }
    println!(
        "check 2: 64³, 200 seeds, {n} random points: mip bound above the true distance {violations} times; bounds average {:.0}% (level 1) and {:.0}% (level 2) of the true distance",
        100.0 * gain1 / n as f64,
        100.0 * gain2 / n as f64
    );
    assert_eq!(violations, 0);
}

#[test]
fn check_03_sphere_tracing_against_exact_rays() {
    let scene = glimpse_scene::load("cornell").unwrap();
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    let g = GBuffer::new(&frame, &tracer, &scene.camera_or_default(1.0), 40, 40);
    for max_steps in [16u32, 64] {
        let df =
            DfScene::build(&frame, &DfParams { trace: SphereTraceParams { max_steps, ..Default::default() }, ..Default::default() }, 3, 0);
        let cell = df.cell_size_world();
        let (mut rays, mut agree, mut clear, mut clear_agree, mut steps, mut exhausted) = (0u64, 0u64, 0u64, 0u64, 0u64, 0u64);
        for i in (0..g.len()).filter(|&i| g.is_hit(i)) {
            let origin = g.position[i] + g.normal[i] * 1.5 * cell;
            let basis = Frame::from_z(g.shading_normal[i]);
            let mut rng = Rng::for_pixel(3, i as u64, 0);
            for _ in 0..4 {
                let d = basis.to_world(cosine_hemisphere(rng.next_2d()));
                let exact = tracer.closest_hit(&Ray::new(origin, d), f32::INFINITY);
                let r = df.field.sphere_trace(origin, d, f32::INFINITY, &df.params.trace);
                let ok = r.hit.is_some() == exact.is_some();
                rays += 1;
                agree += ok as u64;
                steps += r.steps as u64;
                exhausted += (r.hit.is_none() && r.steps == max_steps) as u64;
                if exact.is_none_or(|h| h.t > 2.0 * cell) {
                    clear += 1;
                    clear_agree += ok as u64;
                }
            }
        }
        println!(
            "check 3: cornell DF (128³, ≤ {max_steps} steps): agrees with exact any-hit on {:.2}% of {rays} rays, {:.2}% of the {clear} whose exact hit is > 2 cells away; {:.1} steps per ray, {:.2}% ran out of steps",
            100.0 * agree as f64 / rays as f64,
            100.0 * clear_agree as f64 / clear as f64,
            steps as f64 / rays as f64,
            100.0 * exhausted as f64 / rays as f64
        );
        if max_steps == 64 {
            assert!(clear_agree as f64 >= 0.9 * clear as f64);
        }
    }
    // The backend form (origin moved along the ray) agrees with itself on a blocked segment.
    let df = DfScene::build(&frame, &DfParams::default(), 3, 0);
    let down = Ray::new(Vec3::new(0.28, 0.3, 0.1), -Vec3::Y);
    assert!(df.occluded(&down, f32::INFINITY), "a ray straight down from mid-air hits the floor");
}

#[test]
fn check_04_equal_storage_with_roma() {
    let scene = glimpse_scene::load("cornell").unwrap();
    let df = DfScene::build(&scene.at(0.0), &DfParams::default(), 0, 0);
    let level0 = df.field.levels[0].len() * 2;
    println!(
        "check 4: 128³ DF: level 0 {level0} bytes (= ROMA 128², 4²: {} bytes), with mips {} bytes",
        16 * 128 * 128 * 16,
        df.field.memory_bytes()
    );
    assert_eq!(level0, 4 << 20);
}

#[test]
fn check_05_a_focused_field_keeps_a_contact_shadow() {
    // `focus=auto` (ours, as ROMA's): a 2 m slab floating 5 cm over a 300 m ground. The scene's
    // cube has 3.4 m cells, so the slab and the ground are one layer of cells and the 1.5-cell
    // offset lifts every AO ray above the slab; focused, the ground is tested exactly.
    use glimpse_baselines::technique::AoDf;
    use glimpse_render::ao::AoExact;
    use glimpse_render::{FrameContext, Params, Settings, Technique};
    let toml = "[camera]\nposition = [0.0, 2.5, 4.0]\ntarget = [0.0, 0.2, 0.0]\nfov_y_degrees = 45.0\n\
        [[quad]]\nsize = [300.0, 300.0]\n[[box]]\nsize = [2.0, 0.3, 2.0]\ntranslate = [0.0, 0.2, 0.0]\n";
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("slab.toml");
    std::fs::write(&path, toml).unwrap();
    let scene = glimpse_scene::load(path.to_str().unwrap()).unwrap();
    let ctx = FrameContext::new(&scene, 0.0, 48, 32);
    let g = ctx.gbuffer();
    let mut reference = ctx.image();
    AoExact::new(&Settings { spp: 256, seed: 9 }, &Params::default()).unwrap().render(&ctx, &g, &mut reference).unwrap();
    let error = |focus: &str| {
        let params = Params::parse(&[focus]).unwrap();
        let mut t = AoDf::new(&Settings { spp: 64, seed: 3 }, &params).unwrap();
        params.finish("ao-df").unwrap();
        let stats = t.prepare(&ctx).unwrap();
        let mut img = ctx.image();
        t.render(&ctx, &g, &mut img).unwrap();
        let sum: f64 = img.pixels.iter().zip(&reference.pixels).map(|(p, q)| ((p.x - q.x) as f64).powi(2)).sum();
        let cell = stats.metrics.iter().find(|(k, _)| k == "cell_m").unwrap().1;
        ((sum / img.pixels.len() as f64).sqrt(), cell)
    };
    let ((wide, wide_cell), (focused, focused_cell)) = (error("focus=scene"), error("focus=auto"));
    println!(
        "check 5: ao-df vs ao-exact: scene's cube (cell {wide_cell:.2} m) RMSE {wide:.4}; focused (cell {focused_cell:.3} m) RMSE {focused:.4}"
    );
    assert!(focused_cell < 0.05 * wide_cell);
    assert!(wide > 0.1 && focused < 0.4 * wide && focused < 0.07, "RMSE {wide} → {focused}");
}
