//! Alg. 2, "Compression of 2D array of voxelizations" (§3.2): vector quantization of the rows.
//! 1. Histogram of all rows (hash-map counts), dictionary `D` = the `n` most frequent rows.
//! 2. For c = 0 .. s−1, every still-unmapped row is matched exactly against the dictionary after
//!    OR-down-sampling both by `2^c` (`Simplify`); the stored index points at the full row.
//! 3. Rows still unmapped get a (seeded) random dictionary row, the paper's fallback.
//! 4. Indices are packed with ⌈log2 |D|⌉ bits each (20 bits for the paper's 1M-row dictionary,
//!    which is what reproduces Table 8's 333 MB at 128³; spec §2.4).
//!
//! Gaps filled: among dictionary rows sharing a simplified key, `Find` returns the most frequent
//! (lowest index; the dictionary is sorted by frequency, ties by row value). `Find` is a hash-map
//! lookup of the simplified row (the paper: N·log2 n searches). The histogram and the mapping
//! run in parallel with rayon (the paper: single thread, "rows are independent"). The random
//! fallback is a hash of the row index and the seed, so the result does not depend on threads.
//!
//! Why hash maps: the first version sorted a copy of every row (2 GB at 128³ with 90² directions,
//! the build's 4.2 GB peak) and binary-searched a 1M-row dictionary per row; counting in
//! per-thread hash maps keeps only the distinct rows, and each `Find` is one lookup. The
//! dictionary, and so every index, is the same (`tests/acceptance.rs` pins the compression).

use crate::row::{Row, group_starts, simplify_with};
use rayon::prelude::*;
use rustc_hash::FxHashMap;

/// Alg. 2 settings. `Default`: s = 4 steps (×1, ×2, ×4, ×8) as the paper, and a dictionary of
/// up to [`DEFAULT_DICTIONARY_ROWS`] rows instead of the paper's 1M ([`CompressParams::paper`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompressParams {
    pub dictionary_rows: u32,
    pub steps: u32,
    pub seed: u64,
}

/// The default dictionary's cap: 16M rows (256 MiB of 128-bit rows, 24-bit indices). The
/// dictionary holds the most frequent rows up to this many, so a scene with fewer distinct rows
/// is compressed without loss. The paper's 1M rows is Table 8's 333 MB at 128³; on
/// `sponza-interior` (6.2M distinct rows) it mapped 13 % of the rows to a down-sampled match
/// and 0.8 % to a random row, a third of the array's wrong decisions (ε_v 20.4 % → 14.7 % with
/// every row kept, 349 → 480 MB: `cargo run --release -p glimpse-voxarray --example
/// error_sources -- scenes/suite/sponza-interior.toml 96 64 dictionary=N`).
pub const DEFAULT_DICTIONARY_ROWS: u32 = 1 << 24;

/// Dictionary rows the down-sampled steps (c ≥ 1) match against: the paper's whole 1M-row
/// dictionary, the most frequent 1M rows of a larger one (bounds the lookup tables' memory).
pub const DOWNSAMPLED_MATCH_ROWS: usize = 1 << 20;

impl Default for CompressParams {
    fn default() -> Self {
        Self { dictionary_rows: DEFAULT_DICTIONARY_ROWS, steps: 4, seed: 0 }
    }
}

impl CompressParams {
    /// The paper's setting: a 1M-row dictionary (`profile=paper`).
    pub fn paper() -> Self {
        Self { dictionary_rows: 1 << 20, ..Self::default() }
    }
}

/// The compressed array: dictionary `D` and packed per-row indices `V'`.
#[derive(Clone, Debug)]
pub struct Compressed<R: Row> {
    pub dictionary: Vec<R>,
    pub index_bits: u32,
    /// Packed indices, LSB-first, one spare word at the end so a read never runs past.
    pub indices: Vec<u64>,
    pub rows: usize,
}

/// What compression did, for reports and the acceptance checks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CompressionReport {
    pub rows: u64,
    pub distinct_rows: u64,
    pub dictionary_rows: u64,
    /// Rows mapped at step c (down-sampling 2^c).
    pub mapped_at_step: Vec<u64>,
    /// Rows given a random dictionary row.
    pub random: u64,
    pub ms: f64,
}

impl<R: Row> Compressed<R> {
    #[inline]
    pub fn index(&self, row: usize) -> usize {
        let pos = row * self.index_bits as usize;
        let (w, off) = (pos / 64, pos % 64);
        let both = self.indices[w] as u128 | (self.indices[w + 1] as u128) << 64;
        ((both >> off) as u64 & ((1u64 << self.index_bits) - 1)) as usize
    }

    /// The first packed-index word row `row`'s index lies in (what a prefetch should touch).
    #[inline]
    pub fn index_word(&self, row: usize) -> &u64 {
        &self.indices[row * self.index_bits as usize / 64]
    }

    #[inline]
    pub fn row(&self, row: usize) -> R {
        self.dictionary[self.index(row)]
    }

    /// Every row decoded.
    pub fn decode(&self) -> Vec<R> {
        (0..self.rows).into_par_iter().map(|r| self.row(r)).collect()
    }

    pub fn memory_bytes(&self) -> usize {
        self.dictionary.len() * std::mem::size_of::<R>() + self.indices.len() * 8
    }

    /// Table 8's accounting: dictionary + `rows × index_bits` bits.
    pub fn packed_bytes(&self) -> u64 {
        self.dictionary.len() as u64 * (R::BITS as u64 / 8) + (self.rows as u64 * self.index_bits as u64).div_ceil(8)
    }
}

/// Bits per packed index for a dictionary of `n` rows.
pub fn index_bits(n: usize) -> u32 {
    (usize::BITS - (n.max(2) - 1).leading_zeros()).max(1)
}

/// Alg. 2. Returns the compressed array, the step each row was mapped at (`steps` = random),
/// and the report.
pub fn compress<R: Row>(rows: &[R], p: &CompressParams) -> (Compressed<R>, Vec<u8>, CompressionReport) {
    let sw = std::time::Instant::now();
    // Lines 1–2: histogram, dictionary.
    let distinct = histogram(rows);
    let distinct_rows = distinct.len() as u64;
    let dictionary = choose_dictionary(distinct, p);
    // Lines 3–15: `Find` after Simplify(·, 2^c), then the random fallback.
    let finder = Finder::new(&dictionary, distinct_rows, p);
    let mut assign = vec![0u32; rows.len()];
    let mut step = vec![p.steps as u8; rows.len()];
    assign.par_iter_mut().zip(step.par_iter_mut()).zip(rows.par_iter()).enumerate().for_each(|(i, ((a, st), &r))| {
        let (index, s) = finder.find(r).unwrap_or_else(|| (finder.random(i), p.steps as u8));
        (*a, *st) = (index, s);
    });
    let mut mapped_at_step = vec![0u64; p.steps as usize];
    let mut random = 0u64;
    for &s in &step {
        match mapped_at_step.get_mut(s as usize) {
            Some(m) => *m += 1,
            None => random += 1,
        }
    }
    let bits = index_bits(dictionary.len());
    let indices = pack(&assign, bits);
    let report = CompressionReport {
        rows: rows.len() as u64,
        distinct_rows,
        dictionary_rows: dictionary.len() as u64,
        mapped_at_step,
        random,
        ms: sw.elapsed().as_secs_f64() * 1e3,
    };
    (Compressed { dictionary, index_bits: bits, indices, rows: rows.len() }, step, report)
}

/// Alg. 2 on an array produced slab by slab, without ever holding it whole: `fill(k, slab)`
/// writes rows `k·slab_rows ..` of the array into `slab` (this is Alg. 1 for one θ). Each slab
/// is kept as a small table of its distinct rows and a 32-bit id per row, so the peak memory
/// is a quarter of the plain rows (128-bit rows) plus the packed result, instead of the plain
/// array and the compression's working arrays together (3 GB at 128³ × 90²). The result is
/// exactly [`compress`]'s on the whole array (`tests`).
pub fn compress_slabs<R: Row>(
    slabs: usize,
    slab_rows: usize,
    fill: impl Fn(usize, &mut [R]) + Sync,
    p: &CompressParams,
) -> (Compressed<R>, CompressionReport) {
    let sw = std::time::Instant::now();
    struct Slab<R> {
        /// Distinct rows in order of first appearance, with their counts.
        distinct: Vec<(R, u64)>,
        /// Per row, its index into `distinct`.
        ids: Vec<u32>,
    }
    /// One thread's slab buffer and row table.
    type Scratch<R> = (Vec<R>, FxHashMap<R, u32>);
    let pool: std::sync::Mutex<Vec<Scratch<R>>> = std::sync::Mutex::new(Vec::new());
    let parts: Vec<Slab<R>> = (0..slabs)
        .into_par_iter()
        .map(|k| {
            // A slab buffer and row table per thread, reused slab after slab: rayon's
            // `map_init` makes them per job, not per thread, and a fresh 24 MB buffer faults in
            // zeroed pages for every slab (with the table's growth, a quarter of the build).
            let mut scratch =
                pool.lock().unwrap_or_else(|e| e.into_inner()).pop().unwrap_or_else(|| (vec![R::ZERO; slab_rows], FxHashMap::default()));
            let slab = {
                let (buf, local) = (&mut scratch.0, &mut scratch.1);
                buf.fill(R::ZERO);
                fill(k, buf);
                local.clear();
                let mut distinct: Vec<(R, u64)> = Vec::new();
                // Neighbouring rows are mostly equal (empty space, a wall's run): the previous
                // row's id skips the hash lookup (the same ids, in the same order).
                let mut previous: Option<(R, u32)> = None;
                let ids = buf
                    .iter()
                    .map(|&r| {
                        let id = match previous {
                            Some((q, id)) if q == r => id,
                            _ => *local.entry(r).or_insert_with(|| {
                                distinct.push((r, 0));
                                (distinct.len() - 1) as u32
                            }),
                        };
                        previous = Some((r, id));
                        distinct[id as usize].1 += 1;
                        id
                    })
                    .collect();
                Slab { distinct, ids }
            };
            pool.lock().unwrap_or_else(|e| e.into_inner()).push(scratch);
            slab
        })
        .collect();
    // Lines 1–2 over the slabs' counts.
    let mut counts: FxHashMap<R, u64> = FxHashMap::default();
    for part in &parts {
        for &(r, c) in &part.distinct {
            *counts.entry(r).or_insert(0) += c;
        }
    }
    let distinct_rows = counts.len() as u64;
    let dictionary = choose_dictionary(counts.into_iter().collect(), p);
    let finder = Finder::new(&dictionary, distinct_rows, p);
    let bits = index_bits(dictionary.len());
    let rows = slabs * slab_rows;
    // Lines 3–15 once per distinct row of each slab, then per row through its id; each slab
    // packs into its own words (a slab's bit range starts on a word: slab_rows·bits ≡ 0 mod 64
    // for the N² ≥ 1024 rows of a voxelization).
    assert!((slab_rows * bits as usize).is_multiple_of(64), "slab rows {slab_rows} × {bits} bits must fill whole words");
    let words_per_slab = slab_rows * bits as usize / 64;
    let mut indices = crate::voxelize::alloc_rows::<u64>(slabs * words_per_slab + 2);
    let tallies: Vec<(Vec<u64>, u64)> = indices[..slabs * words_per_slab]
        .par_chunks_mut(words_per_slab)
        .zip(parts.par_iter())
        .enumerate()
        .map(|(k, (words, part))| {
            let found: Vec<Option<(u32, u8)>> = part.distinct.iter().map(|&(r, _)| finder.find(r)).collect();
            let mut mapped_at_step = vec![0u64; p.steps as usize];
            let mut random = 0u64;
            for (&(_, c), f) in part.distinct.iter().zip(&found) {
                match f {
                    Some((_, s)) => mapped_at_step[*s as usize] += c,
                    None => random += c,
                }
            }
            let assign: Vec<u32> = part
                .ids
                .iter()
                .enumerate()
                .map(|(j, &id)| found[id as usize].map_or_else(|| finder.random(k * slab_rows + j), |f| f.0))
                .collect();
            pack_into(&assign, bits, words);
            (mapped_at_step, random)
        })
        .collect();
    let mut mapped_at_step = vec![0u64; p.steps as usize];
    let mut random = 0;
    for (m, r) in tallies {
        mapped_at_step.iter_mut().zip(m).for_each(|(a, b)| *a += b);
        random += r;
    }
    let report = CompressionReport {
        rows: rows as u64,
        distinct_rows,
        dictionary_rows: dictionary.len() as u64,
        mapped_at_step,
        random,
        ms: sw.elapsed().as_secs_f64() * 1e3,
    };
    (Compressed { dictionary, index_bits: bits, indices, rows }, report)
}

/// Line 2: the `dictionary_rows` most frequent rows, most frequent first (ties by row value).
fn choose_dictionary<R: Row>(mut distinct: Vec<(R, u64)>, p: &CompressParams) -> Vec<R> {
    distinct.par_sort_unstable_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    distinct.truncate((p.dictionary_rows as usize).max(1));
    if distinct.is_empty() { vec![R::ZERO] } else { distinct.iter().map(|d| d.0).collect() }
}

/// Lines 3–15's lookups: per step c, simplified row → the lowest (most frequent) dictionary
/// index with it; and the seeded random fallback.
struct Finder<R: Row> {
    steps: Vec<(u32, R, FxHashMap<R, u32>)>,
    dictionary_len: u64,
    seed: u64,
}

impl<R: Row> Finder<R> {
    fn new(dictionary: &[R], distinct_rows: u64, p: &CompressParams) -> Self {
        // A dictionary of every distinct row finds each row at step 0: the down-sampled
        // tables would never be read.
        let steps = if dictionary.len() as u64 >= distinct_rows { p.steps.min(1) } else { p.steps };
        let steps = (0..steps)
            .map(|c| 1u32 << c)
            .filter(|&f| f <= R::BITS)
            .map(|f| {
                let keep: R = group_starts(f);
                // Exact matches (f = 1) against the whole dictionary; down-sampled ones against
                // its most frequent DOWNSAMPLED_MATCH_ROWS rows, so a full 16M-row dictionary
                // does not build three more 16M-entry tables.
                let candidates = if f == 1 { dictionary } else { &dictionary[..dictionary.len().min(DOWNSAMPLED_MATCH_ROWS)] };
                let mut keyed: FxHashMap<R, u32> = FxHashMap::default();
                keyed.reserve(candidates.len());
                for (k, &d) in candidates.iter().enumerate() {
                    keyed.entry(simplify_with(d, f, keep)).or_insert(k as u32);
                }
                (f, keep, keyed)
            })
            .collect();
        Self { steps, dictionary_len: dictionary.len() as u64, seed: p.seed }
    }

    /// (dictionary index, step) of the first step whose simplified row is in the dictionary.
    #[inline]
    fn find(&self, r: R) -> Option<(u32, u8)> {
        self.steps.iter().enumerate().find_map(|(c, (f, keep, keyed))| keyed.get(&simplify_with(r, *f, *keep)).map(|&k| (k, c as u8)))
    }

    /// The fallback's dictionary row for row `i` (a hash of `i` and the seed).
    #[inline]
    fn random(&self, i: usize) -> u32 {
        (splitmix64(self.seed ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)) % self.dictionary_len) as u32
    }
}

/// Indices packed LSB-first with `bits` bits each, plus two spare words.
fn pack(assign: &[u32], bits: u32) -> Vec<u64> {
    let mut indices = crate::voxelize::alloc_rows::<u64>((assign.len() * bits as usize).div_ceil(64) + 2);
    pack_into(assign, bits, &mut indices);
    indices
}

/// Packs `assign` LSB-first with `bits` bits each into `words` (zeroed, long enough). Each
/// 64-bit word gathers the indices that touch it; parallel over words, no races.
fn pack_into(assign: &[u32], bits: u32, words: &mut [u64]) {
    words.par_iter_mut().enumerate().for_each(|(w, word)| {
        let lo_bit = w * 64;
        let first = lo_bit / bits as usize;
        let last = ((lo_bit + 64).div_ceil(bits as usize)).min(assign.len());
        for (k, &a) in assign[first.min(last)..last].iter().enumerate() {
            let pos = (first + k) * bits as usize;
            let shift = pos as i64 - lo_bit as i64;
            let v = a as u128;
            if shift >= 0 {
                if shift < 64 {
                    *word |= (v << shift) as u64;
                }
            } else {
                *word |= (v >> (-shift)) as u64;
            }
        }
    });
}

/// Every distinct row with its count (in no particular order), counted in per-task hash maps
/// merged pairwise. Empty rows, most of any array, are counted apart from the maps.
fn histogram<R: Row>(rows: &[R]) -> Vec<(R, u64)> {
    type Counts<R> = (FxHashMap<R, u64>, u64);
    let (counts, zeros) = rows
        .par_chunks(1 << 18)
        .map(|chunk| {
            let (mut m, mut zeros): Counts<R> = Default::default();
            for &r in chunk {
                if r.is_zero() {
                    zeros += 1;
                } else {
                    *m.entry(r).or_insert(0) += 1;
                }
            }
            (m, zeros)
        })
        .reduce(Counts::<R>::default, |(a, za), (b, zb)| {
            let (mut big, small) = if a.len() >= b.len() { (a, b) } else { (b, a) };
            for (r, c) in small {
                *big.entry(r).or_insert(0) += c;
            }
            (big, za + zb)
        });
    let mut distinct: Vec<(R, u64)> = counts.into_iter().collect();
    if zeros > 0 {
        distinct.push((R::ZERO, zeros));
    }
    distinct
}

fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// Table 8's accounting for an `n_dirs × n_dirs` array at `resolution`³: (uncompressed bytes,
/// compressed bytes with a `dictionary_rows` dictionary and packed ⌈log2 n⌉-bit indices).
pub fn table8_bytes(resolution: u32, n_dirs: u32, dictionary_rows: u32) -> (u64, u64) {
    let rows = (n_dirs as u64).pow(2) * (resolution as u64).pow(2);
    let row_bytes = resolution as u64 / 8;
    (rows * row_bytes, dictionary_rows as u64 * row_bytes + (rows * index_bits(dictionary_rows as usize) as u64).div_ceil(8))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first version of lines 1–12 (sort-based histogram, binary-searched `Find`), kept here
    /// as the reference the hash-map version must reproduce index for index.
    fn reference<R: Row>(rows: &[R], p: &CompressParams) -> (Vec<R>, Vec<u32>) {
        let mut sorted = rows.to_vec();
        sorted.sort_unstable();
        let mut distinct: Vec<(R, u64)> = Vec::new();
        for r in sorted {
            match distinct.last_mut() {
                Some((v, c)) if *v == r => *c += 1,
                _ => distinct.push((r, 1)),
            }
        }
        distinct.sort_unstable_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        distinct.truncate(p.dictionary_rows as usize);
        let dictionary: Vec<R> = distinct.iter().map(|d| d.0).collect();
        let mut assign = vec![u32::MAX; rows.len()];
        for c in 0..p.steps {
            let f = 1u32 << c;
            let keep: R = group_starts(f);
            let mut keyed: Vec<(R, u32)> = dictionary.iter().enumerate().map(|(k, &d)| (simplify_with(d, f, keep), k as u32)).collect();
            keyed.sort_unstable();
            keyed.dedup_by_key(|e| e.0);
            for (a, &r) in assign.iter_mut().zip(rows) {
                if *a == u32::MAX
                    && let Ok(k) = keyed.binary_search_by(|e| e.0.cmp(&simplify_with(r, f, keep)))
                {
                    *a = keyed[k].1;
                }
            }
        }
        (dictionary, assign)
    }

    /// The slab-streamed compression gives exactly the whole-array compression: dictionary,
    /// every index, and the report's counts.
    #[test]
    fn streamed_slabs_equal_the_whole_array() {
        let pool: Vec<u128> =
            (0..500u64).map(|k| (splitmix64(k) & splitmix64(k + 999)) as u128 | ((splitmix64(k + 7) as u128) << 64)).collect();
        let (slabs, slab_rows) = (12, 1024);
        let row = |i: usize| if splitmix64(i as u64).is_multiple_of(4) { 0 } else { pool[(splitmix64(i as u64 ^ 77) % 500) as usize] };
        let whole: Vec<u128> = (0..slabs * slab_rows).map(row).collect();
        for dictionary_rows in [16, 200, 1000] {
            let p = CompressParams { dictionary_rows, steps: 4, seed: 9 };
            let (a, _, ra) = compress(&whole, &p);
            let fill = |k: usize, slab: &mut [u128]| {
                for (j, r) in slab.iter_mut().enumerate() {
                    *r = row(k * slab_rows + j);
                }
            };
            let (b, rb) = compress_slabs(slabs, slab_rows, fill, &p);
            assert_eq!(a.dictionary, b.dictionary);
            let differ = (0..whole.len()).filter(|&i| a.index(i) != b.index(i)).count();
            println!(
                "dictionary {dictionary_rows}: {} rows, {differ} indices differ; steps {:?}, random {}",
                whole.len(),
                rb.mapped_at_step,
                rb.random
            );
            assert_eq!(differ, 0);
            assert_eq!((ra.distinct_rows, ra.mapped_at_step, ra.random), (rb.distinct_rows, rb.mapped_at_step, rb.random));
        }
    }

    #[test]
    fn hash_maps_give_the_sorting_versions_dictionary_and_indices() {
        let mut state = 7u64;
        let mut next = || {
            state = splitmix64(state);
            state
        };
        // Sparse 64-bit rows drawn from a small pool (so rows repeat), a third of them empty.
        let pool: Vec<u64> = (0..3000).map(|_| next() & next() & next()).collect();
        let rows: Vec<u64> = (0..200_000).map(|_| if next() % 3 == 0 { 0 } else { pool[(next() % 3000) as usize] }).collect();
        for dictionary_rows in [64, 700, 5000] {
            let p = CompressParams { dictionary_rows, steps: 4, seed: 3 };
            let (c, step, report) = compress(&rows, &p);
            let (dictionary, assign) = reference(&rows, &p);
            assert_eq!(c.dictionary, dictionary, "dictionary of {dictionary_rows}");
            let mut differ = 0;
            for (i, &a) in assign.iter().enumerate() {
                if a != u32::MAX {
                    differ += (c.index(i) as u32 != a) as usize;
                } else {
                    assert_eq!(step[i] as u32, p.steps, "row {i} has no match: the random fallback");
                }
            }
            println!(
                "dictionary {dictionary_rows}: {} distinct rows, {:?} mapped per step, {} random; {differ} indices differ",
                report.distinct_rows, report.mapped_at_step, report.random
            );
            assert_eq!(differ, 0);
        }
    }

    /// The default dictionary keeps every distinct row (up to 16M): the array reads back exactly;
    /// the paper's 1M-row dictionary is `profile=paper`.
    #[test]
    fn the_default_dictionary_keeps_every_distinct_row() {
        let rows: Vec<u64> = (0..50_000u64).map(|i| splitmix64(i % 7_000) & splitmix64(i % 7_000 + 1)).collect();
        let (c, _, report) = compress(&rows, &CompressParams::default());
        println!(
            "{} rows, {} distinct, dictionary {}, steps {:?}",
            report.rows, report.distinct_rows, report.dictionary_rows, report.mapped_at_step
        );
        assert_eq!((report.dictionary_rows, report.random), (report.distinct_rows, 0));
        assert!((0..rows.len()).all(|i| c.row(i) == rows[i]));
        let read = |pairs: &[&str]| crate::VoxArrayParams::default().read(&glimpse_render::Params::parse(pairs).unwrap()).unwrap();
        assert_eq!(read(&[]).compress.unwrap().dictionary_rows, DEFAULT_DICTIONARY_ROWS);
        assert_eq!(read(&["profile=paper"]).compress.unwrap().dictionary_rows, 1 << 20);
        assert_eq!(read(&["profile=paper", "dictionary=4096"]).compress.unwrap().dictionary_rows, 4096);
    }
}
