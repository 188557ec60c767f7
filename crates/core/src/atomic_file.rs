//! Atomic file output: every file glimpse writes (images, reports, JSON, caches) goes to a
//! temporary file in the destination's directory, is flushed and synced, and only then renamed
//! over the destination. A failure at any step (a full disk, an unwritable folder, Ctrl-C) leaves
//! the previous file untouched and removes the temporary one; the error names the file and the
//! step. The temporary file sits in the same directory because a rename is atomic only within one
//! file system.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// Temporary files being written now, so an interrupt handler can remove them
/// ([`remove_in_flight_and_exit`]) before the process exits.
static IN_FLIGHT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn in_flight() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    IN_FLIGHT.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// For a Ctrl-C handler: removes every temporary file a write of this process has open, so the
/// destinations keep their previous content and no `.tmp` file is left behind, then exits with
/// `code`. Temporary files are created under the same lock, and the lock is held until the
/// process ends, so no write can start a new one in between.
pub fn remove_in_flight_and_exit(code: i32) -> ! {
    let paths = in_flight();
    for p in paths.iter() {
        let _ = std::fs::remove_file(p);
    }
    std::process::exit(code)
}

/// The marker in every temporary file's name: `<name>.tmp<pid>.<n>`.
pub const TEMP_MARKER: &str = ".tmp";

/// Temporary files older than this are left by a killed process and may be removed
/// ([`remove_stale_temps`]): no write glimpse makes takes an hour.
pub const STALE_TEMP_AGE: Duration = Duration::from_secs(3600);

#[derive(Debug, thiserror::Error)]
#[error("{path}: cannot {step}: {source}")]
pub struct WriteError {
    pub path: PathBuf,
    /// What was being done: "create a temporary file", "write", "flush", "sync", "rename".
    pub step: &'static str,
    pub source: io::Error,
}

impl From<WriteError> for io::Error {
    fn from(e: WriteError) -> io::Error {
        io::Error::new(e.source.kind(), e.to_string())
    }
}

/// The temporary path beside `path`, unique within this process.
pub fn temp_path(path: &Path) -> PathBuf {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!("{name}{TEMP_MARKER}{}.{n}", std::process::id()))
}

/// Writes `path` atomically through `fill`, which writes the content into a buffered, seekable
/// writer (image encoders need `Seek`). The buffer's final flush error is reported, not dropped.
pub fn write_atomic<F>(path: &Path, fill: F) -> Result<(), WriteError>
where
    F: FnOnce(&mut BufWriter<File>) -> io::Result<()>,
{
    let err = |step, source| WriteError { path: path.to_owned(), step, source };
    // Renaming over a device (`-o /dev/full`), a FIFO or a folder would replace it: refuse.
    if let Ok(meta) = std::fs::symlink_metadata(path)
        && !meta.is_file()
        && !meta.file_type().is_symlink()
    {
        return Err(err("replace", io::Error::new(io::ErrorKind::InvalidInput, "it exists and is not a regular file")));
    }
    let tmp = temp_path(path);
    let file = {
        let mut registry = in_flight();
        let file = File::create(&tmp).map_err(|e| err("create a temporary file", e))?;
        registry.push(tmp.clone());
        file
    };
    let result = (|| {
        let mut w = BufWriter::new(file);
        fill(&mut w).map_err(|e| err("write", e))?;
        w.flush().map_err(|e| err("flush", e))?;
        let file = w.into_inner().map_err(|e| err("flush", e.into_error()))?;
        file.sync_all().map_err(|e| err("sync", e))?;
        drop(file);
        std::fs::rename(&tmp, path).map_err(|e| err("rename the temporary file over", e))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    in_flight().retain(|p| p != &tmp);
    result
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    write_atomic(path, |w| w.write_all(bytes))
}

/// Removes the temporary files ([`TEMP_MARKER`]) in `dir` older than `max_age`: what a process
/// killed mid-write leaves behind. Best effort (a cache folder's hygiene, not its correctness);
/// returns how many were removed.
pub fn remove_stale_temps(dir: &Path, max_age: Duration) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let is_temp = entry.file_name().to_str().is_some_and(|n| n.contains(TEMP_MARKER));
        let Ok(meta) = entry.metadata() else { continue };
        let old = meta.modified().ok().and_then(|t| t.elapsed().ok()).is_some_and(|age| age >= max_age);
        if is_temp && meta.is_file() && old && std::fs::remove_file(entry.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh, empty folder, removed when the test ends (also when it fails).
    fn dir(name: &str) -> tempfile::TempDir {
        tempfile::Builder::new().prefix(&format!("glimpse-atomic-{name}-")).tempdir().unwrap()
    }

    #[test]
    fn a_failing_writer_leaves_the_old_file_and_no_temporary() {
        let tmp = dir("fail");
        let d = tmp.path();
        let p = d.join("out.txt");
        std::fs::write(&p, b"old").unwrap();
        let e = write_atomic(&p, |w| {
            w.write_all(b"half")?;
            Err(io::Error::other("disk full"))
        })
        .unwrap_err();
        println!("{e}");
        assert!(e.to_string().contains("out.txt") && e.to_string().contains("disk full"), "{e}");
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(d).unwrap().count(), 1, "the temporary file is removed");
    }

    #[test]
    fn a_flush_error_is_reported() {
        // /dev/full accepts the open and fails every write: the buffered bytes fail at flush.
        if !Path::new("/dev/full").exists() {
            println!("skipped: no /dev/full on this system");
            return;
        }
        let mut w = BufWriter::new(File::options().write(true).open("/dev/full").unwrap());
        w.write_all(b"small enough to stay in the buffer").unwrap();
        assert!(w.flush().is_err(), "the check write_atomic relies on");
    }

    #[test]
    fn an_unwritable_directory_is_an_error_naming_the_file() {
        let e = write_bytes_atomic(Path::new("/nonexistent-dir/x.png"), b"x").unwrap_err();
        assert!(e.to_string().contains("/nonexistent-dir/x.png"), "{e}");
    }

    #[test]
    fn a_device_or_folder_is_never_replaced() {
        let tmp = dir("device");
        let e = write_bytes_atomic(tmp.path(), b"x").unwrap_err().to_string();
        assert!(e.contains("not a regular file"), "{e}");
        if Path::new("/dev/full").exists() {
            let e = write_bytes_atomic(Path::new("/dev/full"), b"x").unwrap_err().to_string();
            println!("{e}");
            assert!(e.contains("/dev/full") && e.contains("not a regular file"), "{e}");
        }
    }

    #[test]
    fn success_replaces_the_file_and_leaves_no_temporary() {
        let tmp = dir("ok");
        let d = tmp.path();
        let p = d.join("out.txt");
        std::fs::write(&p, b"old").unwrap();
        write_bytes_atomic(&p, b"new").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(d).unwrap().count(), 1);
    }

    #[test]
    fn stale_temporaries_are_removed_fresh_ones_kept() {
        let tmp = dir("stale");
        let d = tmp.path();
        std::fs::write(d.join("a.bin.tmp123.0"), b"x").unwrap();
        std::fs::write(d.join("a.bin"), b"x").unwrap();
        assert_eq!(remove_stale_temps(d, Duration::from_secs(3600)), 0, "fresh: a writer may be running");
        assert_eq!(remove_stale_temps(d, Duration::ZERO), 1);
        assert!(d.join("a.bin").exists() && !d.join("a.bin.tmp123.0").exists());
    }
}
