//! The compressed array of a static scene, cached on disk (issue #14: "cached on disk for static
//! geometry … so a second `eval` loads it"). The build (Alg. 1 voxelization + Alg. 2 compression)
//! takes seconds to minutes and depends only on the triangles and the array's parameters, so it
//! is stored once under `cache_dir()/voxarray/<key>.bin`, the key an XXH3 of the world-space
//! triangles' bytes and every build parameter.
//!
//! The file is a `glimpse_core::cache_file` (magic `VOXARRAY`, checksummed, written atomically);
//! its payload is validated before use (resolution and direction count as asked, finite grid and
//! biases, index width against the dictionary, every packed index inside the dictionary, the
//! index array long enough for every row), so a corrupt file is discarded and rebuilt, never
//! trusted. Only compressed arrays are cached: an uncompressed 128³ × 90² array is 2 GiB.
//!
//! Payload (little-endian): resolution u32, directions u32, grid centre 3×f32, grid scale f32,
//! bias_start f32, bias_end f32, normal_offset f32, skip_start_run u8, index_bits u32, rows u64,
//! dictionary length u64, dictionary rows (16 bytes each, as u128), index words u64 + the words,
//! then the compression report (rows, distinct, dictionary rows, random u64; ms f64; steps u32 +
//! that many u64).

use crate::compress::{Compressed, CompressionReport};
use crate::directions::Directions;
use crate::row::Row;
use crate::voxelize::Grid;
use crate::{Array, Rows, VoxArray, VoxArrayParams};
use glimpse_core::Vec3;
use glimpse_core::cache_file::{self, CacheFormat, PayloadReader};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

pub const FORMAT: CacheFormat = CacheFormat { magic: *b"VOXARRAY", version: 1 };

/// Largest cache file read back (a 128³ × 90² compressed array is about 350 MB).
const READ_LIMIT: u64 = 8 << 30;

/// The cache file for `triangles` built with `p` in `dir`.
pub fn path_for(dir: &Path, triangles: &[[Vec3; 3]], focus: Option<glimpse_core::Aabb>, p: &VoxArrayParams) -> PathBuf {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    h.update(bytemuck::cast_slice(triangles));
    h.update(format!("{p:?}").as_bytes());
    if let Some(f) = focus {
        h.update(bytemuck::bytes_of(&f));
    }
    dir.join("voxarray").join(format!("{:016x}.bin", h.digest()))
}

/// The array from the cache at `path` if it is there and valid for `p`; else `None` (a bad file
/// is reported and deleted by [`cache_file::load_or_discard`]).
pub fn load(path: &Path, p: &VoxArrayParams) -> Option<VoxArray> {
    cache_file::load_streamed_or_discard(path, FORMAT, READ_LIMIT, |r| from_payload(r, p), |_| Ok(()))
}

/// Writes a compressed array; plain arrays are not cached (returns `Ok(false)`).
pub fn store(path: &Path, array: &VoxArray) -> Result<bool, String> {
    let payload = match array {
        VoxArray::R32(a) => to_payload(a),
        VoxArray::R64(a) => to_payload(a),
        VoxArray::R128(a) => to_payload(a),
    };
    let Some((head, indices, tail)) = payload else { return Ok(false) };
    // `write_parts` creates the folder.
    cache_file::write_parts(path, FORMAT, &[&head, indices, &tail]).map_err(|e| e.to_string())?;
    Ok(true)
}

/// The payload in three parts: the fields up to the packed indices' length, the indices (most
/// of the file, written from the array itself), the compression report.
fn to_payload<R: Row>(a: &Array<R>) -> Option<(Vec<u8>, &[u8], Vec<u8>)> {
    let Rows::Compressed(c) = &a.rows else { return None };
    let mut out = Vec::with_capacity(64 + c.dictionary.len() * 16);
    let put32 = |o: &mut Vec<u8>, v: u32| o.extend_from_slice(&v.to_le_bytes());
    let put64 = |o: &mut Vec<u8>, v: u64| o.extend_from_slice(&v.to_le_bytes());
    let putf = |o: &mut Vec<u8>, v: f32| o.extend_from_slice(&v.to_le_bytes());
    put32(&mut out, R::BITS);
    put32(&mut out, a.dirs.n);
    for v in [a.grid.center.x, a.grid.center.y, a.grid.center.z, a.grid.scale, a.bias_start_cells, a.bias_end_cells, a.normal_offset_cells]
    {
        putf(&mut out, v);
    }
    out.push(a.skip_start_run as u8);
    put32(&mut out, c.index_bits);
    put64(&mut out, c.rows as u64);
    put64(&mut out, c.dictionary.len() as u64);
    for r in &c.dictionary {
        out.extend_from_slice(&r.to_u128().to_le_bytes());
    }
    put64(&mut out, c.indices.len() as u64);
    let head = std::mem::take(&mut out);
    let report = a.compression.clone().unwrap_or_default();
    for v in [report.rows, report.distinct_rows, report.dictionary_rows, report.random] {
        put64(&mut out, v);
    }
    out.extend_from_slice(&report.ms.to_le_bytes());
    put32(&mut out, report.mapped_at_step.len() as u32);
    for &v in &report.mapped_at_step {
        put64(&mut out, v);
    }
    Some((head, bytemuck::cast_slice(&c.indices), out))
}

/// Little-endian fields read off the payload stream, each checked against what is left before
/// anything is allocated for it.
struct Fields<'r, 'a>(&'r mut PayloadReader<'a>);

impl Fields<'_, '_> {
    fn bytes<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let mut b = [0u8; N];
        self.0.read_exact(&mut b)?;
        Ok(b)
    }
    fn u32(&mut self) -> Result<u32, String> {
        self.bytes().map(u32::from_le_bytes)
    }
    fn u64(&mut self) -> Result<u64, String> {
        self.bytes().map(u64::from_le_bytes)
    }
    fn f32(&mut self) -> Result<f32, String> {
        self.bytes().map(f32::from_le_bytes)
    }
    fn f64(&mut self) -> Result<f64, String> {
        self.bytes().map(f64::from_le_bytes)
    }
    /// `count` elements of `size` bytes, read straight into their array.
    fn array<T: bytemuck::Pod>(&mut self, count: u64, what: &str) -> Result<Vec<T>, String> {
        let bytes = count.checked_mul(std::mem::size_of::<T>() as u64).filter(|&b| b <= self.0.remaining());
        if bytes.is_none() {
            return Err(format!("{count} {what}, {} bytes left", self.0.remaining()));
        }
        let mut v = vec![T::zeroed(); count as usize];
        self.0.read_exact(bytemuck::cast_slice_mut(&mut v))?;
        Ok(v)
    }
}

/// The array's first field (its resolution) picks the row type.
fn from_payload(r: &mut PayloadReader, p: &VoxArrayParams) -> Result<VoxArray, String> {
    let bits = Fields(r).u32()?;
    match bits {
        32 => parse::<u32>(r, p).map(VoxArray::R32),
        64 => parse::<u64>(r, p).map(VoxArray::R64),
        128 => parse::<u128>(r, p).map(VoxArray::R128),
        _ => Err(format!("resolution {bits} (32, 64 or 128)")),
    }
}

/// The rest of the payload after its resolution, `R::BITS`.
fn parse<R: Row>(payload: &mut PayloadReader, p: &VoxArrayParams) -> Result<Array<R>, String> {
    let mut r = Fields(payload);
    let bits = R::BITS;
    let n = r.u32()?;
    if bits != p.resolution || n != p.directions {
        return Err(format!("array {bits}³ × {n}² where {}³ × {}² was asked", p.resolution, p.directions));
    }
    if n < 2 || n % 2 == 1 || n > 360 {
        return Err(format!("{n} directions"));
    }
    let f: Vec<f32> = (0..7).map(|_| r.f32()).collect::<Result<_, _>>()?;
    if f.iter().any(|v| !v.is_finite()) || f[3] <= 0.0 {
        return Err("non-finite grid or bias, or a non-positive scale".into());
    }
    let skip_start_run = r.bytes::<1>()?[0] != 0;
    let index_bits = r.u32()?;
    let rows = r.u64()?;
    let expected_rows = (n as u64).pow(2) * (bits as u64).pow(2);
    if rows != expected_rows {
        return Err(format!("{rows} rows, the array has {expected_rows}"));
    }
    let dict_len = r.u64()?;
    if !(1..=32).contains(&index_bits) || dict_len == 0 || dict_len > 1u64 << index_bits {
        return Err(format!("{dict_len} dictionary rows for {index_bits}-bit indices"));
    }
    let dictionary: Vec<R> =
        r.array::<[u8; 16]>(dict_len, "dictionary rows")?.into_iter().map(|b| R::from_u128(u128::from_le_bytes(b))).collect();
    let words = r.u64()?;
    // The query reads two words per index: one spare word past the last row's.
    if words < (rows * index_bits as u64).div_ceil(64) + 1 {
        return Err(format!("{words} index words for {rows} rows of {index_bits} bits"));
    }
    // Read in place: the indices are most of the file (a 128³ × 90² array's: about 350 MB).
    let indices: Vec<u64> = r.array(words, "index words")?.into_iter().map(u64::from_le).collect();
    let compressed = Compressed { dictionary, index_bits, indices, rows: rows as usize };
    let bad = (0..compressed.rows).into_par_iter().find_any(|&row| compressed.index(row) as u64 >= dict_len);
    if let Some(row) = bad {
        return Err(format!("row {row}'s index {} is outside the {dict_len}-row dictionary", compressed.index(row)));
    }
    let mut report =
        CompressionReport { rows: r.u64()?, distinct_rows: r.u64()?, dictionary_rows: r.u64()?, random: r.u64()?, ..Default::default() };
    report.ms = r.f64()?;
    let steps = r.u32()?;
    if steps > 64 {
        return Err(format!("{steps} compression steps"));
    }
    report.mapped_at_step = (0..steps).map(|_| r.u64()).collect::<Result<_, _>>()?;
    Ok(Array {
        grid: Grid { resolution: bits, center: Vec3::new(f[0], f[1], f[2]), scale: f[3] },
        dirs: Directions::new(n),
        rows: Rows::Compressed(compressed),
        bias_start_cells: f[4],
        bias_end_cells: f[5],
        normal_offset_cells: f[6],
        skip_start_run,
        build_ms: 0.0,
        compression: Some(report),
        clip_to_sphere: false,
    })
}
