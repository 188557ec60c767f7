//! The volume every occupancy map of a frame covers, and the "view-projection matrices" of the
//! BOM and of the ray-aligned OMs (paper §3.2, Alg. 1 and 2 inputs `M'_viewproj`, `M_viewproj`).
//!
//! The paper gives no extents, up-vectors or depth ranges (spec §2.3, §4.3 [INFERENCE]); ours:
//! - Every map is an **orthographic cube** of `R³` cells of the same world size, centred on the
//!   scene's bounding-box centre, with half-extent = the bounding sphere's radius plus two cells,
//!   so every rotation of it still holds the whole scene (and the 1.5-cell ray-origin offset and
//!   the jitter stay inside).
//! - The BOM's axes are the world axes, its bit (depth) axis is world z.
//! - OM k's axes are the orthonormal frame of Duff et al. around `d_k` (`Frame::from_z`), with
//!   depth increasing along `d_k` (so a ray along `+d_k` traces towards `+z`, spec §4.3).
//! - Because all maps share centre and cell size, the affine map from OM cell coordinates to BOM
//!   cell coordinates is a pure rotation about the centre: Alg. 1's endpoints-and-step walk
//!   becomes `start + i·d_k` in cell units (spec §4.4: "every matrix is affine").
//! - The per-frame jitter (paper §4.3, "we jitter objects' geometric positions for each OM")
//!   moves the shared centre by a sub-cell offset, which is the same as moving the geometry by
//!   the opposite offset.
//!
//! Cell coordinates are continuous: cell `(x, y, z)` covers `[x, x+1) × [y, y+1) × [z, z+1)`,
//! all in `[0, R)`.

use glimpse_core::{Aabb, Frame, Vec3};

/// The cubic volume of one frame's maps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Cells per axis (= bits per word).
    pub resolution: u32,
    /// Centre of the cube in world space, jitter included.
    pub center: Vec3,
    /// World size of one cell.
    pub cell_size_world: f32,
}

impl Grid {
    /// The cube around `bounds` at `resolution` cells per axis, its centre moved by
    /// `jitter_cells` (each component in [−0.5, 0.5)).
    pub fn around(bounds: Aabb, resolution: u32, jitter_cells: Vec3) -> Grid {
        let r = if bounds.is_empty() { 1.0 } else { (bounds.extent().length() * 0.5).max(1e-6) };
        // half = r + 2 cells, with cell = 2·half/R  ⇒  half = r / (1 − 4/R).
        let half = r / (1.0 - 4.0 / resolution as f32);
        let cell = 2.0 * half / resolution as f32;
        let center = if bounds.is_empty() { Vec3::ZERO } else { bounds.center() } + jitter_cells * cell;
        Grid { resolution, center, cell_size_world: cell }
    }

    pub fn half_extent_world(&self) -> f32 {
        0.5 * self.cell_size_world * self.resolution as f32
    }

    /// World point → BOM cell coordinates.
    #[inline]
    pub fn to_cells(&self, p: Vec3) -> Vec3 {
        (p - self.center) / self.cell_size_world + Vec3::splat(self.resolution as f32 * 0.5)
    }

    /// BOM cell coordinates → world point.
    #[inline]
    pub fn to_world(&self, q: Vec3) -> Vec3 {
        (q - Vec3::splat(self.resolution as f32 * 0.5)) * self.cell_size_world + self.center
    }

    /// World point → cell coordinates of the map with axes `axes` (columns: x, y, depth).
    #[inline]
    pub fn to_map_cells(&self, axes: &Frame, p: Vec3) -> Vec3 {
        axes.to_local(p - self.center) / self.cell_size_world + Vec3::splat(self.resolution as f32 * 0.5)
    }

    /// Cell coordinates of a map with axes `axes` → world point.
    #[inline]
    pub fn from_map_cells(&self, axes: &Frame, q: Vec3) -> Vec3 {
        axes.to_world(q - Vec3::splat(self.resolution as f32 * 0.5)) * self.cell_size_world + self.center
    }
}

/// The axes of the ray-aligned OM of candidate direction `d` (unit): depth along `d`.
pub fn om_axes(d: Vec3) -> Frame {
    Frame::from_z(d)
}

/// The BOM's axes: the world axes.
pub const BOM_AXES: Frame = Frame { x: Vec3::X, y: Vec3::Y, z: Vec3::Z };
