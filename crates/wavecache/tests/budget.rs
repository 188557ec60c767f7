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
    plan_points(&frame, &p, &classes, &areas)
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

/// The ray budget: the tuned `glossy` scene keeps its plan; a scene whose paths are long (the
/// closed, lit Cornell box: light bounces to `max_depth`) gets its path budget cut by its measured
/// rays per path; `ray_budget=0` and the paper's profile lift it.
#[test]
fn the_ray_budget_cuts_scenes_with_long_paths() {
    use glimpse_trace::ExactTracer;
    use glimpse_wavecache::DEFAULT_RAY_BUDGET;
    use glimpse_wavecache::cache::mean_rays_per_path;
    let measure = |spec: &str| {
        let scene = glimpse_scene::load(spec).unwrap();
        let frame = scene.at(0.0);
        let tracer = ExactTracer::build(&frame);
        let p = WavecacheParams::default();
        let m = mean_rays_per_path(&frame, &tracer, &p, 0);
        assert_eq!(m, mean_rays_per_path(&frame, &tracer, &p, 0), "the pilot is deterministic");
        (m, p.effective_path_budget(m), plan(spec, &["budget=0"]).paths)
    };
    let (open_m, open_budget, open_paths) = measure("glossy");
    let bunny = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/bunny-glossy.toml");
    match glimpse_scene::load(bunny) {
        Ok(_) => {
            let (m, budget, paths) = measure(bunny);
            println!("bunny-glossy: {m:.2} rays per path, path budget {budget} for {paths} planned paths");
            assert!(budget >= paths, "the tuned bunny-glossy scene must keep its plan");
        }
        Err(e) => println!("skipping bunny-glossy: {e}"),
    }
    let (closed_m, closed_budget, _) = measure("cornell-lit");
    println!("glossy: {open_m:.2} rays per path, path budget {open_budget} for {open_paths} planned paths");
    println!("cornell-lit: {closed_m:.2} rays per path, path budget {closed_budget}");
    assert!(open_budget >= open_paths, "the tuned glossy scene must keep its plan");
    assert!(closed_m > 2.0 * open_m, "a closed lit box's paths are longer than an open scene's");
    assert!(closed_budget < DEFAULT_PATH_BUDGET && closed_budget as f64 * closed_m <= DEFAULT_RAY_BUDGET as f64 * 1.001);
    let p = WavecacheParams::read(&Params::parse(&["ray_budget=0"]).unwrap()).unwrap();
    assert_eq!(p.effective_path_budget(closed_m), DEFAULT_PATH_BUDGET);
    assert_eq!(WavecacheParams::paper().effective_path_budget(closed_m), 0, "the paper's profile has no budget");
}

/// `min_spacing`: a class of tiny total area does not take its whole point budget there (a 1 cm²
/// diffuse emitter over a 10 m glossy floor got 20,000 points 0.04 mm apart), while the tuned
/// scenes keep their plans point for point.
#[test]
fn no_mesh_is_denser_than_the_minimum_spacing() {
    use glimpse_scene::{Material, Mesh, Scene};
    let root = env!("CARGO_MANIFEST_DIR");
    let bunny = format!("{root}/scenes/bunny-glossy.toml");
    let shared = glimpse_scene::load(&bunny).is_ok();
    for tuned in ["glossy", "cornell-lit"].into_iter().chain(shared.then_some(bunny.as_str())) {
        let (with, without) = (plan(tuned, &[]), plan(tuned, &["min_spacing=0"]));
        println!(
            "{tuned}: {} points with min_spacing, {} without",
            with.points.iter().sum::<usize>(),
            without.points.iter().sum::<usize>()
        );
        assert_eq!(with, without, "{tuned} is a tuned scene: its plan must not change");
    }
    let quad = |name: &str, h: f32, y: f32, material: u32| Mesh {
        name: name.into(),
        positions: [[-h, y, -h], [-h, y, h], [h, y, h], [h, y, -h]].map(glimpse_core::Vec3::from).to_vec(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material,
        ..Default::default()
    };
    let mut s = Scene { name: "tiny emitter over a glossy floor".into(), ..Default::default() };
    let glossy = s.add_material(Material { roughness: 0.3, ..Material::diffuse("glossy", glimpse_core::Vec3::splat(0.5)) });
    let mut lamp = Material::diffuse("lamp", glimpse_core::Vec3::ZERO);
    lamp.emission = glimpse_core::Vec3::splat(10.0);
    let lamp = s.add_material(lamp);
    s.add_mesh(quad("floor", 5.0, 0.0, glossy), glimpse_core::Mat4::IDENTITY);
    s.add_mesh(quad("lamp", 0.005, 2.0, lamp), glimpse_core::Mat4::IDENTITY);
    let frame = s.at(0.0);
    let plan_for = |pairs: &[&str]| {
        let p = WavecacheParams::read(&Params::parse(pairs).unwrap()).unwrap();
        let (classes, areas) = classes_and_areas(&frame, &p);
        assert_eq!(classes, [glimpse_wavecache::Class::Glossy, glimpse_wavecache::Class::Diffuse]);
        (plan_points(&frame, &p, &classes, &areas), p)
    };
    let ((capped, p), (uncapped, _)) = (plan_for(&["budget=0"]), plan_for(&["budget=0", "min_spacing=0"]));
    println!(
        "lamp points: {} capped, {} uncapped; floor points {} / {}",
        capped.points[1], uncapped.points[1], capped.points[0], uncapped.points[0]
    );
    assert_eq!(uncapped.points[1], p.diffuse_points as usize, "without the cap the 1 cm² lamp takes the whole diffuse budget");
    assert_eq!(capped.points[1], p.min_points as usize, "1 cm² at 1.4 cm spacing: only the per-mesh minimum");
    assert_eq!(capped.points[0], uncapped.points[0], "the floor is far sparser than the cap");
    assert!(capped.paths < uncapped.paths);
    // Under a binding budget the paths saved go to the floor.
    let (capped_b, _) = plan_for(&["budget=2000000"]);
    let (uncapped_b, _) = plan_for(&["budget=2000000", "min_spacing=0"]);
    println!("budget 2M: floor points {} capped, {} uncapped", capped_b.points[0], uncapped_b.points[0]);
    // The floor's points grow by the share of the paths the lamp no longer takes.
    let gain = capped_b.points[0] as f64 / uncapped_b.points[0] as f64;
    let expected = uncapped.paths as f64 / capped.paths as f64;
    println!("floor points ×{gain:.3} (paths freed: ×{expected:.3})");
    assert!(gain > 1.1 && (gain - expected).abs() < 0.05 * expected);
    assert!(capped_b.paths as f64 <= 2.0e6 * 1.1);
    assert!(WavecacheParams::read(&Params::parse(&["min_spacing=-1"]).unwrap()).is_err());
}

/// `path_floor` (ours): a scene whose point budgets give fewer paths than the floor has both
/// scaled up to it; the built-in Cornell box (diffuse: 20,000 points × 512 paths) and the tuned
/// scenes are at or over it; `path_floor=0` and `profile=paper` leave the budgets as they are.
#[test]
fn a_light_plan_is_raised_to_the_floor() {
    use glimpse_wavecache::DEFAULT_PATH_FLOOR;
    for scene in ["cornell", "glossy"] {
        let p = plan(scene, &[]);
        assert_eq!(p.scale, 1.0, "{scene}: {} paths", p.paths);
    }
    // A glossy scene made light: few glossy points, and no diffuse ones to speak of.
    let light = ["glossy_points=200", "diffuse_points=100"];
    let raw = plan("glossy", &[&light[..], &["path_floor=0"]].concat());
    let raised = plan("glossy", &light);
    println!(
        "glossy with 200 glossy points: {:.2}M paths, raised to {:.2}M (scale {:.2}; floor {:.0}M)",
        raw.paths as f64 / 1e6,
        raised.paths as f64 / 1e6,
        raised.scale,
        DEFAULT_PATH_FLOOR as f64 / 1e6
    );
    assert!(raw.paths < DEFAULT_PATH_FLOOR && raw.scale == 1.0);
    assert!(raised.scale > 1.0 && raised.paths > raw.paths);
    assert!(raised.paths as f64 <= DEFAULT_PATH_FLOOR as f64 * 1.1, "{} paths", raised.paths);
    assert_eq!(plan("glossy", &[&light[..], &["profile=paper"]].concat()).scale, 1.0);
}

/// A scene of spheres (x, base colour, roughness) on a grey floor under a white sky and a point
/// light, one material each.
/// `metals`: the indices of spheres with metallic 1.
fn spheres(spheres: &[(f32, [f32; 3], f32)], metals: &[usize]) -> glimpse_scene::Scene {
    let mut toml = String::from(
        "[camera]\nposition = [0.0, 1.0, 3.0]\ntarget = [0.0, 0.3, 0.0]\n[environment]\nconstant = [1.0, 1.0, 1.0]\n\
         [[light]]\nkind = \"point\"\nposition = [1.0, 2.0, 1.0]\nintensity = 3.0\n\
         [[quad]]\nsize = [4.0, 4.0]\nmaterial = { base_color = [0.5, 0.5, 0.5], roughness = 1.0 }\n",
    );
    for (i, (x, c, r)) in spheres.iter().enumerate() {
        let m = if metals.contains(&i) { 1.0 } else { 0.0 };
        toml += &format!(
            "[[sphere]]\nradius = 0.3\nsegments = 16\ntranslate = [{x}, 0.3, 0.0]\nmaterial = {{ base_color = {c:?}, roughness = {r}, metallic = {m} }}\n"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    glimpse_scene::load(path.to_str().unwrap()).unwrap()
}

/// Small BRDF tables and caches for the sharing tests.
fn small_tables() -> WavecacheParams {
    WavecacheParams {
        brdf_grid_u1: 8,
        brdf_grid_u2: 16,
        brdf_res: 8,
        brdf_strata: 1,
        diffuse_points: 64,
        glossy_points: 32,
        irradiance_samples: 16,
        texel_samples: 1,
        ..WavecacheParams::default()
    }
}

/// Materials with equal BRDF parameters share one tabulated BRDF (real scenes repeat a material
/// under many names: `scenes/extra/forest`'s 400 placements tabulated 400 tables, 9 GiB); a
/// material that differs in any parameter gets its own, and the images are the same as with
/// one table per material (the shared headers point at the same trees).
#[test]
fn equal_materials_share_their_brdf_table() {
    use glimpse_render::FrameContext;
    use glimpse_wavecache::cache::WaveCache;
    let orange = [0.8, 0.4, 0.2];
    let scene = spheres(&[(-0.8, orange, 0.3), (0.0, orange, 0.3), (0.8, orange, 0.4)], &[]);
    assert_eq!(scene.materials.len(), 4, "one material per placement");
    let ctx = FrameContext::new(&scene, 0.0, 8, 8);
    let p = small_tables();
    assert_eq!(WaveCache::brdf_table_count(&ctx.frame, &p), 2, "roughness 0.3 twice, 0.4 once");
    let cache = WaveCache::build(&ctx.frame, &ctx.tracer, &p, 1, 0, &|_| {}).unwrap();
    let glossy: Vec<usize> = (0..4).filter(|&m| scene.materials[m].roughness < 0.5 && scene.materials[m].roughness > 0.0).collect();
    let t = |m: usize| cache.brdf_tables[m];
    println!("glossy materials {glossy:?}: tables {:?}", glossy.iter().map(|&m| t(m)).collect::<Vec<_>>());
    assert_eq!(glossy.len(), 3);
    assert_eq!(t(glossy[0]), t(glossy[1]), "equal materials share one table");
    assert_ne!(t(glossy[0]).first_tree, t(glossy[2]).first_tree, "a different roughness has its own");
    assert_eq!(cache.brdf_trees.len() as u64, 2 * (p.brdf_grid_u1 * p.brdf_grid_u2) as u64, "two tables' trees, not three");
}

/// Where one table per colour would pass `brdf_max_tables`, materials whose BRDFs differ only
/// in base colour share a white and a black table, which blend to any colour exactly (the BRDF
/// is affine in it): `scenes/extra/forest`'s 400 heads in 6 colours and many roughnesses
/// tabulated one table per colour and roughness (180, 5 GiB). A BRDF of one colour keeps its
/// own single table, and under the limit every material does (one product per point, not two).
/// The shared tables shade as the material's own table does: a cache whose shared material is
/// given its own table renders the same image.
#[test]
fn other_colours_share_white_and_black_tables() {
    use glimpse_render::FrameContext;
    use glimpse_wavecache::brdf::{self, MaterialBrdf};
    use glimpse_wavecache::cache::{BrdfPlan, TablePlan, WaveCache};
    use glimpse_wavecache::technique::{Runtime, ShadePoint};
    let (orange, blue, green) = ([0.8, 0.4, 0.2], [0.1, 0.3, 0.9], [0.2, 0.7, 0.3]);
    let scene = spheres(&[(-0.8, orange, 0.3), (0.0, blue, 0.3), (0.8, orange, 0.4), (1.6, green, 0.3)], &[]);
    let ctx = FrameContext::new(&scene, 0.0, 64, 48);
    let by_colour = |c: [f32; 3], r: f32| scene.materials.iter().position(|m| m.base_color.to_array() == c && m.roughness == r).unwrap();
    let (orange, blue, orange_rough) = (by_colour(orange, 0.3), by_colour(blue, 0.3), by_colour(orange, 0.4));
    let roomy = WavecacheParams { brdf_beta_scale: 0.0, ..small_tables() };
    let own_tables = BrdfPlan::new(&ctx.frame, &roomy);
    assert!(own_tables.tables.iter().flatten().all(|&t| t == TablePlan::Own), "under the limit: one table per colour");
    assert_eq!(own_tables.table_count(&ctx.frame, &roomy), 4);
    let p = WavecacheParams { brdf_max_tables: 3, ..roomy };
    let plans = BrdfPlan::new(&ctx.frame, &p).tables;
    assert_eq!(plans[orange], Some(TablePlan::WhiteAndBlack));
    assert_eq!(plans[blue], Some(TablePlan::WhiteAndBlack));
    assert_eq!(plans[orange_rough], Some(TablePlan::Own), "the only colour of its roughness");
    assert_eq!(WaveCache::brdf_table_count(&ctx.frame, &p), 3, "white and black at 0.3, orange at 0.4");
    let shared = WaveCache::build(&ctx.frame, &ctx.tracer, &p, 1, 0, &|_| {}).unwrap();
    assert_eq!(shared.brdf_tables[orange], shared.brdf_tables[blue], "the two colours read one white table");
    assert_eq!(shared.brdf_trees.len() as u64, 3 * (p.brdf_grid_u1 * p.brdf_grid_u2) as u64);

    // The same cache with the blue material's own table.
    let mut own = shared.clone();
    let m = &scene.materials[blue];
    own.brdf_tables[blue] = brdf::tabulate(
        &MaterialBrdf::pbr(m.base_color, m.metallic, m.roughness),
        p.brdf_grid_u1,
        p.brdf_grid_u2,
        p.brdf_res,
        p.brdf_strata,
        0.0,
        &mut own.brdf_nodes,
        &mut own.brdf_trees,
        &|_| {},
    );
    own.brdf_black[blue] = Default::default();
    own.brdf_base[blue] = m.base_color.to_array();
    let g = ctx.gbuffer();
    let shade = |cache: &WaveCache| -> Vec<glimpse_core::Vec3> {
        let rt = Runtime::new(cache, &p, &ctx.frame, &ctx.tracer);
        (0..g.position.len())
            .filter(|&i| g.material[i] == blue as u32 && g.instance[i] != glimpse_trace::gbuffer::NO_HIT)
            .map(|i| rt.cached(&ShadePoint::at_pixel(&g, i), -g.view_dir[i]))
            .collect()
    };
    let (a, b) = (shade(&shared), shade(&own));
    assert!(a.len() > 20, "the blue sphere covers {} pixels", a.len());
    let worst = a.iter().zip(&b).map(|(x, y)| (*x - *y).abs().max_element() / y.max_element().max(1e-3)).fold(0.0f32, f32::max);
    let mean = b.iter().map(|v| v.max_element()).sum::<f32>() / b.len() as f32;
    println!("blue sphere: {} pixels, mean {mean:.4}, worst relative difference shared vs own table {worst:.2e}", a.len());
    assert!(mean > 0.01, "the sphere is lit");
    assert!(worst < 2e-2, "white and black tables blend to the material's own table (fp16 trees)");
}

/// A scene of more distinct roughnesses than `brdf_max_tables` allows snaps them to fewer
/// levels over their range (each moves by at most half a step), tabulates no more tables than
/// the limit, and says by how much; `brdf_max_tables=0` keeps every roughness.
#[test]
fn many_roughnesses_snap_to_the_table_limit() {
    use glimpse_render::FrameContext;
    use glimpse_wavecache::cache::{BrdfPlan, WaveCache};
    let colours = [[0.8, 0.4, 0.2], [0.1, 0.3, 0.9]];
    let placed: Vec<(f32, [f32; 3], f32)> = (0..12).map(|i| (i as f32 * 0.2 - 1.2, colours[i % 2], 0.2 + 0.02 * i as f32)).collect();
    let scene = spheres(&placed, &[]);
    let ctx = FrameContext::new(&scene, 0.0, 8, 8);
    let unlimited = WavecacheParams { brdf_max_tables: 0, ..small_tables() };
    let free = BrdfPlan::new(&ctx.frame, &unlimited);
    assert_eq!(free.table_count(&ctx.frame, &unlimited), 12, "12 roughnesses of one colour each");
    assert_eq!(free.max_snap(&ctx.frame), 0.0);
    let p = WavecacheParams { brdf_max_tables: 8, ..small_tables() };
    let plan = BrdfPlan::new(&ctx.frame, &p);
    let (count, snap) = (plan.table_count(&ctx.frame, &p), plan.max_snap(&ctx.frame));
    let levels: std::collections::BTreeSet<u32> =
        plan.roughness.iter().zip(&plan.tables).filter(|(_, t)| t.is_some()).map(|(r, _)| r.to_bits()).collect();
    println!("brdf_max_tables 8: {count} tables, {} roughness levels, snapped by up to {snap:.4}", levels.len());
    assert!(count <= 8, "{count} tables over the limit");
    assert_eq!(levels.len(), 4, "8 tables: 4 levels of white and black");
    let step = 0.22 / 3.0;
    assert!(snap > 0.0 && snap <= step / 2.0 + 1e-6, "snapped by {snap}, half a step is {}", step / 2.0);
    let cache = WaveCache::build(&ctx.frame, &ctx.tracer, &p, 1, 0, &|_| {}).unwrap();
    assert_eq!(cache.brdf_trees.len() as u64, count * (p.brdf_grid_u1 * p.brdf_grid_u2) as u64, "the build tabulates the plan");
    // Metals beside dielectrics: each level is tabulated for both, so half the levels.
    let mixed = spheres(&placed, &[0, 3, 6, 9]);
    let ctx = FrameContext::new(&mixed, 0.0, 8, 8);
    let plan = BrdfPlan::new(&ctx.frame, &p);
    let count = plan.table_count(&ctx.frame, &p);
    println!("with metals: {count} tables, snapped by up to {:.4}", plan.max_snap(&ctx.frame));
    assert!(count <= 8, "{count} tables over the limit with metals");
}

/// The table limit is also a bound in bytes: no table can pass [`BrdfPlan::max_table_bytes`]
/// (every tree full), and a finer resolution allows fewer tables, so the tables stay under
/// `BRDF_TABLES_MAX_BYTES` whatever `brdf_res` and the ω_o grid are.
#[test]
fn the_table_limit_bounds_the_tables_bytes() {
    use glimpse_render::FrameContext;
    use glimpse_wavecache::BRDF_TABLES_MAX_BYTES;
    use glimpse_wavecache::cache::{BrdfPlan, WaveCache};
    let defaults = WavecacheParams::default();
    let (bytes, max) = (BrdfPlan::max_table_bytes(&defaults), BrdfPlan::max_tables(&defaults));
    println!("defaults: a table is at most {:.1} MB, {max} tables", bytes as f64 / 1e6);
    assert_eq!(max, defaults.brdf_max_tables as u64, "brdf_max_tables binds at the defaults");
    assert!(max * bytes <= BRDF_TABLES_MAX_BYTES);
    // A smooth dielectric and a rough metal, each tabulated: under the bound.
    let placed = [(-0.6, [0.8, 0.4, 0.2], 0.02), (0.6, [0.5, 0.5, 0.5], 0.6)];
    let scene = spheres(&placed, &[1]);
    let ctx = FrameContext::new(&scene, 0.0, 8, 8);
    let p = small_tables();
    let cache = WaveCache::build(&ctx.frame, &ctx.tracer, &p, 1, 0, &|_| {}).unwrap();
    let (tables, bound) = (cache.brdf_tables.len().max(1) as u64, BrdfPlan::max_table_bytes(&p));
    println!("{} bytes of BRDF tables for 2 materials, {bound} at most each", cache.brdf_bytes());
    assert!(cache.brdf_bytes() as u64 <= 2 * bound, "{} bytes for 2 tables", cache.brdf_bytes());
    assert!(tables >= 2);
    // 128² maps: a table may take 626 MB, so 6 fit, and 12 roughnesses snap to 3 levels.
    let fine = WavecacheParams { brdf_res: 128, ..defaults };
    assert_eq!(BrdfPlan::max_tables(&fine), 6);
    let placed: Vec<(f32, [f32; 3], f32)> = (0..12).map(|i| (i as f32 * 0.2 - 1.2, [0.8, 0.4, 0.2], 0.2 + 0.02 * i as f32)).collect();
    let scene = spheres(&placed, &[]);
    let ctx = FrameContext::new(&scene, 0.0, 8, 8);
    let plan = BrdfPlan::new(&ctx.frame, &fine);
    let count = plan.table_count(&ctx.frame, &fine);
    println!("brdf_res 128: {count} tables, snapped by up to {:.4}", plan.max_snap(&ctx.frame));
    assert!(count <= 6 && plan.max_snap(&ctx.frame) > 0.0, "{count} tables");
    // brdf_max_tables=0 (the paper's profile) lifts both limits.
    assert_eq!(BrdfPlan::max_tables(&WavecacheParams { brdf_max_tables: 0, ..fine }), 0);
}

/// A glossy mesh gets at least enough points for its curvature (`curvature_deg`): its normals'
/// coverage of the sphere of directions / (π θ²), 33 for a sphere at 20°, where sharing the
/// budget by area gave it 16 (`scenes/extra/gallery`'s spheres, 28° apart: highlights twice
/// too bright); a flat mesh covers one cell of directions and keeps the area's share.
#[test]
fn curved_glossy_meshes_get_points_for_their_curvature() {
    use glimpse_wavecache::bake::world_mesh;
    let scene = spheres(&[(-0.8, [0.8, 0.4, 0.2], 0.3), (0.0, [0.1, 0.3, 0.9], 0.3)], &[]);
    let frame = scene.at(0.0);
    let sphere = (0..scene.instances.len()).find(|&i| world_mesh(&frame, i).triangles.len() > 2).unwrap();
    let floor = (0..scene.instances.len()).find(|&i| world_mesh(&frame, i).triangles.len() == 2).unwrap();
    let (cs, cf) = (world_mesh(&frame, sphere).normal_coverage(), world_mesh(&frame, floor).normal_coverage());
    println!("normal coverage: sphere {cs:.2} sr, floor {cf:.4} sr");
    assert!((cs - 4.0 * std::f32::consts::PI).abs() < 0.5, "a sphere's normals cover every direction");
    assert!(cf < 0.03, "a plane's normals are one direction");
    let points = |curvature_deg: f32| {
        let p = WavecacheParams { curvature_deg, path_floor: 0, path_budget: 0, ..small_tables() };
        let (classes, areas) = classes_and_areas(&frame, &p);
        plan_points(&frame, &p, &classes, &areas).points[sphere]
    };
    let (flat, curved) = (points(0.0), points(WavecacheParams::default().curvature_deg));
    println!("sphere points: {flat} by area, {curved} at the default 20°");
    assert_eq!(flat, 16, "the area's share (16 each) or min_points");
    assert!((31..=36).contains(&curved), "{curved} points for a sphere at 20°");
    // The tuned scenes' curved glossy meshes already had more: their plans are unchanged.
    let root = env!("CARGO_MANIFEST_DIR");
    let bunny = format!("{root}/scenes/bunny-glossy.toml");
    let shared = std::path::Path::new(root).join("../../../shared/scenes/stanford-bunny").exists();
    for tuned in ["glossy"].into_iter().chain(shared.then_some(bunny.as_str())) {
        assert_eq!(plan(tuned, &["curvature_deg=0"]).points, plan(tuned, &[]).points, "{tuned}'s plan changed");
    }
}
