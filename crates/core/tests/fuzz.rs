//! Fuzzing on stable Rust (issue #15): proptest-driven structured mutations
//! ([`glimpse_core::mutate`]) of small HDR, EXR and PNG files through [`Image::read`], and of a
//! cache file through [`cache_file::decode`]. Every case is read or refused with an error naming
//! the file; a panic fails the test. Cases per target: `GLIMPSE_FUZZ_CASES` (default 1000).

use glimpse_core::cache_file::{self, CacheFormat};
use glimpse_core::mutate::{self, Mutation};
use glimpse_core::{Image, ToneMap, Vec3};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::path::Path;

fn cases() -> u32 {
    std::env::var("GLIMPSE_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(1000)
}

fn mutations() -> impl Strategy<Value = Vec<Mutation>> {
    prop::collection::vec((0..mutate::KINDS, any::<u32>(), any::<u32>()).prop_map(|(kind, at, value)| Mutation { kind, at, value }), 1..6)
}

fn runner() -> TestRunner {
    TestRunner::new(Config { cases: cases(), failure_persistence: None, ..Config::default() })
}

/// A fresh folder, removed when the test ends (also when it fails).
fn temp_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("glimpse-{name}-")).tempdir().unwrap()
}

fn fuzz_image(ext: &str) {
    let tmp = temp_dir(&format!("fuzz-image-{ext}"));
    let dir = tmp.path();
    let seed_path = dir.join(format!("seed.{ext}"));
    Image::from_fn(5, 3, |x, y| Vec3::new(x as f32 * 0.3, y as f32 * 2.0, 0.25)).write(&seed_path, ToneMap::default()).unwrap();
    let seed = std::fs::read(&seed_path).unwrap();
    let path = dir.join(format!("fuzz.{ext}"));
    let (mut ok, mut refused) = (0, 0);
    let result = runner().run(&mutations(), |m| {
        std::fs::write(&path, mutate::mutated(&seed, &m)).unwrap();
        match Image::read(&path) {
            Ok(img) => prop_assert_eq!(img.pixels.len(), (img.width * img.height) as usize),
            Err(e) => prop_assert!(e.to_string().contains("fuzz."), "error does not name the file: {}", e),
        }
        Ok(())
    });
    // Count outside the runner (its closure must be Fn).
    for k in 0..cases().min(200) {
        let m = [Mutation { kind: (k % 8) as u8, at: k * 7919, value: k * 31 }];
        std::fs::write(&path, mutate::mutated(&seed, &m)).unwrap();
        if Image::read(&path).is_ok() { ok += 1 } else { refused += 1 }
    }
    println!("{ext}: {} proptest cases + {} fixed ({ok} read, {refused} refused), 0 panics", cases(), ok + refused);
    if let Err(e) = result {
        panic!("{ext}: {e}");
    }
}

#[test]
fn fuzz_hdr() {
    fuzz_image("hdr");
}

#[test]
fn fuzz_exr() {
    fuzz_image("exr");
}

#[test]
fn fuzz_png() {
    fuzz_image("png");
}

#[test]
fn fuzz_cache_file() {
    let format = CacheFormat { magic: *b"FUZZCACH", version: 1 };
    let payload: Vec<u8> = (0..300u32).flat_map(|i| i.wrapping_mul(2654435761).to_le_bytes()).collect();
    let file = cache_file::encode(format, &payload);
    let result = runner().run(&mutations(), |m| {
        let data = mutate::mutated(&file, &m);
        match cache_file::decode(format, Path::new("fuzz.bin"), &data) {
            // Accepted only when the bytes that matter are the original ones.
            Ok(p) => prop_assert_eq!(p, payload.clone()),
            Err(e) => prop_assert!(e.to_string().contains("fuzz.bin")),
        }
        Ok(())
    });
    println!("cache file: {} cases, every accepted payload identical to the original, 0 panics", cases());
    if let Err(e) = result {
        panic!("{e}");
    }
}

/// A header whose data window claims a huge layer is refused before decoding: the EXR decoder
/// sizes each block's output from the header, and the fuzz test once found a header that made
/// it request 36 GiB (an abort, not an error).
#[test]
fn exr_with_a_huge_data_window_is_refused_not_aborted() {
    let dir = temp_dir("exr-window");
    let path = dir.path().join("window.exr");
    Image::from_fn(5, 3, |x, y| Vec3::new(x as f32, y as f32, 0.5)).write(&path, ToneMap::default()).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    // dataWindow: name, type "box2i", size 16, then xMin, yMin, xMax, yMax (i32, little endian).
    let at = bytes.windows(11).position(|w| w == b"dataWindow\0").expect("a dataWindow attribute") + 11 + 6 + 4;
    // xMax only: still one chunk of 16 scan lines (so the chunk count matches), 1G pixels wide.
    bytes[at + 8..at + 12].copy_from_slice(&0x3fff_fff0i32.to_le_bytes());
    std::fs::write(&path, &bytes).unwrap();
    let e = Image::read(&path).expect_err("a 1G-pixel-wide layer is refused");
    println!("{e}");
    assert!(e.to_string().contains("window.exr"), "{e}");
}
