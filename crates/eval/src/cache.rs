//! Reference images cached on disk, keyed by a hash of everything that determines them: the
//! scene (its name, or its file's path, size and modification time), the technique and its
//! effective parameters, the image size, samples, seed, time and glimpse's version. A rerun of
//! `glimpse eval` then skips the slow references.

use glimpse_core::{Image, ToneMap};
use std::hash::{DefaultHasher, Hash, Hasher};
use std::path::PathBuf;

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
        self.dir.as_ref().map(|d| d.join(format!("ref-{key}.exr")))
    }

    pub fn load(&self, key: &str) -> Option<Image> {
        let p = self.path(key)?;
        Image::read(&p).ok()
    }

    /// Best effort: a cache that cannot be written only costs time.
    pub fn store(&self, key: &str, image: &Image) {
        if let Some(p) = self.path(key) {
            if let Some(dir) = p.parent() {
                let _ = std::fs::create_dir_all(dir);
                glimpse_core::atomic_file::remove_stale_temps(dir, glimpse_core::atomic_file::STALE_TEMP_AGE);
            }
            // Image::write is atomic (temporary file, sync, rename).
            let _ = image.write(&p, ToneMap::default());
        }
    }
}
