//! CS5 of the paper (§3.2.3, Fig. 12, Algorithm 2 lines 28–30): per cell, a reduction counting
//! the set pixels of the occlusion map (N_occ) and of the visibility map (N_vis);
//! `l_occ = 1` iff N_occ > N_vis (`r_occ > 0.5`). Ties and empty cells give 0, and every cell is
//! written every frame, so no label survives from a previous frame (spec §4.6).

use crate::grid::Masks;
use rayon::prelude::*;

/// The label rule.
#[inline]
pub fn label(n_vis: u32, n_occ: u32) -> u8 {
    (n_occ > n_vis) as u8
}

/// CS5: one label per cell, in parallel over cells.
pub fn occlusion_labels(masks: &Masks) -> Vec<u8> {
    (0..masks.cells())
        .into_par_iter()
        .map(|c| {
            let (v, o) = masks.counts(c);
            label(v, o)
        })
        .collect()
}
