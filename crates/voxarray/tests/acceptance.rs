//! The spec's CPU acceptance checks (`shared/specs/voxel-array-shadows.md` §7), small
//! configurations (resolution 32, few directions). Each prints what it measured first.

mod common;

use glimpse_core::{Mat3, Mat4, Quat, Rng, Vec3};
use glimpse_render::metrics::ShadowErrors;
use glimpse_trace::{ExactTracer, GBuffer};
use glimpse_voxarray::compress::{self, CompressParams};
use glimpse_voxarray::directions::{self, Directions};
use glimpse_voxarray::dynamic::{self, Instanced};
use glimpse_voxarray::query::{self, clip_hits, clip_msb_first};
use glimpse_voxarray::row::Row;
use glimpse_voxarray::voxelize::{self, Grid};
use glimpse_voxarray::{Array, Rows, VoxArray, VoxArrayParams, epsilon};

fn small(resolution: u32, directions: u32) -> VoxArrayParams {
    VoxArrayParams { resolution, directions, compress: None, ..VoxArrayParams::default() }
}

/// Twelve triangles of an axis-aligned box.
fn box_tris(c: Vec3, h: Vec3) -> Vec<[Vec3; 3]> {
    let p = |x: f32, y: f32, z: f32| c + h * Vec3::new(x, y, z);
    let q = [
        [p(-1., -1., -1.), p(1., -1., -1.), p(1., 1., -1.), p(-1., 1., -1.)],
        [p(-1., -1., 1.), p(1., -1., 1.), p(1., 1., 1.), p(-1., 1., 1.)],
        [p(-1., -1., -1.), p(-1., 1., -1.), p(-1., 1., 1.), p(-1., -1., 1.)],
        [p(1., -1., -1.), p(1., 1., -1.), p(1., 1., 1.), p(1., -1., 1.)],
        [p(-1., -1., -1.), p(1., -1., -1.), p(1., -1., 1.), p(-1., -1., 1.)],
        [p(-1., 1., -1.), p(1., 1., -1.), p(1., 1., 1.), p(-1., 1., 1.)],
    ];
    q.iter().flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]]).collect()
}

fn random_scene(seed: u64, count: usize) -> Vec<[Vec3; 3]> {
    let mut rng = Rng::new(seed, 0);
    let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
    let mut tris = Vec::new();
    for _ in 0..count {
        let c = v() * 0.7;
        tris.push([c + v() * 0.3, c + v() * 0.3, c + v() * 0.3]);
    }
    tris.extend(box_tris(Vec3::ZERO, Vec3::splat(1.0))); // a frame so the grid is fixed
    tris
}

fn plain<R: Row>(a: &Array<R>) -> &[R] {
    match &a.rows {
        Rows::Plain(v) => v,
        Rows::Compressed(_) => panic!("expected an uncompressed array"),
    }
}

#[test]
fn check_01_bit_clipping_fig4() {
    let row = 0x0200_8100u32;
    let clipped = clip_msb_first(row, 4, 27);
    println!("Fig. 4: row {row:#010x}, s=4, e=27 → clipped {clipped:#x} (paper: 0x200810), literal lines 5–6 give {:#x}", (row << 4) >> 9);
    assert_eq!(clipped, 0x20_0810);
    assert_ne!(clipped, 0);
    assert_eq!(clip_msb_first(row, 8, 15), 0);
    assert_eq!(clip_msb_first(row, 0, 5), 0);
    // LSB-first mask form = MSB-first shift form on the bit-reversed row, for every s ≤ e.
    let mut checked = 0;
    for s in 0..32 {
        for e in s..32 {
            assert_eq!(clip_msb_first(row, s, e) != 0, clip_hits(row.reverse_bits(), s, e), "s={s} e={e}");
            checked += 1;
        }
    }
    println!(
        "mask vs shift agree on all {checked} (s, e) pairs; edge masks: u32 {:#x}, u64 {:#x}, u128 {:#x}",
        u32::mask(0, 31),
        u64::mask(63, 63),
        u128::mask(0, 127)
    );
    assert_eq!(u32::mask(0, 31), u32::MAX);
    assert_eq!(u64::mask(0, 63), u64::MAX);
    assert_eq!(u128::mask(0, 127), u128::MAX);
    assert_eq!(u128::mask(127, 127), 1u128 << 127);
    assert_eq!(u64::mask(5, 5), 1 << 5);
    // The 128-bit row as four 32-bit words (the paper's RGBA32UI texel): per-word masks agree.
    let r: u128 = 0x8000_0000_0000_0001_0000_0100_0000_0000;
    for (s, e) in [(0, 127), (40, 40), (41, 126), (127, 127), (0, 39)] {
        let words = [r as u32, (r >> 32) as u32, (r >> 64) as u32, (r >> 96) as u32];
        let m = u128::mask(s, e);
        let any = (0..4).any(|w| words[w] & (m >> (32 * w)) as u32 != 0);
        assert_eq!(any, clip_hits(r, s, e));
    }
}

#[test]
fn check_02_aligned_rays_equal_voxel_traversal() {
    let tris = random_scene(2, 60);
    let p = VoxArrayParams { bias_start_cells: 0.0, bias_end_cells: 0.0, ..small(32, 6) };
    let a = Array::<u32>::build(&tris, &p);
    let rows = plain(&a);
    let n = 32u32;
    let mut rng = Rng::new(7, 0);
    let (mut total, mut agree, mut hits, mut symmetric) = (0, 0, 0, 0);
    for _ in 0..4000 {
        let i = (rng.next_f32() * 6.0) as u32 % 6;
        let mut j = (rng.next_f32() * 6.0) as u32 % 6;
        if j == 3 {
            j = 2; // skip the pole φ = 90°, where every θ is the same line
        }
        let r = a.dirs.rotation(i, j);
        let (x, y) = ((rng.next_f32() * n as f32) as u32 % n, (rng.next_f32() * n as f32) as u32 % n);
        let (u, v) = (0.2 + 0.6 * rng.next_f32(), 0.2 + 0.6 * rng.next_f32());
        let z0 = (rng.next_f32() * n as f32).floor() + 0.5;
        let z1 = (rng.next_f32() * n as f32).floor() + 0.5;
        if z0 == z1 {
            continue;
        }
        let cell = |z: f32| Vec3::new(x as f32 + u, y as f32 + v, z);
        let world = |q: Vec3| r.transpose() * ((q - Vec3::splat(n as f32 * 0.5)) / a.grid.scale) + a.grid.center;
        let (pa, pb) = (world(cell(z0)), world(cell(z1)));
        let got = a.occluded_segment(pa, pb);
        symmetric += (got == a.occluded_segment(pb, pa)) as u32;
        // Amanatides–Woo through V[i][j] from cell(z0) to cell(z1): an aligned ray steps only in z.
        let vox = &rows[((i * 6 + j) * n * n) as usize..((i * 6 + j + 1) * n * n) as usize];
        let dda = dda_any(vox, n, a.grid.to_cells(&r, pa), a.grid.to_cells(&r, pb));
        total += 1;
        agree += (got == dda) as u32;
        hits += dda as u32;
    }
    println!("aligned rays: {agree}/{total} equal to the voxel traversal ({hits} occluded), {symmetric}/{total} symmetric (P,L)=(L,P)");
    assert_eq!(agree, total);
    assert_eq!(symmetric, total);
    assert!(hits > 0 && hits < total);
}

/// Amanatides–Woo traversal of one voxelization (rows along z) from cell point `a` to `b`:
/// any occupied voxel visited.
fn dda_any(vox: &[u32], n: u32, a: Vec3, b: Vec3) -> bool {
    let d = b - a;
    let mut c = a.floor().as_ivec3();
    let end = b.floor().as_ivec3();
    let step = d.signum().as_ivec3();
    let next = |k: usize| {
        if d[k] > 0.0 {
            (c[k] as f32 + 1.0 - a[k]) / d[k]
        } else if d[k] < 0.0 {
            (c[k] as f32 - a[k]) / d[k]
        } else {
            f32::INFINITY
        }
    };
    let mut t_max = Vec3::new(next(0), next(1), next(2));
    let t_delta = Vec3::new(1.0 / d.x.abs(), 1.0 / d.y.abs(), 1.0 / d.z.abs());
    let inside = |c: glimpse_core::glam::IVec3| c.min_element() >= 0 && c.max_element() < n as i32;
    for _ in 0..3 * n + 3 {
        if inside(c) && vox[(c.y as u32 * n + c.x as u32) as usize].get(c.z as u32) {
            return true;
        }
        if c == end {
            break;
        }
        let k = if t_max.x <= t_max.y && t_max.x <= t_max.z {
            0
        } else if t_max.y <= t_max.z {
            1
        } else {
            2
        };
        c[k] += step[k];
        t_max[k] += t_delta[k];
    }
    false
}

#[test]
fn check_03_direction_discretization() {
    let dirs = Directions::new(90);
    let mut roundtrip = 0;
    for i in 0..90 {
        for j in 0..90 {
            if j == 45 {
                continue;
            }
            let d = dirs.row_direction(i, j);
            assert_eq!(dirs.discretize(d), (i, j), "d({i},{j})");
            assert_eq!(dirs.discretize(-d), (i, j), "−d({i},{j})");
            // R(θ, φ) maps the row direction onto +z.
            assert!((dirs.rotation(i, j) * d - Vec3::Z).length() < 1e-5);
            roundtrip += 1;
        }
    }
    let mut rng = Rng::new(3, 0);
    let mut worst = 0.0f32;
    for _ in 0..20000 {
        let d = glimpse_core::sampling::uniform_sphere(rng.next_2d());
        let (i, j) = dirs.discretize(d);
        let cos = d.dot(dirs.row_direction(i, j)).abs().min(1.0);
        worst = worst.max(cos.acos().to_degrees());
    }
    let fig3 = directions::discretize(directions::row_direction(30f32.to_radians(), 42f32.to_radians()), 90);
    println!(
        "{roundtrip} sampled directions and negations round-trip; worst misalignment over 20,000 random directions {worst:.3}° (k/√2 = 1.414°); Fig. 3 (θ=30°, φ=42°) → V{fig3:?}"
    );
    assert!(worst <= 1.42, "worst {worst}");
    assert_eq!(fig3, (15, 21));
}

#[test]
fn check_04_transposition_identity() {
    let tris = random_scene(4, 80);
    let a = Array::<u32>::build(&tris, &small(32, 6));
    let rows = plain(&a);
    let (n, per) = (32u32, 32 * 32usize);
    let (mut differ, mut set, mut perm_ok) = (0u64, 0u64, true);
    for i in 0..6u32 {
        for j in 0..3u32 {
            let v = &rows[(i * 6 + j) as usize * per..][..per];
            let t = &rows[(i * 6 + j + 3) as usize * per..][..per];
            // The rasterized half is the direct voxelization at its rotation, bit for bit.
            assert!(v == voxelize::voxelize_direct::<u32>(&tris, &a.grid, &a.dirs.rotation(i, j)), "V[{i}][{j}]");
            // Exactly a permutation of V[i][j].
            let mut again = vec![0u32; per];
            voxelize::transpose(v, &mut again);
            perm_ok &= again == t && v.iter().map(|r| r.count_ones()).sum::<u32>() == t.iter().map(|r| r.count_ones()).sum::<u32>();
            // Against a direct voxelization at (θ_i, φ_j + 90°).
            let direct: Vec<u32> = voxelize::voxelize_direct(
                &tris,
                &a.grid,
                &directions::rotation(directions::angle_rad(6, i), directions::angle_rad(6, j + 3)),
            );
            for (x, y) in t.iter().zip(&direct) {
                differ += (x ^ y).count_ones() as u64;
                set += (x | y).count_ones() as u64;
            }
        }
    }
    let _ = n;
    println!(
        "transposed V[i][j+n/2] is a permutation of V[i][j]: {perm_ok}; against direct voxelization at φ+90°: {differ} of {set} occupied voxels differ ({:.4}%)",
        100.0 * differ as f64 / set as f64
    );
    assert!(perm_ok);
    // Fragment-centre voxelization is rotation-consistent except for fragments on cell faces.
    assert!((differ as f64) <= 0.005 * set as f64);
}

#[test]
fn check_05_empty_scene_and_closed_box() {
    let empty = VoxArray::from_triangles(&[], &small(32, 6));
    let mut rng = Rng::new(5, 0);
    let mut occluded = 0;
    for _ in 0..1000 {
        let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
        let q = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
        occluded += empty.occluded_segment(p, q) as u32;
    }
    // A closed box of half-size 1 inside a frame of half-size 4; a point at its centre, lights
    // outside it (default bias: 1 cell at each end).
    let mut tris = box_tris(Vec3::ZERO, Vec3::splat(1.0));
    tris.extend(box_tris(Vec3::ZERO, Vec3::splat(4.0)));
    let boxed = VoxArray::from_triangles(&tris, &small(32, 10));
    let mut inside = 0;
    let total = 2000;
    for _ in 0..total {
        let d = glimpse_core::sampling::uniform_sphere(rng.next_2d());
        inside += boxed.occluded_segment(Vec3::new(0.1, -0.2, 0.05), d * 3.0) as u32;
    }
    println!(
        "empty scene: {occluded}/1000 segments occluded; point inside a closed box, lights outside (bias 1 cell each end): {inside}/{total} occluded"
    );
    assert_eq!(occluded, 0);
    assert_eq!(inside, total);
}

#[test]
fn check_06_dictionary_and_lossless() {
    let tris = random_scene(6, 40);
    let a = Array::<u32>::build(&tris, &small(32, 4));
    let rows = plain(&a);
    let (c, _, rep) = compress::compress(rows, &CompressParams::default());
    let lossless = c.decode() == rows;
    println!(
        "{} rows, {} distinct, dictionary {} (n = 2^20): decode == original: {lossless}",
        rep.rows, rep.distinct_rows, rep.dictionary_rows
    );
    assert!(rep.distinct_rows <= 1 << 20);
    assert!(lossless);
    // With a small dictionary, D holds the n most frequent rows.
    let n = 50;
    let (c, _, rep) = compress::compress(rows, &CompressParams { dictionary_rows: n, ..Default::default() });
    let mut counts = std::collections::HashMap::new();
    for r in rows {
        *counts.entry(*r).or_insert(0u64) += 1;
    }
    let min_in = c.dictionary.iter().map(|r| counts[r]).min().unwrap();
    let max_out = counts.iter().filter(|(r, _)| !c.dictionary.contains(r)).map(|(_, k)| *k).max().unwrap_or(0);
    println!(
        "n = {n}: least frequent dictionary row occurs {min_in}×, most frequent row left out {max_out}×; {} indices of {} bits",
        rep.rows, c.index_bits
    );
    assert_eq!(c.dictionary.len(), n as usize);
    assert!(min_in >= max_out);
    assert_eq!(c.index_bits, 6);
}

#[test]
fn check_07_step_invariant() {
    let tris = random_scene(7, 200);
    let a = Array::<u64>::build(&tris, &small(64, 4));
    let rows = plain(&a);
    let (c, step, rep) = compress::compress(rows, &CompressParams { dictionary_rows: 256, steps: 4, seed: 1 });
    let mut violations = 0;
    for (k, r) in rows.iter().enumerate() {
        let s = step[k] as u32;
        if s < 4 {
            let f = 1 << s;
            violations += (c.row(k).simplify(f) != r.simplify(f)) as u32;
        }
    }
    let total = rep.rows as f64;
    let frac: Vec<String> = rep.mapped_at_step.iter().map(|m| format!("{:.3}%", 100.0 * *m as f64 / total)).collect();
    println!(
        "{} rows, {} distinct, n = 256: mapped at steps ×1,×2,×4,×8: {frac:?}, random {:.3}%; invariant violations {violations}",
        rep.rows,
        rep.distinct_rows,
        100.0 * rep.random as f64 / total
    );
    assert_eq!(violations, 0);
    assert_eq!(rep.mapped_at_step.iter().sum::<u64>() + rep.random, rep.rows);
    assert!(rep.mapped_at_step[1] + rep.mapped_at_step[2] + rep.mapped_at_step[3] > 0);
}

#[test]
fn check_08_memory_accounting() {
    let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
    let mut lines = Vec::new();
    for (res, table_u, table_c) in [(32u64, 32.0, 36.0), (64, 254.0, 95.0), (128, 2025.0, 333.0), (256, 16200.0, 1298.0)] {
        let (u, c) = compress::table8_bytes(res as u32, 90, 1 << 20);
        lines.push(format!("{res}³: {:.1} MiB → {:.1} MiB (Table 8: {table_u} → {table_c})", mib(u), mib(c)));
        if res == 128 {
            assert_eq!(90 * 90 * 128 * 128, 132_710_400);
            assert!((mib(u) - 2025.0).abs() < 0.5 && (mib(c) - 332.4).abs() < 0.1);
        }
        if res == 256 {
            assert!((mib(u) - 16200.0).abs() < 0.5 && (mib(c) - 1297.6).abs() < 0.1);
        }
    }
    // The built structure reports the same accounting.
    let tris = random_scene(8, 30);
    let mut a = Array::<u32>::build(&tris, &small(32, 4));
    let before = a.uncompressed_bytes();
    a.compress(&CompressParams::default());
    let Rows::Compressed(c) = &a.rows else { unreachable!() };
    println!(
        "{}; a 32³ 4×4 array: {before} B → {} B packed ({} dictionary rows, {}-bit indices)",
        lines.join("; "),
        c.packed_bytes(),
        c.dictionary.len(),
        c.index_bits
    );
    assert_eq!(before, 4 * 4 * 32 * 32 * 4);
}

/// A small many-lights frame for the ε checks.
fn many_lights_eps(p: &VoxArrayParams, lights: usize, size: u32) -> (epsilon::Epsilon, f64) {
    let scene = glimpse_scene::builtin::many_lights(lights);
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    let camera = scene.camera_or_default(1.0);
    let g = GBuffer::new(&frame, &tracer, &camera, size, size);
    let sw = std::time::Instant::now();
    let a = VoxArray::build(&frame, p);
    let ms = sw.elapsed().as_secs_f64() * 1e3;
    (epsilon::epsilon(&frame, &g, &tracer, lights, |_, ps, s| a.occluded_from_surface(ps, s.normal)), ms)
}

#[test]
fn check_09_compression_quality() {
    let base = small(32, 10);
    let (plain_eps, _) = many_lights_eps(&base, 64, 24);
    let vq = VoxArrayParams { compress: Some(CompressParams { dictionary_rows: 512, ..Default::default() }), ..base };
    let (vq_eps, _) = many_lights_eps(&vq, 64, 24);
    println!(
        "many-lights, 64 lights, 24², 32³, 10×10 dirs, bias 1/1, normal offset 1.5: uncompressed ε_v {:.2}% ε_s {:.2}%; dictionary 512 rows: ε_v {:.2}% ε_s {:.2}%",
        100.0 * plain_eps.all.epsilon_v(),
        100.0 * plain_eps.all.epsilon_s_abs(),
        100.0 * vq_eps.all.epsilon_v(),
        100.0 * vq_eps.all.epsilon_s_abs()
    );
    assert!(vq_eps.all.epsilon_v() >= plain_eps.all.epsilon_v() - 0.01);
    assert!(vq_eps.all.epsilon_v() < plain_eps.all.epsilon_v() + 0.1);
}

#[test]
fn check_10_metric_unit() {
    let mut e = ShadowErrors::new();
    e.add_pixel(10, 5, 1000);
    println!("n = 1000, FV = 10, FI = 5: ε_v {:.2}%, ε_s {:.2}%", 100.0 * e.epsilon_v(), 100.0 * e.epsilon_s_abs());
    assert!((e.epsilon_v() - 0.015).abs() < 1e-12);
    assert!((e.epsilon_s_abs() - 0.005).abs() < 1e-12);
}

#[test]
fn check_11_12_error_magnitude_and_resolution_trend() {
    let mut eps = Vec::new();
    for res in [32, 64] {
        let (e, ms) = many_lights_eps(&small(res, 16), 64, 24);
        println!(
            "many-lights, 64 lights, 24², {res}³, 16×16 dirs, bias 1/1, normal offset 1.5: ε_v {:.2}% ε_s {:.2}% (signed {:+.2}%), facing-only ε_v {:.2}% ε_s {:.2}%; build {ms:.0} ms",
            100.0 * e.all.epsilon_v(),
            100.0 * e.all.epsilon_s_abs(),
            100.0 * e.all.epsilon_s_signed(),
            100.0 * e.facing.epsilon_v(),
            100.0 * e.facing.epsilon_s_abs()
        );
        eps.push(e);
    }
    assert!(eps[1].all.epsilon_v() < eps[0].all.epsilon_v(), "ε_v must fall from 32³ to 64³");
    assert!(eps[1].all.epsilon_v() < 0.25);
}

#[test]
fn check_13_rigid_instances() {
    let object = box_tris(Vec3::ZERO, Vec3::new(0.5, 0.3, 0.2));
    let p = small(32, 10);
    let local = VoxArray::from_triangles(&object, &p);
    let m = Mat4::from_rotation_translation(Quat::from_rotation_y(0.7) * Quat::from_rotation_x(0.3), Vec3::new(1.0, 0.5, -2.0));
    let inv = m.inverse();
    let inst = Instanced { static_part: None, types: vec![Some(local.clone())], instances: vec![(0, inv)], build_ms: 0.0 };
    let mut rng = Rng::new(13, 0);
    let (mut same, mut hits) = (0, 0);
    let total = 2000;
    for _ in 0..total {
        let a = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
        let b = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
        // Moving instance and ray together by m gives the local answer.
        let moved = inst.occluded_segment(m.transform_point3(a), m.transform_point3(b));
        let here = local.occluded_segment(a, b);
        same += (moved == here) as u32;
        hits += here as u32;
    }
    // With a static part too: the answer is the OR.
    let wall = box_tris(Vec3::new(0.0, 0.0, 3.0), Vec3::new(2.0, 2.0, 0.1));
    let st = VoxArray::from_triangles(&wall, &p);
    let both = Instanced { static_part: Some(st.clone()), ..inst.clone() };
    let mut or_ok = 0;
    for _ in 0..total {
        let a = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 3.0;
        let b = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 3.0;
        let expect = st.occluded_segment(a, b) || local.occluded_segment(inv.transform_point3(a), inv.transform_point3(b));
        or_ok += (both.occluded_segment(a, b) == expect) as u32;
    }
    println!("rigid instance moved with the ray: {same}/{total} identical ({hits} occluded); static ∪ instance = OR: {or_ok}/{total}");
    assert_eq!(same, total);
    assert_eq!(or_ok, total);
    assert!(hits > 0);
}

#[test]
fn check_14_alg6_against_alg1() {
    let tris = random_scene(14, 120);
    let p = small(32, 6);
    let a1 = Array::<u32>::build(&tris, &p);
    let a6 = dynamic::rebuild_from_fragments::<u32>(&tris, a1.grid, &p);
    let (r1, r6) = (plain(&a1), plain(&a6));
    let per = 32 * 32;
    let diff = |k: usize| -> (u64, u64) {
        let (x, y) = (&r1[k * per..][..per], &r6[k * per..][..per]);
        x.iter().zip(y).fold((0, 0), |(d, s), (a, b)| (d + (a ^ b).count_ones() as u64, s + (a | b).count_ones() as u64))
    };
    let (d0, s0) = diff(0);
    let (mut d, mut s) = (0, 0);
    for k in 1..36 {
        let (a, b) = diff(k);
        d += a;
        s += b;
    }
    let (e1, e6) = (epsilon_vs(&a1, &tris), epsilon_vs(&a6, &tris));
    println!(
        "Alg. 6 vs Alg. 1: V[0][0] {d0} of {s0} voxels differ; other directions {d} of {s} ({:.2}%); segment disagreement with a brute-force oracle: Alg. 1 {:.2}%, Alg. 6 {:.2}%",
        100.0 * d as f64 / s as f64,
        100.0 * e1,
        100.0 * e6
    );
    assert!(d0 as f64 <= 0.001 * s0 as f64);
    assert!((d as f64) < 0.5 * s as f64);
}

/// Fraction of random segments on which `a` disagrees with an exact segment–triangle test.
fn epsilon_vs(a: &Array<u32>, tris: &[[Vec3; 3]]) -> f64 {
    let mut rng = Rng::new(99, 0);
    let mut wrong = 0;
    let total = 2000;
    for _ in 0..total {
        let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.6 - 0.8;
        let q = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.6 - 0.8;
        let exact = tris.iter().any(|t| segment_hits(p, q, t));
        wrong += (exact != a.occluded_segment(p, q)) as u32;
    }
    wrong as f64 / total as f64
}

fn segment_hits(p: Vec3, q: Vec3, t: &[Vec3; 3]) -> bool {
    let d = q - p;
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let h = d.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-12 {
        return false;
    }
    let s = p - t[0];
    let u = s.dot(h) / det;
    let qv = s.cross(e1);
    let v = d.dot(qv) / det;
    let tt = e2.dot(qv) / det;
    u >= 0.0 && v >= 0.0 && u + v <= 1.0 && tt > 0.0 && tt < 1.0
}

#[allow(dead_code)]
fn unused(_: Mat3, _: Grid, _: query::Extent) {}

/// `lights-voxarray` end to end (Alg. 4) on a static, a rigid-dynamic (Alg. 5) and a deforming
/// (Alg. 6) scene: renders, reports its stages, and stays close to `lights-exact`.
#[test]
fn check_15_technique_alg4_static_rigid_deforming() {
    use glimpse_render::{FrameContext, Params, Settings, Technique};
    use glimpse_voxarray::technique::LightsVoxArray;
    for (name, extra) in [("many-lights", "lights=32"), ("cornell-dynamic", "lights=8"), ("deforming", "lights=8")] {
        let scene = match name {
            "many-lights" => glimpse_scene::builtin::many_lights(32),
            "cornell-dynamic" => common::cornell_dynamic_lit(8),
            _ => glimpse_scene::load(name).unwrap(),
        };
        let ctx = FrameContext::new(&scene, 0.5, 20, 20);
        let g = ctx.gbuffer();
        let params = Params::parse(&["resolution=32", "directions=8", "compress=true", "dictionary=4096", extra]).unwrap();
        let mut t = LightsVoxArray::new(&scene, &Settings::default(), &params).unwrap();
        params.finish("lights-voxarray").unwrap();
        let prep = t.prepare(&ctx).unwrap();
        let mut img = ctx.image();
        let st = t.render(&ctx, &g, &mut img).unwrap();
        let exact_params = Params::parse(&[extra]).unwrap();
        let mut ex = glimpse_render::lights::LightsExact::new(&scene, &Settings::default(), &exact_params).unwrap();
        let mut ref_img = ctx.image();
        ex.render(&ctx, &g, &mut ref_img).unwrap();
        let (mut sum, mut sum_ref) = (0.0f64, 0.0f64);
        for (a, b) in img.pixels.iter().zip(&ref_img.pixels) {
            sum += a.x as f64 + a.y as f64 + a.z as f64;
            sum_ref += b.x as f64 + b.y as f64 + b.z as f64;
        }
        let kind = match t.structure {
            Some(glimpse_voxarray::technique::Structure::Static(_)) => "static (Alg. 1+2)",
            Some(glimpse_voxarray::technique::Structure::Instanced(_)) => "rigid (Alg. 5)",
            Some(glimpse_voxarray::technique::Structure::Deforming(_)) => "deforming (Alg. 6)",
            None => "none",
        };
        let metric = |k: &str| st.metrics.iter().find(|(n, _)| n == k).map(|m| m.1);
        println!(
            "{name}: {kind}, prepare {:?}, memory {:.1} KiB, {} shadow queries, mean radiance {:.4} vs lights-exact {:.4}, reported {:?}",
            prep.stages.iter().map(|(s, ms)| format!("{s} {ms:.0} ms")).collect::<Vec<_>>(),
            st.memory_bytes as f64 / 1024.0,
            st.rays,
            sum / img.pixels.len() as f64,
            sum_ref / ref_img.pixels.len() as f64,
            st.metrics
        );
        assert!(st.rays > 0);
        // ε is reported for eval (param `epsilon`, on by default): 0 ≤ |ε_s| ≤ ε_v ≤ 100 %.
        let (eps_v, eps_s) = (metric("eps_v_pct").unwrap(), metric("eps_s_pct").unwrap());
        assert!((0.0..=100.0).contains(&eps_v) && eps_s <= eps_v + 1e-9 && eps_v < 50.0, "{eps_v} {eps_s}");
        assert!(sum > 0.3 * sum_ref && sum < 2.0 * sum_ref);
    }
}
