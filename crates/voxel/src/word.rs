//! Occupancy words: one texel of an occupancy map, B depth slices packed into a B-bit unsigned
//! integer (paper §3.1: "every 32 cells along z are encoded in one 32-bit integer"; the paper's
//! code extends this to more bits, spec §2.1). Slice `i` (0 = nearest) is bit `B − 1 − i`, so
//! slice 0 is the MSB (spec §2.2, derived from Alg. 1 lines 13 and 15).
//!
//! Positional resolution R equals the bit count B (spec §2.1 [INFERENCE]): R = 32, 64, 128 use
//! `u32`, `u64`, `u128`. The words are unsigned on purpose: the paper's listing tests `U > 0`
//! on `int`, which reports a miss whenever slice 0 is occupied (erratum, spec §4.6 pitfall 1).

use std::fmt::Debug;
use std::ops::{BitAnd, BitOr, BitOrAssign, Shl, Shr};

/// An unsigned integer used as a column of B occupancy bits.
pub trait Word:
    Copy
    + Default
    + Eq
    + Debug
    + Send
    + Sync
    + 'static
    + BitOr<Output = Self>
    + BitOrAssign
    + BitAnd<Output = Self>
    + Shl<u32, Output = Self>
    + Shr<u32, Output = Self>
{
    /// Bits per word = depth slices per texel = positional resolution.
    const BITS: u32;
    const ZERO: Self;
    const ONE: Self;
    const ALL: Self;
    fn leading_zeros(self) -> u32;
    fn trailing_zeros(self) -> u32;
    fn count_ones(self) -> u32;
    fn from_u128(v: u128) -> Self;

    /// The bit of slice `i` (`i < BITS`).
    #[inline]
    fn slice_bit(i: u32) -> Self {
        Self::ONE << (Self::BITS - 1 - i)
    }

    /// Is slice `i` occupied? Alg. 1 line 13 `(U << t) >> 31`, with logical shifts.
    #[inline]
    fn has_slice(self, i: u32) -> bool {
        (self >> (Self::BITS - 1 - i)) & Self::ONE != Self::ZERO
    }

    /// Slices `lo..=hi` set (`lo ≤ hi < BITS`).
    #[inline]
    fn slice_range(lo: u32, hi: u32) -> Self {
        // Ones in slices ≥ lo, then clear slices > hi.
        (Self::ALL >> lo) & (Self::ALL << (Self::BITS - 1 - hi))
    }
}

macro_rules! impl_word {
    ($t:ty) => {
        impl Word for $t {
            const BITS: u32 = <$t>::BITS;
            const ZERO: Self = 0;
            const ONE: Self = 1;
            const ALL: Self = <$t>::MAX;
            #[inline]
            fn leading_zeros(self) -> u32 {
                <$t>::leading_zeros(self)
            }
            #[inline]
            fn trailing_zeros(self) -> u32 {
                <$t>::trailing_zeros(self)
            }
            #[inline]
            fn count_ones(self) -> u32 {
                <$t>::count_ones(self)
            }
            #[inline]
            fn from_u128(v: u128) -> Self {
                v as $t
            }
        }
    };
}

impl_word!(u32);
impl_word!(u64);
impl_word!(u128);

#[cfg(test)]
mod tests {
    use super::*;

    fn ranges<W: Word>() {
        for lo in 0..W::BITS {
            for hi in lo..W::BITS {
                let m = W::slice_range(lo, hi);
                for i in 0..W::BITS {
                    assert_eq!(m.has_slice(i), (lo..=hi).contains(&i), "B={} lo={lo} hi={hi} i={i}", W::BITS);
                }
            }
        }
        assert!(W::slice_bit(0).has_slice(0) && W::slice_bit(0).leading_zeros() == 0);
    }

    #[test]
    fn slice_ranges_for_every_width() {
        ranges::<u32>();
        ranges::<u64>();
        ranges::<u128>();
    }
}
