//! Combining a pixel's snapped AO samples (ours, `snap_weight=cos`; the paper counts the open
//! samples).
//!
//! A snapped sample is unbiased for the cosine-weighted AO integral only after its
//! [`crate::CandidateSet::cosine_weight`] g: the estimate g·open has the right mean, but where
//! every sample agrees (a pixel wholly open or wholly blocked) it adds noise that counting did
//! not have. So each sample i uses a control variate: g_i·open_i + (1 − g_i)·c_i, where c_i
//! does not depend on sample i (the mean of the pixel's other samples, or for a lone sample
//! the neighbouring pixel's): E[1 − g_i] = 0 keeps the mean, and when open_i = c_i the weight
//! drops out, so an all-open or all-blocked pixel is exactly 1 or 0 as before.

use glimpse_core::{Image, Vec3};

/// One snapped AO sample: open (1) or blocked (0), and its weight (1 = the paper's count).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SnappedSample {
    pub open: f32,
    pub weight: f32,
}

/// Each pixel's open fraction from its `spp` samples (`None`: the pixel sees no surface and
/// stays open), one image row: `samples` holds `spp` per pixel of `out`.
pub fn open_fractions(samples: &[Option<SnappedSample>], spp: usize, out: &mut [Vec3]) {
    let width = out.len();
    let pixel = |x: usize| &samples[x * spp..(x + 1) * spp];
    for (x, px) in out.iter_mut().enumerate() {
        let own = pixel(x);
        let Some(first) = own[0] else {
            *px = Vec3::ONE;
            continue;
        };
        let value = if spp == 1 {
            // A lone sample: the stand-in is the left neighbour's sample (the right one at the
            // row's start), else its own (the paper's count).
            let neighbour = [x.checked_sub(1), Some(x + 1)].into_iter().flatten().filter(|&n| n < width).find_map(|n| pixel(n)[0]);
            let c = neighbour.map_or(first.open, |s| s.open);
            first.weight * first.open + (1.0 - first.weight) * c
        } else {
            let total: f32 = own.iter().flatten().map(|s| s.open).sum();
            let others = (spp - 1) as f32;
            own.iter().flatten().map(|s| s.weight * s.open + (1.0 - s.weight) * (total - s.open) / others).sum::<f32>() / spp as f32
        };
        *px = Vec3::splat(value);
    }
}

/// A weighted frame's open fraction can leave [0, 1] (its mean over frames cannot): the image
/// shown keeps AO in [0, 1]; the accumulator's history, blended before this, does not.
pub fn clamp_open_fraction(image: &mut Image) {
    image.pixels.iter_mut().for_each(|p| *p = p.clamp(Vec3::ZERO, Vec3::ONE));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(open: bool, weight: f32) -> Option<SnappedSample> {
        Some(SnappedSample { open: open as u8 as f32, weight })
    }

    #[test]
    fn unit_weights_count_the_open_samples() {
        let s = [sample(true, 1.0), sample(false, 1.0), sample(true, 1.0), sample(true, 1.0), None, None, None, None];
        let mut out = [Vec3::ZERO; 2];
        open_fractions(&s, 4, &mut out);
        assert_eq!(out, [Vec3::splat(0.75), Vec3::ONE]);
    }

    #[test]
    fn agreeing_samples_ignore_their_weights() {
        for open in [false, true] {
            let s = [sample(open, 0.3), sample(open, 1.9), sample(open, 0.0), sample(open, 3.5)];
            let mut out = [Vec3::splat(-1.0)];
            open_fractions(&s, 4, &mut out);
            assert_eq!(out[0], Vec3::splat(open as u8 as f32), "all {open}");
            // Lone samples whose neighbours agree.
            let mut row = [Vec3::splat(-1.0); 4];
            open_fractions(&s, 1, &mut row);
            assert_eq!(row, [Vec3::splat(open as u8 as f32); 4]);
        }
    }

    #[test]
    fn a_lone_sample_stands_in_its_neighbour() {
        // Blocked with weight 2 beside an open neighbour: 2·0 + (1 − 2)·1 = −1 (its mean over
        // frames is what is unbiased); beside a miss, the right neighbour; alone, its own.
        let s = [None, sample(false, 2.0), sample(true, 0.5)];
        let mut out = [Vec3::ZERO; 3];
        open_fractions(&s, 1, &mut out);
        assert_eq!(out[1], Vec3::splat(-1.0));
        assert_eq!(out[2], Vec3::splat(0.5), "0.5·1 + 0.5·0");
        let mut lone = [Vec3::ZERO];
        open_fractions(&[sample(false, 2.0)], 1, &mut lone);
        assert_eq!(lone[0], Vec3::ZERO);
    }
}
