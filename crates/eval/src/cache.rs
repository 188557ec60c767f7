//! Reference images cached on disk, keyed by a hash of everything that determines them: the
//! scene (its name, or its file's path, size and modification time), the technique and its
//! effective parameters, the image size, samples, seed, time and glimpse's version. A rerun of
//! `glimpse eval` then skips the slow references.
//!
//! Each image is one [`glimpse_core::cache_file`] (magic, version, XXH3 checksum): its payload is
//! width and height (u32 LE) then the linear f32 RGB pixels, validated (size matches, every value
//! finite) before use. A bad file is reported in one warning line, deleted and rendered again.

use glimpse_core::cache_file::{self, CacheFormat};
use glimpse_core::{Image, Vec3};
use std::hash::{DefaultHasher, Hash, Hasher};
use std::path::PathBuf;

const FORMAT: CacheFormat = CacheFormat { magic: *b"GLREFIMG", version: 1 };
/// 16384² RGB f32 plus the header: the largest frame the CLI accepts.
const MAX_BYTES: u64 = 16384 * 16384 * 12 + 64;

#[derive(Clone, Debug)]
pub struct Cache {
    pub dir: Option<PathBuf>,
}

impl Cache {
    /// [`glimpse_render::cache_dir`].
    pub fn default_dir() -> Option<PathBuf> {
        glimpse_render::cache_dir()
    }

    pub fn disabled() -> Self {
        Self { dir: None }
    }

    pub fn key(parts: &[&str], scene_spec: &str) -> String {
        let mut h = DefaultHasher::new();
        env!("CARGO_PKG_VERSION").hash(&mut h);
        glimpse_render::RESULTS_REVISION.hash(&mut h);
        parts.hash(&mut h);
        scene_spec.hash(&mut h);
        if let Ok(meta) = std::fs::metadata(scene_spec) {
            meta.len().hash(&mut h);
            if let Ok(t) = meta.modified() {
                t.hash(&mut h);
            }
        }
        format!("{:016x}", h.finish())
    }

    fn path(&self, key: &str) -> Option<PathBuf> {
        self.dir.as_ref().map(|d| d.join(format!("ref-{key}.bin")))
    }

    pub fn load(&self, key: &str) -> Option<Image> {
        let p = self.path(key)?;
        cache_file::load_or_discard(&p, FORMAT, MAX_BYTES, decode)
    }

    /// Best effort: a cache that cannot be written only costs time. The write is atomic
    /// (temporary file, sync, rename) and clears stale temporaries from the folder.
    pub fn store(&self, key: &str, image: &Image) {
        if let Some(p) = self.path(key) {
            let _ = cache_file::write(&p, FORMAT, &encode(image));
        }
    }
}

fn encode(image: &Image) -> Vec<u8> {
    let mut out = Vec::with_capacity(8 + image.pixels.len() * 12);
    out.extend_from_slice(&image.width.to_le_bytes());
    out.extend_from_slice(&image.height.to_le_bytes());
    for p in &image.pixels {
        for c in p.to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    out
}

fn decode(payload: &[u8]) -> Result<Image, String> {
    let word = |i: usize| u32::from_le_bytes(payload[i..i + 4].try_into().unwrap());
    if payload.len() < 8 {
        return Err(format!("{} bytes, shorter than the 8-byte size header", payload.len()));
    }
    let (width, height) = (word(0), word(4));
    let expected = 8 + width as u64 * height as u64 * 12;
    if payload.len() as u64 != expected {
        return Err(format!("a {width}x{height} image needs {expected} bytes, the payload has {}", payload.len()));
    }
    let floats: Vec<f32> = payload[8..].chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
    if let Some(i) = floats.iter().position(|v| !v.is_finite()) {
        return Err(format!("pixel {} holds a non-finite value", i / 3));
    }
    let pixels = floats.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
    Ok(Image { width, height, pixels })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cache in a folder that does not exist yet (the first store creates it), inside a
    /// scratch folder removed when the test ends (also when it fails): keep the `TempDir`.
    fn temp_cache(name: &str) -> (tempfile::TempDir, Cache) {
        let tmp = tempfile::Builder::new().prefix(&format!("glimpse-refcache-{name}-")).tempdir().unwrap();
        let dir = tmp.path().join("cache");
        (tmp, Cache { dir: Some(dir) })
    }

    #[test]
    fn round_trip_is_exact() {
        let (_tmp, cache) = temp_cache("round");
        let image = Image::from_fn(5, 3, |x, y| Vec3::new(x as f32 * 0.1, y as f32 * 1e-3, 7.5));
        cache.store("k", &image);
        let back = cache.load("k").expect("stored image loads");
        assert_eq!((back.width, back.height), (5, 3));
        assert_eq!(back.pixels, image.pixels);
    }

    /// Every single-byte corruption and every truncation is a miss (the file deleted), never a
    /// different image; a well-formed payload with a NaN or a wrong size is refused the same way.
    #[test]
    fn corrupt_files_are_deleted_not_used() {
        let (_tmp, cache) = temp_cache("corrupt");
        let image = Image::from_fn(4, 2, |x, y| Vec3::splat((x + y) as f32));
        cache.store("k", &image);
        let path = cache.path("k").unwrap();
        let good = std::fs::read(&path).unwrap();
        let mut refused = 0;
        for i in 0..good.len() {
            let mut bad = good.clone();
            bad[i] ^= 0x5a;
            std::fs::write(&path, &bad).unwrap();
            assert!(cache.load("k").is_none(), "a flipped byte {i} was used");
            assert!(!path.exists(), "byte {i}: the bad file must be deleted");
            refused += 1;
        }
        for len in [0, 7, 31, 32, good.len() - 1] {
            std::fs::write(&path, &good[..len]).unwrap();
            assert!(cache.load("k").is_none() && !path.exists(), "truncated to {len}");
            refused += 1;
        }
        let mut nan = encode(&image);
        nan[8..12].copy_from_slice(&f32::NAN.to_le_bytes());
        cache_file::write(&path, FORMAT, &nan).unwrap();
        assert!(cache.load("k").is_none() && !path.exists(), "a NaN pixel");
        let mut short = encode(&image);
        short.truncate(short.len() - 12);
        cache_file::write(&path, FORMAT, &short).unwrap();
        assert!(cache.load("k").is_none() && !path.exists(), "a size that does not match the pixels");
        println!("reference cache: {} corrupt files refused and deleted, 0 used", refused + 2);
    }
}
