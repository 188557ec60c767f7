//! Batched Alg. 3: the same decisions as [`crate::Array::occluded_segment`], answered for a
//! batch of segments in windows of [`WINDOW`] (extents in lanes of [`LANES`]) in three passes,
//! so the row loads of a window overlap:
//!
//! 1. every segment's extent (direction discretization, rotation of both ends, clip) — pure
//!    arithmetic, no memory traffic besides the cos/sin table;
//! 2. a software prefetch of each row the lane will read (for a compressed array: the packed
//!    index word, then the dictionary row once the index is known);
//! 3. the row fetch and the masked test.
//!
//! A scalar query waits on one random row load (the 2 GB array at 128³ misses every cache level
//! and the TLB) before it starts the next ray's arithmetic; here up to 64 loads are in flight
//! at once (8 before the tiled shader's commit). Pass 1 of a full lane runs 8-wide with AVX2 where the CPU has it ([`crate::extent8`]:
//! the scalar code's float operations in the same order, so the extents are bit-identical); a
//! partial lane, a CPU without AVX2 or `GLIMPSE_VOXARRAY_SCALAR=1` runs the scalar code lane by
//! lane. The answers are bit-identical to the scalar query (`tests/batch.rs` checks every ray on
//! several scenes, and 5.46M extents, random and adversarial, SIMD against scalar).
//!
//! Measured (issue #14; 2 shared cores, release build, median of 3 interleaved runs, the same
//! binary with `GLIMPSE_VOXARRAY_SCALAR=1` for the scalar pass 1):
//! - `glimpse bench rays many-lights --kind shadow --only voxarray --rays 4000000`: voxarray
//!   9.34 → 26.98 Mrays/s (2.9×); vs the exact BVH tracer of the same run 1.25× → 3.26×
//!   (exact 6.2–9.7 Mrays/s, noisy on the shared cores).
//! - `glimpse render many-lights -t lights-voxarray --size 320x240` (array loaded from the disk
//!   cache): shade 6095 → 4098 ms (6.71 → 9.97 Mrays/s); `-t lights-exact`: shade 6192 ms
//!   (6.60 Mrays/s), so lights-voxarray renders 1.51× faster than lights-exact (was 1.02×).
//!   The scalar and AVX2 images are byte-identical.
//! - Window 8 → 64 (same session, `--rays 16000000` so the trace takes ~0.6 s; median of 3
//!   alternated runs): voxarray 2.75× → 3.14× the exact tracer (24.90 → 24.55 Mrays/s medians,
//!   runs 20–33 Mrays/s: within the shared cores' noise; memory-bound, random rows).
//! - `lights-voxarray` no longer goes through this batch path: see [`crate::shade8`] and the
//!   numbers in [`crate::technique`].

use crate::extent8;
use crate::query::{self, Extent};
use crate::row::Row;
use crate::{Array, Rows};
use glimpse_core::{Ray, Vec3};

/// Segments whose extents are computed together (one AVX2 register of `f32`, a GPU's
/// quarter-warp).
pub const LANES: usize = 8;

/// Queries whose row loads are in flight together (passes 2 and 3 run over this many).
pub const WINDOW: usize = 64;

/// Hints the CPU to bring the cache line holding `*p` into every cache level. No-op off x86-64.
#[inline(always)]
fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: prefetch never faults and reads nothing architecturally; SSE is baseline on x86-64.
    #[allow(unused_unsafe)]
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p as *const i8);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

impl<R: Row> Array<R> {
    /// `out[k] = self.occluded_segment(segments[k].0, segments[k].1)` for every `k`.
    pub fn occluded_segments(&self, segments: &[(Vec3, Vec3)], out: &mut [bool]) {
        self.occluded_segments_with(segments, out, extent8::avx2_available());
    }

    /// [`Self::occluded_segments`] with the AVX2 pass 1 only if `simd` (and the CPU has it):
    /// `false` runs the scalar extents (the same answers).
    pub fn occluded_segments_with(&self, segments: &[(Vec3, Vec3)], out: &mut [bool], simd: bool) {
        assert_eq!(segments.len(), out.len(), "occluded_segments: one answer per segment");
        self.occluded_lanes(segments, out, simd, |&(a, b)| (a, b), |row, x| query::clip_hits(row, x.s, x.e));
    }

    /// Passes 2 and 3 over a whole list of row queries at once (the tiled shader's queries of
    /// one light over a tile, [`crate::shade8`], up to 64 in flight rather than 8): query `k` reads row `rows[k]` (an index into
    /// the flat row array, as [`Extent::row_index`]) clipped to `s[k]..=e[k]`. Every row (or
    /// packed index word) is prefetched, then for a compressed array every dictionary row once
    /// its index is known, then the rows are loaded and clipped. Calls `occluded(k)` for each
    /// query whose clipped row has a set bit. `rows` is overwritten (by the dictionary entries,
    /// when compressed).
    pub fn occluded_rows(&self, rows: &mut [u32], s: &[u32], e: &[u32], mut occluded: impl FnMut(usize)) {
        assert!(rows.len() == s.len() && rows.len() == e.len(), "occluded_rows: one clip per row");
        match &self.rows {
            Rows::Plain(v) => {
                for &r in rows.iter() {
                    prefetch(&v[r as usize]);
                }
                for (k, &r) in rows.iter().enumerate() {
                    if query::clip_hits(v[r as usize], s[k], e[k]) {
                        occluded(k);
                    }
                }
            }
            Rows::Compressed(c) => {
                for &r in rows.iter() {
                    prefetch(c.index_word(r as usize));
                }
                for r in rows.iter_mut() {
                    let entry = c.index(*r as usize);
                    prefetch(&c.dictionary[entry]);
                    *r = entry as u32;
                }
                for (k, &r) in rows.iter().enumerate() {
                    if query::clip_hits(c.dictionary[r as usize], s[k], e[k]) {
                        occluded(k);
                    }
                }
            }
        }
    }

    /// The batched form of the `Visibility` query (the ray's segment, the along-row bias and,
    /// with `skip_start_run`, the start run ignored).
    pub(crate) fn occluded_rays(&self, rays: &[(Ray, f32)], out: &mut [bool]) {
        assert_eq!(rays.len(), out.len(), "occluded_batch: one answer per ray");
        self.occluded_lanes(
            rays,
            out,
            extent8::avx2_available(),
            |(ray, t_max)| self.segment(ray, *t_max),
            |row, x| {
                if self.skip_start_run { query::clip_hits_after_start_run(row, x) } else { query::clip_hits(row, x.s, x.e) }
            },
        );
    }

    /// The three passes over windows of `WINDOW` queries: every query's extent (`segment` gives
    /// its world-space segment; 8 at a time), then the window's rows fetched together, then
    /// `hits` per query with an extent.
    #[inline]
    fn occluded_lanes<T>(
        &self,
        queries: &[T],
        out: &mut [bool],
        simd: bool,
        segment: impl Fn(&T) -> (Vec3, Vec3),
        hits: impl Fn(R, &Extent) -> bool,
    ) {
        for (queries, out) in queries.chunks(WINDOW).zip(out.chunks_mut(WINDOW)) {
            let mut extents = [None; WINDOW];
            for (extents, queries) in extents.chunks_mut(LANES).zip(queries.chunks(LANES)) {
                if simd && queries.len() == LANES {
                    let (mut starts, mut ends) = ([Vec3::ZERO; LANES], [Vec3::ZERO; LANES]);
                    for ((a, b), q) in starts.iter_mut().zip(&mut ends).zip(queries) {
                        (*a, *b) = segment(q);
                    }
                    let (g, d, bs, be) = (&self.grid, &self.dirs, self.bias_start_cells, self.bias_end_cells);
                    let x = extent8::extents_simd(g, d, &starts, &ends, bs, be)
                        .unwrap_or_else(|| extent8::extents_scalar(g, d, &starts, &ends, bs, be));
                    extents.copy_from_slice(&x);
                } else {
                    for (x, q) in extents.iter_mut().zip(queries) {
                        let (a, b) = segment(q);
                        *x = query::extent(&self.grid, &self.dirs, a, b, self.bias_start_cells, self.bias_end_cells);
                    }
                }
            }
            let rows = self.fetch_rows(&extents[..queries.len()]);
            for ((o, x), row) in out.iter_mut().zip(&extents).zip(rows) {
                *o = x.as_ref().is_some_and(|x| hits(row, x));
            }
        }
    }

    /// Passes 2 and 3: prefetch every query's row, then load them (`R::ZERO` where no extent).
    #[inline]
    fn fetch_rows(&self, extents: &[Option<Extent>]) -> [R; WINDOW] {
        let mut index = [usize::MAX; WINDOW];
        for (i, x) in index.iter_mut().zip(extents) {
            if let Some(x) = x {
                *i = x.row_index(R::BITS);
            }
        }
        let mut rows = [R::ZERO; WINDOW];
        match &self.rows {
            Rows::Plain(v) => {
                for &i in index.iter().filter(|&&i| i != usize::MAX) {
                    prefetch(&v[i]);
                }
                for (r, &i) in rows.iter_mut().zip(&index) {
                    if i != usize::MAX {
                        *r = v[i];
                    }
                }
            }
            Rows::Compressed(c) => {
                for &i in index.iter().filter(|&&i| i != usize::MAX) {
                    prefetch(c.index_word(i));
                }
                let mut entry = [usize::MAX; WINDOW];
                for (e, &i) in entry.iter_mut().zip(&index) {
                    if i != usize::MAX {
                        *e = c.index(i);
                        prefetch(&c.dictionary[*e]);
                    }
                }
                for (r, &e) in rows.iter_mut().zip(&entry) {
                    if e != usize::MAX {
                        *r = c.dictionary[e];
                    }
                }
            }
        }
        rows
    }
}
