//! The on-disk cache of a static scene's compressed array (`glimpse_voxarray::disk_cache`): a
//! stored array loads back answering every query as the built one does, and a corrupt, truncated,
//! foreign or mismatched file is refused (and deleted), never used.

use glimpse_core::cache_file;
use glimpse_core::{Ray, Rng, Vec3};
use glimpse_trace::Visibility;
use glimpse_voxarray::disk_cache::{self, FORMAT};
use glimpse_voxarray::{CompressParams, VoxArray, VoxArrayParams};

fn triangles() -> Vec<[Vec3; 3]> {
    let mut rng = Rng::new(5, 0);
    let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
    (0..60)
        .map(|_| {
            let c = v() * 0.7;
            [c + v() * 0.3, c + v() * 0.3, c + v() * 0.3]
        })
        .collect()
}

fn params() -> VoxArrayParams {
    VoxArrayParams {
        resolution: 32,
        directions: 8,
        compress: Some(CompressParams { dictionary_rows: 256, ..Default::default() }),
        ..Default::default()
    }
}

/// A fresh folder, removed when the test ends (also when it fails).
fn dir(test: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("glimpse-voxcache-{test}-")).tempdir().unwrap()
}

fn answers(a: &VoxArray) -> Vec<bool> {
    let mut rng = Rng::new(9, 1);
    (0..4000)
        .map(|_| {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
            let d = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0).normalize_or(Vec3::Y);
            a.occluded(&Ray::new(p, d), 1.5)
        })
        .collect()
}

#[test]
fn a_stored_array_loads_back_with_the_same_answers() {
    let (tris, p) = (triangles(), params());
    let built = VoxArray::from_triangles(&tris, &p);
    let tmp = dir("roundtrip");
    let dir = tmp.path();
    let path = disk_cache::path_for(dir, &tris, None, &p);
    assert!(disk_cache::store(&path, &built).unwrap(), "a compressed array is stored");
    let loaded = disk_cache::load(&path, &p).expect("the stored array loads");
    let (a, b) = (answers(&built), answers(&loaded));
    println!(
        "{} queries, {} occluded; loaded array differs in {}",
        a.len(),
        a.iter().filter(|&&x| x).count(),
        a.iter().zip(&b).filter(|(x, y)| x != y).count()
    );
    assert_eq!(a, b);
    assert_eq!(built.memory_bytes(), loaded.memory_bytes());
    // Other triangles or other parameters are another file.
    let mut moved = tris.clone();
    moved[0][0].x += 1e-3;
    assert_ne!(disk_cache::path_for(dir, &moved, None, &p), path);
    assert_ne!(disk_cache::path_for(dir, &tris, None, &VoxArrayParams { directions: 10, ..p }), path);
    // A plain array is not cached (2 GiB at the defaults).
    let plain = VoxArray::from_triangles(&tris, &VoxArrayParams { compress: None, ..p });
    assert!(!disk_cache::store(&dir.join("plain.bin"), &plain).unwrap());
}

#[test]
fn bad_cache_files_are_refused_and_deleted() {
    let (tris, p) = (triangles(), params());
    let built = VoxArray::from_triangles(&tris, &p);
    let tmp = dir("bad");
    let path = tmp.path().join("a.bin");
    disk_cache::store(&path, &built).unwrap();
    let good = std::fs::read(&path).unwrap();
    let payload = cache_file::decode(FORMAT, &path, &good).unwrap();

    let mut cases: Vec<(&str, Vec<u8>)> = Vec::new();
    let mut flipped = good.clone();
    let k = good.len() / 2;
    flipped[k] ^= 0x10;
    cases.push(("a flipped bit (checksum)", flipped));
    cases.push(("truncated", good[..good.len() - 100].to_vec()));
    cases.push(("foreign magic", {
        let mut g = good.clone();
        g[..8].copy_from_slice(b"WAVECACH");
        g
    }));
    // Valid checksums around invalid content: re-encoded payloads.
    let reencode = |f: &dyn Fn(&mut Vec<u8>)| {
        let mut p = payload.clone();
        f(&mut p);
        cache_file::encode(FORMAT, &p)
    };
    cases.push(("another resolution", reencode(&|p| p[..4].copy_from_slice(&64u32.to_le_bytes()))));
    cases.push(("a NaN grid centre", reencode(&|p| p[8..12].copy_from_slice(&f32::NAN.to_le_bytes()))));
    // A dictionary cut down to its first row: the packed indices now point past its end.
    // (index_bits sits after 2 u32 + 7 f32 + 1 byte = 37 bytes, then rows u64, length u64.)
    cases.push((
        "an index outside the dictionary",
        reencode(&|p| {
            let len = u64::from_le_bytes(p[49..57].try_into().unwrap()) as usize;
            assert!(len > 1, "the test needs a dictionary of several rows");
            p[49..57].copy_from_slice(&1u64.to_le_bytes());
            p.drain(57 + 16..57 + 16 * len);
        }),
    ));
    // A length far past the file's end is refused before anything is allocated for it.
    cases.push((
        "a dictionary of 2³² rows in a small file",
        reencode(&|p| {
            p[37..41].copy_from_slice(&32u32.to_le_bytes());
            p[49..57].copy_from_slice(&(1u64 << 32).to_le_bytes());
        }),
    ));
    cases.push(("trailing bytes", reencode(&|p| p.extend_from_slice(&[0; 3]))));
    for (what, bytes) in cases {
        std::fs::write(&path, &bytes).unwrap();
        assert!(disk_cache::load(&path, &p).is_none(), "{what}: used");
        assert!(!path.exists(), "{what}: the bad file is still there");
        println!("{what}: refused and deleted");
    }
    // The right file for other parameters is refused too (and rebuilt by the caller).
    std::fs::write(&path, &good).unwrap();
    assert!(disk_cache::load(&path, &VoxArrayParams { directions: 10, ..p }).is_none());
}
