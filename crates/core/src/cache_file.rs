//! The one on-disk container of every glimpse cache (wavelet cache, voxel arrays, …):
//!
//! ```text
//! offset  size  field
//!      0     8  magic (which cache, e.g. b"WAVECACH")
//!      8     4  format version (u32 LE): bumped whenever the payload's layout changes
//!     12     4  reserved, 0
//!     16     8  payload length in bytes (u64 LE)
//!     24     8  XXH3-64 of the payload (u64 LE)
//!     32     …  payload
//! ```
//!
//! Written atomically ([`crate::atomic_file`]); read back with every header field and the checksum
//! validated, so a truncated, bit-flipped or foreign file is a typed [`CacheFileError`], never data.
//! The checksum only proves the bytes are the ones written: each cache still validates its payload's
//! structure (index ranges, finite floats) before use. [`load_or_discard`] is the policy every
//! reader follows: a bad file is reported in one warning line, deleted, and the caller rebuilds.

use crate::atomic_file::{self, STALE_TEMP_AGE, WriteError};
use crate::bounded_read::{self, ReadError};
use std::io::{Read, Write};
use std::path::Path;

pub const HEADER_BYTES: usize = 32;

/// Which cache a file holds and the layout version its payload has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CacheFormat {
    pub magic: [u8; 8],
    pub version: u32,
}

#[derive(Debug, thiserror::Error)]
pub enum CacheFileError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("{path}: not a {expected} cache file (magic {found:?})")]
    Magic { path: String, expected: String, found: String },
    #[error("{path}: format version {found}, this glimpse reads version {expected}")]
    Version { path: String, found: u32, expected: u32 },
    #[error("{path}: the header says {expected} payload bytes, the file holds {found}")]
    Length { path: String, expected: u64, found: u64 },
    #[error("{path}: checksum mismatch (the file is corrupt)")]
    Checksum { path: String },
    #[error("{path}: invalid content: {message}")]
    Invalid { path: String, message: String },
}

impl CacheFileError {
    /// No file there (a plain cache miss, not worth a warning).
    pub fn is_missing(&self) -> bool {
        matches!(self, CacheFileError::Read(e) if e.is_not_found())
    }
}

/// XXH3-64 of `payload`, the checksum in the header.
pub fn checksum(payload: &[u8]) -> u64 {
    xxhash_rust::xxh3::xxh3_64(payload)
}

/// The file's header for the payload that is `parts` one after another.
fn header(format: CacheFormat, parts: &[&[u8]]) -> Vec<u8> {
    let mut sum = xxhash_rust::xxh3::Xxh3::new();
    parts.iter().for_each(|p| sum.update(p));
    let len: usize = parts.iter().map(|p| p.len()).sum();
    let mut out = Vec::with_capacity(HEADER_BYTES);
    out.extend_from_slice(&format.magic);
    out.extend_from_slice(&format.version.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&(len as u64).to_le_bytes());
    out.extend_from_slice(&sum.digest().to_le_bytes());
    out
}

/// The whole file (header + payload) as bytes.
pub fn encode(format: CacheFormat, payload: &[u8]) -> Vec<u8> {
    let mut out = header(format, &[payload]);
    out.extend_from_slice(payload);
    out
}

/// Validates a whole file's bytes and returns its payload.
pub fn decode(format: CacheFormat, path: &Path, data: &[u8]) -> Result<Vec<u8>, CacheFileError> {
    check(format, path, data)?;
    Ok(data[HEADER_BYTES..].to_vec())
}

/// Validates a whole file's bytes: magic, version, length and checksum.
fn check(format: CacheFormat, path: &Path, data: &[u8]) -> Result<(), CacheFileError> {
    let sum = check_header(format, path, data, data.len().saturating_sub(HEADER_BYTES) as u64)?;
    if checksum(&data[HEADER_BYTES..]) != sum {
        return Err(CacheFileError::Checksum { path: path.display().to_string() });
    }
    Ok(())
}

/// Validates the header at the start of `data` for a file whose payload is `found` bytes
/// (magic, version, length) and returns the checksum it records.
fn check_header(format: CacheFormat, path: &Path, data: &[u8], found: u64) -> Result<u64, CacheFileError> {
    let p = || path.display().to_string();
    let u32_at = |at: usize| u32::from_le_bytes(data[at..at + 4].try_into().unwrap_or([0; 4]));
    let u64_at = |at: usize| u64::from_le_bytes(data[at..at + 8].try_into().unwrap_or([0; 8]));
    if data.len() < HEADER_BYTES || data[..8] != format.magic {
        let found = String::from_utf8_lossy(&data[..data.len().min(8)]).into_owned();
        return Err(CacheFileError::Magic { path: p(), expected: String::from_utf8_lossy(&format.magic).into(), found });
    }
    if u32_at(8) != format.version {
        return Err(CacheFileError::Version { path: p(), found: u32_at(8), expected: format.version });
    }
    let len = u64_at(16);
    if len != found || u32_at(12) != 0 {
        return Err(CacheFileError::Length { path: p(), expected: len, found });
    }
    Ok(u64_at(24))
}

/// Writes `payload` to `path` (creating its folder) atomically, and removes stale temporary
/// files that killed writers left in that folder.
pub fn write(path: &Path, format: CacheFormat, payload: &[u8]) -> Result<(), WriteError> {
    write_parts(path, format, &[payload])
}

/// [`write`] for a payload given as consecutive parts, never copied into one buffer (a large
/// array can be written from where it lies: caches reach hundreds of MB).
pub fn write_parts(path: &Path, format: CacheFormat, parts: &[&[u8]]) -> Result<(), WriteError> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|source| WriteError { path: path.to_owned(), step: "create the folder of", source })?;
        atomic_file::remove_stale_temps(dir, STALE_TEMP_AGE);
    }
    let header = header(format, parts);
    atomic_file::write_atomic(path, |w| {
        w.write_all(&header)?;
        parts.iter().try_for_each(|p| w.write_all(p))
    })
}

/// Reads and validates the file at `path` (a regular file of at most `limit` bytes).
pub fn read(path: &Path, format: CacheFormat, limit: u64) -> Result<Vec<u8>, CacheFileError> {
    let mut data = bounded_read::read_bounded(path, "cache file", limit)?;
    check(format, path, &data)?;
    // The payload in place, not a copy beside the file's bytes (caches reach GBs).
    data.drain(..HEADER_BYTES);
    Ok(data)
}

/// The policy of every cache reader: reads `path` and turns its payload into a value with
/// `parse` (which validates the payload's structure). A missing file is `None`; a bad one
/// (header, checksum or `parse` failing) is reported in one warning line on stderr and deleted,
/// and is `None` too, so the caller rebuilds and rewrites it.
pub fn load_or_discard<T>(path: &Path, format: CacheFormat, limit: u64, parse: impl FnOnce(&[u8]) -> Result<T, String>) -> Option<T> {
    let result = read(path, format, limit)
        .and_then(|payload| parse(&payload).map_err(|message| CacheFileError::Invalid { path: path.display().to_string(), message }));
    discard_bad(path, result)
}

/// A payload read as a stream and hashed as it passes, for caches too large to hold twice
/// ([`read_streamed`]): its parser reads each array straight into its own storage.
pub struct PayloadReader<'a> {
    inner: &'a mut dyn Read,
    hash: xxhash_rust::xxh3::Xxh3,
    left: u64,
}

impl<'a> PayloadReader<'a> {
    /// The payload of `len` bytes that `inner` yields.
    pub fn new(inner: &'a mut dyn Read, len: u64) -> Self {
        PayloadReader { inner, hash: xxhash_rust::xxh3::Xxh3::new(), left: len }
    }

    /// Bytes of the payload not read yet: a length read from the payload is checked against
    /// it before anything is allocated.
    pub fn remaining(&self) -> u64 {
        self.left
    }

    /// Fills `buf` from the payload.
    pub fn read_exact(&mut self, buf: &mut [u8]) -> Result<(), String> {
        if buf.len() as u64 > self.left {
            return Err(format!("truncated: {} bytes wanted, {} left", buf.len(), self.left));
        }
        self.inner.read_exact(buf).map_err(|e| format!("read failed: {e}"))?;
        self.hash.update(buf);
        self.left -= buf.len() as u64;
        Ok(())
    }

    /// A u64 byte length followed by that many bytes, as an array of `T`.
    pub fn array<T: bytemuck::Pod>(&mut self, what: &str) -> Result<Vec<T>, String> {
        let mut len = [0u8; 8];
        self.read_exact(&mut len).map_err(|e| format!("{what}: {e}"))?;
        let len = u64::from_le_bytes(len);
        let size = std::mem::size_of::<T>() as u64;
        if len > self.left {
            return Err(format!("{what}: {len} bytes, {} left", self.left));
        }
        if !len.is_multiple_of(size) {
            return Err(format!("{what}: {len} bytes is not a whole number of elements"));
        }
        let mut v = vec![T::zeroed(); (len / size) as usize];
        self.read_exact(bytemuck::cast_slice_mut(&mut v)).map_err(|e| format!("{what}: {e}"))?;
        Ok(v)
    }
}

/// [`read`] for large payloads, never held whole beside what `parse` builds of them: the header
/// is checked (magic, version, the length against the file's size), `parse` reads the payload
/// from a [`PayloadReader`], every byte must be read, and the checksum must match before its
/// result is returned (it is never used on a corrupt file; the caller still validates it).
pub fn read_streamed<T>(
    path: &Path,
    format: CacheFormat,
    limit: u64,
    parse: impl FnOnce(&mut PayloadReader) -> Result<T, String>,
) -> Result<T, CacheFileError> {
    let size = bounded_read::check_file(path, "cache file", limit)?;
    let io = |source| CacheFileError::Read(ReadError::Io { path: path.to_owned(), source });
    let mut file = std::io::BufReader::with_capacity(1 << 20, std::fs::File::open(path).map_err(io)?);
    let mut header = vec![0u8; (HEADER_BYTES as u64).min(size) as usize];
    file.read_exact(&mut header).map_err(io)?;
    let invalid = |message: String| CacheFileError::Invalid { path: path.display().to_string(), message };
    let len = size.saturating_sub(HEADER_BYTES as u64);
    let sum = check_header(format, path, &header, len)?;
    let mut reader = PayloadReader::new(&mut file, len);
    let value = parse(&mut reader).map_err(invalid)?;
    if reader.remaining() != 0 {
        return Err(invalid(format!("{} bytes after the last array", reader.remaining())));
    }
    if reader.hash.digest() != sum {
        return Err(CacheFileError::Checksum { path: path.display().to_string() });
    }
    Ok(value)
}

/// [`load_or_discard`] through [`read_streamed`]: `parse` reads the payload, `validate` checks
/// what it built once the checksum has matched.
pub fn load_streamed_or_discard<T>(
    path: &Path,
    format: CacheFormat,
    limit: u64,
    parse: impl FnOnce(&mut PayloadReader) -> Result<T, String>,
    validate: impl FnOnce(&T) -> Result<(), String>,
) -> Option<T> {
    let result = read_streamed(path, format, limit, parse)
        .and_then(|v| validate(&v).map(|()| v).map_err(|message| CacheFileError::Invalid { path: path.display().to_string(), message }));
    discard_bad(path, result)
}

/// The policy's second half: a missing file is `None`; a bad one is reported and deleted.
fn discard_bad<T>(path: &Path, result: Result<T, CacheFileError>) -> Option<T> {
    match result {
        Ok(v) => Some(v),
        Err(e) if e.is_missing() => None,
        Err(e) => {
            let removed = if std::fs::remove_file(path).is_ok() { "deleted it; rebuilding" } else { "rebuilding" };
            eprintln!("warning: bad cache file {e}; {removed}");
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const F: CacheFormat = CacheFormat { magic: *b"TESTCACH", version: 3 };

    /// A fresh folder for one test's files, removed when the test ends (also when it fails).
    fn tmp() -> tempfile::TempDir {
        tempfile::Builder::new().prefix("glimpse-cachefile-").tempdir().unwrap()
    }

    #[test]
    fn round_trip() {
        let dir = tmp();
        let p = dir.path().join("ok.bin");
        write(&p, F, b"payload bytes").unwrap();
        assert_eq!(read(&p, F, 1 << 20).unwrap(), b"payload bytes");
    }

    /// The streamed reader reads what `read` reads, and refuses what it refuses: every bit
    /// flip (checksum, or a header field), every truncation, trailing bytes, an array length
    /// past the end (before allocating it), and a parser that leaves bytes unread.
    #[test]
    fn the_streamed_reader_agrees_with_read() {
        let dir = tmp();
        let p = dir.path().join("arrays.bin");
        let values: Vec<u32> = (0..40).collect();
        let body: &[u8] = bytemuck::cast_slice(&values);
        write_parts(&p, F, &[&(body.len() as u64).to_le_bytes(), body]).unwrap();
        let parse = |r: &mut PayloadReader| r.array::<u32>("values");
        assert_eq!(read_streamed(&p, F, 1 << 20, parse).unwrap(), values);
        let file = std::fs::read(&p).unwrap();
        let bad = dir.path().join("bad.bin");
        let refused = |data: &[u8]| {
            std::fs::write(&bad, data).unwrap();
            read_streamed(&bad, F, 1 << 20, parse).is_err()
        };
        for bit in 0..file.len() * 8 {
            let mut m = file.clone();
            m[bit / 8] ^= 1 << (bit % 8);
            assert!(refused(&m), "flip of bit {bit} accepted");
        }
        for len in 0..file.len() {
            assert!(refused(&file[..len]), "truncation to {len} accepted");
        }
        let mut longer = file.clone();
        longer.push(0);
        assert!(refused(&longer));
        // A length past the end, with a valid header and checksum: refused, not allocated.
        let huge = u64::MAX / 2;
        write_parts(&bad, F, &[&huge.to_le_bytes(), body]).unwrap();
        let e = read_streamed(&bad, F, 1 << 20, parse).unwrap_err();
        assert!(e.to_string().contains("left"), "{e}");
        // A parser that stops early.
        let e = read_streamed(&p, F, 1 << 20, |r| r.read_exact(&mut [0u8; 8])).unwrap_err();
        assert!(e.to_string().contains("after the last array"), "{e}");
    }

    #[test]
    fn a_payload_written_in_parts_is_the_same_file() {
        let dir = tmp();
        let (whole, parts) = (dir.path().join("whole.bin"), dir.path().join("parts.bin"));
        write(&whole, F, b"payload bytes").unwrap();
        write_parts(&parts, F, &[b"pay", b"", b"load bytes"]).unwrap();
        assert_eq!(std::fs::read(&parts).unwrap(), std::fs::read(&whole).unwrap());
        assert_eq!(std::fs::read(&parts).unwrap(), encode(F, b"payload bytes"));
    }

    #[test]
    fn every_single_bit_flip_and_truncation_is_rejected() {
        let file = encode(F, b"some payload of a cache");
        let p = Path::new("mem");
        for bit in 0..file.len() * 8 {
            let mut m = file.clone();
            m[bit / 8] ^= 1 << (bit % 8);
            assert!(decode(F, p, &m).is_err(), "flip of bit {bit} accepted");
        }
        for len in 0..file.len() {
            assert!(decode(F, p, &file[..len]).is_err(), "truncation to {len} accepted");
        }
        let mut longer = file.clone();
        longer.push(0);
        assert!(decode(F, p, &longer).is_err());
        let other = CacheFormat { version: 4, ..F };
        assert!(matches!(decode(other, p, &file), Err(CacheFileError::Version { found: 3, expected: 4, .. })));
        println!("{} bit flips and {} truncations rejected", file.len() * 8, file.len());
    }

    #[test]
    fn a_bad_file_is_deleted_and_a_missing_one_is_a_quiet_miss() {
        let dir = tmp();
        let p = dir.path().join("bad.bin");
        let mut data = encode(F, b"abc");
        *data.last_mut().unwrap() ^= 0x40;
        std::fs::write(&p, &data).unwrap();
        assert!(load_or_discard(&p, F, 1 << 20, |b| Ok(b.to_vec())).is_none());
        assert!(!p.exists(), "the bad file is deleted");
        assert!(load_or_discard(&p, F, 1 << 20, |b| Ok(b.to_vec())).is_none());
        // A payload its parser rejects is discarded too.
        write(&p, F, b"abc").unwrap();
        assert!(load_or_discard(&p, F, 1 << 20, |_| Err::<(), _>("bad index".into())).is_none());
        assert!(!p.exists());
        write(&p, F, b"abc").unwrap();
        assert_eq!(load_or_discard(&p, F, 1 << 20, |b| Ok(b.to_vec())).as_deref(), Some(&b"abc"[..]));
    }
}
