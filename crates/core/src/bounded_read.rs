//! Bounded file reads: every file glimpse reads (scenes, buffers, textures, environment maps,
//! caches) must be a regular file no larger than a limit stated per kind, checked before a byte is
//! read — so a `uri` that points at `/dev/zero`, a FIFO or a 40 GB file is an error naming the
//! file, the limit and what it is, never a read until memory runs out.

use std::io::Read;
use std::path::{Path, PathBuf};

/// Size limits per kind of file (bytes). Generous for real scenes, far below a machine's memory.
pub mod limit {
    /// scene.toml, .mtl, .gltf JSON, Mitsuba XML.
    pub const TEXT: u64 = 64 << 20;
    /// OBJ meshes, glTF buffers, GLB files, PLY meshes.
    pub const MESH: u64 = 4 << 30;
    /// Textures and environment maps (encoded).
    pub const IMAGE: u64 = 1 << 30;
    /// Disk caches.
    pub const CACHE: u64 = 8 << 30;
}

#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: not a regular file (every {kind} must be a plain file, not a device, FIFO or folder)")]
    NotRegular { path: PathBuf, kind: &'static str },
    #[error("{path}: {size} bytes is more than the {limit}-byte limit for a {kind}")]
    TooLarge { path: PathBuf, kind: &'static str, size: u64, limit: u64 },
}

impl ReadError {
    /// The message without the leading path (for errors that name the file themselves).
    pub fn reason(&self) -> String {
        let path = match self {
            ReadError::Io { path, .. } | ReadError::NotRegular { path, .. } | ReadError::TooLarge { path, .. } => path,
        };
        let text = self.to_string();
        text.strip_prefix(&format!("{}: ", path.display())).map(str::to_owned).unwrap_or(text)
    }

    pub fn is_not_found(&self) -> bool {
        matches!(self, ReadError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound)
    }
}

/// Checks that `path` is a regular file of at most `limit` bytes; returns its size.
pub fn check_file(path: &Path, kind: &'static str, limit: u64) -> Result<u64, ReadError> {
    let meta = std::fs::metadata(path).map_err(|source| ReadError::Io { path: path.to_owned(), source })?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular { path: path.to_owned(), kind });
    }
    if meta.len() > limit {
        return Err(ReadError::TooLarge { path: path.to_owned(), kind, size: meta.len(), limit });
    }
    Ok(meta.len())
}

/// Reads all of `path` (a regular file of at most `limit` bytes). The read itself is capped too,
/// in case the file grows between the check and the read.
pub fn read_bounded(path: &Path, kind: &'static str, limit: u64) -> Result<Vec<u8>, ReadError> {
    let size = check_file(path, kind, limit)?;
    let io = |source| ReadError::Io { path: path.to_owned(), source };
    let file = std::fs::File::open(path).map_err(io)?;
    let mut data = Vec::with_capacity(size as usize);
    file.take(limit + 1).read_to_end(&mut data).map_err(io)?;
    if data.len() as u64 > limit {
        return Err(ReadError::TooLarge { path: path.to_owned(), kind, size: data.len() as u64, limit });
    }
    Ok(data)
}

/// [`read_bounded`] as UTF-8 text.
pub fn read_text_bounded(path: &Path, kind: &'static str, limit: u64) -> Result<String, ReadError> {
    let data = read_bounded(path, kind, limit)?;
    String::from_utf8(data).map_err(|e| ReadError::Io {
        path: path.to_owned(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, format!("not UTF-8 text: {e}")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_folders_are_refused_before_reading() {
        if Path::new("/dev/zero").exists() {
            let e = read_bounded(Path::new("/dev/zero"), "glTF buffer", limit::MESH).unwrap_err().to_string();
            println!("{e}");
            assert!(e.contains("/dev/zero") && e.contains("not a regular file"), "{e}");
        }
        let e = read_bounded(&std::env::temp_dir(), "texture", limit::IMAGE).unwrap_err().to_string();
        assert!(e.contains("not a regular file"), "{e}");
    }

    #[test]
    fn a_file_over_the_limit_names_size_and_limit() {
        let dir = tempfile::Builder::new().prefix("glimpse-bounded-").tempdir().unwrap();
        let p = dir.path().join("bounded.txt");
        std::fs::write(&p, vec![b'x'; 100]).unwrap();
        let e = read_bounded(&p, "material library", 10).unwrap_err().to_string();
        println!("{e}");
        assert!(e.contains("100 bytes") && e.contains("10-byte limit") && e.contains("material library"), "{e}");
        assert_eq!(read_bounded(&p, "material library", 100).unwrap().len(), 100);
    }
}
