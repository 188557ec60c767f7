//! Issue #15, item 1: no corrupt or crafted wavecache file may panic, hang or give a silently
//! wrong image. A small real cache file is mutated many ways (bit flips, truncations, u32 fields
//! set to wrapping values, self-referencing octree and Haar nodes):
//! - as a file on disk, every mutation is rejected (and the file deleted), or it loads back
//!   equal to the original, so its image is bit-identical;
//! - with the checksum recomputed (a crafted file), the structural validation rejects it, or the
//!   cache renders a frame without panicking (indices in range, finite, terminating).
//!
//! Then end to end: a corrupted file in the disk cache is replaced by a rebuild, and the image is
//! bit-identical to the first run's. One test function, because it sets `GLIMPSE_CACHE` (the
//! environment must not change while another test thread reads it).

use glimpse_core::Rng;
use glimpse_core::cache_file::{self, HEADER_BYTES};
use glimpse_render::{FrameContext, Settings, Technique};
use glimpse_trace::GBuffer;
use glimpse_wavecache::bake::CachePoint;
use glimpse_wavecache::haar::{HaarNode, TreeRef};
use glimpse_wavecache::points::OctNode;
use glimpse_wavecache::technique::{Runtime, ShadePoint};
use glimpse_wavecache::{EnvDirect, WaveCache, Wavecache, WavecacheParams};
use std::path::Path;

fn params() -> WavecacheParams {
    WavecacheParams {
        brdf_grid_u1: 4,
        brdf_grid_u2: 8,
        brdf_res: 8,
        map_scale: 8,
        texel_samples: 1,
        irradiance_samples: 16,
        diffuse_points: 60,
        path_floor: 0,
        glossy_points: 40,
        disk_cache: false,
        progress: false,
        // The glossy maps also get environment visibility maps, so their arrays are mutated too.
        env_direct: EnvDirect::On,
        ..WavecacheParams::default()
    }
}

/// Shades every pixel with `cache` through the runtime (what `render` does), so any index a
/// mutated cache holds is exercised.
fn shade_all(cache: &WaveCache, p: &WavecacheParams, ctx: &FrameContext, g: &GBuffer) -> Vec<glimpse_core::Vec3> {
    let rt = Runtime::new(cache, p, &ctx.frame, &ctx.tracer);
    (0..g.position.len())
        .filter(|&i| g.instance[i] != glimpse_trace::gbuffer::NO_HIT)
        .map(|i| rt.shade(&ShadePoint::at_pixel(g, i), -g.view_dir[i], 0, &mut glimpse_core::Rng::new(i as u64, 0)).0)
        .collect()
}

/// Byte offset (in the payload) of each array's body and its length, in file order.
fn sections(payload: &[u8]) -> Vec<(usize, usize)> {
    let mut at = 8;
    let mut out = Vec::new();
    while at < payload.len() {
        let len = u64::from_le_bytes(payload[at..at + 8].try_into().unwrap()) as usize;
        out.push((at + 8, len));
        at += 8 + len;
    }
    out
}

const BRDF_BLACK: usize = 1;
const BRDF_BASE: usize = 2;
const BRDF_TREES: usize = 3;
const BRDF_NODES: usize = 4;
const MESHES: usize = 6;
const OCTREE: usize = 7;
const POINTS: usize = 8;
const IRRADIANCE: usize = 9;
const RADIANCE_TREES: usize = 10;
const RADIANCE_NODES: usize = 11;
const VISIBILITY_FIRST: usize = 12;

fn set_u32(b: &mut [u8], at: usize, v: u32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

#[test]
fn mutated_cache_files_are_rejected_or_harmless() {
    let scene = glimpse_scene::load("glossy").unwrap();
    let ctx = FrameContext::new(&scene, 0.0, 12, 9);
    let g = ctx.gbuffer();
    let p = params();
    let key = glimpse_wavecache::cache::cache_key(&ctx.frame, &p, 1);
    let original = WaveCache::build(&ctx.frame, &ctx.tracer, &p, 1, key, &|_| {}).unwrap();
    let reference = shade_all(&original, &p, &ctx, &g);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().to_path_buf();
    let path = dir.join("cache.bin");
    original.save(&path).unwrap();
    let file = std::fs::read(&path).unwrap();
    let payload = original.to_payload();
    let secs = sections(&payload);
    println!(
        "cache file: {} bytes, {} octree nodes, {} points, {} radiance nodes, {} visibility bytes",
        file.len(),
        original.octree.len(),
        original.points.len(),
        original.radiance_nodes.len(),
        original.env_visibility.len()
    );
    assert!(!original.env_visibility.is_empty(), "the mutated cache must hold visibility maps");

    // 1. Raw mutations of the file: rejected and deleted, or equal to the original.
    let mut rng = Rng::new(15, 1);
    let wraps = [u32::MAX, u32::MAX - 1, 0x8000_0000, 0x7fff_ffff, 0, 1, 3];
    let (mut rejected, mut identical) = (0, 0);
    let raw_cases = 400;
    for case in 0..raw_cases {
        let mut m = file.clone();
        match case % 4 {
            0 => {
                let bit = (rng.next_f32() * (m.len() * 8) as f32) as usize % (m.len() * 8);
                m[bit / 8] ^= 1 << (bit % 8);
            }
            1 => m.truncate((rng.next_f32() * m.len() as f32) as usize),
            2 => {
                let at = (rng.next_f32() * (m.len() - 4) as f32) as usize & !3;
                set_u32(&mut m, at, wraps[case / 4 % wraps.len()]);
            }
            _ => {
                // A few random bytes anywhere, header included.
                for _ in 0..1 + case % 5 {
                    let at = (rng.next_f32() * m.len() as f32) as usize % m.len();
                    m[at] = (rng.next_f32() * 256.0) as u8;
                }
            }
        }
        std::fs::write(&path, &m).unwrap();
        match WaveCache::load_or_discard(&path, key) {
            None => {
                rejected += 1;
                assert!(!path.exists(), "case {case}: a rejected file is deleted");
            }
            Some(c) => {
                assert_eq!(c, original, "case {case}: a mutated file was accepted with different content");
                identical += 1;
            }
        }
    }
    println!("raw mutations: {raw_cases} cases, {rejected} rejected and deleted, {identical} identical, 0 panics");
    assert_eq!(rejected + identical, raw_cases);

    // 2. Crafted files (checksum recomputed): structural validation or a harmless render.
    let mut crafted: Vec<(String, Vec<u8>)> = Vec::new();
    let field = |sec: usize, elem_bytes: usize, index: usize, offset: usize| secs[sec].0 + index * elem_bytes + offset;
    let count = |sec: usize, elem_bytes: usize| secs[sec].1 / elem_bytes;
    let (oct, haar, tree, mesh, point) = (
        size_of::<OctNode>(),
        size_of::<HaarNode>(),
        size_of::<TreeRef>(),
        size_of::<glimpse_wavecache::bake::MeshCache>(),
        size_of::<CachePoint>(),
    );
    // Every u32 field of every structure with index meaning, set to wrapping values.
    let u32_fields: Vec<(usize, usize, usize, &str)> = vec![
        (OCTREE, oct, 36, "octree first_child"),
        (OCTREE, oct, 40, "octree child_count"),
        (OCTREE, oct, 44, "octree first_point"),
        (OCTREE, oct, 48, "octree point_count"),
        (BRDF_NODES, haar, 24, "BRDF haar first_child"),
        (RADIANCE_NODES, haar, 24, "radiance haar first_child"),
        (BRDF_TREES, tree, 0, "BRDF tree first"),
        (BRDF_TREES, tree, 4, "BRDF tree count"),
        (BRDF_TREES, tree, 8, "BRDF tree levels"),
        (RADIANCE_TREES, tree, 0, "radiance tree first"),
        (RADIANCE_TREES, tree, 4, "radiance tree count"),
        (RADIANCE_TREES, tree, 8, "radiance tree levels"),
        (RADIANCE_TREES, tree, 12, "radiance tree depth"),
        (MESHES, mesh, 4, "mesh material"),
        (MESHES, mesh, 8, "mesh first_node"),
        (MESHES, mesh, 12, "mesh node_count"),
        (MESHES, mesh, 16, "mesh first_point"),
        (MESHES, mesh, 20, "mesh point_count"),
        (POINTS, point, 40, "point payload"),
        (VISIBILITY_FIRST, 4, 0, "visibility map offset"),
        (0, 16, 0, "BRDF table n_u1"),
        (0, 16, 4, "BRDF table n_u2"),
        (0, 16, 12, "BRDF table first_tree"),
        (BRDF_BLACK, 16, 8, "black-base BRDF table res"),
        (BRDF_BLACK, 16, 12, "black-base BRDF table first_tree"),
    ];
    for &(sec, size, off, name) in &u32_fields {
        let n = count(sec, size);
        for k in 0..n.min(6) {
            let index = if k < 3 { k } else { n - 1 - (k - 3) };
            for &v in &wraps {
                let mut b = payload.clone();
                set_u32(&mut b, field(sec, size, index, off), v);
                crafted.push((format!("{name}[{index}] = {v:#x}"), b));
            }
        }
    }
    // Self-referencing and cyclic nodes.
    for i in 0..count(OCTREE, oct).min(8) {
        let mut b = payload.clone();
        set_u32(&mut b, field(OCTREE, oct, i, 36), i as u32);
        set_u32(&mut b, field(OCTREE, oct, i, 40), 1);
        crafted.push((format!("octree node {i} is its own child"), b));
    }
    for i in 1..count(RADIANCE_NODES, haar).min(8) {
        let mut b = payload.clone();
        set_u32(&mut b, field(RADIANCE_NODES, haar, i, 24), 0);
        crafted.push((format!("radiance node {i}'s children start at the root"), b));
    }
    // Non-finite floats: octree bounds, point positions, fp16 infinity in Haar and irradiance.
    for (sec, at, name) in
        [(BRDF_BASE, 0, "BRDF table base colour"), (OCTREE, 0, "octree min"), (POINTS, 0, "point position"), (POINTS, 36, "point energy")]
    {
        let mut b = payload.clone();
        b[field(sec, 0, 0, at)..][..4].copy_from_slice(&f32::NAN.to_le_bytes());
        crafted.push((format!("{name} = NaN"), b));
    }
    for (sec, name) in [(RADIANCE_NODES, "radiance C"), (IRRADIANCE, "irradiance")] {
        let mut b = payload.clone();
        b[secs[sec].0..][..2].copy_from_slice(&0x7c00u16.to_le_bytes());
        crafted.push((format!("{name} = +inf (fp16)"), b));
    }
    // Random bit flips with the checksum fixed.
    for _ in 0..300 {
        let mut b = payload.clone();
        let bit = (rng.next_f32() * (b.len() * 8) as f32) as usize % (b.len() * 8);
        b[bit / 8] ^= 1 << (bit % 8);
        crafted.push(("random bit flip".into(), b));
    }
    let (mut refused, mut rendered) = (0, 0);
    for (name, b) in &crafted {
        // Through the real reader: a file with a valid header and checksum.
        std::fs::write(&path, cache_file::encode(WaveCache::FORMAT, b)).unwrap();
        assert!(std::fs::read(&path).unwrap().len() >= HEADER_BYTES);
        match WaveCache::load(Path::new(&path), key) {
            Err(_) => refused += 1,
            Ok(c) => {
                let img = shade_all(&c, &p, &ctx, &g);
                assert_eq!(img.len(), reference.len(), "{name}");
                rendered += 1;
            }
        }
    }
    println!(
        "crafted (checksum-valid) mutations: {} cases, {refused} refused by validation, {rendered} rendered without a panic",
        crafted.len()
    );
    assert!(refused > crafted.len() / 2, "most index mutations must be caught");

    // 3. End to end: the technique with a disk cache; a corrupt file is rebuilt, same image.
    // SAFETY: this binary's only test; nothing else reads the environment concurrently.
    unsafe { std::env::set_var("GLIMPSE_CACHE", &dir) };
    let p_disk = WavecacheParams { disk_cache: true, ..params() };
    let run = || {
        let mut t = Wavecache::with_params(&Settings { spp: 1, seed: 1 }, p_disk.clone());
        t.prepare(&ctx).unwrap();
        let mut img = ctx.image();
        t.render(&ctx, &g, &mut img).unwrap();
        img
    };
    let first = run();
    let disk_path = WaveCache::path_for(glimpse_wavecache::cache::cache_key(&ctx.frame, &p_disk, 1)).unwrap();
    let mut bytes = std::fs::read(&disk_path).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x10;
    std::fs::write(&disk_path, &bytes).unwrap();
    let second = run();
    assert!(first.pixels == second.pixels, "the rebuilt cache renders the same image");
    assert!(WaveCache::load(&disk_path, glimpse_wavecache::cache::cache_key(&ctx.frame, &p_disk, 1)).is_ok(), "the file was rewritten");
    println!("end to end: a corrupt disk cache was replaced and the image is bit-identical");
}
