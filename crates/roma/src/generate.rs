//! `Generate` (paper Alg. 1, §3.2): "rotate" the BOM into one ray-aligned occupancy map per
//! candidate direction, by nearest-neighbour resampling, in parallel over the maps' texels.
//!
//! For texel `(x, y)` of OM k the `B` cell centres `(x+½, y+½, i+½)` are mapped to BOM cell
//! coordinates and bit `i` is set when the BOM cell containing the mapped point is occupied.
//! Since both maps are cubes with the same centre and cell size ([`crate::grid`]), the mapping
//! is `start + i·d_k` in cell units (Alg. 1 lines 2–7 and 17, with the endpoints computed
//! directly rather than accumulated).
//!
//! Errata fixed (spec §11): line 16 accumulates into `U_aligned` (the listing says `U_result`);
//! the BOM fetch uses logical shifts on unsigned words (`Word::has_slice`); points outside the
//! BOM are empty (the paper has no bounds test; the Mitsuba prototype of spec Appendix B does).

use crate::occupancy::OccupancyMap;
use crate::word::Word;
use glimpse_core::{Frame, Vec3};
use rayon::prelude::*;

/// The BOM-cell coordinates of the centre of cell `(x, y, 0)` of the map with axes `axes`, and
/// the step to the next slice.
#[inline]
pub fn column_start_and_step(axes: &Frame, x: u32, y: u32, resolution: u32) -> (Vec3, Vec3) {
    let half = resolution as f32 * 0.5;
    let local = Vec3::new(x as f32 + 0.5 - half, y as f32 + 0.5 - half, 0.5 - half);
    // Only rotation: BOM axes are the world axes and the cubes share centre and cell size.
    (axes.to_world(local) + Vec3::splat(half), axes.z)
}

/// One texel of a ray-aligned OM (Alg. 1's body).
#[inline]
pub fn generate_texel<W: Word>(bom: &OccupancyMap<W>, axes: &Frame, x: u32, y: u32) -> W {
    let (start, step) = column_start_and_step(axes, x, y, W::BITS);
    let mut out = W::ZERO;
    for i in 0..W::BITS {
        if bom.get_at(start + step * i as f32) {
            out |= W::slice_bit(i);
        }
    }
    out
}

/// One ray-aligned OM, as a stand-alone map (for tests).
pub fn generate_map<W: Word>(bom: &OccupancyMap<W>, axes: &Frame) -> OccupancyMap<W> {
    let r = W::BITS;
    let words = (0..r * r).into_par_iter().map(|i| generate_texel(bom, axes, i % r, i / r)).collect();
    OccupancyMap { words }
}

/// Every OM of the array, layer-major: word `k·R² + y·R + x`.
pub fn generate_all<W: Word>(bom: &OccupancyMap<W>, axes: &[Frame]) -> Vec<W> {
    let r = W::BITS as usize;
    let mut maps = vec![W::ZERO; axes.len() * r * r];
    maps.par_chunks_mut(r).enumerate().for_each(|(row, words)| {
        let (k, y) = (row / r, (row % r) as u32);
        for (x, w) in words.iter_mut().enumerate() {
            *w = generate_texel(bom, &axes[k], x as u32, y);
        }
    });
    maps
}
