//! The CPU acceptance checks 1–15 of `shared/specs/roma.md` §12. Each prints what it measured
//! before asserting. Thresholds marked [OURS] in the spec are ours, not the paper's (the paper
//! gives no per-ray accuracy numbers).

use glimpse_core::sampling::{cosine_hemisphere, uniform_sphere, uniform_triangle};
use glimpse_core::{Aabb, Frame, Image, Mat4, Ray, Rng, Vec2, Vec3};
use glimpse_render::ao::AoExact;
use glimpse_render::direct::area_light_segment;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_roma::directions::{CandidateSet, hemisphere_to_square, square_to_hemisphere};
use glimpse_roma::generate::generate_map;
use glimpse_roma::grid::{BOM_AXES, Grid, om_axes};
use glimpse_roma::occupancy::{OccupancyMap, Voxelization, voxelize};
use glimpse_roma::technique::{AoRoma, shadow_blocked};
use glimpse_roma::trace::{any_hit, closest_hit_slices, range_bits};
use glimpse_roma::{Roma, RomaParams, Word, with_maps};
use glimpse_scene::{Light, Material, Mesh, Scene};
use glimpse_trace::{ExactTracer, GBuffer};
use std::f32::consts::PI;

// ---------------------------------------------------------------------------------------------
// Helpers

fn random_word<W: Word>(rng: &mut Rng) -> W {
    let v = (rng.next_u32() as u128) | (rng.next_u32() as u128) << 32 | (rng.next_u32() as u128) << 64 | (rng.next_u32() as u128) << 96;
    // Vary the density so that sparse words (few bits) are common too.
    let mask = match rng.below(4) {
        0 => (rng.next_u32() as u128) << 64 | rng.next_u32() as u128,
        1 => !0u128,
        _ => (rng.next_u32() as u128 & rng.next_u32() as u128 & rng.next_u32() as u128).rotate_left(rng.below(128)),
    };
    W::from_u128(v & mask)
}

fn random_bom<W: Word>(seed: u64) -> OccupancyMap<W> {
    let mut rng = Rng::new(seed, 7);
    OccupancyMap { words: (0..W::BITS * W::BITS).map(|_| random_word::<W>(&mut rng)).collect() }
}

fn mesh_scene(name: &str, meshes: Vec<Mesh>) -> Scene {
    let mut s = Scene { name: name.into(), ..Default::default() };
    let m = s.add_material(Material::diffuse("white", Vec3::splat(0.7)));
    for mut mesh in meshes {
        mesh.material = m;
        s.add_mesh(mesh, Mat4::IDENTITY);
    }
    s
}

fn quad(name: &str, corners: [Vec3; 4]) -> Mesh {
    Mesh { name: name.into(), positions: corners.to_vec(), indices: vec![[0, 1, 2], [0, 2, 3]], ..Default::default() }
}

fn sphere(center: Vec3, radius: f32, rings: u32, segments: u32) -> Mesh {
    let mut m = glimpse_scene::builtin::sphere_mesh("sphere", 0, rings, segments);
    m.positions.iter_mut().for_each(|p| *p = center + *p * radius);
    m
}

/// Twelve spheres of various sizes on a ground quad.
fn sphere_field() -> Scene {
    let mut rng = Rng::new(11, 3);
    let mut meshes =
        vec![quad("ground", [Vec3::new(-2.0, 0.0, -2.0), Vec3::new(-2.0, 0.0, 2.0), Vec3::new(2.0, 0.0, 2.0), Vec3::new(2.0, 0.0, -2.0)])];
    for _ in 0..12 {
        let r = 0.1 + 0.35 * rng.next_f32();
        let c = Vec3::new(rng.next_f32() * 3.2 - 1.6, r + rng.next_f32() * 0.3, rng.next_f32() * 3.2 - 1.6);
        meshes.push(sphere(c, r, 16, 24));
    }
    let mut s = mesh_scene("sphere-field", meshes);
    s.camera = Some(glimpse_scene::Camera::look_at(Vec3::new(0.0, 2.2, 4.0), Vec3::new(0.0, 0.2, 0.0), Vec3::Y, 50.0));
    s
}

/// The Stanford bunny from the shared scenes, if the OBJ loader can read it.
fn bunny() -> Option<Scene> {
    match glimpse_scene::load("/work/shared/scenes/stanford-bunny/stanford-bunny.obj") {
        Ok(s) => Some(s),
        Err(e) => {
            println!("(bunny not loaded: {e})");
            None
        }
    }
}

fn build(scene: &Scene, params: RomaParams, frame_index: u32) -> Roma {
    Roma::build(&scene.at(0.0), &params, 1, frame_index)
}

/// Brute-force range: occupied slices of `u` in [lo, hi], slice j at bit (hi − j).
fn brute_range<W: Word>(u: W, lo: u32, hi: u32) -> W {
    let mut out = W::ZERO;
    for j in lo..=hi {
        if u.has_slice(j) {
            out |= W::ONE << (hi - j);
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// 1–2: Alg. 2 on single words

fn trace_semantics<W: Word>(cases: &mut u64, closest_ok: &mut u64) {
    let b = W::BITS;
    let mut rng = Rng::new(b as u64, 1);
    for _ in 0..300 {
        let u: W = random_word(&mut rng);
        for t_start in 0..b {
            // Both directions to the end of the volume, and a random finite end slice.
            let finite = rng.below(b);
            for t_end in [b - 1, 0, finite] {
                let (lo, hi) = (t_start.min(t_end), t_start.max(t_end));
                let ur = range_bits(u, t_start, t_end);
                assert_eq!(ur, brute_range(u, lo, hi), "B={b} U={u:?} t_start={t_start} t_end={t_end}");
                let occupied: Vec<u32> = (lo..=hi).filter(|&j| u.has_slice(j)).collect();
                assert_eq!(any_hit(ur), !occupied.is_empty());
                // ClosestHit: towards +z when t_end ≥ t_start (and for the finite end, either way).
                let directions: &[bool] = if t_end > t_start {
                    &[true]
                } else if t_end < t_start {
                    &[false]
                } else {
                    &[true, false]
                };
                for &plus in directions {
                    let expected = if plus { occupied.first().map(|&j| j as f32 + 0.5) } else { occupied.last().map(|&j| j as f32 + 1.0) };
                    let got = closest_hit_slices(ur, hi, plus);
                    *closest_ok += (got == expected) as u64;
                    assert_eq!(got, expected, "B={b} U={u:?} range [{lo},{hi}] plus={plus}");
                }
                *cases += 1;
            }
        }
    }
}

#[test]
fn check_01_trace_range_semantics() {
    let (mut cases, mut ok) = (0, 0);
    trace_semantics::<u32>(&mut cases, &mut ok);
    trace_semantics::<u64>(&mut cases, &mut ok);
    trace_semantics::<u128>(&mut cases, &mut ok);
    println!("check 1: {cases} (word, t_start, t_end) cases over B = 32, 64, 128: U_result and AnyHit equal the brute force in 100%");
}

#[test]
fn check_02_closest_hit_formulas() {
    let (mut cases, mut ok) = (0, 0);
    trace_semantics::<u32>(&mut cases, &mut ok);
    trace_semantics::<u64>(&mut cases, &mut ok);
    trace_semantics::<u128>(&mut cases, &mut ok);
    println!("check 2: ClosestHit = j_min + 0.5 (+z) / j_max + 1 (−z) in {ok} of {ok} direction cases");
    // Regression: 0x7FFFFFFF (slice 0 empty, slices 1..31 occupied) → 1.5 with integer clz;
    // the paper's float log2 gives floor(log2(2^31 − 1 as f32)) = 31 → 0.5, one slice too near.
    let u = 0x7FFF_FFFFu32;
    let got = closest_hit_slices(range_bits(u, 0, 31), 31, true);
    let float_log2 = 32.0 - (u as f32).log2().floor() - 0.5;
    println!("  U = 0x7FFFFFFF: integer clz gives {got:?}, float log2 would give {float_log2}");
    assert_eq!(got, Some(1.5));
    assert_eq!(float_log2, 0.5, "the erratum this guards against");
    // Slice 0 occupied (the sign bit): a signed `U > 0` would report a miss.
    for (u, name) in [(0x8000_0000u32, "0x80000000"), (0xFFFF_FFFF, "0xFFFFFFFF")] {
        let ur = range_bits(u, 0, 31);
        println!(
            "  U = {name}: AnyHit {}, ClosestHit(+z) {:?}, as i32 {} (> 0: {})",
            any_hit(ur),
            closest_hit_slices(ur, 31, true),
            ur as i32,
            (ur as i32) > 0
        );
        assert!(any_hit(ur));
        assert_eq!(closest_hit_slices(ur, 31, true), Some(0.5));
    }
    assert_eq!(closest_hit_slices(range_bits(1u128, 127, 0), 127, false), Some(128.0));
}

// ---------------------------------------------------------------------------------------------
// 3–5: Generate

#[test]
fn check_03_generate_identity() {
    fn run<W: Word>() -> usize {
        let bom = random_bom::<W>(3);
        let out = generate_map(&bom, &BOM_AXES);
        let differing = out.words.iter().zip(&bom.words).filter(|(a, b)| a != b).count();
        println!("check 3: B = {}: Generate with the BOM's own matrix: {differing} of {} texels differ", W::BITS, bom.words.len());
        differing
    }
    assert_eq!(run::<u32>() + run::<u64>() + run::<u128>(), 0);
}

#[test]
fn check_04_generate_axis_permutations() {
    fn run<W: Word>() -> usize {
        let r = W::BITS;
        let bom = random_bom::<W>(4);
        let mut wrong = 0;
        for d in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
            let axes = om_axes(d);
            let out = generate_map(&bom, &axes);
            // The exact integer permutation: BOM component c comes from the local axis l with
            // axes[l][c] = ±1, mirrored when −1.
            let cols = [axes.x, axes.y, axes.z];
            for y in 0..r {
                for x in 0..r {
                    for i in 0..r {
                        let local = [x, y, i];
                        let mut cell = [0u32; 3];
                        for (c, slot) in cell.iter_mut().enumerate() {
                            let l = (0..3).find(|&l| cols[l][c].abs() > 0.5).unwrap();
                            *slot = if cols[l][c] > 0.0 { local[l] } else { r - 1 - local[l] };
                        }
                        wrong += (out.get(x, y, i) != bom.get(cell[0], cell[1], cell[2])) as usize;
                    }
                }
            }
        }
        println!("check 4: B = {r}: OMs along ±x, ±y, ±z vs the integer permutation of the BOM: {wrong} of {} cells differ", 6 * r * r * r);
        wrong
    }
    assert_eq!(run::<u32>() + run::<u64>() + run::<u128>(), 0);
}

#[test]
fn check_05_generate_is_nearest_neighbour_resampling() {
    let scene = glimpse_scene::load("cornell").unwrap();
    let frame = scene.at(0.0);
    let grid = Grid::around(frame.bounds, 64, Vec3::new(0.21, -0.13, 0.37));
    let bom = voxelize::<u64>(&frame.world_triangles(), &grid, Voxelization::Conservative);
    let mut rng = Rng::new(5, 5);
    let (mut cells, mut mismatches, mut set) = (0u64, 0u64, 0u64);
    for _ in 0..12 {
        let axes = om_axes(uniform_sphere(rng.next_2d()));
        let out = generate_map(&bom, &axes);
        for y in 0..64 {
            for x in 0..64 {
                for i in 0..64 {
                    let world = grid.from_map_cells(&axes, Vec3::new(x as f32 + 0.5, y as f32 + 0.5, i as f32 + 0.5));
                    let expected = bom.get_at(grid.to_cells(world));
                    mismatches += (out.get(x, y, i) != expected) as u64;
                    set += expected as u64;
                    cells += 1;
                }
            }
        }
    }
    println!(
        "check 5: 12 random directions, {cells} aligned cells ({set} occupied): {mismatches} differ from the BOM cell at their world centre ({:.5}%; floating-point ties on cell boundaries)",
        100.0 * mismatches as f64 / cells as f64
    );
    assert!(mismatches as f64 <= 1e-4 * cells as f64);
}

// ---------------------------------------------------------------------------------------------
// 6: snapped tracing = marching the column

#[test]
fn check_06_snapped_trace_equals_column_march() {
    let scene = sphere_field();
    let params = RomaParams { resolution: 64, ..Default::default() };
    let roma = build(&scene, params, 0);
    let Roma::R64(m) = &roma else { unreachable!("resolution 64") };
    let grid = m.grid;
    let mut rng = Rng::new(6, 6);
    let (mut rays, mut any_ok, mut closest_ok) = (0u64, 0u64, 0u64);
    for _ in 0..40_000 {
        let k = rng.below(m.candidates.len() as u32) as usize;
        let sign = if rng.below(2) == 0 { 1.0 } else { -1.0 };
        let q = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 64.0;
        let origin = grid.from_map_cells(&m.axes[k], q);
        let t_max = if rng.below(3) == 0 { f32::INFINITY } else { rng.next_f32() * 70.0 * grid.cell_size_world };
        // Independent march along the column of the origin's texel.
        let (x, y) = (q.x as u32, q.y as u32);
        let z0 = q.z as i32;
        let z_end = if t_max.is_finite() {
            (q.z + sign * t_max / grid.cell_size_world).floor().clamp(0.0, 63.0) as i32
        } else if sign > 0.0 {
            63
        } else {
            0
        };
        let step = if sign > 0.0 { 1 } else { -1 };
        let mut first = None;
        let mut j = z0;
        loop {
            if m.word(k, x, y).has_slice(j as u32) {
                first = Some(j);
                break;
            }
            if j == z_end {
                break;
            }
            j += step;
        }
        let hit = m.any_hit_snapped(k, sign, origin, t_max);
        any_ok += (hit == first.is_some()) as u64;
        let expected_t = first.map(|j| {
            let z_hit = if sign > 0.0 { j as f32 + 0.5 } else { j as f32 + 1.0 };
            ((z_hit - q.z) * sign).max(0.0) * grid.cell_size_world
        });
        let got = m.closest_hit_snapped(k, sign, origin, t_max);
        let same = match (got, expected_t) {
            (None, None) => true,
            (Some(a), Some(b)) => (a - b).abs() <= 1e-3 * grid.cell_size_world,
            _ => false,
        };
        closest_ok += same as u64;
        rays += 1;
    }
    println!(
        "check 6: {rays} snapped rays on OMs of the sphere field (64³, 4²): any-hit agrees {any_ok}/{rays}, closest-hit {closest_ok}/{rays} with the column march"
    );
    assert_eq!((any_ok, closest_ok), (rays, rays));
}

// ---------------------------------------------------------------------------------------------
// 7: strata

#[test]
fn check_07_stratum_selection() {
    for n in [4u32, 8] {
        let set = CandidateSet::draw(n, &mut Rng::new(7, n as u64), true);
        // (a) Area per stratum: midpoint rule on the hemisphere's equal-area (z, φ) grid.
        let grid_n = 500 * n;
        let mut counts = vec![0u64; (n * n) as usize];
        for i in 0..grid_n {
            let z = (i as f32 + 0.5) / grid_n as f32;
            let s = (1.0 - z * z).sqrt();
            for j in 0..grid_n {
                let phi = 2.0 * PI * (j as f32 + 0.5) / grid_n as f32;
                let u = hemisphere_to_square(Vec3::new(s * phi.cos(), s * phi.sin(), z));
                let (a, b) = (((u.x * n as f32) as u32).min(n - 1), ((u.y * n as f32) as u32).min(n - 1));
                counts[(a * n + b) as usize] += 1;
            }
        }
        let expected = 2.0 * PI as f64 / (n * n) as f64;
        let worst =
            counts.iter().map(|&c| ((c as f64 / (grid_n * grid_n) as f64 * 2.0 * PI as f64) / expected - 1.0).abs()).fold(0.0, f64::max);
        println!("check 7: n = {n}: every stratum covers 2π/n² = {expected:.5} sr within {:.2e} relative", worst);
        assert!(worst < 1e-3);

        // (b) The selected candidate is the ray's own stratum's; (c) how close it is.
        let mut rng = Rng::new(77, n as u64);
        let (mut own, mut boundary, mut total, mut not_nearest) = (0u64, 0u64, 0u64, 0u64);
        let (mut max_angle, mut sum_angle) = (0.0f32, 0.0f64);
        for _ in 0..200_000 {
            let (a, b) = (rng.below(n), rng.below(n));
            let u = Vec2::new((a as f32 + rng.next_f32()) / n as f32, (b as f32 + rng.next_f32()) / n as f32);
            let flip = rng.below(2) == 1;
            let local = square_to_hemisphere(u);
            let d = set.hemisphere.to_world(local).normalize() * if flip { -1.0 } else { 1.0 };
            let (k, sign) = set.select(d);
            total += 1;
            // Points within 1e-5 of a stratum edge may round into the neighbour.
            let edge = (u * n as f32 - (u * n as f32).round()).abs().min_element() < 1e-4 * n as f32;
            if k == (a * n + b) as usize && (sign < 0.0) == flip {
                own += 1;
            } else {
                assert!(edge, "u = {u} selected stratum {k}, expected {}", a * n + b);
                boundary += 1;
            }
            let snapped = set.dirs[k] * sign;
            let angle = snapped.dot(d).clamp(-1.0, 1.0).acos();
            max_angle = max_angle.max(angle);
            sum_angle += angle as f64;
            let best = set.dirs.iter().flat_map(|&c| [c, -c]).map(|c| c.dot(d)).fold(f32::MIN, f32::max);
            not_nearest += (snapped.dot(d) < best - 1e-6) as u64;
        }
        println!(
            "  {own}/{total} rays select their own stratum ({boundary} on stratum edges); angle to the candidate: mean {:.2}°, max {:.2}°; not the argmax-dot candidate in {:.2}%",
            (sum_angle / total as f64).to_degrees(),
            max_angle.to_degrees(),
            100.0 * not_nearest as f64 / total as f64
        );
        assert!(boundary as f64 <= 1e-3 * total as f64);
    }
}

/// 7b (ours): the batch path (`Visibility::occluded_batch`, stratum selection over SIMD lanes)
/// answers exactly as the per-ray path, ray for ray — including axis-aligned, polar and
/// zero-length directions, infinite and tiny `t_max`, origins outside the grid, and a batch
/// length that is not a multiple of the lane count.
#[test]
fn check_07b_batch_equals_per_ray() {
    use glimpse_trace::Visibility;
    let scene = glimpse_scene::builtin::cornell();
    let frame = scene.at(0.0);
    let mut rng = Rng::new(71, 0);
    let b = frame.bounds;
    let mut rays: Vec<(Ray, f32)> = (0..20_003)
        .map(|_| {
            let o = b.min + (b.max - b.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.2 - (b.max - b.min) * 0.1;
            let t = if rng.below(3) == 0 { f32::INFINITY } else { rng.next_f32() * (b.max - b.min).length() };
            (Ray::new(o, uniform_sphere(rng.next_2d())), t)
        })
        .collect();
    for d in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z, Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0).normalize()] {
        rays.push((Ray::new(b.center(), d), f32::INFINITY));
        rays.push((Ray::new(b.center(), d), 1e-6));
    }
    for r in [32u32, 64, 128] {
        for n in [4u32, 8] {
            let roma = Roma::build(&frame, &RomaParams { resolution: r, n, ..Default::default() }, 5, 0);
            let mut batch = vec![false; rays.len()];
            roma.occluded_batch(&rays, &mut batch);
            let differ = rays.iter().zip(&batch).filter(|((ray, t), o)| roma.occluded(ray, *t) != **o).count();
            let occluded = batch.iter().filter(|&&o| o).count();
            println!("check 7b: {r}³, n = {n}: {} rays, {occluded} occluded; batch ≠ per-ray for {differ}", rays.len());
            assert_eq!(differ, 0);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 8: storage

#[test]
fn check_08_storage() {
    let tri = vec![[Vec3::ZERO, Vec3::X, Vec3::Y]];
    let bounds = Aabb::new(Vec3::ZERO, Vec3::ONE);
    for (r, n) in [(32u32, 4u32), (64, 4), (128, 4), (128, 8)] {
        let roma = Roma::build_from_triangles(&tri, bounds, &RomaParams { resolution: r, n, ..Default::default() }, 0, 0);
        let maps = with_maps!(&roma, m => m.maps.len() * std::mem::size_of_val(&m.maps[0]));
        let formula = (n * n * r * r * r / 8) as usize;
        let df = (r * r * r * 2) as usize;
        println!(
            "check 8: {r}², {n}²: ROMA {maps} bytes = n²·R²·B/8 = {formula}; a {r}³ float16 DF: {df} bytes ({:.0}×)",
            maps as f64 / df as f64
        );
        assert_eq!(maps, formula);
        if (r, n) == (128, 4) {
            assert_eq!(maps, 4 << 20);
            assert_eq!(maps, df);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 9: BOM coverage

#[test]
fn check_09_bom_coverage() {
    let mut scenes = vec![glimpse_scene::load("cornell").unwrap(), sphere_field()];
    scenes.extend(bunny());
    for scene in &scenes {
        let frame = scene.at(0.0);
        let tris = frame.world_triangles();
        let grid = Grid::around(frame.bounds, 128, Vec3::new(0.1, 0.3, -0.2));
        let mut rng = Rng::new(9, 9);
        let points: Vec<Vec3> = tris
            .iter()
            .flat_map(|t| {
                let k = if tris.len() > 5000 { 2 } else { 200 };
                (0..k)
                    .map(|_| {
                        let b = uniform_triangle(rng.next_2d());
                        t[0] * (1.0 - b.x - b.y) + t[1] * b.x + t[2] * b.y
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let coverage = |mode| {
            let bom = voxelize::<u128>(&tris, &grid, mode);
            let inside = points.iter().filter(|p| bom.get_at(grid.to_cells(**p))).count();
            (inside as f64 / points.len() as f64, bom.count())
        };
        let (z_only, z_cells) = coverage(Voxelization::Sampled { axes: 0b100 });
        let (union, u_cells) = coverage(Voxelization::Sampled { axes: 0b111 });
        let (cons, c_cells) = coverage(Voxelization::Conservative);
        println!(
            "check 9: {}: {} points on {} triangles in occupied cells: z pass only {:.3}% ({z_cells} cells), x∪y∪z (paper) {:.3}% ({u_cells} cells), conservative {:.4}% ({c_cells} cells)",
            scene.name,
            points.len(),
            tris.len(),
            100.0 * z_only,
            100.0 * union,
            100.0 * cons
        );
        assert!(union > z_only, "the union must fix the z pass's steep-surface holes");
        assert!(cons >= 0.999, "[OURS] ≥ 99.9% coverage");
    }
}

// ---------------------------------------------------------------------------------------------
// 10–12: against exact rays

struct RayStudy {
    rays: u64,
    agree: u64,
    clear_rays: u64,
    clear_agree: u64,
    /// |t_roma − t_exact| in cells for rays that hit in both.
    distance_errors: Vec<f32>,
}

/// Snapped rays from the GBuffer points of `scene` (cosine around the shading normal, snapped,
/// origin 1.5 cells along the normal), ROMA against exact along the same snapped ray.
fn study(scene: &Scene, params: RomaParams, size: u32, per_pixel: u32) -> RayStudy {
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    let roma = Roma::build(&frame, &params, 3, 0);
    let cell = roma.cell_size_world();
    let g = GBuffer::new(&frame, &tracer, &scene.camera_or_default(1.0), size, size);
    let mut s = RayStudy { rays: 0, agree: 0, clear_rays: 0, clear_agree: 0, distance_errors: Vec::new() };
    for i in (0..g.len()).filter(|&i| g.is_hit(i)) {
        let origin = g.position[i] + g.normal[i] * (1.5 * cell);
        let basis = Frame::from_z(g.shading_normal[i]);
        let mut rng = Rng::for_pixel(3, i as u64, 0);
        for _ in 0..per_pixel {
            let (k, sign) = roma.select(basis.to_world(cosine_hemisphere(rng.next_2d())));
            let dir = roma.candidates().dirs[k] * sign;
            let exact = tracer.closest_hit(&Ray::new(origin, dir), f32::INFINITY);
            let occluded = roma.any_hit_snapped(k, sign, origin, f32::INFINITY);
            let ok = occluded == exact.is_some();
            s.rays += 1;
            s.agree += ok as u64;
            if exact.is_none_or(|h| h.t > 2.0 * cell) {
                s.clear_rays += 1;
                s.clear_agree += ok as u64;
            }
            if let (Some(h), Some(t)) = (exact, roma.closest_hit_snapped(k, sign, origin, f32::INFINITY)) {
                s.distance_errors.push((t - h.t).abs() / cell);
            }
        }
    }
    s
}

fn percentile(v: &mut [f32], p: f64) -> f32 {
    v.sort_by(f32::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn test_scenes() -> Vec<Scene> {
    let mut s = vec![glimpse_scene::load("cornell").unwrap(), sphere_field()];
    s.extend(bunny());
    s
}

#[test]
fn check_10_any_hit_vs_exact_on_the_snapped_ray() {
    for scene in test_scenes() {
        for voxelization in [Voxelization::PAPER, Voxelization::Conservative] {
            let s = study(&scene, RomaParams { voxelization, ..Default::default() }, 40, 4);
            let (all, clear) = (s.agree as f64 / s.rays as f64, s.clear_agree as f64 / s.clear_rays as f64);
            println!(
                "check 10: {} (128³, 4², {voxelization:?}): snapped any-hit agrees with exact any-hit on the same ray in {:.2}% of {} rays, {:.2}% of the {} whose exact hit is > 2 cells away (or that miss)",
                scene.name,
                100.0 * all,
                s.rays,
                100.0 * clear,
                s.clear_rays
            );
            if voxelization == RomaParams::default().voxelization {
                assert!(clear >= 0.95, "[OURS] ≥ 95% for rays with clearance > 2 cells");
            }
        }
    }
}

#[test]
fn check_11_closest_hit_distance_error() {
    for scene in test_scenes() {
        let mut s = study(&scene, RomaParams::default(), 40, 4);
        let e = &mut s.distance_errors;
        let mean = e.iter().sum::<f32>() / e.len() as f32;
        let (p50, p90, p99, max) = (percentile(e, 0.5), percentile(e, 0.9), percentile(e, 0.99), percentile(e, 1.0));
        let within = e.iter().filter(|&&x| x <= 1.0 + 3f32.sqrt()).count() as f64 / e.len() as f64;
        println!(
            "check 11: {}: |t_ROMA − t_exact| over {} rays hitting in both (cells): mean {mean:.2}, median {p50:.2}, p90 {p90:.2}, p99 {p99:.2}, max {max:.1}; {:.1}% within 1 + √3",
            scene.name,
            e.len(),
            100.0 * within
        );
        assert!(p50 <= 1.0 + 3f32.sqrt(), "[OURS] typical error about one cell plus the voxelization error");
    }
}

#[test]
fn check_12_self_occlusion() {
    // An isolated plane and an isolated sphere: every ray leaving them is unoccluded exactly.
    let plane = mesh_scene(
        "plane",
        vec![quad("p", [Vec3::new(-1.0, 0.0, -1.0), Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, -1.0)])],
    );
    let ball = mesh_scene("sphere", vec![sphere(Vec3::ZERO, 1.0, 48, 96)]);
    let bins = [0.0f32, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0];
    for (scene, voxelization) in [(&plane, Voxelization::Conservative), (&ball, Voxelization::Conservative), (&ball, Voxelization::PAPER)] {
        let mut false_occ = vec![(0u64, 0u64); bins.len() - 1];
        for frame_index in 0..4 {
            let roma = build(scene, RomaParams { voxelization, ..Default::default() }, frame_index);
            let cell = roma.cell_size_world();
            let mut rng = Rng::new(12, frame_index as u64);
            for _ in 0..40_000 {
                let (p, n) = if scene.name == "plane" {
                    (
                        Vec3::new(rng.next_f32() * 1.6 - 0.8, 0.0, rng.next_f32() * 1.6 - 0.8),
                        if rng.below(2) == 0 { Vec3::Y } else { -Vec3::Y },
                    )
                } else {
                    let n = uniform_sphere(rng.next_2d());
                    (n, n)
                };
                let d = Frame::from_z(n).to_world(cosine_hemisphere(rng.next_2d()));
                let (k, sign) = roma.select(d);
                let snapped = roma.candidates().dirs[k] * sign;
                let cos = snapped.dot(n);
                if cos <= 0.0 {
                    continue;
                }
                let bin = bins.windows(2).position(|w| cos >= w[0] && cos < w[1]).unwrap_or(bins.len() - 2);
                false_occ[bin].1 += 1;
                false_occ[bin].0 += roma.any_hit_snapped(k, sign, p + n * 1.5 * cell, f32::INFINITY) as u64;
            }
        }
        let line: Vec<String> = bins
            .windows(2)
            .zip(&false_occ)
            .map(|(w, (o, t))| format!("n·d∈[{:.2},{:.2}): {:.1}%", w[0], w[1], 100.0 * *o as f64 / (*t).max(1) as f64))
            .collect();
        println!("check 12: {} ({voxelization:?}) false occlusion after the 1.5-cell offset: {}", scene.name, line.join(", "));
        // A measurement (the paper admits over-darkening); only steep rays must be clean.
        let (o, t) = false_occ[5];
        assert!((o as f64) < 0.05 * t as f64, "rays with n·d ≥ 0.7 should leave the surface");
    }
}

// ---------------------------------------------------------------------------------------------
// 13: AO convergence over frames

fn mse(a: &Image, b: &Image) -> f64 {
    a.pixels.iter().zip(&b.pixels).map(|(p, q)| ((p.x - q.x) as f64).powi(2)).sum::<f64>() / a.pixels.len() as f64
}

/// MSE of `ao-roma` (`set`) against `reference` after each of `frames` accumulated frames.
fn ao_roma_errors(scene: &Scene, set: &[&str], spp: u32, frames: u32, reference: &Image, size: u32) -> Vec<f64> {
    let mut ctx = FrameContext::new(scene, 0.0, size, size);
    let g = ctx.gbuffer();
    let params = Params::parse(set).unwrap();
    let mut t = AoRoma::new(&Settings { spp, seed: 5 }, &params).unwrap();
    params.finish("ao-roma").unwrap();
    (0..frames)
        .map(|k| {
            ctx.frame_index = k;
            t.prepare(&ctx).unwrap();
            let mut img = ctx.image();
            t.render(&ctx, &g, &mut img).unwrap();
            mse(&img, reference)
        })
        .collect()
}

#[test]
fn check_13_ao_converges_over_frames() {
    let scene = glimpse_scene::load("cornell").unwrap();
    let size = 40;
    let ctx = FrameContext::new(&scene, 0.0, size, size);
    let mut reference = ctx.image();
    let mut exact = AoExact::new(&Settings { spp: 512, seed: 99 }, &Params::default()).unwrap();
    exact.render(&ctx, &ctx.gbuffer(), &mut reference).unwrap();

    let default = ao_roma_errors(&scene, &["accumulate=16"], 2, 16, &reference, size);
    println!(
        "check 13: cornell ao-roma (128², 4², 2 spp/frame) MSE vs ao-exact after K frames: K=1 {:.5}, K=4 {:.5}, K=16 {:.5}",
        default[0], default[3], default[15]
    );
    assert!(default[15] < default[3] && default[3] < default[0], "error decreases with accumulated frames");

    let n4 = ao_roma_errors(&scene, &["accumulate=16", "resolution=64", "n=4"], 2, 16, &reference, size);
    let n8 = ao_roma_errors(&scene, &["accumulate=16", "resolution=64", "n=8"], 2, 16, &reference, size);
    let r32 = ao_roma_errors(&scene, &["accumulate=16", "resolution=32"], 2, 16, &reference, size);
    println!("  after 16 frames: 64² 4²: {:.5}, 64² 8²: {:.5}; 32² 4²: {:.5}, 128² 4²: {:.5}", n4[15], n8[15], r32[15], default[15]);
    println!("  after 1 frame:   64² 4²: {:.5}, 64² 8²: {:.5}; 32² 4²: {:.5}, 128² 4²: {:.5}", n4[0], n8[0], r32[0], default[0]);
    assert!(n8[15] < n4[15], "8² below 4² (qualitatively as Fig. 9)");
    assert!(default[15] < r32[15], "128² below 32² (qualitatively as Fig. 9)");
}

// ---------------------------------------------------------------------------------------------
// 14: snapping policy

#[test]
fn check_14_snapping_policy() {
    // Soft shadows in the Cornell box (a small area light): wrong shadow decisions per sample.
    let scene = glimpse_scene::load("cornell").unwrap();
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    let g = GBuffer::new(&frame, &tracer, &scene.camera_or_default(1.0), 48, 48);
    let roma = Roma::build(&frame, &RomaParams { n: 8, ..Default::default() }, 14, 0);
    let offset = 1.5 * roma.cell_size_world();
    let (mut samples, mut wrong_snapped, mut wrong_dda, mut wrong_dda64) = (0u64, 0u64, 0u64, 0u64);
    for i in (0..g.len()).filter(|&i| g.is_hit(i) && g.emission[i] == Vec3::ZERO) {
        let s = glimpse_render::direct::Shading::from_gbuffer(&g, i).unwrap();
        let mut rng = Rng::for_pixel(14, i as u64, 0);
        for _ in 0..4 {
            let Some((ls, from, to)) = area_light_segment(&frame, &s, rng.next_f32(), rng.next_2d(), offset) else { continue };
            let exact = tracer.occluded(&ls.shadow, ls.t_max);
            samples += 1;
            wrong_snapped += (shadow_blocked(&roma, from, to, true, 8) != exact) as u64;
            wrong_dda += (shadow_blocked(&roma, from, to, false, 8) != exact) as u64;
            wrong_dda64 += (shadow_blocked(&roma, from, to, false, 64) != exact) as u64;
        }
    }
    let pct = |w: u64| 100.0 * w as f64 / samples as f64;
    println!(
        "check 14: cornell soft-shadow decisions (128², 8²) over {samples} samples: snapped wrong {:.2}%, un-snapped DDA ≤ 8 wrong {:.2}%, DDA ≤ 64 wrong {:.2}%",
        pct(wrong_snapped),
        pct(wrong_dda),
        pct(wrong_dda64)
    );
    assert!(wrong_dda < wrong_snapped, "un-snapped shadow rays are closer to exact than snapped ones");

    // AO: snapped vs un-snapped (DDA along the original direction, 256 steps), averaged over
    // frames (one frame's 16 candidates are shared by every pixel, so a single frame's mean is
    // noisy): the difference should be small (Fig. 8a).
    let (mut ao_snapped, mut ao_unsnapped, mut ao_exact, mut count) = (0.0f64, 0.0f64, 0.0f64, 0u64);
    for frame_index in 0..6 {
        let roma = Roma::build(&frame, &RomaParams::default(), 14, frame_index);
        let offset = 1.5 * roma.cell_size_world();
        for i in (0..g.len()).filter(|&i| g.is_hit(i)) {
            let origin = g.position[i] + g.normal[i] * offset;
            let basis = Frame::from_z(g.shading_normal[i]);
            let mut rng = Rng::for_pixel(15, i as u64, frame_index as u64);
            for _ in 0..2 {
                let d = basis.to_world(cosine_hemisphere(rng.next_2d()));
                let (k, sign) = roma.select(d);
                ao_snapped += !roma.any_hit_snapped(k, sign, origin, f32::INFINITY) as u32 as f64;
                let far = origin + d * (4.0 * roma.grid().half_extent_world());
                ao_unsnapped += !roma.any_hit_unsnapped(origin, far, 256) as u32 as f64;
                ao_exact += !tracer.occluded(&Ray::new(origin, d), f32::INFINITY) as u32 as f64;
                count += 1;
            }
        }
    }
    let (s, u, e) = (ao_snapped / count as f64, ao_unsnapped / count as f64, ao_exact / count as f64);
    println!(
        "  cornell mean AO over {count} rays in 6 frames: snapped {s:.4}, un-snapped {u:.4}, exact {e:.4} (snap − no-snap: {:+.4})",
        s - u
    );
    assert!((s - u).abs() < 0.03, "snapping is nearly free for AO (Fig. 8a)");
}

// ---------------------------------------------------------------------------------------------
// 15: hard-shadow leakage

#[test]
fn check_15_hard_shadow_leakage() {
    // A floor, a thin plate hovering `gap` cells above it, a point light above the plate.
    let base = mesh_scene(
        "leak",
        vec![quad("floor", [Vec3::new(-1.0, 0.0, -1.0), Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, -1.0)])],
    );
    let cell_probe = build(&base, RomaParams::default(), 0).cell_size_world();
    for gap_cells in [0.8f32, 4.0] {
        let mut scene = base.clone();
        let h = gap_cells * cell_probe;
        let plate = quad("plate", [Vec3::new(-0.4, h, -0.4), Vec3::new(-0.4, h, 0.4), Vec3::new(0.4, h, 0.4), Vec3::new(0.4, h, -0.4)]);
        scene.add_mesh(Mesh { material: 0, ..plate }, Mat4::IDENTITY);
        scene.lights.push(Light::point(Vec3::new(0.0, 0.8, 0.0), Vec3::ONE));
        let frame = scene.at(0.0);
        let tracer = ExactTracer::build(&frame);
        let (mut shadowed, mut leaked) = (0u64, 0u64);
        for frame_index in 0..4 {
            let roma = Roma::build(&frame, &RomaParams { n: 8, ..Default::default() }, 15, frame_index);
            let cell = roma.cell_size_world();
            let mut rng = Rng::new(15, frame_index as u64);
            for _ in 0..5000 {
                let p = Vec3::new(rng.next_f32() * 0.5 - 0.25, 0.0, rng.next_f32() * 0.5 - 0.25);
                let light = Vec3::new(0.0, 0.8, 0.0);
                if !tracer.occluded(&Ray::new(p + Vec3::Y * 1e-4, (light - p).normalize()), (light - p).length() * 0.999) {
                    continue;
                }
                shadowed += 1;
                leaked += !shadow_blocked(&roma, p + Vec3::Y * 1.5 * cell, light, false, 8) as u64;
            }
        }
        let rate = leaked as f64 / shadowed as f64;
        println!(
            "check 15: plate {gap_cells} cells above the floor, point light above: {:.1}% of {shadowed} exactly shadowed floor points are lit by ROMA (un-snapped)",
            100.0 * rate
        );
        if gap_cells < 1.5 {
            assert!(rate > 0.5, "a plate inside the 1.5-cell origin offset leaks: expected, documented as unsupported");
        } else {
            assert!(rate < 0.05, "a plate beyond the offset shadows");
        }
    }
}
