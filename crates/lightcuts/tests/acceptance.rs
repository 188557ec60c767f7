//! The CPU acceptance checks of ../shared/specs/stochastic-lightcuts.md §11 (numbered as there).
//! Each prints what it measured before asserting. Small configurations (2 shared cores); no
//! ../shared files (the built-in `cornell` and scenes built here).

use glimpse_core::{Frame, Image, Rng, Vec2, Vec3, luminance};
use glimpse_lightcuts::cut::{BlockCuts, Surface, build_cut, cmp_priority, completely_behind, mock_cut, stochastic_select, weight};
use glimpse_lightcuts::sample::{ClusterLight, Sampler, Strategy, brute_force, sample_point, traverse};
use glimpse_lightcuts::technique::block_cuts;
use glimpse_lightcuts::tree::{bitonic_sort, sort_key, sort_vpls};
use glimpse_lightcuts::upsample::{LowRes, upsample_pixel};
use glimpse_lightcuts::vpl::{self, Similarity, edge_aware_filter, mip_pyramid, randomized_hammersley, warp};
use glimpse_lightcuts::{Flatness, LightcutsParams, Sst, SstNode, Variant, Vpl, VplTechnique};
use glimpse_render::direct::{Shading, Unoccluded};
use glimpse_render::metrics::rmse;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_scene::{Light, Scene};
use glimpse_trace::GBuffer;
use std::collections::{BinaryHeap, HashMap};
use std::sync::atomic::AtomicU32;

// ---------------------------------------------------------------------------------------------
// Helpers

fn random_vpls(n: usize, seed: u64, normal: impl Fn(&mut Rng) -> Vec3) -> Vec<Vpl> {
    let mut rng = Rng::new(seed, 0);
    (0..n)
        .map(|_| {
            let pos = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
            let color = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) + 0.01;
            Vpl { pos, normal: normal(&mut rng), color, error_scale: 1.0 }
        })
        .collect()
}

fn random_normal(rng: &mut Rng) -> Vec3 {
    glimpse_core::sampling::uniform_sphere(rng.next_2d())
}

fn params(pairs: &[&str]) -> Params {
    Params::parse(pairs).expect("valid key=value pairs")
}

fn render(variant: Variant, spp: u32, seed: u64, pairs: &[&str], ctx: &FrameContext, g: &GBuffer) -> (Image, VplTechnique) {
    let mut t = VplTechnique::new(variant, &Settings { spp, seed }, &params(pairs)).expect("valid parameters");
    t.prepare(ctx).expect("prepare");
    let mut img = ctx.image();
    t.render(ctx, g, &mut img).expect("render");
    (img, t)
}

/// Leaves below `node` as a VPL index range.
fn leaves(tree: &Sst, node: u32) -> std::ops::Range<u32> {
    let (a, n) = tree.leaf_range(node);
    a..a + n
}

/// Floor plane y = 0 receivers and VPLs hovering above it facing down-ish: a planar receiver,
/// where culling at a block centre equals culling at every pixel of the plane.
fn floor_setup(n_vpls: usize) -> (Sst, Vec<Shading>, u32, u32) {
    let mut rng = Rng::new(11, 3);
    let vpls: Vec<Vpl> = (0..n_vpls)
        .map(|_| {
            let pos = Vec3::new(rng.next_f32() * 2.0 - 1.0, 0.2 + rng.next_f32() * 0.8, rng.next_f32() * 2.0 - 1.0);
            let n = (Vec3::new(0.0, -1.0, 0.0) + random_normal(&mut rng) * 0.6).normalize();
            Vpl { pos, normal: n, color: Vec3::new(0.5 + rng.next_f32(), 0.5, 0.2 + rng.next_f32()) * 0.01, error_scale: 1.0 }
        })
        .collect();
    let tree = Sst::build_sequential(&sort_vpls(&vpls), Flatness::default());
    let (w, h) = (24u32, 16u32);
    let pixels = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let p = Vec3::new(-1.2 + 2.4 * (x as f32 + 0.5) / w as f32, 0.0, -0.8 + 1.6 * (y as f32 + 0.5) / h as f32);
            Shading { position: p, error_scale: 1.2, normal: Vec3::Y, shading_normal: Vec3::Y, albedo: Vec3::splat(0.7) }
        })
        .collect();
    (tree, pixels, w, h)
}

/// Block cuts over a synthetic receiver grid.
fn synthetic_cuts(tree: &Sst, pixels: &[Shading], w: u32, h: u32, block: u32, n: u32, clamp2: f32) -> BlockCuts {
    let len = pixels.len();
    let g = GBuffer {
        width: w,
        height: h,
        camera: glimpse_scene::Camera::look_at(Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO, Vec3::Z, 60.0),
        position: pixels.iter().map(|s| s.position).collect(),
        error_scale: pixels.iter().map(|s| s.error_scale).collect(),
        normal: pixels.iter().map(|s| s.normal).collect(),
        shading_normal: pixels.iter().map(|s| s.shading_normal).collect(),
        depth: vec![1.0; pixels.len()],
        albedo: pixels.iter().map(|s| s.albedo).collect(),
        material: vec![0; len],
        instance: vec![0; len],
        uv: vec![Vec2::ZERO; len],
        emission: vec![Vec3::ZERO; len],
        view_dir: vec![-Vec3::Y; len],
    };
    block_cuts(tree, &g, w, h, &|x, y| (y * w + x) as usize, block, n, clamp2)
}

// ---------------------------------------------------------------------------------------------
// Tree build

#[test]
fn check_01_conservation_at_the_root() {
    let vpls = random_vpls(1024, 1, random_normal);
    let tree = Sst::build_sequential(&sort_vpls(&vpls), Flatness::default());
    let sum: Vec3 = vpls.iter().map(|v| v.color).sum();
    let root = tree.root();
    let rel = ((root.color - sum).abs() / sum).max_element();
    let (lo, hi) = vpls.iter().fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(a, b), v| (a.min(v.pos), b.max(v.pos)));
    let isum: f64 = vpls.iter().map(|v| luminance(v.color) as f64).sum();
    let mean = vpls.iter().fold(glimpse_core::glam::DVec3::ZERO, |m, v| m + v.pos.as_dvec3() * luminance(v.color) as f64) / isum;
    let pos_err = (root.pos.as_dvec3() - mean).length();
    println!("root colour rel. error {rel:e}; box {:?}..{:?} vs {lo:?}..{hi:?}; mean position error {pos_err:e}", root.bb_min, root.bb_max);
    assert!(rel < 1e-5);
    assert_eq!((root.bb_min, root.bb_max), (lo, hi));
    assert!(pos_err < 1e-4);
}

#[test]
fn check_02_variance_exact_in_a_shared_frame() {
    let vpls = random_vpls(512, 2, |_| Vec3::new(0.0, 0.0, 1.0));
    let tree = Sst::build_sequential(&sort_vpls(&vpls), Flatness::default());
    let f = Frame::from_z(Vec3::Z);
    let isum: f64 = vpls.iter().map(|v| luminance(v.color) as f64).sum();
    let local = |p: Vec3| f.to_local(p).as_dvec3();
    let mean = vpls.iter().fold(glimpse_core::glam::DVec3::ZERO, |m, v| m + local(v.pos) * luminance(v.color) as f64) / isum;
    let var = vpls.iter().fold(glimpse_core::glam::DVec3::ZERO, |m, v| {
        let d = local(v.pos) - mean;
        m + d * d * luminance(v.color) as f64
    }) / isum;
    let got = tree.root().var.as_dvec3();
    let rel = ((got - var).abs() / var).max_element();
    println!("root variance {got:?} vs direct {var:?}: rel. error {rel:e}");
    assert!(rel < 1e-3);
}

#[test]
fn check_03_flat_and_opposite_sets() {
    let mut rng = Rng::new(3, 0);
    let flat: Vec<Vpl> = (0..256)
        .map(|_| Vpl { pos: Vec3::new(rng.next_f32(), 0.5, rng.next_f32()), normal: Vec3::Y, color: Vec3::ONE, error_scale: 1.0 })
        .collect();
    let tree = Sst::build_sequential(&sort_vpls(&flat), Flatness::default());
    let max_sz = tree.nodes[1..].iter().map(|n| n.var.z).fold(0.0f32, f32::max);
    let min_v = tree.nodes[1..].iter().map(|n| n.v).fold(1.0f32, f32::min);
    let all_suitable = tree.nodes[1..].iter().all(|n| n.suitable);
    let x = Surface { pos: Vec3::ZERO, normal: Vec3::Y };
    let steps = traverse(&tree, 1, &x, Some(f32::INFINITY), 1e-4, &mut rng).steps;
    println!("coplanar: max σ_z {max_sz:e}, min v {min_v}, all suitable {all_suitable}, steps from the root {steps}");
    assert!(max_sz < 1e-10 && min_v == 1.0 && all_suitable && steps == 0);
    let pair = [
        Vpl { pos: Vec3::ZERO, normal: Vec3::Y, color: Vec3::ONE, error_scale: 1.0 },
        Vpl { pos: Vec3::X, normal: -Vec3::Y, color: Vec3::ONE, error_scale: 1.0 },
    ];
    let mut four = pair.to_vec();
    four.extend([
        Vpl { pos: Vec3::Z, normal: Vec3::Y, color: Vec3::ONE, error_scale: 1.0 },
        Vpl { pos: Vec3::ONE, normal: Vec3::Y, color: Vec3::ONE, error_scale: 1.0 },
    ]);
    let t = Sst::build_sequential(&four, Flatness::default());
    println!("opposite normals: v(parent) = {}, v(root) = {}", t.nodes[2].v, t.nodes[1].v);
    assert!(t.nodes[2].v == 0.0 && t.nodes[1].v == 0.0 && !t.nodes[1].suitable);
}

#[test]
fn check_04_parallel_build_equals_sequential() {
    let mut counters: Vec<AtomicU32> = Vec::new();
    for (seed, n) in [(4u64, 4096usize), (5, 64), (6, 2), (7, 4096)] {
        let sorted = sort_vpls(&random_vpls(n, seed, random_normal));
        let a = Sst::build_sequential(&sorted, Flatness::default());
        let b = Sst::build_parallel(&sorted, Flatness::default(), &mut counters);
        let same = a.nodes.iter().zip(&b.nodes).all(|(x, y)| {
            x.pos.to_array().map(f32::to_bits) == y.pos.to_array().map(f32::to_bits)
                && x.var.to_array().map(f32::to_bits) == y.var.to_array().map(f32::to_bits)
                && x == y
        });
        println!("{n} VPLs (counters reused): parallel == sequential bit for bit: {same}");
        assert!(same);
    }
}

#[test]
fn check_05_sorting() {
    let vpls = random_vpls(4096, 8, random_normal);
    let (lo, hi) = vpls.iter().fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(a, b), v| (a.min(v.pos), b.max(v.pos)));
    let mut keys: Vec<u64> = vpls.iter().enumerate().map(|(i, v)| sort_key(v, i as u32, 4096, lo, hi)).collect();
    let mut unique = keys.clone();
    unique.sort_unstable();
    unique.dedup();
    println!("{} keys, {} unique", keys.len(), unique.len());
    assert_eq!(unique.len(), keys.len());
    // Sorting (key, index) then permuting = sorting whole VPLs by key.
    let mut whole: Vec<(u64, Vpl)> = keys.iter().copied().zip(vpls.iter().copied()).collect();
    whole.sort_by_key(|e| e.0);
    let permuted = sort_vpls(&vpls);
    let equal = whole.iter().map(|e| e.1).eq(permuted.iter().copied());
    println!("key sort + permute == whole sort: {equal}");
    assert!(equal);
    let mut rng = Rng::new(9, 0);
    for log in 0..=14 {
        let mut a: Vec<u64> = (0..1usize << log).map(|_| ((rng.below(64) as u64) << 32) | (rng.next_u32() as u64 % 7)).collect();
        let mut b = a.clone();
        bitonic_sort(&mut a);
        b.sort_unstable();
        assert_eq!(a, b, "bitonic sort of 2^{log} keys");
    }
    bitonic_sort(&mut keys);
    assert!(keys.windows(2).all(|w| w[0] < w[1]));
    println!("bitonic sort == sort_unstable for 2^0..2^14 random keys (with duplicates)");
}

// ---------------------------------------------------------------------------------------------
// VPL generation

#[test]
fn check_06_hierarchical_warping_histogram() {
    let r = 512u32;
    let mut rng = Rng::new(12, 0);
    let mut pdf: Vec<f32> = (0..r * r)
        .map(|i| {
            let (x, y) = (i % r, i / r);
            if (x / 64 + y / 64) % 3 == 0 { 0.0 } else { 0.2 + rng.next_f32() + ((x as f32) * 0.02).sin().abs() }
        })
        .collect();
    let s: f32 = pdf.iter().sum();
    pdf.iter_mut().for_each(|p| *p /= s);
    let mips = mip_pyramid(&pdf, r);
    let m = 1_000_000u32;
    let mut hist = vec![0u32; (r * r) as usize];
    let mut u_rng = Rng::new(13, 0);
    for _ in 0..m {
        let (x, y) = warp(&mips, u_rng.next_2d());
        hist[(y * r + x) as usize] += 1;
    }
    let zero_hits: u32 = hist.iter().zip(&pdf).filter(|(_, p)| **p == 0.0).map(|(h, _)| *h).sum();
    // Chi-square over 16×16-texel bins (≈ 4000 points each), and over texels.
    let bins = 32usize;
    let (mut chi_bins, mut dof_bins) = (0.0f64, 0usize);
    let mut hb = vec![0f64; bins * bins];
    let mut pb = vec![0f64; bins * bins];
    for i in 0..(r * r) as usize {
        let b = (i / r as usize / 16) * bins + (i % r as usize) / 16;
        hb[b] += hist[i] as f64;
        pb[b] += pdf[i] as f64;
    }
    for (h, p) in hb.iter().zip(&pb) {
        if *p > 0.0 {
            let e = p * m as f64;
            chi_bins += (h - e) * (h - e) / e;
            dof_bins += 1;
        }
    }
    let (mut chi, mut dof) = (0.0f64, 0usize);
    for (h, p) in hist.iter().zip(&pdf) {
        if *p > 0.0 {
            let e = *p as f64 * m as f64;
            chi += (*h as f64 - e).powi(2) / e;
            dof += 1;
        }
    }
    println!(
        "9 warp levels, {m} points: zero-PDF hits {zero_hits}; χ²/dof over 16² bins {:.3} ({dof_bins} bins), over texels {:.3} ({dof} texels)",
        chi_bins / dof_bins as f64,
        chi / dof as f64
    );
    assert_eq!(zero_hits, 0);
    assert!((chi_bins / dof_bins as f64 - 1.0).abs() < 0.15);
    assert!((chi / dof as f64 - 1.0).abs() < 0.05);
}

#[test]
fn check_07_randomized_hammersley() {
    let n = 4096u32;
    for shift in [Vec2::ZERO, Vec2::new(0.37, 0.81), Vec2::new(0.999, 0.0001)] {
        let pts = randomized_hammersley(n, shift);
        let mut rows = vec![0u32; n as usize];
        let mut cols = vec![0u32; n as usize];
        for p in &pts {
            cols[((p.x * n as f32) as usize).min(n as usize - 1)] += 1;
            rows[((p.y * n as f32) as usize).min(n as usize - 1)] += 1;
        }
        let ok = rows.iter().all(|&c| c == 1) && cols.iter().all(|&c| c == 1);
        println!("shift {shift:?}: one point in each of the {n} rows and columns: {ok}");
        assert!(ok);
    }
    // In expectation over shifts, the density is uniform: the mean point is (0.5, 0.5).
    let mut rng = Rng::new(14, 0);
    let mut mean = Vec2::ZERO;
    let trials = 200;
    for _ in 0..trials {
        let pts = randomized_hammersley(64, rng.next_2d());
        mean += pts[7] / trials as f32;
    }
    println!("mean of point 7 over {trials} random shifts: {mean:?}");
    assert!((mean - Vec2::splat(0.5)).abs().max_element() < 0.06);
}

#[test]
fn check_08_edge_aware_filter() {
    let r = 32u32;
    let n = (r * r) as usize;
    let position: Vec<Vec3> = (0..n).map(|i| Vec3::new((i % 32) as f32 * 0.01, (i / 32) as f32 * 0.01, 0.0)).collect();
    // Left half faces +z, right half faces +x: S = 0 across the seam.
    let normal: Vec<Vec3> = (0..n).map(|i| if i % 32 < 16 { Vec3::Z } else { Vec3::X }).collect();
    let valid = vec![true; n];
    let sim = Similarity { n_min: 0.9, d_max: 1.0 };
    let constant = edge_aware_filter(&vec![3.0; n], &position, &normal, &valid, r, 2, 1.0, sim);
    let worst = constant.iter().map(|v| (v - 3.0).abs()).fold(0.0f32, f32::max);
    let step: Vec<f32> = (0..n).map(|i| if i % 32 < 16 { 1.0 } else { 5.0 }).collect();
    let f = edge_aware_filter(&step, &position, &normal, &valid, r, 2, 1.0, sim);
    let leak = (0..n).map(|i| (f[i] - step[i]).abs()).fold(0.0f32, f32::max);
    println!("constant input: worst change {worst:e}; step across an S = 0 seam: worst leak {leak:e}");
    assert!(worst < 1e-5 && leak < 1e-5);
}

/// A floor and a back wall lit by a spot light, seen from the front.
fn spot_room() -> Scene {
    let mut s = glimpse_scene::builtin::cornell();
    s.name = "cornell-spot".into();
    // Remove the area light's emission: light the box with a spot instead.
    for m in &mut s.materials {
        m.emission = Vec3::ZERO;
    }
    s.lights.push(Light::spot(Vec3::new(0.278, 0.54, 0.28), Vec3::new(0.0, -1.0, 0.0), Vec3::splat(3.0), 0.6, 1.0));
    s
}

#[test]
fn check_09_unbiased_vpl_weights() {
    let scene = spot_room();
    let ctx = FrameContext::new(&scene, 0.0, 48, 48);
    let g = ctx.gbuffer();
    let p = LightcutsParams { vpl_count: 256, rsm_resolution: 64, ..Default::default() }.vpl_params(ctx.frame.bounds.extent().length());
    let frames = 64;
    let (mut ratio, mut ratio2) = (0.0f64, 0.0f64);
    for f in 0..frames {
        let set = vpl::generate(&ctx.frame, &ctx.tracer, &g, &p, 77, f);
        let r = luminance(set.vpls.iter().map(|v| v.color).sum::<Vec3>()) as f64 / luminance(set.pvpl_flux) as f64;
        ratio += r / frames as f64;
        ratio2 += r * r / frames as f64;
    }
    let sd = ((ratio2 - ratio * ratio).max(0.0) / frames as f64).sqrt();
    println!("Σ VPL flux / Σ pVPL flux over {frames} frames: {ratio:.4} ± {sd:.4}");
    assert!((ratio - 1.0).abs() < 4.0 * sd + 0.01);
}

// ---------------------------------------------------------------------------------------------
// Cuts, blending, traversal

/// Max-priority-queue reference of the cut (a `BinaryHeap`).
fn reference_cut(tree: &Sst, x: &Surface, n: usize, clamp2: f32) -> Vec<u32> {
    #[derive(PartialEq)]
    struct E(f32, u32);
    impl Eq for E {}
    impl PartialOrd for E {
        fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
            Some(self.cmp(o))
        }
    }
    impl Ord for E {
        fn cmp(&self, o: &Self) -> std::cmp::Ordering {
            cmp_priority((self.0, self.1), (o.0, o.1))
        }
    }
    let mut heap = BinaryHeap::new();
    let mut done = Vec::new();
    if !completely_behind(tree.root(), x) {
        heap.push(E(weight(tree.root(), x, clamp2), 1));
    }
    while heap.len() + done.len() < n {
        let Some(E(_, node)) = heap.pop() else { break };
        if tree.is_leaf(node) {
            done.push(node);
            continue;
        }
        for c in [2 * node, 2 * node + 1] {
            if !completely_behind(&tree.nodes[c as usize], x) {
                heap.push(E(weight(&tree.nodes[c as usize], x, clamp2), c));
            }
        }
    }
    let mut cut: Vec<u32> = heap.into_iter().map(|e| e.1).chain(done).collect();
    cut.sort_by_key(|&i| tree.leaf_range(i).0);
    cut
}

#[test]
fn check_10_light_cut_validity() {
    let tree = Sst::build_sequential(&sort_vpls(&random_vpls(4096, 15, random_normal)), Flatness::default());
    let mut rng = Rng::new(16, 0);
    let (mut sizes, mut culled_total) = (Vec::new(), 0usize);
    for trial in 0..200 {
        let x = Surface { pos: Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 5.0 - 2.5, normal: random_normal(&mut rng) };
        let n = [1usize, 4, 13, 32, 100][trial % 5];
        let cut = build_cut(&tree, &x, n, 1e-4);
        assert!(cut.len() <= n);
        assert_eq!(cut, reference_cut(&tree, &x, n, 1e-4), "splitting order = max-priority-queue reference");
        // No ancestors; coverage: every leaf in exactly one cut node or behind the surface.
        let mut covered = vec![0u8; 4096];
        for &c in &cut {
            for l in leaves(&tree, c) {
                covered[l as usize] += 1;
            }
        }
        let mut culled = 0;
        for (l, &c) in covered.iter().enumerate() {
            assert!(c <= 1, "leaf {l} in two cut nodes (an ancestor pair)");
            if c == 0 {
                let leaf = &tree.nodes[4096 + l];
                assert!(completely_behind(leaf, &x), "an uncovered leaf must lie in a culled (behind) subtree");
                culled += 1;
            }
        }
        // Every maximal uncovered node is made of culled subtrees (all 8 corners behind).
        fn is_culled(tree: &Sst, i: u32, x: &Surface) -> bool {
            completely_behind(&tree.nodes[i as usize], x)
                || (!tree.is_leaf(i) && is_culled(tree, 2 * i, x) && is_culled(tree, 2 * i + 1, x))
        }
        for i in 1..8192u32 {
            let r = leaves(&tree, i);
            let parent_uncovered = i > 1 && leaves(&tree, i / 2).all(|l| covered[l as usize] == 0);
            if !parent_uncovered && r.clone().all(|l| covered[l as usize] == 0) {
                assert!(is_culled(&tree, i, &x));
            }
        }
        sizes.push(cut.len());
        culled_total += culled;
    }
    println!(
        "200 cuts: sizes {:?}…, mean culled leaves {:.1}; all valid and equal to the heap reference",
        &sizes[..10],
        culled_total as f64 / 200.0
    );
}

#[test]
fn check_11_mock_cut() {
    let tree = Sst::build_sequential(&sort_vpls(&random_vpls(4096, 17, random_normal)), Flatness::default());
    for (n, expected) in [(4u32, 4usize), (13, 8), (32, 32)] {
        let m: Vec<u32> = mock_cut(&tree, n).collect();
        let mut covered = vec![0u8; 4096];
        for &c in &m {
            for l in leaves(&tree, c) {
                covered[l as usize] += 1;
            }
        }
        println!("n = {n}: mock cut of {} nodes at level {}", m.len(), m[0].ilog2());
        assert_eq!(m.len(), expected);
        assert!(covered.iter().all(|&c| c == 1));
    }
}

#[test]
fn check_12_blending_probabilities() {
    let (tree, pixels, w, h) = floor_setup(256);
    let cuts = synthetic_cuts(&tree, &pixels, w, h, 8, 8, 1e-4);
    let sim = Similarity { n_min: 0.9, d_max: 10.0 };
    let x = |px: u32, py: u32| Surface { pos: pixels[(py * w + px) as usize].position, normal: Vec3::Y };
    let mut worst = 0.0f32;
    for py in 0..h {
        for px in 0..w {
            let p = cuts.blend_weights(px, py, &x(px, py), sim).expect("similar everywhere on the plane");
            worst = worst.max((p.iter().map(|e| e.1).sum::<f32>() - 1.0).abs());
        }
    }
    let centre = cuts.blend_weights(12, 4, &x(12, 4), sim).unwrap();
    let at_centre: f32 = centre.iter().filter(|e| e.0 == 1).map(|e| e.1).sum();
    // Frequencies of the chosen cut.
    let p = cuts.blend_weights(9, 6, &x(9, 6), sim).unwrap();
    let mut rng = Rng::new(18, 0);
    let trials = 200_000;
    let mut freq: HashMap<u32, f64> = HashMap::new();
    for _ in 0..trials {
        *freq.entry(stochastic_select(&p, rng.next_f32())).or_default() += 1.0 / trials as f64;
    }
    let mut expected: HashMap<u32, f64> = HashMap::new();
    for e in p {
        *expected.entry(e.0).or_default() += e.1 as f64;
    }
    let freq_err = expected.iter().map(|(b, e)| (freq.get(b).copied().unwrap_or(0.0) - e).abs()).fold(0.0, f64::max);
    let never = Similarity { n_min: 2.0, d_max: 0.0 };
    let none = cuts.blend_weights(9, 6, &x(9, 6), never).is_none();
    println!(
        "Σp − 1 worst {worst:e}; block-centre pixel picks its cut with p = {at_centre}; frequency error {freq_err:.4} ({expected:?}); S = 0 → mock cut: {none}"
    );
    assert!(worst < 1e-6 && (at_centre - 1.0).abs() < 1e-6 && freq_err < 0.005 && none);
}

#[test]
fn check_13_traversal_distribution() {
    let vpls = random_vpls(16, 19, random_normal);
    let tree = Sst::build_sequential(&sort_vpls(&vpls), Flatness { v_min: 2.0, sigma_max: 0.0 });
    let x = Surface { pos: Vec3::new(0.1, -3.0, 0.2), normal: Vec3::Y };
    // Expected: product of Eq. 5.4 probabilities along each path.
    let mut expected = HashMap::new();
    fn walk(tree: &Sst, node: u32, p: f64, x: &Surface, out: &mut HashMap<u32, f64>) {
        if tree.is_leaf(node) {
            out.insert(node, p);
            return;
        }
        let wl = weight(&tree.nodes[2 * node as usize], x, 1e-4) as f64;
        let wr = weight(&tree.nodes[2 * node as usize + 1], x, 1e-4) as f64;
        if wl + wr > 0.0 {
            walk(tree, 2 * node, p * wl / (wl + wr), x, out);
            walk(tree, 2 * node + 1, p * wr / (wl + wr), x, out);
        }
    }
    walk(&tree, 1, 1.0, &x, &mut expected);
    let mut rng = Rng::new(20, 0);
    let trials = 200_000;
    let mut freq: HashMap<u32, f64> = HashMap::new();
    let mut p_err = 0.0f64;
    for _ in 0..trials {
        if let Some((node, p)) = traverse(&tree, 1, &x, Some(f32::INFINITY), 1e-4, &mut rng).node {
            *freq.entry(node).or_default() += 1.0 / trials as f64;
            p_err = p_err.max((p as f64 - expected[&node]).abs());
        }
    }
    let worst = expected.iter().map(|(n, e)| (freq.get(n).copied().unwrap_or(0.0) - e).abs()).fold(0.0, f64::max);
    // Both children with w = 0: no sample.
    let mut dark = vpls.clone();
    dark.iter_mut().for_each(|v| v.color = Vec3::ZERO);
    let dark_tree = Sst::build_sequential(&dark, Flatness { v_min: 2.0, sigma_max: 0.0 });
    let none = traverse(&dark_tree, 1, &x, Some(f32::INFINITY), 1e-4, &mut rng).node.is_none();
    println!("terminal-node frequency vs Π Eq. 5.4: worst error {worst:.4}; returned P error {p_err:e}; zero weights → None: {none}");
    assert!(worst < 0.005 && p_err < 1e-5 && none);
}

/// Relative RMSE of `est` against `truth` (over pixels, luminance).
fn rel_rmse(est: &[Vec3], truth: &[Vec3]) -> f64 {
    let (mut se, mut s) = (0.0f64, 0.0f64);
    for (a, b) in est.iter().zip(truth) {
        se += (luminance(*a) as f64 - luminance(*b) as f64).powi(2);
        s += (luminance(*b) as f64).powi(2);
    }
    (se / s.max(1e-30)).sqrt()
}

fn mean_estimate(sampler: &Sampler, pixels: &[Shading], w: u32, rounds: u32, seed: u64) -> Vec<Vec3> {
    pixels
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let mut rng = Rng::new(seed, i as u64);
            let mut acc = Vec3::ZERO;
            for _ in 0..rounds {
                acc += sampler.pixel(i as u32 % w, i as u32 / w, s, &mut rng).0;
            }
            acc / rounds as f32
        })
        .collect()
}

#[test]
fn check_14_estimator_converges_to_the_brute_force_sum() {
    // (a) The built-in Cornell box, per-pixel cuts (k = 1), traversal to leaves (RTSLC).
    let mut scene = glimpse_scene::builtin::cornell();
    // Pixel centres: the bounds below were measured on those pixels (a statistical test).
    scene.film.filter = glimpse_scene::Filter::PixelCentre;
    let (w, h) = (24u32, 18u32);
    let ctx = FrameContext::new(&scene, 0.0, w, h);
    let g = ctx.gbuffer();
    let lp = LightcutsParams { vpl_count: 512, rsm_resolution: 128, ..Default::default() };
    let diag = ctx.frame.bounds.extent().length();
    let vp = lp.vpl_params(diag);
    let clamp2 = vp.clamp * vp.clamp;
    let set = vpl::generate(&ctx.frame, &ctx.tracer, &g, &vp, 5, 0);
    let tree = Sst::build_sequential(&sort_vpls(&set.vpls), Flatness { v_min: 2.0, sigma_max: 0.0 });
    let n = 8;
    let cuts = block_cuts(&tree, &g, w, h, &|x, y| (y * w + x) as usize, 1, n, clamp2);
    let pixels: Vec<(usize, Shading)> = (0..g.len()).filter_map(|i| Shading::from_gbuffer(&g, i).map(|s| (i, s))).collect();
    let truth: Vec<Vec3> = pixels.iter().map(|(_, s)| brute_force(&tree, &ctx.tracer, s, clamp2).0).collect();
    let sampler = Sampler {
        tree: &tree,
        vis: &ctx.tracer,
        cuts: Some(&cuts),
        strategy: Strategy::Rtslc,
        n,
        clamp2,
        similarity: vp.similarity,
        stop_ratio: f32::INFINITY,
        cluster_light: ClusterLight::Substitute,
    };
    let est = |rounds: u32, seed: u64| -> Vec<Vec3> {
        pixels
            .iter()
            .map(|(i, s)| {
                let mut rng = Rng::new(seed, *i as u64);
                (0..rounds).map(|_| sampler.pixel(*i as u32 % w, *i as u32 / w, s, &mut rng).0).sum::<Vec3>() / rounds as f32
            })
            .collect()
    };
    let (e1, e4) = (rel_rmse(&est(64, 99), &truth), rel_rmse(&est(256, 99), &truth));
    // The image sum from 1,024 rounds: the per-pixel estimates are heavy-tailed (a VPL close to
    // a receiver), so at 256 rounds one seed's sum was off by 1.6 % where three others were
    // within 0.5 % (after a change of ray offsets moved the VPLs by a few ulps).
    let total_est: f64 = est(1024, 7).iter().map(|v| luminance(*v) as f64).sum();
    let total_truth: f64 = truth.iter().map(|v| luminance(*v) as f64).sum();
    println!(
        "cornell, k = 1, leaves: rel. RMSE {e1:.4} (M = 64) → {e4:.4} (M = 256), ratio {:.2} (1/√M: 2); image sum {:.5} (M = 1024) vs {:.5}",
        e1 / e4,
        total_est,
        total_truth
    );
    // e4 over four seeds: 0.088–0.127.
    assert!(e4 < 0.14 && e1 / e4 > 1.5 && (total_est / total_truth - 1.0).abs() < 0.01);

    // (b) A planar receiver with 8×8 blocks and blending: still unbiased (§6.3 linearity).
    let (tree, floor, fw, fh) = floor_setup(1024);
    let leaf_tree = Sst { nodes: tree.nodes.iter().map(|n| SstNode { suitable: false, ..*n }).collect(), leaves: tree.leaves };
    let cuts = synthetic_cuts(&leaf_tree, &floor, fw, fh, 8, 8, 1e-4);
    let sim = Similarity { n_min: 0.9, d_max: 10.0 };
    let truth: Vec<Vec3> = floor.iter().map(|s| brute_force(&leaf_tree, &Unoccluded, s, 1e-4).0).collect();
    let sampler = Sampler {
        tree: &leaf_tree,
        vis: &Unoccluded,
        cuts: Some(&cuts),
        strategy: Strategy::Rtslc,
        n: 8,
        clamp2: 1e-4,
        similarity: sim,
        stop_ratio: f32::INFINITY,
        cluster_light: ClusterLight::Substitute,
    };
    let (b1, b4) =
        (rel_rmse(&mean_estimate(&sampler, &floor, fw, 100, 1), &truth), rel_rmse(&mean_estimate(&sampler, &floor, fw, 400, 1), &truth));
    // (c) Early termination on (the thesis' method): a fixed bias that does not vanish.
    let proposed = Sampler { tree: &tree, strategy: Strategy::Proposed, ..sampler };
    let cuts_p = synthetic_cuts(&tree, &floor, fw, fh, 8, 8, 1e-4);
    let proposed = Sampler { cuts: Some(&cuts_p), ..proposed };
    let (c1, c4) =
        (rel_rmse(&mean_estimate(&proposed, &floor, fw, 100, 2), &truth), rel_rmse(&mean_estimate(&proposed, &floor, fw, 400, 2), &truth));
    let bias: f64 = {
        let m = mean_estimate(&proposed, &floor, fw, 400, 2);
        m.iter().map(|v| luminance(*v) as f64).sum::<f64>() / truth.iter().map(|v| luminance(*v) as f64).sum::<f64>() - 1.0
    };
    // (d) Our stop rule (stop_ratio 0.1): flat clusters near the receiver are traversed on, so
    // the fixed bias of (c) shrinks.
    let near = Sampler { stop_ratio: glimpse_lightcuts::DEFAULT_STOP_RATIO, ..proposed };
    let d4 = rel_rmse(&mean_estimate(&near, &floor, fw, 400, 2), &truth);
    // (e) Ours (the default): a stopped cluster lights the point through one of its VPLs picked
    // ∝ intensity, so early termination, even under the thesis' rule, keeps the estimator
    // unbiased: the error falls as 1/√M like (b)'s, with no floor.
    let picked = Sampler { cluster_light: ClusterLight::Vpl, ..proposed };
    let (e1, e4) =
        (rel_rmse(&mean_estimate(&picked, &floor, fw, 100, 2), &truth), rel_rmse(&mean_estimate(&picked, &floor, fw, 400, 2), &truth));
    let picked_bias: f64 = {
        let m = mean_estimate(&picked, &floor, fw, 1600, 3);
        m.iter().map(|v| luminance(*v) as f64).sum::<f64>() / truth.iter().map(|v| luminance(*v) as f64).sum::<f64>() - 1.0
    };
    println!("floor, 8×8 blocks + blending, leaves: rel. RMSE {b1:.4} (M = 100) → {b4:.4} (M = 400), ratio {:.2}", b1 / b4);
    println!(
        "floor, early termination, clusters lit by a VPL picked ∝ intensity: rel. RMSE {e1:.4} → {e4:.4} (ratio {:.2}); image-sum bias {picked_bias:+.4} (M = 1600)",
        e1 / e4
    );
    println!(
        "floor, early termination (v_min 0.7, σ_max 0.3): rel. RMSE {c1:.4} → {c4:.4} (ratio {:.2}); image-sum bias {:+.4}",
        c1 / c4,
        bias
    );
    println!("floor, early termination with stop_ratio {}: rel. RMSE {d4:.4} (M = 400)", glimpse_lightcuts::DEFAULT_STOP_RATIO);
    assert!(b4 < 0.03 && b1 / b4 > 1.6);
    assert!(d4 < c4, "the receiver-relative stop should cut the early termination's error: {d4} vs {c4}");
    assert!(
        e1 / e4 > 1.6 && e4 < c4 && picked_bias.abs() < 0.01,
        "picking a cluster's VPL should be unbiased: {e1} → {e4}, bias {picked_bias}"
    );
}

#[test]
fn check_15_cluster_sampling() {
    let mut rng = Rng::new(21, 0);
    let leaf = SstNode::leaf(&Vpl { pos: Vec3::new(1.0, 2.0, 3.0), normal: Vec3::Y, color: Vec3::ONE, error_scale: 1.0 });
    assert_eq!(sample_point(&leaf, &mut rng), leaf.pos);
    let node = SstNode {
        bb_min: Vec3::splat(-100.0),
        bb_max: Vec3::splat(100.0),
        color: Vec3::ONE,
        pos: Vec3::new(0.5, -0.2, 0.1),
        normal: Vec3::new(0.3, 0.9, -0.1).normalize(),
        var: Vec3::new(0.04, 0.09, 0.0025),
        v: 1.0,
        suitable: true,
        error_scale: 100.0,
    };
    let f = node.frame();
    let m = 200_000;
    let (mut mean, mut sq) = (Vec3::ZERO.as_dvec3(), Vec3::ZERO.as_dvec3());
    for _ in 0..m {
        let l = f.to_local(sample_point(&node, &mut rng) - node.pos).as_dvec3();
        mean += l / m as f64;
        sq += l * l / m as f64;
    }
    let small = SstNode { bb_min: Vec3::new(0.4, -0.3, 0.0), bb_max: Vec3::new(0.6, 0.0, 0.2), ..node };
    let inside = (0..10_000).all(|_| {
        let p = sample_point(&small, &mut rng);
        p.cmpge(small.bb_min).all() && p.cmple(small.bb_max).all()
    });
    println!("node-frame sample mean {mean:?} (0), variance {sq:?} vs {:?}; small box: all inside {inside}", node.var);
    assert!(mean.abs().max_element() < 3e-3 && ((sq - node.var.as_dvec3()).abs() / node.var.as_dvec3()).max_element() < 0.02 && inside);
}

/// Mean traversal steps per sample of the three strategies at n = 32 on `scene`.
fn traversal_steps(scene: &Scene) -> [f64; 3] {
    let ctx = FrameContext::new(scene, 0.0, 64, 48);
    let g = ctx.gbuffer();
    let small = ["rsm_resolution=128", "direct_samples=1"];
    [Variant::Lightcuts, Variant::Sst, Variant::Rtslc].map(|v| {
        let (_, t) = render(v, 32, 3, &small, &ctx, &g);
        let r = t.report.as_ref().unwrap();
        assert_eq!(r.tree.levels(), 12, "4096 VPLs");
        r.steps_per_sample
    })
}

#[test]
fn check_16_traversal_step_ordering() {
    // The thesis' trend (Fig. 7.2): SST ≈ 2× and RTSLC ≈ 3× the proposed method's steps. The
    // proposed method must take the fewest; SST against RTSLC depends on how high in the tree
    // flat clusters appear (printed, not asserted: in the Cornell box SST takes more).
    for (name, scene) in [("cornell", glimpse_scene::builtin::cornell()), ("deforming", glimpse_scene::builtin::deforming())] {
        let s = traversal_steps(&scene);
        println!(
            "{name}: mean traversal steps per sample, 4096 VPLs (12 levels), n = 32: proposed {:.2}, SST {:.2} ({:.1}×), RTSLC {:.2} ({:.1}×) (thesis ≈ 2× and 3×)",
            s[0],
            s[1],
            s[1] / s[0],
            s[2],
            s[2] / s[0]
        );
        assert!(s[0] < s[1] && s[0] < s[2]);
    }
}

#[test]
fn check_17_upsampling() {
    let (w, h) = (8u32, 6u32);
    let n = (w * h) as usize;
    let low = |value: Vec<Vec3>| LowRes {
        width: w,
        height: h,
        value,
        position: (0..n).map(|i| Vec3::new((i as u32 % w) as f32 * 2.0, 0.0, (i as u32 / w) as f32 * 2.0)).collect(),
        normal: (0..n).map(|i| if i as u32 % w < 4 { Vec3::Y } else { Vec3::X }).collect(),
        valid: vec![true; n],
    };
    let sim = Similarity { n_min: 0.9, d_max: 100.0 };
    let c = low(vec![Vec3::splat(0.25); n]);
    let step = low((0..n).map(|i| if i as u32 % w < 4 { Vec3::ONE } else { Vec3::splat(9.0) }).collect());
    let (mut worst_c, mut leak) = (0.0f32, 0.0f32);
    for y in 0..2 * h {
        for x in 0..2 * w {
            let n_full = if x / 2 < 4 { Vec3::Y } else { Vec3::X };
            let p = Vec3::new(x as f32, 0.0, y as f32);
            worst_c = worst_c.max((upsample_pixel(&c, x, y, p, n_full, sim) - Vec3::splat(0.25)).abs().max_element());
            let expect = if x / 2 < 4 { 1.0 } else { 9.0 };
            leak = leak.max((upsample_pixel(&step, x, y, p, n_full, sim) - Vec3::splat(expect)).abs().max_element());
        }
    }
    println!("constant upsampled: worst change {worst_c:e}; across an S = 0 normal seam: worst leak {leak:e}");
    assert!(worst_c < 1e-6 && leak < 1e-6);
}

#[test]
fn check_18_rmse_trends_against_vpl_exact() {
    let scene = glimpse_scene::builtin::cornell();
    let ctx = FrameContext::new(&scene, 0.0, 64, 48);
    let g = ctx.gbuffer();
    let small = ["rsm_resolution=128", "vpl_count=1024", "direct_samples=1"];
    // One RMSE varies 2× from seed to seed at this size, so the mean over 3 seeds is compared;
    // the VPLs are the seed's, so each seed has its own truth.
    let seeds = [4u64, 5, 6];
    let truths: Vec<Image> = seeds.iter().map(|&seed| render(Variant::Exact, 1, seed, &small, &ctx, &g).0).collect();
    let mut table = Vec::new();
    for n in [8u32, 32] {
        let mut row = Vec::new();
        for v in [Variant::Lightcuts, Variant::Rtslc, Variant::Sst] {
            let total: f64 =
                seeds.iter().zip(&truths).map(|(&seed, truth)| rmse(&render(v, n, seed, &small, &ctx, &g).0, truth, None).unwrap()).sum();
            row.push(total / seeds.len() as f64);
        }
        table.push(row);
    }
    println!(
        "mean RMSE over 3 seeds vs vpl-exact (64×48 cornell, 1024 VPLs): [proposed, RTSLC, SST] n=8 {:.5?}, n=32 {:.5?}",
        table[0], table[1]
    );
    for row in &table {
        assert!(row[0] < row[2], "proposed below SST at equal sample count");
        assert!(row[0] < 1.5 * row[1], "proposed close to RTSLC");
    }
    for (hi, lo) in table[1].iter().zip(&table[0]) {
        assert!(hi < lo, "RMSE decreases as n grows");
    }
}

#[test]
fn bad_parameters_are_errors_not_panics() {
    for bad in ["vpl_count=1000", "rsm_resolution=300", "v_min=nan", "block=0", "clamp=-1", "stop_ratio=0", "stop_ratio=nan"] {
        let e = VplTechnique::new(Variant::Lightcuts, &Settings::default(), &params(&[bad])).err().map(|e| e.to_string());
        println!("{bad}: {e:?}");
        assert!(e.is_some());
    }
    let e = VplTechnique::new(Variant::Lightcuts, &Settings { spp: 0, seed: 0 }, &params(&[])).err().map(|e| e.to_string());
    assert!(e.is_some());
    let none = Scene { name: "dark".into(), ..Default::default() };
    let r = (VplTechnique::info(Variant::Exact).create)(&none, &Settings::default(), &params(&[]));
    println!("scene without lights: {:?}", r.as_ref().err().map(|e| e.to_string()));
    assert!(r.is_err());
}

#[test]
fn same_seed_same_vpls_in_every_technique() {
    let scene = glimpse_scene::builtin::cornell();
    let ctx = FrameContext::new(&scene, 0.0, 32, 24);
    let g = ctx.gbuffer();
    let small = ["rsm_resolution=64", "vpl_count=256"];
    let (_, a) = render(Variant::Exact, 1, 9, &small, &ctx, &g);
    let (img_b, b) = render(Variant::Lightcuts, 4, 9, &small, &ctx, &g);
    let (img_b2, _) = render(Variant::Lightcuts, 4, 9, &small, &ctx, &g);
    let (_, c) = render(Variant::Lightcuts, 4, 10, &small, &ctx, &g);
    let repeat = img_b.pixels == img_b2.pixels;
    println!("same command twice → the same image: {repeat}");
    assert!(repeat);
    let same = a.report.as_ref().unwrap().vpls.vpls == b.report.as_ref().unwrap().vpls.vpls;
    let differ = a.report.as_ref().unwrap().vpls.vpls != c.report.as_ref().unwrap().vpls.vpls;
    println!("vpl-exact and vpl-lightcuts share the seed's VPLs: {same}; another seed differs: {differ}");
    assert!(same && differ);
}

#[test]
fn vpls_from_every_light_kind_share_the_budget_by_power() {
    // The Cornell box without its area light, lit by a point, a spot and a directional light,
    // then the built-in box with its area light.
    let mut s = spot_room();
    s.lights.push(Light::point(Vec3::new(0.4, 0.4, 0.3), Vec3::splat(0.5)));
    s.lights.push(Light::directional(Vec3::new(0.2, -1.0, -0.3), Vec3::splat(0.5)));
    let ctx = FrameContext::new(&s, 0.0, 32, 32);
    let g = ctx.gbuffer();
    let p = LightcutsParams { vpl_count: 1024, rsm_resolution: 64, ..Default::default() }.vpl_params(ctx.frame.bounds.extent().length());
    let set = vpl::generate(&ctx.frame, &ctx.tracer, &g, &p, 3, 0);
    let lights = glimpse_render::rsm::rsm_lights(&ctx.frame, &mut Rng::new(0, 0));
    let power: Vec<f32> = lights.iter().map(vpl::light_power).collect();
    let total: f32 = power.iter().sum();
    let share: Vec<f32> = power.iter().map(|w| 1024.0 * w / total).collect();
    println!(
        "spot, point, directional: VPLs per light {:?} (power shares {share:.1?}); Σ VPL flux / Σ pVPL flux {:.3}",
        set.per_light,
        luminance(set.vpls.iter().map(|v| v.color).sum::<Vec3>()) / luminance(set.pvpl_flux)
    );
    assert_eq!(set.per_light.iter().sum::<u32>(), 1024);
    assert_eq!(set.vpls.len(), 1024);
    for (n, e) in set.per_light.iter().zip(&share) {
        assert!((*n as f32 - e).abs() <= 1.0);
    }
    let mut start = 0usize;
    for (k, n) in set.per_light.iter().enumerate() {
        let flux: f32 = set.vpls[start..start + *n as usize].iter().map(|v| luminance(v.color)).sum();
        println!("light {k}: {n} VPLs, Σ flux {flux:.4}");
        assert!(flux > 0.0);
        start += *n as usize;
    }
    let area = glimpse_scene::builtin::cornell();
    let ctx = FrameContext::new(&area, 0.0, 32, 32);
    let g = ctx.gbuffer();
    let set = vpl::generate(&ctx.frame, &ctx.tracer, &g, &p, 3, 0);
    let flux = luminance(set.vpls.iter().map(|v| v.color).sum::<Vec3>());
    println!(
        "area light (RSM from one seeded point): {} VPLs, Σ flux {flux:.4} vs Σ pVPL flux {:.4}",
        set.vpls.len(),
        luminance(set.pvpl_flux)
    );
    assert!(flux > 0.0 && (flux / luminance(set.pvpl_flux) - 1.0).abs() < 0.25);
}

/// `rsm_resolution=auto` (the default) sizes each light's RSM by the VPLs it gets at the thesis'
/// 64 texels per VPL (its one light: 512² for 4,096); a number or `profile=paper` gives every
/// light that size.
#[test]
fn rsm_size_follows_each_lights_vpls() {
    let rsm_resolution_for = vpl::rsm_resolution_for;
    assert_eq!(rsm_resolution_for(4096, 512), 512);
    assert_eq!(rsm_resolution_for(1024, 512), 256);
    assert_eq!(rsm_resolution_for(100, 512), 128);
    assert_eq!(rsm_resolution_for(1, 512), 16);
    assert_eq!(rsm_resolution_for(1 << 20, 512), 512);
    let read = |pairs: &[&str]| LightcutsParams::read(&params(pairs), Variant::Lightcuts).unwrap();
    assert!(read(&[]).rsm_per_light);
    assert!(!read(&["rsm_resolution=256"]).rsm_per_light && read(&["rsm_resolution=256"]).rsm_resolution == 256);
    assert!(!read(&["profile=paper"]).rsm_per_light && read(&["profile=paper"]).rsm_resolution == 512);
    // Two lights: the dimmer one's map is smaller, so the per-light working set shrinks.
    let mut scene = glimpse_scene::builtin::cornell_lit();
    scene.lights.truncate(2);
    scene.lights[1].intensity *= 0.05;
    let ctx = FrameContext::new(&scene, 0.0, 32, 24);
    let g = ctx.gbuffer();
    let diag = ctx.frame.bounds.extent().length();
    let generate = |pairs: &[&str]| vpl::generate(&ctx.frame, &ctx.tracer, &g, &read(pairs).vpl_params(diag), 3, 0);
    let (auto, fixed) = (generate(&["vpl_count=1024"]), generate(&["vpl_count=1024", "rsm_resolution=512"]));
    println!("VPLs per light {:?}; largest working set {} vs {} bytes", auto.per_light, auto.memory_bytes, fixed.memory_bytes);
    assert_eq!(auto.per_light, fixed.per_light);
    assert!(auto.memory_bytes < fixed.memory_bytes / 2);
}
