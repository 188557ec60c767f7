//! glimpse-voxel: the voxel structures that more than one technique builds on, kept below the
//! technique crates so that none of them depends on another. ROMA's base occupancy map (BOM) is
//! also the input of the distance-field baseline, which the ROMA paper builds "from the same BOM".
//!
//! - [`word`]: occupancy words (u32/u64/u128, one bit per depth cell).
//! - [`grid`]: the cubic grid frame around the scene.
//! - [`occupancy`]: voxelization into a BOM.
//! - [`jitter`]: the per-frame sub-cell jitter.
//! - [`accumulate`]: temporal accumulation of frames.

pub mod accumulate;
pub mod grid;
pub mod jitter;
pub mod occupancy;
pub mod word;

pub use accumulate::{Accumulator, DEFAULT_ACCUMULATE};
pub use grid::Grid;
pub use jitter::frame_jitter;
pub use occupancy::{OccupancyMap, Voxelization};
pub use word::Word;
