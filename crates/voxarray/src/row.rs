//! Rows of occupancy bits (paper §3, "a row of the voxelization, with one bit per voxel"): one
//! unsigned integer per row, 32, 64 or 128 bits for resolution 32³, 64³ or 128³.
//!
//! Bit order: LSB-first, bit `z` is voxel `z` along the row. The paper's Fig. 4 writes rows
//! MSB-first; the two are equivalent as long as `ComputeExtent` uses the same convention, which
//! `tests/acceptance.rs` pins against the Fig. 4 example.
//!
//! [`Row::simplify`] is Alg. 2's `Simplify(row, 2^c)` (OR-down-sampling) kept *uncompacted*: bit
//! `b·f` of the result is the OR of bits `b·f .. b·f+f−1`, all other bits are 0. It is a
//! bijection of the paper's compacted `N/f`-bit row, so equality tests (Alg. 2's `Find`) are the
//! same, and it costs three shifts instead of a bit gather.

use std::fmt::Debug;
use std::hash::Hash;

pub trait Row: Copy + Send + Sync + Default + Eq + Ord + Hash + Debug + 'static {
    /// Bits per row = voxels per axis.
    const BITS: u32;
    const ZERO: Self;
    fn bit(z: u32) -> Self;
    /// Bits `s..=e` set (`s ≤ e < BITS`); no shift by the full width, so no overflow trap.
    fn mask(s: u32, e: u32) -> Self;
    fn or(self, o: Self) -> Self;
    fn and(self, o: Self) -> Self;
    fn is_zero(self) -> bool;
    fn count_ones(self) -> u32;
    fn get(self, z: u32) -> bool;
    /// Alg. 2's `Simplify(row, f)` for `f` in 1, 2, 4, 8 (uncompacted; see the module doc).
    fn simplify(self, f: u32) -> Self;
    fn to_u128(self) -> u128;
    fn from_u128(v: u128) -> Self;
}

macro_rules! impl_row {
    ($t:ty) => {
        impl Row for $t {
            const BITS: u32 = <$t>::BITS;
            const ZERO: Self = 0;
            #[inline]
            fn bit(z: u32) -> Self {
                1 << z
            }
            #[inline]
            fn mask(s: u32, e: u32) -> Self {
                debug_assert!(s <= e && e < Self::BITS);
                (<$t>::MAX >> (Self::BITS - 1 - (e - s))) << s
            }
            #[inline]
            fn or(self, o: Self) -> Self {
                self | o
            }
            #[inline]
            fn and(self, o: Self) -> Self {
                self & o
            }
            #[inline]
            fn is_zero(self) -> bool {
                self == 0
            }
            #[inline]
            fn count_ones(self) -> u32 {
                <$t>::count_ones(self)
            }
            #[inline]
            fn get(self, z: u32) -> bool {
                self >> z & 1 == 1
            }
            #[inline]
            fn simplify(self, f: u32) -> Self {
                let mut x = self;
                let mut shift = 1;
                while shift < f {
                    x |= x >> shift;
                    shift *= 2;
                }
                // Keep the bits at multiples of f.
                let keep = (0..Self::BITS).step_by(f as usize).fold(0 as $t, |m, b| m | (1 << b));
                x & keep
            }
            #[inline]
            fn to_u128(self) -> u128 {
                self as u128
            }
            #[inline]
            fn from_u128(v: u128) -> Self {
                v as $t
            }
        }
    };
}

impl_row!(u32);
impl_row!(u64);
impl_row!(u128);

/// Group-start masks are computed per call above for clarity; this is the hot-path version for
/// the compressor, with the mask precomputed once per step.
#[inline]
pub fn simplify_with<R: Row>(row: R, f: u32, keep: R) -> R {
    let mut x = row.to_u128();
    let mut shift = 1;
    while shift < f {
        x |= x >> shift;
        shift *= 2;
    }
    R::from_u128(x).and(keep)
}

/// The group-start mask of [`Row::simplify`] for factor `f`.
pub fn group_starts<R: Row>(f: u32) -> R {
    (0..R::BITS).step_by(f as usize).fold(R::ZERO, |m, b| m.or(R::bit(b)))
}
